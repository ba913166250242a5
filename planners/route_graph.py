"""The building's route graph: a node per real door and per region, straight edges in free space.

Door nodes sit in the middle of every opening between two regions of the region graph where
the robot fits (one per opening, however wide); region nodes at each region's most open
point. Inside each region the exact shortest paths between all its nodes (the region's
visibility graph, :class:`~planners.visibility.VisibilityGraph`) are joined into one graph:
their bends are ``corner`` nodes shared by the paths through them, so every edge is a straight
segment a robot can follow. That is what the Nav2 route server needs: it drives the straight
line between an edge's two nodes and never reads an edge's geometry. The union holds every
shortest path, so route lengths over the graph are the exact shortest lengths through the
regions' doors.

Nodes carry ``x``, ``y`` (map frame, metres), ``frame`` and ``metadata``
(``kind``: ``door`` with ``regions``, ``region_names``, ``door_width_m`` (the opening)
and ``passable_width_m`` (the part of it the robot's centre can cross); ``region`` with
``region``, ``name``, ``label`` and ``area_m2``; ``corner`` with ``region``). Directed edges,
one per direction, carry ``id``, ``cost`` (the segment's length), ``overridable`` (true: the
route server's scorers may price it), ``line`` (its two ends) and ``metadata`` (the region
crossed: ``region``, ``name``, ``label``).

Examples
--------
Two 4 x 4 m rooms, the wall between them (in no region) open over 0.8 m, for a robot of
radius 0.1 m:

>>> import networkx as nx
>>> import numpy as np
>>> from maps.grid import OccupancyGrid
>>> from planners.hierarchical import HierarchicalPlanner
>>> from planners.workspace import Workspace
>>> cells = np.zeros((40, 80), np.int8)
>>> cells[:, 39:41] = 100
>>> cells[18:26, 39:41] = 0  # the doorway
>>> labels = np.where(np.arange(80) < 40, 1, 2)[None].repeat(40, 0)
>>> labels[cells == 100] = 0
>>> space = Workspace(OccupancyGrid(cells, resolution=0.1), 0.1)
>>> planner = HierarchicalPlanner(space, labels, nx.Graph([(1, 2)]))
>>> [(door.a, door.b, round(door.width, 6)) for door in region_doors(planner)]
[(1, 2, 0.6)]
>>> route = building_route_graph(planner)
>>> [route.nodes[n]["metadata"]["kind"] for n in route]
['door', 'region', 'region']
>>> door = route.nodes[0]["metadata"]
>>> round(door["door_width_m"], 6), round(door["passable_width_m"], 6), len(route.edges)
(0.8, 0.6, 4)
>>> sorted({kind["kind"] for _, kind in planner_route_graph(planner).nodes(data="metadata")})
['portal', 'region']
"""

from __future__ import annotations

import contextlib
import itertools
import math
from typing import Any

import networkx as nx
import numpy as np

from maps.geometry import polyline_length
from planners.doors import Door, find_doors
from planners.errors import PlanningError
from planners.hierarchical import HierarchicalPlanner
from planners.visibility import VisibilityGraph
from planners.workspace import Point
from segmentation.transitions import find_transitions


def region_doors(planner: HierarchicalPlanner) -> list[Door]:
    """One door per opening between two regions of the planner's labels (every free cell in
    a region) where its robot fits (see the module's example).
    """
    openings = find_transitions(planner.space.grid, planner.labels)
    return find_doors(planner.space, planner.labels, openings, spacing=math.inf)


def region_point(planner: HierarchicalPlanner, region: int) -> Point | None:
    """The region graph's most open point of ``region`` if the robot fits there, else the
    point of the region farthest from walls for the robot; None if it fits nowhere in it."""
    data = planner.graph.nodes[region]
    candidates = [(float(data["x"]), float(data["y"]))] if "x" in data else []
    with contextlib.suppress(PlanningError):
        candidates.append(planner.centre(region))
    for x, y in candidates:
        if planner.region_at(x, y) == region and planner.space.point_free(x, y):
            return (x, y)
    return None


def building_route_graph(planner: HierarchicalPlanner) -> nx.DiGraph:
    """The route graph of the building of ``planner`` (see the module's text and example)."""
    regions = planner.graph
    names, labels = _names(regions)
    route = nx.DiGraph(frame="map")
    doors = region_doors(planner)
    sites: dict[int, list[int]] = {region: [] for region in sorted(regions.nodes)}
    for node, door in enumerate(doors):
        metadata = {
            "kind": "door",
            "regions": [door.a, door.b],
            "region_names": [names[door.a], names[door.b]],
            "door_width_m": door.opening.width,
            "passable_width_m": door.width,
        }
        _add_node(route, node, door.point, metadata)
        sites[door.a].append(node)
        sites[door.b].append(node)
    cells = np.bincount(planner.labels.ravel(), minlength=max(sites, default=0) + 1)
    for region in sites:
        point = region_point(planner, region)
        if point is None:
            continue  # a region too narrow for the robot has no node
        node = route.number_of_nodes()
        metadata = {"kind": "region", "region": region, "name": names[region]}
        area = regions.nodes[region].get(
            "area_m2", cells[region] * planner.space.grid.resolution**2
        )
        metadata |= {"label": labels[region], "area_m2": float(area)}
        _add_node(route, node, point, metadata)
        sites[region].append(node)
    for region, nodes in sites.items():
        about = {"region": region, "name": names[region], "label": labels[region]}
        _join_in_region(planner, route, region, nodes, about)
    return _number_edges(route)


