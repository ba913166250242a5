"""``topomap plan``: a path on a map, printed as JSON."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from maps.files import check_output_file
from topomap.cli.commands.common import (
    RADIUS,
    add_robot_options,
    load_map,
    map_inputs,
    point_or_region,
    refuse_inputs_as_outputs,
    robot_spec,
)
from topomap.errors import UsageError


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add the command to the subcommands ``sub``."""
    plan = sub.add_parser("plan", help="plan a path on a map, print it as JSON")
    plan.add_argument("map", help="map_server YAML")
    plan.add_argument(
        "--start",
        required=True,
        type=point_or_region,
        help="X,Y in metres (X,Y,YAW with --robot), a region id or a name",
    )
    plan.add_argument(
        "--goal", required=True, type=point_or_region, help="X,Y[,YAW], a region id or a name"
    )
    plan.add_argument("--regions", help="folder written by `topomap segment` (else segment now)")
    plan.add_argument("--robot-radius", type=RADIUS, default=0.2, help="disc robot, metres")
    add_robot_options(plan)
    plan.add_argument("--draw", help="write a PNG of the path")
    plan.add_argument("--force", action="store_true", help="overwrite an existing --draw file")
    plan.add_argument(
        "--compare", action="store_true", help="also draw a flat RRTConnect path (with --draw)"
    )
    plan.set_defaults(func=cmd_plan)


def cmd_plan(args: argparse.Namespace) -> int:
    from planners.robots import Disc, parse_robot
    from topomap.labels import find_region

    if args.compare and args.draw is None:
        raise UsageError("--compare draws a flat RRTConnect path beside this one: give --draw too")
    if args.draw is not None:
        if Path(args.draw).suffix.lower() != ".png":
            raise UsageError(
                f"--draw {args.draw!r}: the picture is a PNG, give a name ending in .png"
            )
        refuse_inputs_as_outputs([args.draw], map_inputs(args))
        check_output_file(args.draw, overwrite=args.force, how="--force")
    spec = robot_spec(args)
    robot = Disc(args.robot_radius) if spec is None else parse_robot(spec)
    topo = load_map(args)
    start, goal = args.start, args.goal
    if not isinstance(robot, Disc) and not isinstance(start, tuple):
        raise UsageError("a robot with a footprint starts at a pose: give --start as X,Y,YAW")
    if isinstance(robot, Disc) and any(isinstance(e, tuple) and len(e) == 3 for e in (start, goal)):
        raise UsageError("a disc robot has no heading: give --start and --goal as X,Y")
    start, goal = (e if isinstance(e, tuple) else find_region(topo.graph, e) for e in (start, goal))
    if isinstance(robot, Disc):
        planner: Any = topo.planner(robot.radius)
        for end, what in ((start, "start"), (goal, "goal")):
            if isinstance(end, tuple):  # refused before a large map's minute of preparing
                planner.space.check(end, what)
        if not planner.restored:
            _prepare(args, topo, planner)
    else:
        planner = topo.kinematic_planner(robot)
    path = planner.plan(start, goal)
    result = path.to_dict()
    result["region_names"] = [topo.graph.nodes[r].get("name", str(r)) for r in path.regions]
    if args.draw is not None:
        from topomap.cli.drawing import draw_paths

        paths = {"hierarchical": path}
        if args.compare:
            paths["flat RRTConnect"] = _flat(planner, path)
        draw_paths(args.draw, topo.grid, planner.labels, paths, title=Path(args.map).name)
    print(json.dumps(result))
    return 0


def _prepare(args: argparse.Namespace, topo: Any, planner: Any) -> None:
    """Prepare the disc robot's planner with a progress bar and, for regions read from a
    folder, keep it there for the next runs (:func:`topomap.saving.save_door_graph`)."""
    from topomap.saving import save_door_graph

    radius = planner.space.robot_radius
    args.progress.stage(f"preparing the planner for a {radius:g} m robot")
    planner.prepare(lambda parts: args.progress(parts, "submaps"))
    if topo.source is None:
        return
    try:
        kept = save_door_graph(topo, radius)
    except OSError as err:
        args.progress.line(f"the prepared planner is not kept in {topo.source}: {err}")
    else:
        args.progress.line(f"kept the prepared planner in {kept} for the next runs")


def _flat(planner: Any, path: Any) -> Any:
    """Flat RRTConnect's path between the ends of ``path`` in ``planner``'s space."""
    if path.headings is None:
        from planners.flat import FlatPlanner

        return FlatPlanner(planner.space).plan(path.waypoints[0], path.waypoints[-1])
    from planners.kinematic import FlatKinematicPlanner

    return FlatKinematicPlanner(planner.cspace).plan(path.poses[0], path.poses[-1])
