"""Route graphs in the GeoJSON layout the Nav2 route server (``nav2_route``) reads, and back.

A route graph is a :class:`networkx.DiGraph`: nodes with ``x``, ``y``, ``frame`` and
``metadata`` (and ``operations`` if any), directed edges with ``id``, ``cost``,
``overridable``, ``line`` (the geometry, a tuple of ``(x, y)``) and ``metadata`` (and
``operations``). Two are made here: the building's graph of doors and regions
(:func:`planners.route_graph.building_route_graph`, the one to give Nav2) and the hierarchical
planner's internal portal graph (:func:`planners.route_graph.planner_route_graph`, for
debugging the planner).

In the file every node is a ``Point`` feature with ``id``, ``frame`` and ``metadata``; every
edge a ``MultiLineString`` feature with ``id``, ``startid``, ``endid``, ``cost``,
``overridable`` and ``metadata``; ids are unique over nodes and edges together, as the route
server requires. Coordinates are map-frame metres (REP-103), as the server expects with
``frame: map``. Metadata holds no ``null`` (the server's parser refuses one).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import networkx as nx

from maps.files import check_output_file, write_text
from planners.errors import PlanningError


class RouteGraphError(PlanningError, ValueError):
    """A route graph file that does not follow the nav2_route GeoJSON layout."""


def route_geojson(route: nx.DiGraph) -> dict[str, Any]:
    """``route`` as a nav2_route GeoJSON dict (see the module's text).

    Examples
    --------
    >>> route = nx.DiGraph()
    >>> route.add_node(0, x=0.0, y=0.0, frame="map", metadata={"kind": "door"})
    >>> route.add_node(1, x=1.0, y=0.0, frame="map", metadata={"kind": "region"})
    >>> route.add_edge(0, 1, id=2, cost=1.0, overridable=True, line=((0.0, 0.0), (1.0, 0.0)),
    ...                metadata={})
    >>> [f["properties"]["id"] for f in route_geojson(route)["features"]]
    [0, 1, 2]
    """
    features: list[dict[str, Any]] = []
    for node, data in sorted(route.nodes(data=True)):
        properties = {"id": node, "frame": data["frame"], "metadata": data["metadata"]}
        if "operations" in data:
            properties["operations"] = data["operations"]
        geometry = {"type": "Point", "coordinates": [data["x"], data["y"]]}
        features.append({"type": "Feature", "properties": properties, "geometry": geometry})
    for start, end, data in sorted(route.edges(data=True), key=lambda e: e[2]["id"]):
        properties = {"id": data["id"], "startid": start, "endid": end, "cost": data["cost"]}
        properties |= {"overridable": data["overridable"], "metadata": data["metadata"]}
        if "operations" in data:
            properties["operations"] = data["operations"]
        coordinates = [[list(point) for point in data["line"]]]
        geometry = {"type": "MultiLineString", "coordinates": coordinates}
        features.append({"type": "Feature", "properties": properties, "geometry": geometry})
    return {
        "type": "FeatureCollection",
        "name": "graph",
        "properties": {"frame": "map", "units": "metres, map frame (REP-103)"},
        "features": features,
    }


def write_nav2_route(route: nx.DiGraph, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write :func:`route_geojson` of ``route`` to ``path`` atomically (never over an existing
    file unless ``overwrite``)."""
    check_output_file(path, overwrite=overwrite)
    return write_text(path, json.dumps(route_geojson(route), indent=1), overwrite=overwrite)


def read_nav2_route(path: str | Path) -> nx.DiGraph:
    """Read a nav2_route GeoJSON graph into the route graph it was written from (the keys of
    the module's text; a missing ``frame``, ``metadata``, ``cost`` or ``overridable`` reads as
    the route server's default: none, ``{}``, 0.0, true).

    Raises
    ------
    RouteGraphError
        A file that is not JSON, a feature without its ids, a repeated id, a geometry that
        is neither a point nor lines, or an edge naming a missing node.
    """
    try:
        data = json.loads(Path(path).read_text())
        features = list(data["features"])
    except (ValueError, TypeError, KeyError, RecursionError) as err:
        raise RouteGraphError(f"{path}: not a GeoJSON FeatureCollection: {err!r}") from None
    route = nx.DiGraph(frame=data.get("properties", {}).get("frame", "map"))
    seen: set[int] = set()
    edges = []
    for k, feature in enumerate(features):
        kind = (feature.get("geometry") or {}).get("type")
        props = feature.get("properties") or {}
        if not isinstance(props.get("id"), int) or props["id"] in seen:
            raise RouteGraphError(f"{path}: feature {k} has a missing or repeated id")
        seen.add(props["id"])
        if kind == "Point":
            x, y = (float(v) for v in feature["geometry"]["coordinates"][:2])
            extra = {"operations": props["operations"]} if "operations" in props else {}
            route.add_node(
                props["id"], x=x, y=y, frame=props.get("frame"), metadata=props.get("metadata", {})
            )
            route.nodes[props["id"]].update(extra)
        elif kind in ("MultiLineString", "LineString"):
            edges.append(feature)
        else:
            raise RouteGraphError(f"{path}: feature {k} has geometry {kind!r}")
    for feature in edges:
        props = feature["properties"]
        for end in ("startid", "endid"):
            if props.get(end) not in route:
                raise RouteGraphError(f"{path}: edge {props['id']} {end} names no node")
        coordinates = feature["geometry"].get("coordinates") or []
        lines = coordinates if feature["geometry"]["type"] == "MultiLineString" else [coordinates]
        line = tuple((float(p[0]), float(p[1])) for part in lines for p in part)
        attributes = {
            "id": props["id"],
            "cost": float(props.get("cost", 0.0)),
            "overridable": bool(props.get("overridable", True)),
            "line": line,
            "metadata": props.get("metadata", {}),
        }
        if "operations" in props:
            attributes["operations"] = props["operations"]
        route.add_edge(props["startid"], props["endid"], **attributes)
    return route
