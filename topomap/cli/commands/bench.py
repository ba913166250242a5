"""``topomap bench``: the benchmarks, each printing a table and writing results.json."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from topomap.cli.commands.common import (
    ONLINE_METHODS,
    RADIUS,
    SHARE,
    add_output_options,
    add_robot_options,
    count_type,
    number_type,
    refuse_existing,
    robot_spec,
    worker_count,
)
from topomap.cli.tables import markdown_table

#: ``--time-limit`` and ``--budget``: seconds, up to an hour.
SECONDS = number_type(0.0, 3600.0, low_open=True, unit="s")


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    bench = sub.add_parser("bench", help="benchmarks: print a table, write results.json")
    bench_sub = bench.add_subparsers(dest="bench", required=True)
    sim = bench_sub.add_parser("sim", help="laser simulator speed")
    add_output_options(sim, "out/bench-sim")
    sim.add_argument("--scans", type=count_type(1, 1_000_000), nargs="+", default=[1_000, 10_000])
    sim.add_argument("--beams", type=count_type(2, 100_000), nargs="+", default=[181, 361])
    sim.set_defaults(func=cmd_bench_sim)
    seg_bench = bench_sub.add_parser("segment", help="spectral partition speed against naive")
    add_output_options(seg_bench, "out/bench-segment")
    seg_bench.add_argument(
        "--sizes", type=count_type(2, 100_000), nargs="+", default=[1_000, 2_000, 5_000, 10_000]
    )
    seg_bench.add_argument("--naive-up-to", type=count_type(0, 100_000), default=2_000)
    seg_bench.add_argument("--building", default="campus", choices=["flat", "office", "campus"])
    seg_bench.set_defaults(func=cmd_bench_segment)
    maps_bench = bench_sub.add_parser("maps", help="the whole segmentation over map sizes")
    add_output_options(maps_bench, "out/bench-maps")
    maps_bench.add_argument(
        "--sizes", nargs="*", default=["flat", "office", "campus"], help="generated buildings"
    )
    maps_bench.add_argument("--logs", help="a folder of CARMEN *.log.gz: maps built from them")
    maps_bench.add_argument(
        "--command",
        metavar="DATA_DIR",
        help="time `topomap segment` itself on every map of DATA_DIR (ipa or ROSE² layout)",
    )
    maps_bench.add_argument(
        "--canvas",
        type=count_type(1, 20_000),
        metavar="CELLS",
        help="with --command: each map also in the middle of CELLS x CELLS unknown cells, as "
        "a SLAM package saves it (gmapping: 4000)",
    )
    maps_bench.set_defaults(func=cmd_bench_maps)
    online_bench = bench_sub.add_parser("online", help="online segmentation: latency, agreement")
    add_output_options(online_bench, "out/bench-online")
    online_bench.add_argument(
        "--parts",
        nargs="+",
        default=["latency", "quality", "growing"],
        choices=["latency", "quality", "growing"],
    )
    online_bench.add_argument(
        "--keyframes", type=count_type(2, 1_000_000), default=10_000, help="of the long run"
    )
    online_bench.add_argument(
        "--seed-keyframes", type=count_type(2, 100_000), default=500, help="long run's seed"
    )
    online_bench.add_argument("--building", default="campus", choices=["flat", "office", "campus"])
    online_bench.add_argument(
        "--offline-up-to",
        type=count_type(0, 1_000_000),
        default=2_000,
        help="re-run offline every 100 up to this",
    )
    online_bench.add_argument(
        "--online-method", default="windows", choices=ONLINE_METHODS, help="long run's"
    )
    online_bench.add_argument("--logs", default="../shared/data/carmen", help="CARMEN logs")
    online_bench.add_argument(
        "--snapshots", default="../shared/data/rose2_partial", help="growing-map snapshots"
    )
    online_bench.add_argument(
        "--seed-fraction",
        type=SHARE,
        help="quality runs: share of keyframes seeded (default 10 %%, at least 40)",
    )
    online_bench.add_argument("--theta", type=SHARE, default=0.5, help="in [0, 1]")
    online_bench.set_defaults(func=cmd_bench_online)
    plan_bench = bench_sub.add_parser("plan", help="hierarchical against flat planning")
    add_output_options(plan_bench, "out/bench-plan")
    plan_bench.add_argument("--maps", help="also every map YAML in this folder")
    plan_bench.add_argument(
        "--sizes",
        nargs="*",
        default=["flat", "office", "campus"],
        help="generated buildings (flat, office, campus) and 512 x 512 grid maps of rooms "
        "8, 16 or 32 cells apart with one-cell doors (rooms8, rooms16, rooms32)",
    )
    plan_bench.add_argument("--queries", type=count_type(1, 10_000), default=30, help="per map")
    plan_bench.add_argument("--robot-radius", type=RADIUS, default=0.2, help="metres")
    plan_bench.add_argument("--time-limit", type=SECONDS, default=20.0, help="flat planners, s")
    plan_bench.add_argument(
        "--budget", type=SECONDS, default=30.0, help="query seconds per planner and map, then skip"
    )
    plan_bench.add_argument(
        "--python-astar", action="store_true", help="also the pure-Python grid A* (reference)"
    )
    plan_bench.add_argument("--cache", default="out/cache/exact", help="exact-reference cache")
    plan_bench.add_argument("--no-cache", action="store_true", help="recompute the reference")
    add_robot_options(plan_bench)
    plan_bench.add_argument(
        "--planners",
        nargs="+",
        metavar="NAME",
        help="only these planners run (default all; a disc: hierarchical, grid_mcp, "
        "flat_rrtconnect, flat_prm, flat_bitstar, grid_astar; a footprint --robot: "
        "hierarchical, hierarchical_union, flat_rrtconnect, flat_rrt, flat_rrtstar, "
        "flat_bitstar, flat_kpiece1, flat_prm)",
    )
    plan_bench.set_defaults(func=cmd_bench_plan)
    batch_bench = bench_sub.add_parser("batch", help="topomap batch: maps per minute, 1-2 workers")
    add_output_options(batch_bench, "out/bench-batch")
    batch_bench.add_argument(
        "--maps", type=count_type(1, 10_000), default=24, help="generated buildings"
    )
    batch_bench.add_argument("--size", default="flat", choices=["flat", "office"])
    batch_bench.add_argument("--workers", type=worker_count, nargs="+", default=[1, 2])
    batch_bench.add_argument("--rounds", type=worker_count, default=2, help="turns per count")
    batch_bench.add_argument(
        "--campus", action="store_true", help="also the block-wise campus segmentation"
    )
    batch_bench.set_defaults(func=cmd_bench_batch)


def cmd_bench_sim(args: argparse.Namespace) -> int:
    from topomap.cli.bench import bench_sim

    refuse_existing(Path(args.out), ["results.json"], args.force)
    records = bench_sim(
        args.out, scans=tuple(args.scans), beams=tuple(args.beams), progress=args.progress
    )
    print(markdown_table(records, ["scans", "beams", "seconds", "scans_per_s", "rays_per_s"]))
    print(
        f"set-up (distance transform of {records[0]['map_cells']} cells): "
        f"{records[0]['setup_seconds']} s; wrote {args.out}/results.json"
    )
    return 0


def cmd_bench_segment(args: argparse.Namespace) -> int:
    from topomap.cli.bench import bench_segment

    refuse_existing(Path(args.out), ["results.json"], args.force)
    records = bench_segment(
        args.out,
        sizes=tuple(args.sizes),
        naive_up_to=args.naive_up_to,
        building=args.building,
        progress=args.progress,
    )
    rows = []
    for n in sorted({r["keyframes"] for r in records}):
        by = {r["method"]: r for r in records if r["keyframes"] == n}
        naive = by.get("naive")
        rows.append(
            {
                "keyframes": n,
                "topomap_s": by["topomap"]["seconds"],
                "naive_s": naive["seconds"] if naive else "-",
                "speed-up": f"{naive['seconds'] / by['topomap']['seconds']:.0f}x" if naive else "-",
                "regions": by["topomap"]["regions"],
            }
        )
    print(markdown_table(rows, ["keyframes", "topomap_s", "naive_s", "speed-up", "regions"]))
    print(f"wrote {args.out}/results.json")
    return 0


def cmd_bench_maps(args: argparse.Namespace) -> int:
    from maps.errors import MapFileNotFoundError
    from topomap.cli.bench_maps import bench_command, bench_maps

    if args.command is not None:
        refuse_existing(Path(args.out), ["command.json"], args.force)
        records = bench_command(args.command, args.out, progress=args.progress, canvas=args.canvas)
        columns = ["map", "seconds", "cpu_s", "startup_s", "segmentation_s", "outputs_s"]
        mean = {c: round(sum(r[c] for r in records) / len(records), 3) for c in columns[1:]}
        print(markdown_table([*records, {"map": "mean", **mean}], columns))
        print(f"wrote {args.out}/command.json")
        return 0
    refuse_existing(Path(args.out), ["results.json"], args.force)
    logs = Path(args.logs) if args.logs else None
    if logs is not None and not logs.is_dir():
        raise MapFileNotFoundError(f"no such folder of CARMEN logs: {logs}")
    records = bench_maps(args.out, sizes=args.sizes, logs=logs, progress=args.progress)
    columns = ["map", "free_m2", "free_cells", "regions", "keyframes", "seconds", "cpu_seconds"]
    print(markdown_table(records, [*columns, "s_per_m_free_cells"]))
    print(f"wrote {args.out}/results.json")
    return 0


def cmd_bench_online(args: argparse.Namespace) -> int:
    from topomap.cli.bench_online import bench_online
    from topomap.errors import UsageError

    if "latency" in args.parts and args.keyframes <= args.seed_keyframes:
        raise UsageError(
            f"--keyframes must be more than --seed-keyframes ({args.seed_keyframes}): the "
            f"latency is of the keyframes after the seed, got {args.keyframes}"
        )
    drawn = ["latency.png"] if "latency" in args.parts else []
    refuse_existing(Path(args.out), ["results.json", *drawn], args.force)
    results = bench_online(
        args.out,
        parts=tuple(args.parts),
        progress=args.progress,
        keyframes=args.keyframes,
        seed_keyframes=args.seed_keyframes,
        building=args.building,
        offline_up_to=args.offline_up_to,
        logs_dir=args.logs,
        seed_fraction=args.seed_fraction,
        theta=args.theta,
        snapshots_dir=args.snapshots,
        method=args.online_method,
    )
    if "latency" in results:
        columns = ["keyframes_seen", "median_ms", "p95_ms", "max_ms", "cpu_median_ms"]
        columns += ["cpu_p95_ms", "cpu_max_ms", "offline_rerun_s", "regions"]
        batches = results["latency"]["batches"]
        step = max(1, len(batches) // 20)
        shown = batches[::step] + batches[-1:] if len(batches) > 1 else batches
        print(markdown_table(shown, columns))
        print(json.dumps(results["latency"]["summary"], indent=2))
    if "quality" in results:
        columns = ["run", "method", "keyframes", "seed_keyframes", "offline_regions"]
        columns += [
            "online_regions",
            "ari",
            "ari_online_resolution",
            "offline_across_resolutions",
            "churn",
            "mcc_offline",
            "mcc_online",
        ]
        columns += ["median_ms", "p95_ms", "max_ms"]
        print(markdown_table(results["quality"], columns))
    if "growing" in results:
        columns = ["map", "regions", "rose2_iou", "released_iou", "kept", "merged", "split"]
        columns += ["created", "removed", "rooms_unchanged", "ids_kept"]
        print(markdown_table(results["growing"], columns))
        unchanged = sum(r.get("rooms_unchanged", 0) for r in results["growing"])
        kept = sum(r.get("ids_kept", 0) for r in results["growing"])
        print(f"ids kept where the room did not change: {kept} of {unchanged}")
    print(f"wrote {args.out}/results.json" + (", latency.png" if "latency" in results else ""))
    return 0


def cmd_bench_plan(args: argparse.Namespace) -> int:
    from topomap.cli.bench import bench_plan
    from topomap.cli.plan_report import COLUMNS

    written = ["results.json", "results.md", "summary.json", "preprocessing.json", "times.png"]
    refuse_existing(Path(args.out), written, args.force)
    _, summary = bench_plan(
        args.out,
        sizes=tuple(args.sizes),
        maps_dir=args.maps,
        queries=args.queries,
        robot_radius=args.robot_radius,
        time_limit=args.time_limit,
        budget=args.budget,
        python_astar=args.python_astar,
        cache=None if args.no_cache else args.cache,
        robot=robot_spec(args),
        planners=None if args.planners is None else tuple(args.planners),
        progress=args.progress,
    )
    print(markdown_table(summary, COLUMNS))
    skipped = json.loads((Path(args.out) / "preprocessing.json").read_text())
    for name, pre in skipped.items():
        if pre["skipped_queries"]:
            print(f"{name}: skipped after the {args.budget:g} s budget: {pre['skipped_queries']}")
    print(f"wrote {args.out}/results.json, results.md, summary.json, preprocessing.json, times.png")
    print(f"wrote {args.out}/ompl/*.log (OMPL benchmark logs, for Planner Arena)")
    return 0


def cmd_bench_batch(args: argparse.Namespace) -> int:
    from topomap.cli.bench_batch import bench_batch

    refuse_existing(Path(args.out), ["results.json"], args.force)
    results = bench_batch(
        args.out,
        maps=args.maps,
        workers=args.workers,
        size=args.size,
        rounds=args.rounds,
        campus=args.campus,
    )
    columns = ["workers", "maps", "startup_s", "seconds", "maps_per_min", "speedup", "failed"]
    print(markdown_table(results["batch"], columns))
    if "campus_blocks" in results:
        campus = results["campus_blocks"]
        print(markdown_table(campus, list(campus[0])))
    print(f"wrote {args.out}/results.json")
    return 0
