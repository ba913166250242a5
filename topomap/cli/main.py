"""The ``topomap`` command line."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from maps.errors import TopomapError
from maps.files import OutputFolder, check_output_file, check_outputs, write_text
from maps.limits import MAX_LENGTH, MAX_ROBOT_RADIUS, RESOLUTION_RANGE, finite_in
from topomap.cli.progress import Progress
from topomap.errors import UsageError

#: The packages whose loggers ``-v`` turns to DEBUG (third-party loggers stay at WARNING).
PACKAGES = ("maps", "segmentation", "planners", "topomap")


def _table(rows: list[dict[str, object]], columns: list[str]) -> str:
    """A markdown table of ``rows`` restricted to ``columns``."""
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(str(r.get(c, "-")) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


def _read_keyframes(source: Path, args: argparse.Namespace) -> list:
    from maps.carmen import read_carmen
    from maps.rosbag import read_bag_scans

    if _is_bag(source):
        found = read_bag_scans(
            source,
            scan_topic=args.scan_topic,
            pose_topic=args.pose_topic,
            fixed_frame=args.fixed_frame,
        )
        print(f"{source}: {found.describe()}", file=sys.stderr)
        return found.keyframes
    return read_carmen(source)


def _is_bag(source: Path) -> bool:
    """A ROS 1 ``.bag`` or a ROS 2 bag folder."""
    return source.is_dir() or source.suffix in (".bag", ".mcap", ".db3")


def _add_bag_options(parser: argparse.ArgumentParser, *, map_topic: bool) -> None:
    """``--fixed-frame`` for scans in bags (and ``--map-topic``, ``--stamp`` for their maps)."""
    parser.add_argument(
        "--fixed-frame", help="place bag scans in this tf frame (default: map, else odom)"
    )
    if map_topic:
        parser.add_argument(
            "--map-topic", help="segment the bag's nav_msgs/OccupancyGrid on this topic"
        )
        parser.add_argument(
            "--stamp", type=float, help="with --map-topic: the last map at or before this time, s"
        )


def _refuse_existing(out: Path, names: Iterable[str], force: bool) -> None:
    """Stop before any work when a file the command would write exists and ``--force`` is
    not given, or when ``out`` or a file in it cannot be written (a file in the place of the
    folder, a folder in the place of a file)."""
    check_outputs(out, names, overwrite=force, how="--force")


def cmd_demo(args: argparse.Namespace) -> int:
    from topomap.cli.demo import run_demo, summary_rows

    summary = run_demo(
        args.out, size=args.size, seed=args.seed, jobs=args.jobs, on_stage=args.progress.stage
    )
    print(_table(summary_rows(summary), ["stage", "seconds", "result"]))
    names = summary["segment_plan"]["names"].values()
    print(
        "regions of the plan that are not rooms: "
        + ", ".join(n for n in names if not n.startswith("room "))
    )
    print(f"wrote {args.out}/summary.json (every number) and pictures")
    return 0


def cmd_map(args: argparse.Namespace) -> int:
    from maps.mapping import grid_from_keyframes
    from maps.scan import poses_array, select_keyframes
    from topomap.cli.drawing import draw_map

    out = Path(args.out)
    names = ["map.yaml", "map.pgm", "map.png"]
    _refuse_existing(out, names, args.force)
    args.progress.stage(f"reading {args.log}")
    frames = _read_keyframes(Path(args.log), args)
    keyframes = select_keyframes(frames, distance=args.distance)
    args.progress.stage(f"building the map from {len(keyframes)} keyframes")
    grid = grid_from_keyframes(keyframes, args.resolution, max_range=args.max_range)
    with OutputFolder(out, names, overwrite=args.force, how="--force") as work:
        grid.save(work / "map.yaml")
        draw_map(
            work / "map.png", grid, keyframes=poses_array(keyframes), title=Path(args.log).name
        )
    print(
        f"{len(frames)} scans, {len(keyframes)} keyframes -> {out / 'map.yaml'} "
        f"({grid.shape[1]} x {grid.shape[0]} cells)"
    )
    return 0


def cmd_generate(args: argparse.Namespace) -> int:
    import cv2

    from maps.floorplan import generate_floor_plan

    out = Path(args.out)
    names = ["map.yaml", "map.pgm", "rooms.png", "rooms.json"]
    _refuse_existing(out, names, args.force)
    args.progress.stage(f"generating a {args.size} building")
    plan = generate_floor_plan(
        args.size, resolution=args.resolution, furniture=args.furniture, random_state=args.seed
    )
    with OutputFolder(out, names, overwrite=args.force, how="--force") as work:
        plan.grid.save(work / "map.yaml")
        cv2.imwrite(str(work / "rooms.png"), plan.labels.astype("uint16"))
        rooms = [{"id": i, "type": t} for i, t in enumerate(plan.types, start=1)]
        write_text(work / "rooms.json", json.dumps(rooms, indent=1))
    print(f"{plan.n_rooms} spaces, {len(plan.doors)} doors -> {out}")
    return 0


def cmd_bench_sim(args: argparse.Namespace) -> int:
    from topomap.cli.bench import bench_sim

    _refuse_existing(Path(args.out), ["results.json"], args.force)
    records = bench_sim(
        args.out, scans=tuple(args.scans), beams=tuple(args.beams), progress=args.progress
    )
    print(_table(records, ["scans", "beams", "seconds", "scans_per_s", "rays_per_s"]))
    print(
        f"set-up (distance transform of {records[0]['map_cells']} cells): "
        f"{records[0]['setup_seconds']} s; wrote {args.out}/results.json"
    )
    return 0


def _segmenter_options(args: argparse.Namespace) -> dict[str, Any]:
    """The segmentation options of ``topomap segment``, ``eval segment`` and ``batch``."""
    return {
        "criterion": args.criterion,
        "k": args.k,
        "p": args.p,
        "spacing": args.spacing,
        "robot_radius": args.robot_radius,
        "clutter_size": args.clutter_size,
        "method": args.method,
        "contrast": args.contrast,
    }


def _segment_online(args: argparse.Namespace, out: Path) -> int:
    """``topomap segment --scans LOG --online``."""
    from maps.scan import select_keyframes
    from topomap.cli.online import segment_online

    if args.scans is None:
        raise UsageError("--online needs --scans LOG: keyframes arrive one by one from a log")
    if args.previous is not None:
        raise UsageError("--previous is for maps segmented whole, not with --online")
    args.progress.stage(f"reading {args.scans}")
    keyframes = select_keyframes(_read_keyframes(Path(args.scans), args), distance=args.distance)
    args.progress.stage(f"online segmentation of {len(keyframes)} keyframes")
    summary = segment_online(
        keyframes,
        out,
        source=args.scans,
        seed_keyframes=args.seed_keyframes,
        method=args.online_method,
        theta=args.theta,
        frames_every=args.frames,
        overwrite=args.force,
        progress=lambda items: args.progress(items, "keyframes"),
        criterion=args.criterion,
        k=args.k,
        p=args.p,
    )
    print(json.dumps(summary, indent=2))
    print(f"wrote {', '.join(summary['written'])}, summary.json to {out}")
    return 0


def cmd_segment(args: argparse.Namespace) -> int:
    from maps.grid import OccupancyGrid
    from maps.scan import select_keyframes
    from topomap.cli.drawing import draw_regions
    from topomap.topomap import SAVED, TopoMap

    out = Path(args.out)
    if args.online:
        return _segment_online(args, out)
    written_names = [*SAVED, "map.yaml", "map.pgm", "segmentation.png", "summary.json"]
    if args.scans is not None:
        written_names.append("keyframes.csv")
    if args.previous is not None:
        written_names.append("changes.json")
    _refuse_existing(out, written_names, args.force)
    previous = None if args.previous is None else TopoMap.load(args.previous)
    if args.scans is not None:
        frames = _read_keyframes(Path(args.scans), args)
        keyframes = select_keyframes(frames, distance=args.distance)
        options = {"on_stage": args.progress.stage, **_segmenter_options(args)}
        if previous is not None:
            from maps.mapping import grid_from_keyframes

            topo = previous.update(grid_from_keyframes(keyframes, 0.05), keyframes, **options)
        else:
            topo = TopoMap.from_keyframes(keyframes, **options)
        source = args.scans
    else:
        if args.map_topic is not None or _is_bag(Path(args.map)):
            from maps.rosbag import read_rosbag_map

            grid = read_rosbag_map(args.map, topic=args.map_topic, stamp=args.stamp)
        else:
            grid = OccupancyGrid.load(args.map)
        options = {"on_stage": args.progress.stage, **_segmenter_options(args)}
        topo = (
            TopoMap.from_grid(grid, **options)
            if previous is None
            else previous.update(grid, **options)
        )
        source = args.map
    folder = OutputFolder(out, written_names, overwrite=args.force, how="--force", last=SAVED[-1])
    with folder as work:  # every file appears at once; an interrupted run leaves none
        written = topo.save(work)
        if args.scans is not None:
            written.append(topo.save_keyframes(work / "keyframes.csv"))
        count = topo.graph.number_of_nodes()
        written.append(
            draw_regions(
                work / "segmentation.png",
                topo.grid,
                topo.regions.labels,
                topo.graph,
                title=f"{Path(source).name}: {count} regions",
            )
        )
        summary = _write_summary(work / "summary.json", topo, source, count)
        if previous is not None:
            write_text(work / "changes.json", json.dumps(topo.changes, indent=1))
            written.append(work / "changes.json")
    print(summary)
    print(f"wrote {', '.join(p.name for p in written)}, summary.json to {out}")
    return 0


def _write_summary(path: Path, topo: Any, source: str, count: int) -> str:
    """Write ``summary.json`` of ``topomap segment``; returns its text."""
    summary = {
        "source": str(source),
        "regions": count,
        "spectral_clusters": topo.segmenter.n_regions_,
        "keyframes": len(topo.keyframes),
        "conditioning": topo.conditioned.summary(),
        "coverage": {
            "filled_cells": topo.found.coverage.filled_cells,
            "rooms_seen_through_doors": topo.found.coverage.seen_rooms,
        },
        "doors": sum(len(d) for _, _, d in topo.graph.edges(data="doors")),
        "names": {int(r): name for r, name in sorted(topo.graph.nodes(data="name"))},
        "silhouette_by_k": {
            str(k): round(v, 4) for k, v in topo.segmenter.silhouette_by_k_.items()
        },
        "seconds": {k: round(v, 3) for k, v in topo.seconds.items()},
    }
    text = json.dumps(summary, indent=2)
    write_text(path, text)
    return text


def cmd_eval_segment(args: argparse.Namespace) -> int:
    from topomap.cli.evaluate import evaluate_all, means, read_anchors

    out = Path(args.out)
    _refuse_existing(out, ["results.json"], args.force)
    records = evaluate_all(args.data, progress=args.progress, **_segmenter_options(args))
    columns = ["map", "furnished", "variant", "segments", "rooms", "recall", "precision", "mcc"]
    columns += ["ari", "rose2_precision", "rose2_recall", "rose2_iou", "seconds"]
    print(_table(records, columns))
    print()
    summary = means(records, read_anchors(args.data))
    print(
        _table(
            summary,
            [
                *["method", "furnished", "maps", "recall", "precision", "mcc", "min_mcc", "ari"],
                *["rose2_precision", "rose2_recall", "rose2_iou", "mean_s", "max_s"],
            ],
        )
    )
    text = json.dumps({"maps": records, "means": summary}, indent=2)
    write_text(out / "results.json", text, overwrite=args.force)
    print(f"wrote {out / 'results.json'}")
    return 0


def cmd_eval_labels(args: argparse.Namespace) -> int:
    from topomap.cli.label_report import run

    _refuse_existing(Path(args.out), ["results.json"], args.force)
    run(args, _table)
    return 0


def cmd_bench_maps(args: argparse.Namespace) -> int:
    from maps.errors import MapFileNotFoundError
    from topomap.cli.bench_maps import bench_command, bench_maps

    if args.command is not None:
        _refuse_existing(Path(args.out), ["command.json"], args.force)
        records = bench_command(args.command, args.out, progress=args.progress)
        columns = ["map", "seconds", "startup_s", "segmentation_s", "outputs_s"]
        mean = {c: round(sum(r[c] for r in records) / len(records), 3) for c in columns[1:]}
        print(_table([*records, {"map": "mean", **mean}], columns))
        print(f"wrote {args.out}/command.json")
        return 0
    _refuse_existing(Path(args.out), ["results.json"], args.force)
    logs = Path(args.logs) if args.logs else None
    if logs is not None and not logs.is_dir():
        raise MapFileNotFoundError(f"no such folder of CARMEN logs: {logs}")
    records = bench_maps(args.out, sizes=args.sizes, logs=logs, progress=args.progress)
    columns = ["map", "free_m2", "free_cells", "regions", "keyframes", "seconds", "cpu_seconds"]
    print(_table(records, [*columns, "s_per_m_free_cells"]))
    print(f"wrote {args.out}/results.json")
    return 0


def cmd_bench_segment(args: argparse.Namespace) -> int:
    from topomap.cli.bench import bench_segment

    _refuse_existing(Path(args.out), ["results.json"], args.force)
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
    print(_table(rows, ["keyframes", "topomap_s", "naive_s", "speed-up", "regions"]))
    print(f"wrote {args.out}/results.json")
    return 0


def cmd_bench_online(args: argparse.Namespace) -> int:
    from topomap.cli.bench_online import bench_online

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
        print(_table(batches[::step] + batches[-1:] if len(batches) > 1 else batches, columns))
        print(json.dumps(results["latency"]["summary"], indent=2))
    if "quality" in results:
        columns = ["run", "method", "keyframes", "seed_keyframes", "offline_regions"]
        columns += ["online_regions", "ari", "churn", "mcc_offline", "mcc_online"]
        columns += ["median_ms", "p95_ms", "max_ms"]
        rows = [{c: r.get(c, "-") for c in columns} for r in results["quality"]]
        print(_table(rows, columns))
    if "growing" in results:
        columns = ["map", "regions", "rose2_iou", "released_iou", "kept", "merged", "split"]
        columns += ["created", "removed", "rooms_unchanged", "ids_kept"]
        rows = [{c: r.get(c, "-") for c in columns} for r in results["growing"]]
        print(_table(rows, columns))
        unchanged = sum(r.get("rooms_unchanged", 0) for r in results["growing"])
        kept = sum(r.get("ids_kept", 0) for r in results["growing"])
        print(f"ids kept where the room did not change: {kept} of {unchanged}")
    print(f"wrote {args.out}/results.json" + (", latency.png" if "latency" in results else ""))
    return 0


def cmd_bench_plan(args: argparse.Namespace) -> int:
    from planners.benchmark import markdown_table
    from topomap.cli.bench import bench_plan

    written = ["results.json", "results.md", "summary.json", "preprocessing.json", "times.png"]
    _refuse_existing(Path(args.out), written, args.force)
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
        robot=args.robot,
        progress=args.progress,
    )
    print(markdown_table(summary))
    skipped = json.loads((Path(args.out) / "preprocessing.json").read_text())
    for name, pre in skipped.items():
        if pre["skipped_queries"]:
            print(f"{name}: skipped after the {args.budget:g} s budget: {pre['skipped_queries']}")
    print(f"wrote {args.out}/results.json, results.md, summary.json, preprocessing.json, times.png")
    print(f"wrote {args.out}/ompl/*.log (OMPL benchmark logs, for Planner Arena)")
    return 0


def cmd_batch(args: argparse.Namespace) -> int:
    from topomap.cli.batch import BatchOptions, check_batch, dask_client, run_batch, tqdm_bar

    options = BatchOptions(
        distance=args.distance,
        resolution=args.resolution,
        scan_topic=args.scan_topic,
        fixed_frame=args.fixed_frame,
        map_topic=args.map_topic,
        stamp=args.stamp,
        segmenter=_segmenter_options(args),
    )
    # a bad input, output folder or address stops the command before a cluster starts
    check_batch(args.inputs, args.out, force=args.force, scheduler=args.scheduler)
    bar = None if getattr(args, "quiet", False) else tqdm_bar
    with dask_client(args.workers, args.scheduler) as client:
        records = run_batch(
            args.inputs, args.out, client=client, force=args.force, options=options, progress=bar
        )
    print(_table(records, ["name", "status", "regions", "keyframes", "seconds", "error"]))
    statuses = [r["status"] for r in records]
    print(
        f"{statuses.count('ok')} done, {statuses.count('skipped')} skipped (done before), "
        f"{statuses.count('failed')} failed; wrote {args.out}/index.csv and summary.json"
    )
    return 1 if "failed" in statuses else 0


def cmd_bench_batch(args: argparse.Namespace) -> int:
    from topomap.cli.bench_batch import bench_batch

    _refuse_existing(Path(args.out), ["results.json"], args.force)
    results = bench_batch(
        args.out,
        maps=args.maps,
        workers=args.workers,
        size=args.size,
        rounds=args.rounds,
        campus=args.campus,
    )
    columns = ["workers", "maps", "startup_s", "seconds", "maps_per_min", "speedup", "failed"]
    print(_table(results["batch"], columns))
    if "campus_blocks" in results:
        campus = results["campus_blocks"]
        print(_table(campus, list(campus[0])))
    print(f"wrote {args.out}/results.json")
    return 0


def _number(lo: float, hi: float, *, low_open: bool = False, unit: str = "m") -> Any:
    """An argparse type: a finite number in ``[lo, hi]`` (``(lo, hi]`` with ``low_open``),
    so a bad value is a usage error before any work."""

    def number(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
        problem = finite_in(value, "the value", lo, hi, unit=unit, low_open=low_open)
        if problem is not None:
            raise argparse.ArgumentTypeError(problem.replace("the value ", "", 1))
        return value

    return number


#: ``--robot-radius``, ``--resolution``, lengths and ranges in metres.
_RADIUS = _number(0.0, MAX_ROBOT_RADIUS, low_open=True)
_RESOLUTION = _number(*RESOLUTION_RANGE, unit="m per cell")
_LENGTH = _number(0.0, MAX_LENGTH, low_open=True)
_DISTANCE = _number(0.0, MAX_LENGTH)


def _pose(text: str) -> tuple[float, ...]:
    """``"X,Y"`` or ``"X,Y,YAW"`` (metres, radians) as floats (an argparse type)."""
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        values = ()
    if len(values) not in (2, 3):
        raise argparse.ArgumentTypeError(
            f"expected X,Y in metres, got {text!r} (or X,Y,YAW, radians)"
        )
    return values


def _goal(text: str) -> tuple[float, ...] | int | str:
    """``--goal``: ``X,Y`` (or ``X,Y,YAW``) is a point, a whole number a region id, anything
    else a name."""
    if "," in text:
        return _pose(text)
    return int(text) if text.strip().isdigit() else text


def _map(args: argparse.Namespace) -> Any:
    """The :class:`TopoMap` of ``args.map``: the regions in ``args.regions`` (a folder
    written by ``topomap segment``) or a segmentation made now."""
    from maps.grid import OccupancyGrid
    from topomap.topomap import TopoMap

    grid = OccupancyGrid.load(args.map)
    if args.regions is not None:
        topo = TopoMap.load(args.regions)
        if topo.grid != grid:
            raise UsageError(f"{args.regions} holds the regions of another map than {args.map}")
        return topo
    args.progress.stage(f"segmenting {args.map}")
    return TopoMap.from_grid(grid)


def cmd_export(args: argparse.Namespace) -> int:
    from topomap.cli.export import run_export

    return run_export(args)


def cmd_view(args: argparse.Namespace) -> int:
    from topomap.cli.viewer import run_view

    return run_view(args)


def cmd_plan(args: argparse.Namespace) -> int:
    from planners.flat import FlatPlanner
    from planners.robots import Disc, parse_robot
    from topomap.cli.drawing import draw_paths
    from topomap.labels import find_region

    if args.draw is not None:
        check_output_file(args.draw, overwrite=args.force, how="--force")
    robot = Disc(args.robot_radius) if args.robot is None else parse_robot(args.robot)
    topo = _map(args)
    start, goal = args.start, args.goal
    if not isinstance(goal, tuple):
        goal = find_region(topo.graph, goal)
    if isinstance(robot, Disc):
        if len(start) == 3 or (isinstance(goal, tuple) and len(goal) == 3):
            raise UsageError("a disc robot has no heading: give --start and --goal as X,Y")
        planner: Any = topo.planner(robot.radius)
        flat: Any = FlatPlanner(planner.space) if args.compare else None
    else:
        from planners.kinematic import FlatKinematicPlanner

        planner = topo.kinematic_planner(args.robot)
        flat = FlatKinematicPlanner(planner.cspace) if args.compare else None
    path = planner.plan(start, goal)
    result = path.to_dict()
    result["region_names"] = [topo.graph.nodes[r].get("name", str(r)) for r in path.regions]
    if args.draw is not None:
        paths = {"hierarchical": path}
        if flat is not None:
            ends = path.poses if path.headings is not None else path.waypoints
            paths["flat RRTConnect"] = flat.plan(ends[0], ends[-1])
        draw_paths(args.draw, topo.grid, planner.labels, paths, title=Path(args.map).name)
    print(json.dumps(result))
    return 0


ROBOT_HELP = (
    "robot model: disc:R, rect:LxW (turns in place), dubins:radius=R,footprint=LxW, "
    "reeds-shepp:radius=R,footprint=LxW (metres; a disc of --robot-radius by default)"
)


def _add_segmenter_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--method",
        default="spectral",
        choices=["spectral", "doors"],
        help="regions from the spectral partition (default) or the door-rule baseline",
    )
    parser.add_argument(
        "--criterion", default="nn", choices=["nn", "hausdorff", "features", "view"]
    )
    parser.add_argument(
        "--contrast",
        type=float,
        default=2.0,
        help="how much a narrow passage weakens the affinity across it (0: similarity alone)",
    )
    parser.add_argument(
        "--k", type=int, help="guess of the number of regions (default: clearance basins)"
    )
    parser.add_argument("--p", type=float, default=0.3, help="sparsification parameter in [0, 1)")
    parser.add_argument(
        "--spacing", type=_LENGTH, default=2.0, help="virtual keyframe lattice on a map, metres"
    )
    parser.add_argument(
        "--robot-radius",
        type=_RADIUS,
        default=0.2,
        help="free space thinner than the robot is dropped, metres",
    )
    parser.add_argument(
        "--clutter-size",
        type=_LENGTH,
        default=2.0,
        help="free-standing obstacles smaller than this are clutter, not walls, metres",
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand."""
    parser = argparse.ArgumentParser(prog="topomap", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="run the whole pipeline on a generated building")
    demo.add_argument("--out", default="out/demo")
    demo.add_argument("--size", default="office", choices=["flat", "office", "campus"])
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument(
        "--jobs", type=int, default=2, help="processes for the stages that run side by side"
    )
    demo.set_defaults(func=cmd_demo)

    build = sub.add_parser("map", help="build an occupancy map from a laser log or bag")
    build.add_argument("log", help="CARMEN log (.log, .gz) or ROS bag (.bag file, ROS 2 folder)")
    build.add_argument("--out", required=True)
    build.add_argument("--resolution", type=_RESOLUTION, default=0.05, help="metres per cell")
    build.add_argument("--distance", type=_DISTANCE, default=0.5, help="keyframe spacing, metres")
    build.add_argument("--max-range", type=_LENGTH, default=30.0, help="metres")
    build.add_argument("--scan-topic")
    build.add_argument("--pose-topic")
    _add_bag_options(build, map_topic=False)
    build.add_argument("--force", action="store_true", help="overwrite existing map files")
    build.set_defaults(func=cmd_map)

    gen = sub.add_parser("generate", help="generate a building: map YAML + ground-truth rooms")
    gen.add_argument("--size", default="office", choices=["flat", "office", "campus"])
    gen.add_argument("--seed", type=int, default=0)
    gen.add_argument("--resolution", type=_RESOLUTION, default=0.05)
    gen.add_argument("--furniture", type=float, default=0.0, help="blocks per 10 m^2")
    gen.add_argument("--out", required=True)
    gen.add_argument("--force", action="store_true", help="overwrite existing map files")
    gen.set_defaults(func=cmd_generate)

    seg = sub.add_parser("segment", help="segment a map or a laser log into regions")
    source = seg.add_mutually_exclusive_group(required=True)
    source.add_argument("map", nargs="?", help="map_server YAML")
    source.add_argument("--scans", help="CARMEN log or ROS bag instead of a map")
    seg.add_argument("--out", required=True)
    seg.add_argument("--distance", type=_DISTANCE, default=0.5, help="keyframe spacing in a log, m")
    seg.add_argument("--scan-topic")
    seg.add_argument("--pose-topic")
    _add_bag_options(seg, map_topic=True)
    seg.add_argument("--force", action="store_true", help="overwrite existing files")
    _add_segmenter_options(seg)
    seg.add_argument(
        "--online", action="store_true", help="with --scans: assign keyframes as they come"
    )
    seg.add_argument(
        "--online-method",
        default="windows",
        choices=["windows", "centres"],
        help="--online: the offline engine on the robot's neighbourhood, or the paper's centres",
    )
    seg.add_argument(
        "--seed-keyframes",
        type=int,
        help="--online: keyframes segmented offline first (default 10%% of the log, at least 40)",
    )
    seg.add_argument(
        "--theta", type=float, default=0.5, help="--online-method centres: acceptance, in [0, 1]"
    )
    seg.add_argument("--frames", type=int, help="a picture every N keyframes and regions.gif")
    seg.add_argument(
        "--previous",
        metavar="DIR",
        help="the output of an earlier map of this building: continued regions keep their ids",
    )
    seg.set_defaults(func=cmd_segment)

    evaluation = sub.add_parser("eval", help="evaluations against ground truth")
    eval_sub = evaluation.add_subparsers(dest="evaluation", required=True)
    eval_seg = eval_sub.add_parser(
        "segment", help="room segmentation against people's rooms (ipa plans, ROSE² maps)"
    )
    eval_seg.add_argument(
        "data", help="folder of map YAMLs with *_gt_labels.png, or of maps/ and gt/ (ROSE²)"
    )
    eval_seg.add_argument("--out", default="out/eval-segment")
    eval_seg.add_argument("--force", action="store_true", help="overwrite existing results")
    _add_segmenter_options(eval_seg)
    eval_seg.set_defaults(func=cmd_eval_segment)

    eval_labels = eval_sub.add_parser(
        "labels", help="region labels on labelled buildings, whole buildings left out"
    )
    eval_labels.add_argument("data", help="folder of NAME.png with NAME_places.png (ipa_places)")
    eval_labels.add_argument("--rose2", metavar="DIR", help="ROSE²'s maps (rose2_partial)")
    eval_labels.add_argument("--carmen", metavar="DIR", help="folder of the four CARMEN logs")
    eval_labels.add_argument(
        "--generated", action="store_true", help="also generated buildings (plans and scanned)"
    )
    eval_labels.add_argument(
        "--hand-labels",
        default="tests/data/labels",
        metavar="DIR",
        help="rose2_partial.csv and carmen.json: the room types drawn by hand",
    )
    eval_labels.add_argument("--out", default="out/eval-labels")
    eval_labels.add_argument("--force", action="store_true", help="overwrite existing results")
    eval_labels.add_argument(
        "--save-model", metavar="SKOPS", help="write a forest trained on all labelled regions"
    )
    eval_labels.set_defaults(func=cmd_eval_labels)

    bench = sub.add_parser("bench", help="benchmarks: print a table, write results.json")
    bench_sub = bench.add_subparsers(dest="bench", required=True)
    sim = bench_sub.add_parser("sim", help="laser simulator speed")
    sim.add_argument("--out", default="out/bench-sim")
    sim.add_argument("--force", action="store_true", help="overwrite existing results")
    sim.add_argument("--scans", type=int, nargs="+", default=[1_000, 10_000])
    sim.add_argument("--beams", type=int, nargs="+", default=[181, 361])
    sim.set_defaults(func=cmd_bench_sim)
    seg_bench = bench_sub.add_parser("segment", help="spectral partition speed against naive")
    seg_bench.add_argument("--out", default="out/bench-segment")
    seg_bench.add_argument("--force", action="store_true", help="overwrite existing results")
    seg_bench.add_argument("--sizes", type=int, nargs="+", default=[1_000, 2_000, 5_000, 10_000])
    seg_bench.add_argument("--naive-up-to", type=int, default=2_000)
    seg_bench.add_argument("--building", default="campus", choices=["flat", "office", "campus"])
    seg_bench.set_defaults(func=cmd_bench_segment)
    maps_bench = bench_sub.add_parser("maps", help="the whole segmentation over map sizes")
    maps_bench.add_argument("--out", default="out/bench-maps")
    maps_bench.add_argument("--force", action="store_true", help="overwrite existing results")
    maps_bench.add_argument(
        "--sizes", nargs="*", default=["flat", "office", "campus"], help="generated buildings"
    )
    maps_bench.add_argument("--logs", help="a folder of CARMEN *.log.gz: maps built from them")
    maps_bench.add_argument(
        "--command",
        metavar="DATA_DIR",
        help="time `topomap segment` itself on every map of DATA_DIR (ipa or ROSE² layout)",
    )
    maps_bench.set_defaults(func=cmd_bench_maps)
    online_bench = bench_sub.add_parser("online", help="online segmentation: latency, agreement")
    online_bench.add_argument("--out", default="out/bench-online")
    online_bench.add_argument(
        "--parts",
        nargs="+",
        default=["latency", "quality", "growing"],
        choices=["latency", "quality", "growing"],
    )
    online_bench.add_argument("--keyframes", type=int, default=10_000, help="of the long run")
    online_bench.add_argument("--seed-keyframes", type=int, default=500, help="long run's seed")
    online_bench.add_argument("--building", default="campus", choices=["flat", "office", "campus"])
    online_bench.add_argument(
        "--offline-up-to", type=int, default=2_000, help="re-run offline every 100 up to this"
    )
    online_bench.add_argument(
        "--online-method", default="windows", choices=["windows", "centres"], help="long run's"
    )
    online_bench.add_argument("--logs", default="../shared/data/carmen", help="CARMEN logs")
    online_bench.add_argument(
        "--snapshots", default="../shared/data/rose2_partial", help="growing-map snapshots"
    )
    online_bench.add_argument(
        "--seed-fraction",
        type=float,
        help="quality runs: share of keyframes seeded (default 10 %%, at least 40)",
    )
    online_bench.add_argument("--theta", type=float, default=0.5, help="in [0, 1]")
    online_bench.set_defaults(func=cmd_bench_online)
    plan_bench = bench_sub.add_parser("plan", help="hierarchical against flat planning")
    plan_bench.add_argument("--out", default="out/bench-plan")
    plan_bench.add_argument("--force", action="store_true", help="overwrite existing results")
    plan_bench.add_argument("--maps", help="also every map YAML in this folder")
    plan_bench.add_argument(
        "--sizes", nargs="*", default=["flat", "office", "campus"], help="generated buildings"
    )
    plan_bench.add_argument("--queries", type=int, default=30, help="per map")
    plan_bench.add_argument("--robot-radius", type=float, default=0.2, help="metres")
    plan_bench.add_argument("--time-limit", type=float, default=20.0, help="flat planners, s")
    plan_bench.add_argument(
        "--budget", type=float, default=30.0, help="query seconds per planner and map, then skip"
    )
    plan_bench.add_argument(
        "--python-astar", action="store_true", help="also the pure-Python grid A* (reference)"
    )
    plan_bench.add_argument("--cache", default="out/cache/exact", help="exact-reference cache")
    plan_bench.add_argument("--no-cache", action="store_true", help="recompute the reference")
    plan_bench.add_argument("--robot", help=ROBOT_HELP)
    plan_bench.set_defaults(func=cmd_bench_plan)

    from topomap.cli.batch import worker_count

    batch = sub.add_parser("batch", help="segment many maps, logs and bags on a Dask cluster")
    batch.add_argument("inputs", nargs="+", help="map YAMLs, logs, bags, folders or globs")
    batch.add_argument("--out", required=True, help="one folder per input, index.csv, summary.json")
    batch.add_argument("--workers", type=worker_count, default=2, help="local worker processes")
    batch.add_argument("--scheduler", help="address of a running Dask scheduler (tcp://host:8786)")
    batch.add_argument("--force", action="store_true", help="redo inputs already done")
    batch.add_argument(
        "--distance", type=_DISTANCE, default=0.5, help="keyframe spacing in a log, m"
    )
    batch.add_argument(
        "--resolution", type=_RESOLUTION, default=0.05, help="maps from logs, m/cell"
    )
    batch.add_argument("--scan-topic")
    _add_bag_options(batch, map_topic=True)
    _add_segmenter_options(batch)
    batch.set_defaults(func=cmd_batch)
    batch_bench = bench_sub.add_parser("batch", help="topomap batch: maps per minute, 1-2 workers")
    batch_bench.add_argument("--out", default="out/bench-batch")
    batch_bench.add_argument("--force", action="store_true", help="overwrite existing results")
    batch_bench.add_argument("--maps", type=int, default=24, help="generated buildings")
    batch_bench.add_argument("--size", default="flat", choices=["flat", "office"])
    batch_bench.add_argument("--workers", type=worker_count, nargs="+", default=[1, 2])
    batch_bench.add_argument("--rounds", type=worker_count, default=2, help="turns per count")
    batch_bench.add_argument(
        "--campus", action="store_true", help="also the block-wise campus segmentation"
    )
    batch_bench.set_defaults(func=cmd_bench_batch)

    plan = sub.add_parser("plan", help="plan a path on a map, print it as JSON")
    plan.add_argument("map", help="map_server YAML")
    plan.add_argument(
        "--start", required=True, type=_pose, help="X,Y in metres (X,Y,YAW with --robot)"
    )
    plan.add_argument("--goal", required=True, type=_goal, help="X,Y[,YAW], a region id or a name")
    plan.add_argument("--regions", help="folder written by `topomap segment` (else segment now)")
    plan.add_argument("--robot-radius", type=_RADIUS, default=0.2, help="disc robot, metres")
    plan.add_argument("--robot", help=ROBOT_HELP)
    plan.add_argument("--draw", help="write a PNG of the path")
    plan.add_argument("--force", action="store_true", help="overwrite an existing --draw file")
    plan.add_argument(
        "--compare", action="store_true", help="also draw a flat RRTConnect path (with --draw)"
    )
    plan.set_defaults(func=cmd_plan)

    export = sub.add_parser("export", help="route graphs for Nav2, a ROS 2 bag for RViz/Foxglove")
    export.add_argument("map", help="map_server YAML")
    export.add_argument("--regions", help="folder written by `topomap segment` (else segment now)")
    export.add_argument(
        "--nav2-route", help="OUT.geojson: the building's route graph (doors, regions)"
    )
    export.add_argument(
        "--planner-graph", help="OUT.geojson: the planner's internal portal graph (debugging)"
    )
    export.add_argument("--rosbag", help="OUT: a ROS 2 bag folder (map, regions, markers)")
    export.add_argument("--storage", default="mcap", choices=["mcap", "sqlite3"])
    export.add_argument(
        "--path",
        nargs=2,
        action="append",
        type=_goal,
        metavar=("FROM", "TO"),
        help="a planned path into the bag: X,Y or a region id or name at each end (repeatable)",
    )
    export.add_argument("--robot-radius", type=_RADIUS, default=0.2, help="metres")
    export.add_argument("--force", action="store_true", help="overwrite existing files")
    export.set_defaults(func=cmd_export)

    view = sub.add_parser("view", help="one self-contained HTML page of a map, for a browser")
    view.add_argument("regions", help="folder written by `topomap segment`")
    view.add_argument("--out", required=True, help="OUT.html")
    view.add_argument("--robot-radius", type=_RADIUS, default=0.2, help="metres")
    view.add_argument(
        "--max-paths",
        type=int,
        default=400,
        help="plan every pair of regions up to this many pairs, else neighbours' legs",
    )
    view.add_argument("--force", action="store_true", help="overwrite an existing file")
    view.set_defaults(func=cmd_view)
    _add_output_options(parser)
    parser.set_defaults(verbose=False, quiet=False)
    return parser


