"""``topomap export``: route graphs for Nav2, a ROS 2 bag for RViz and Foxglove."""

from __future__ import annotations

import argparse

from topomap.cli.commands.common import RADIUS, output_path, point_or_region


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    export = sub.add_parser("export", help="route graphs for Nav2, a ROS 2 bag for RViz/Foxglove")
    export.add_argument("map", help="map_server YAML")
    export.add_argument("--regions", help="folder written by `topomap segment` (else segment now)")
    export.add_argument(
        "--nav2-route",
        type=output_path,
        help="OUT.geojson: the building's route graph (doors, regions)",
    )
    export.add_argument(
        "--planner-graph",
        type=output_path,
        help="OUT.geojson: the planner's internal portal graph (debugging)",
    )
    export.add_argument(
        "--rosbag", type=output_path, help="OUT: a ROS 2 bag folder (map, regions, markers)"
    )
    export.add_argument(
        "--storage", choices=["mcap", "sqlite3"], help="--rosbag: its storage (default mcap)"
    )
    export.add_argument(
        "--path",
        nargs=2,
        action="append",
        type=point_or_region,
        metavar=("FROM", "TO"),
        help="a planned path into the bag: X,Y or a region id or name at each end (repeatable)",
    )
    export.add_argument("--robot-radius", type=RADIUS, default=0.2, help="metres")
    export.add_argument("--force", action="store_true", help="overwrite existing files")
    export.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    from topomap.cli.export import run_export

    return run_export(args)
