"""``topomap export``: the route graphs for Nav2 and a ROS 2 bag for RViz and Foxglove."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from maps.files import check_output_file, check_outputs
from topomap.errors import ExportError, UsageError


def _point(topo: Any, planner: Any, end: tuple[float, ...] | int | str) -> Any:
    """A ``--path`` end: a point as given, a region (id or name) at its most open point."""
    if isinstance(end, tuple):
        return end
    return planner.centre(topo.region(end))


def run_export(args: argparse.Namespace) -> int:
    """Write every output asked for; all are checked before any work."""
    from planners.nav2_route import write_nav2_route
    from planners.route_graph import building_route_graph, planner_route_graph
    from topomap.cli.commands.common import load_map, map_inputs, refuse_inputs_as_outputs
    from topomap.rosbag_export import bag_files, write_rosbag

    outputs = [args.nav2_route, args.planner_graph, args.rosbag]
    if all(out is None for out in outputs):
        raise UsageError("export: give --nav2-route, --planner-graph and/or --rosbag")
    if args.path and args.rosbag is None:
        raise UsageError("--path draws planned paths into the bag: give --rosbag too")
    if args.storage is not None and args.rosbag is None:
        raise UsageError("--storage is the bag's: give --rosbag too")
    storage = args.storage or "mcap"
    refuse_inputs_as_outputs(outputs, map_inputs(args))
    files = [Path(out).resolve() for out in (args.nav2_route, args.planner_graph) if out]
    if args.rosbag is not None:
        bag = Path(args.rosbag).resolve()
        if any(file == bag or bag in file.parents for file in files):
            raise UsageError("--rosbag and the route graph files must be different paths")
    if len(set(files)) < len(files):
        raise UsageError("--nav2-route and --planner-graph must be different files")
    for out in (args.nav2_route, args.planner_graph):
        if out is not None:
            check_output_file(out, overwrite=args.force, how="--force")
    if args.rosbag is not None:
        names = bag_files(args.rosbag, storage)
        check_outputs(args.rosbag, names, overwrite=args.force, how="--force")
    topo = load_map(args)
    planner = topo.planner(args.robot_radius)
    paths = [  # planned before anything is written: a query that fails leaves no file
        planner.plan(_point(topo, planner, start), _point(topo, planner, goal))
        for start, goal in args.path or []
    ]
    graphs = {  # made before anything is written: an empty one leaves no file
        option: make(planner)
        for option, out, make in (
            ("--nav2-route", args.nav2_route, building_route_graph),
            ("--planner-graph", args.planner_graph, planner_route_graph),
        )
        if out is not None
    }
    for option, graph in graphs.items():
        if graph.number_of_nodes() == 0:
            raise ExportError(
                f"{option}: no region of {args.map} has room for a robot of radius "
                f"{args.robot_radius:g} m, the route graph would be empty"
            )
    if args.nav2_route is not None:
        route = graphs["--nav2-route"]
        write_nav2_route(route, args.nav2_route, overwrite=args.force)
        kinds = [kind["kind"] for _, kind in route.nodes(data="metadata")]
        doors = sum(len(d) for _, _, d in topo.graph.edges(data="doors"))
        print(
            f"wrote {args.nav2_route}: {kinds.count('door')} door nodes (of {doors} openings in "
            f"the region graph; the rest too narrow for the robot), {kinds.count('region')} "
            f"region nodes, {kinds.count('corner')} corner nodes, {route.number_of_edges()} "
            "straight edges (one per direction)"
        )
    if args.planner_graph is not None:
        fine = graphs["--planner-graph"]
        write_nav2_route(fine, args.planner_graph, overwrite=args.force)
        print(
            f"wrote {args.planner_graph}: the planner's portal graph, {fine.number_of_nodes()} "
            f"nodes, {fine.number_of_edges()} edges"
        )
    if args.rosbag is not None:
        written = write_rosbag(
            topo,
            args.rosbag,
            storage=storage,
            paths=paths,
            robot_radius=args.robot_radius,
            overwrite=args.force,
        )
        topics = f"map, regions, markers, route graph, {len(paths)} paths"
        print(f"wrote {written} ({storage}): {topics}")
    return 0