def _add_output_options(parser: argparse.ArgumentParser) -> None:
    """``-v`` and ``-q`` on ``parser`` and every subcommand, so they work before and after
    it (SUPPRESS: a subcommand's default does not undo what was given before it)."""
    parser.add_argument(
        "-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="debug logging"
    )
    parser.add_argument(
        "-q", "--quiet", action="store_true", default=argparse.SUPPRESS, help="no progress"
    )
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for subcommand in action.choices.values():
                _add_output_options(subcommand)


def run() -> None:
    """The console script: :func:`main`'s status is the exit status."""
    sys.exit(main())


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status.

    Bad input (any :class:`~maps.errors.TopomapError`: a missing or malformed file, a value
    out of range, a file that would be overwritten) ends with one line on stderr and status
    2, as do usage errors; anything else is a bug and keeps its traceback.
    """
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as done:  # a usage error (2) or --help (0), already printed
        return int(done.code or 0)
    logging.basicConfig(format="%(levelname)s %(name)s: %(message)s")
    if args.verbose:
        for package in PACKAGES:
            logging.getLogger(package).setLevel(logging.DEBUG)
    args.progress = Progress(quiet=args.quiet)
    try:
        return int(args.func(args))
    except TopomapError as err:
        print(f"topomap: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # outputs are written under temporary names: none is half done
        print("topomap: interrupted; no output was left half-written", file=sys.stderr)
        return 130
