"""``topomap map``: an occupancy map from a laser log or bag."""

from __future__ import annotations

import argparse
from pathlib import Path

from maps.files import OutputFolder
from topomap.cli.commands.common import (
    DISTANCE,
    KEYFRAME_DISTANCE,
    LENGTH,
    RESOLUTION,
    add_bag_options,
    add_output_options,
    add_picture_option,
    read_keyframes,
    refuse_existing,
)


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    build = sub.add_parser("map", help="build an occupancy map from a laser log or bag")
    build.add_argument("log", help="CARMEN log (.log, .gz) or ROS bag (.bag file, ROS 2 folder)")
    build.add_argument("--resolution", type=RESOLUTION, default=0.05, help="metres per cell")
    build.add_argument(
        "--distance", type=DISTANCE, default=KEYFRAME_DISTANCE, help="keyframe spacing, metres"
    )
    build.add_argument("--max-range", type=LENGTH, default=30.0, help="metres")
    build.add_argument("--scan-topic")
    build.add_argument("--pose-topic")
    add_bag_options(build, map_topic=False)
    add_output_options(build, force="overwrite existing map files")
    add_picture_option(build, "map.png")
    build.set_defaults(func=cmd_map)


def cmd_map(args: argparse.Namespace) -> int:
    from maps.mapping import grid_from_keyframes
    from maps.scan import poses_array, select_keyframes
    from topomap.cli.drawing import draw_map

    out = Path(args.out)
    names = ["map.yaml", "map.pgm", *([] if args.no_picture else ["map.png"])]
    refuse_existing(out, names, args.force)
    args.progress.stage(f"reading {args.log}")
    frames = read_keyframes(Path(args.log), args)
    keyframes = select_keyframes(frames, distance=args.distance)
    args.progress.stage(f"building the map from {len(keyframes)} keyframes")
    grid = grid_from_keyframes(keyframes, args.resolution, max_range=args.max_range)
    with OutputFolder(out, names, overwrite=args.force, how="--force") as work:
        grid.save(work / "map.yaml")
        if not args.no_picture:
            args.progress.stage("drawing map.png")
            draw_map(
                work / "map.png", grid, keyframes=poses_array(keyframes), title=Path(args.log).name
            )
    print(
        f"{len(frames)} scans, {len(keyframes)} keyframes -> {out / 'map.yaml'} "
        f"({grid.shape[1]} x {grid.shape[0]} cells)"
    )
    return 0
