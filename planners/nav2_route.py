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
from typing import Any, TypeGuard

import networkx as nx

from maps.errors import MapFileNotFoundError
from maps.files import check_output_file, write_text
from maps.limits import MAX_COORDINATE, finite_in
from planners.errors import PlanningError

#: Bytes a route graph file may have: a building's graph of thousands of doors holds a few MB.
MAX_ROUTE_BYTES = 64 << 20


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
    MapFileNotFoundError
        If the file does not exist.
    RouteGraphError
        A file that cannot be read, is larger than :data:`MAX_ROUTE_BYTES` or is not JSON, a
        feature without its ids, a repeated id, a geometry that is neither a point nor lines,
        a coordinate or cost that is not a finite number (a cost below 0, a point farther than
        :data:`~maps.limits.MAX_COORDINATE`), an edge naming a missing node or repeating
        another's nodes; the message names the file and the feature.
    """
    path = Path(path)
    try:
        if path.stat().st_size > MAX_ROUTE_BYTES:
            raise RouteGraphError(
                f"{path}: {path.stat().st_size} bytes, more than a route graph's "
                f"{MAX_ROUTE_BYTES} bytes"
            )
        data = json.loads(path.read_bytes())
        features = data["features"]
        frame = (data.get("properties") or {}).get("frame", "map")
    except FileNotFoundError:
        raise MapFileNotFoundError(path, "route graph") from None
    except OSError as err:
        raise RouteGraphError(f"{path}: cannot be read ({err.strerror})") from None
    except (ValueError, TypeError, KeyError, AttributeError, RecursionError) as err:
        raise RouteGraphError(f"{path}: not a GeoJSON FeatureCollection: {err!r}") from None
    if not isinstance(features, list):
        raise RouteGraphError(f"{path}: 'features' is not a list")
    route = nx.DiGraph(frame=frame)
    edges = []
    seen: set[int] = set()
    for k, feature in enumerate(features):
        try:
            edge = _read_feature(route, feature, seen)
        except (ValueError, TypeError, KeyError, AttributeError, IndexError) as err:
            reason = f"no {err}" if isinstance(err, KeyError) else str(err)
            raise RouteGraphError(f"{path}: feature {k}: {reason}") from None
        if edge is not None:
            edges.append((k, edge))
    for k, (start, end, attributes) in edges:
        for name, node in (("startid", start), ("endid", end)):
            if node not in route:
                raise RouteGraphError(
                    f"{path}: feature {k}: edge {attributes['id']} {name} names no node"
                )
        if route.has_edge(start, end):
            raise RouteGraphError(
                f"{path}: feature {k}: edge {attributes['id']} repeats edge "
                f"{route.edges[start, end]['id']} from node {start} to {end}"
            )
        route.add_edge(start, end, **attributes)
    return route


def _read_feature(
    route: nx.DiGraph, feature: dict[str, Any], seen: set[int]
) -> tuple[int, int, dict[str, Any]] | None:
    """Add a ``Point`` feature to ``route`` as a node, or return a line feature's
    ``(startid, endid, attributes)``; what is malformed raises ValueError (or the error
    indexing it raises)."""
    kind = (feature.get("geometry") or {}).get("type")
    props = feature.get("properties") or {}
    key = props.get("id")
    if not _is_id(key) or key in seen:
        raise ValueError("a missing or repeated id")
    seen.add(key)
    metadata = props.get("metadata", {})
    if not isinstance(metadata, dict):
        raise ValueError(f"metadata must be an object, got {metadata!r:.80}")
    extra = {"operations": props["operations"]} if "operations" in props else {}
    if kind == "Point":
        frame = props.get("frame")
        if frame is not None and not isinstance(frame, str):
            raise ValueError(f"frame must be a string, got {frame!r:.80}")
        point = feature["geometry"]["coordinates"]
        x, y = _number(point[0], "x"), _number(point[1], "y")
        route.add_node(key, x=x, y=y, frame=frame, metadata=metadata, **extra)
        return None
    if kind not in ("MultiLineString", "LineString"):
        raise ValueError(f"geometry {kind!r}")
    start, end = props.get("startid"), props.get("endid")
    if not (_is_id(start) and _is_id(end)):
        raise ValueError(f"edge {key}: startid and endid must be node ids, got {start!r}, {end!r}")
    coordinates = feature["geometry"].get("coordinates") or []
    lines = coordinates if kind == "MultiLineString" else [coordinates]
    line = tuple((_number(p[0], "x"), _number(p[1], "y")) for part in lines for p in part)
    cost = _number(props.get("cost", 0.0), "the cost")
    if cost < 0:
        raise ValueError(f"edge {key}: the cost must be 0 or more, got {cost}")
    overridable = props.get("overridable", True)
    if not isinstance(overridable, bool):
        raise ValueError(f"edge {key}: overridable must be true or false, got {overridable!r:.80}")
    attributes = {"id": key, "cost": cost, "overridable": overridable, "line": line}
    return start, end, attributes | {"metadata": metadata} | extra


def _is_id(value: object) -> TypeGuard[int]:
    """Whether ``value`` is a feature id: a whole number (not a boolean)."""
    return isinstance(value, int) and not isinstance(value, bool)


def _number(value: object, what: str) -> float:
    """``value`` as a float: a finite number within :data:`~maps.limits.MAX_COORDINATE`."""
    problem = finite_in(value, what, -MAX_COORDINATE, MAX_COORDINATE)
    if problem is not None:
        raise ValueError(problem)
    return float(value)  # type: ignore[arg-type]
