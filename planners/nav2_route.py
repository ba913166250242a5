"""The door graph as a Nav2 route graph (the GeoJSON read by ``nav2_route``'s parser).

Nodes are GeoJSON ``Point`` features with a unique integer ``id`` and ``frame: map``: one per
door (where two submaps meet) and one per region (its most open point, so a route can end in
a room). Edges are ``MultiLineString`` features with their own unique ``id``, ``startid`` and
``endid``, one feature per direction, whose geometry is the shortest path inside the submap
they cross; ``cost`` is that path's length (``overridable: false``) and ``metadata`` names the
region (id, name, label), the door widths at both ends and the length. Coordinates are
map-frame metres (REP-103), as the route server expects with ``frame: map``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np
from numpy.typing import NDArray

from maps.files import check_output_file, write_text
from planners.errors import PlanningError
from planners.hierarchical import HierarchicalPlanner


class RouteGraphError(PlanningError, ValueError):
    """A route graph file that does not follow the nav2_route GeoJSON layout."""


def _node(node_id: int, point: tuple[float, float], metadata: dict[str, Any]) -> dict[str, Any]:
    return {
        "type": "Feature",
        "geometry": {"type": "Point", "coordinates": [round(point[0], 4), round(point[1], 4)]},
        "properties": {"id": node_id, "frame": "map", "metadata": metadata},
    }


def _edge(
    edge_id: int, start: int, end: int, line: NDArray[np.float64], metadata: dict[str, Any]
) -> dict[str, Any]:
    coordinates = [[[round(float(x), 4), round(float(y), 4)] for x, y in line]]
    return {
        "type": "Feature",
        "geometry": {"type": "MultiLineString", "coordinates": coordinates},
        "properties": {
            "id": edge_id,
            "startid": start,
            "endid": end,
            "cost": metadata["length_m"],
            "overridable": False,
            "metadata": metadata,
        },
    }


def nav2_route_graph(planner: HierarchicalPlanner) -> dict[str, Any]:
    """The planner's door graph (with every door open) as a nav2_route GeoJSON dict.

    Examples
    --------
    >>> from maps.grid import OccupancyGrid
    >>> from planners.workspace import Workspace
    >>> cells = np.zeros((40, 80), np.int8)
    >>> cells[:, 39:41] = 100
    >>> cells[18:26, 39:41] = 0
    >>> labels = np.where(np.arange(80) < 40, 1, 2)[None].repeat(40, 0)
    >>> planner = HierarchicalPlanner(
    ...     Workspace(OccupancyGrid(cells, resolution=0.1), 0.1), labels, nx.Graph([(1, 2)])
    ... )
    >>> graph = nav2_route_graph(planner)
    >>> sorted({f["geometry"]["type"] for f in graph["features"]})
    ['MultiLineString', 'Point']
    """
    planner.prepare()
    names = {r: planner.graph.nodes[r].get("name", str(r)) for r in planner.graph.nodes}
    labels = {r: planner.graph.nodes[r].get("label", "") for r in planner.graph.nodes}
    features: list[dict[str, Any]] = []
    for index, door in enumerate(planner.doors):
        regions = sorted({planner.region_of[door.a], planner.region_of[door.b]})
        metadata = {
            "kind": "door",
            "regions": regions,
            "region_names": [names.get(r, str(r)) for r in regions],
            "door_width_m": round(door.width, 4),
        }
        features.append(_node(index, door.point, metadata))
    next_id = len(planner.doors)

    def add_edges(a: int, b: int, line: NDArray[np.float64], region: int, widths: list) -> None:
        nonlocal next_id
        length = float(np.hypot(*np.diff(line, axis=0).T).sum())
        metadata = {
            "region": region,
            "name": names.get(region, str(region)),
            "label": labels.get(region, ""),
            "door_width_m": widths,
            "length_m": round(length, 4),
        }
        features.append(_edge(next_id, a, b, line, metadata))
        features.append(_edge(next_id + 1, b, a, line[::-1], metadata))
        next_id += 2

    def width(node: int) -> float | None:
        return round(planner.doors[node].width, 4) if node < len(planner.doors) else None

    for (a, b), part in planner.door_edges().items():
        region = planner.region_of[part]
        add_edges(a, b, planner.leg(part, a, b), region, [width(a), width(b)])
    centres = {}
    for region in sorted(planner.graph.nodes):
        try:
            centres[region] = planner.centre(region)
        except PlanningError:
            continue  # a region too narrow for the robot has no node
    region_nodes = {region: next_id + k for k, region in enumerate(centres)}
    next_id += len(centres)
    for region, point in centres.items():
        metadata = {"kind": "region", "region": region, "name": names[region]}
        metadata["label"] = labels[region]
        features.append(_node(region_nodes[region], point, metadata))
    for region, point in centres.items():
        reach = planner.reach(point)
        for door, via in zip(reach.doors.tolist(), reach.via.tolist(), strict=True):
            line = planner.path_in_part(reach.part, door, via)[::-1]
            line = np.vstack([[point], line])
            add_edges(region_nodes[region], door, line, region, [None, width(door)])
    return {
        "type": "FeatureCollection",
        "name": "topomap_route_graph",
        "properties": {"frame": "map", "units": "metres, map frame (REP-103)"},
        "features": features,
    }


def write_nav2_route(
    planner: HierarchicalPlanner, path: str | Path, *, overwrite: bool = False
) -> Path:
    """Write :func:`nav2_route_graph` to ``path`` (never over an existing file unless
    ``overwrite``)."""
    check_output_file(path, overwrite=overwrite)  # before the graph is computed
    return write_text(path, json.dumps(nav2_route_graph(planner), indent=1), overwrite=overwrite)


def read_nav2_route(path: str | Path) -> nx.DiGraph:
    """Read a nav2_route GeoJSON graph: node ``id`` -> ``x``, ``y``, ``frame``, ``metadata``;
    a directed edge per ``MultiLineString`` with ``id``, ``line`` (``(n, 2)`` array),
    ``cost`` and ``metadata``.

    Raises
    ------
    RouteGraphError
        A feature without its ids, a repeated id, or an edge naming a missing node.
    """
    data = json.loads(Path(path).read_text())
    graph = nx.DiGraph()
    seen: set[int] = set()
    edges = []
    for k, feature in enumerate(data.get("features", [])):
        kind = feature.get("geometry", {}).get("type")
        props = feature.get("properties", {})
        if "id" not in props or props["id"] in seen:
            raise RouteGraphError(f"{path}: feature {k} has a missing or repeated id")
        seen.add(props["id"])
        if kind == "Point":
            x, y = feature["geometry"]["coordinates"][:2]
            graph.add_node(
                props["id"], x=x, y=y, frame=props.get("frame"), metadata=props.get("metadata")
            )
        elif kind == "MultiLineString":
            edges.append(feature)
        else:
            raise RouteGraphError(f"{path}: feature {k} has geometry {kind!r}")
    for feature in edges:
        props = feature["properties"]
        for end in ("startid", "endid"):
            if props.get(end) not in graph:
                raise RouteGraphError(f"{path}: edge {props['id']} {end} names no node")
        line = np.concatenate([np.asarray(p, float) for p in feature["geometry"]["coordinates"]])
        graph.add_edge(
            props["startid"],
            props["endid"],
            id=props["id"],
            line=line,
            cost=props.get("cost"),
            metadata=props.get("metadata"),
        )
    return graph
