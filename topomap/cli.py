"""The ``topomap`` command line."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

from maps.errors import MapsError


def _table(rows: list[dict[str, object]], columns: list[str]) -> str:
    """A markdown table of ``rows`` restricted to ``columns``."""
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(str(r[c]) for c in columns) + " |" for r in rows]
    return "\n".join(lines)


def _read_keyframes(source: Path, args: argparse.Namespace) -> list:
    from maps.carmen import read_carmen
    from maps.rosbag import read_rosbag

    if source.is_dir() or source.suffix in (".bag", ".mcap", ".db3"):
        return read_rosbag(source, scan_topic=args.scan_topic, pose_topic=args.pose_topic)
    return read_carmen(source)


def cmd_demo(args: argparse.Namespace) -> int:
    from topomap.demo import run_demo

    summary = run_demo(args.out, size=args.size, seed=args.seed)
    print(json.dumps(summary, indent=2))
    print(f"wrote {args.out}/summary.json and pictures")
    return 0


def cmd_map(args: argparse.Namespace) -> int:
    from maps.mapping import grid_from_keyframes
    from maps.scan import poses_array, select_keyframes
    from topomap.drawing import draw_map

    frames = _read_keyframes(Path(args.log), args)
    keyframes = select_keyframes(frames, distance=args.distance)
    grid = grid_from_keyframes(keyframes, args.resolution, max_range=args.max_range)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    grid.save(out / "map.yaml", overwrite=args.force)
    draw_map(out / "map.png", grid, keyframes=poses_array(keyframes), title=Path(args.log).name)
    print(
        f"{len(frames)} scans, {len(keyframes)} keyframes -> {out / 'map.yaml'} "
        f"({grid.shape[1]} x {grid.shape[0]} cells)"
    )
    return 0


def cmd_generate(args: argparse.Namespace) -> int:
    import cv2

    from maps.floorplan import generate_floor_plan

    plan = generate_floor_plan(
        args.size, resolution=args.resolution, furniture=args.furniture, random_state=args.seed
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    plan.grid.save(out / "map.yaml", overwrite=args.force)
    cv2.imwrite(str(out / "rooms.png"), plan.labels.astype("uint16"))
    (out / "rooms.json").write_text(
        json.dumps([{"id": i, "type": t} for i, t in enumerate(plan.types, start=1)], indent=1)
    )
    print(f"{plan.n_rooms} spaces, {len(plan.doors)} doors -> {out}")
    return 0


def cmd_bench_sim(args: argparse.Namespace) -> int:
    from topomap.bench import bench_sim

    records = bench_sim(args.out, scans=tuple(args.scans), beams=tuple(args.beams))
    print(_table(records, ["scans", "beams", "seconds", "scans_per_s", "rays_per_s"]))
    print(
        f"set-up (distance transform of {records[0]['map_cells']} cells): "
        f"{records[0]['setup_seconds']} s; wrote {args.out}/results.json"
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand."""
    parser = argparse.ArgumentParser(prog="topomap", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress")
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="run the whole pipeline on a generated building")
    demo.add_argument("--out", default="out/demo")
    demo.add_argument("--size", default="office", choices=["flat", "office", "campus"])
    demo.add_argument("--seed", type=int, default=0)
    demo.set_defaults(func=cmd_demo)

    build = sub.add_parser("map", help="build an occupancy map from a laser log or bag")
    build.add_argument("log", help="CARMEN log (.log, .gz) or ROS bag (.bag file, ROS 2 folder)")
    build.add_argument("--out", required=True)
    build.add_argument("--resolution", type=float, default=0.05, help="metres per cell")
    build.add_argument("--distance", type=float, default=0.5, help="keyframe spacing, metres")
    build.add_argument("--max-range", type=float, default=30.0, help="metres")
    build.add_argument("--scan-topic")
    build.add_argument("--pose-topic")
    build.add_argument("--force", action="store_true", help="overwrite existing map files")
    build.set_defaults(func=cmd_map)

    gen = sub.add_parser("generate", help="generate a building: map YAML + ground-truth rooms")
    gen.add_argument("--size", default="office", choices=["flat", "office", "campus"])
    gen.add_argument("--seed", type=int, default=0)
    gen.add_argument("--resolution", type=float, default=0.05)
    gen.add_argument("--furniture", type=float, default=0.0, help="blocks per 10 m^2")
    gen.add_argument("--out", required=True)
    gen.add_argument("--force", action="store_true", help="overwrite existing map files")
    gen.set_defaults(func=cmd_generate)

    bench = sub.add_parser("bench", help="benchmarks: print a table, write results.json")
    bench_sub = bench.add_subparsers(dest="bench", required=True)
    sim = bench_sub.add_parser("sim", help="laser simulator speed")
    sim.add_argument("--out", default="out/bench-sim")
    sim.add_argument("--scans", type=int, nargs="+", default=[1_000, 10_000])
    sim.add_argument("--beams", type=int, nargs="+", default=[181, 361])
    sim.set_defaults(func=cmd_bench_sim)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (2 for bad input)."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="%(levelname)s %(name)s: %(message)s",
    )
    try:
        return int(args.func(args))
    except (MapsError, FileNotFoundError, FileExistsError, ValueError) as err:
        print(f"topomap: error: {err}", file=sys.stderr)
        return 2