def planner_route_graph(planner: HierarchicalPlanner) -> nx.DiGraph:
    """The hierarchical planner's door graph over its near-convex submaps (every door open)
    as a route graph: a ``portal`` node per door between submaps (one per metre of opening,
    internal cuts of a region included), a ``region`` node per region, and an edge per
    direction whose ``line`` is the shortest path inside the submap it crosses (not straight:
    the route server would cut its corners; give it :func:`building_route_graph`; see the
    module's example).
    """
    planner.prepare()
    names, labels = _names(planner.graph)
    route = nx.DiGraph(frame="map")
    for index, door in enumerate(planner.doors):
        regions = sorted({planner.region_of[door.a], planner.region_of[door.b]})
        metadata = {"kind": "portal", "regions": regions, "door_width_m": door.width}
        _add_node(
            route, index, door.point, metadata | {"region_names": [names[r] for r in regions]}
        )

    def add_edges(a: int, b: int, line: Any, region: int) -> None:
        points = tuple((float(x), float(y)) for x, y in line)
        points = ((route.nodes[a]["x"], route.nodes[a]["y"]), *points[1:-1])
        points += ((route.nodes[b]["x"], route.nodes[b]["y"]),)
        cost = polyline_length(points)
        about = {"region": region, "name": names[region], "label": labels[region]}
        for start, end, ends in ((a, b, points), (b, a, points[::-1])):
            route.add_edge(start, end, cost=cost, overridable=False, line=ends, metadata=about)

    for (a, b), part in planner.door_edges().items():
        add_edges(a, b, planner.leg(part, a, b), planner.region_of[part])
    for region in sorted(planner.graph.nodes):
        try:
            point = planner.centre(region)
        except PlanningError:
            continue  # a region too narrow for the robot has no node
        node = route.number_of_nodes()
        metadata = {"kind": "region", "region": region, "name": names[region]}
        _add_node(route, node, point, metadata | {"label": labels[region]})
        reach = planner.reach(point)
        for door, via in zip(reach.doors.tolist(), reach.via.tolist(), strict=True):
            line = np.vstack([[point], planner.path_in_part(reach.part, door, via)[::-1]])
            add_edges(node, door, line, region)
    return _number_edges(route)


def _names(regions: nx.Graph) -> tuple[dict[int, str], dict[int, str]]:
    """Each region's name (its id if it has none) and label ("" if none)."""
    names = {r: str(regions.nodes[r].get("name", r)) for r in regions.nodes}
    return names, {r: str(regions.nodes[r].get("label", "")) for r in regions.nodes}


def _number_edges(route: nx.DiGraph) -> nx.DiGraph:
    """Give every edge an ``id`` after the node ids (unique over both, as the route server
    requires); returns ``route``."""
    for k, (a, b) in enumerate(sorted(route.edges)):
        route.edges[a, b]["id"] = route.number_of_nodes() + k
    return route


def _add_node(route: nx.DiGraph, node: int, point: Point, metadata: dict[str, Any]) -> None:
    route.add_node(node, x=float(point[0]), y=float(point[1]), frame="map", metadata=metadata)


def _join_in_region(
    planner: HierarchicalPlanner,
    route: nx.DiGraph,
    region: int,
    nodes: list[int],
    about: dict[str, Any],
) -> None:
    """Add the shortest paths inside ``region`` between every two of its ``nodes``, their
    bends as corner nodes, as straight edges both ways."""
    if len(nodes) < 2:
        return
    points = [(route.nodes[n]["x"], route.nodes[n]["y"]) for n in nodes]
    visibility = VisibilityGraph(planner.region_space(region), points)
    corners = len(visibility.corners)
    distances = visibility.site_distances()
    bends: dict[tuple[float, float], int] = {}
    for i, j in itertools.combinations(range(len(nodes)), 2):
        if not np.isfinite(distances[i, corners + j]):
            continue
        line = visibility.site_path(i, corners + j)
        chain = [nodes[i]]
        for bend in line[1:-1]:
            key = (float(bend[0]), float(bend[1]))
            if key not in bends:
                bends[key] = route.number_of_nodes()
                _add_node(route, bends[key], key, {"kind": "corner", "region": region})
            chain.append(bends[key])
        chain.append(nodes[j])
        for a, b in itertools.pairwise(chain):
            _add_edge(route, a, b, about)


def _add_edge(route: nx.DiGraph, a: int, b: int, about: dict[str, Any]) -> None:
    """The straight edge ``a -> b`` and ``b -> a``, unless they are there already."""
    if a == b or route.has_edge(a, b):
        return
    ends = [(route.nodes[n]["x"], route.nodes[n]["y"]) for n in (a, b)]
    cost = math.dist(*ends)
    for start, end in ((a, b), (b, a)):
        line = (ends[0], ends[1]) if start == a else (ends[1], ends[0])
        route.add_edge(start, end, cost=cost, overridable=True, line=line, metadata=dict(about))
