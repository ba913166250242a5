"""Topological routes: the regions and doors between two regions, without geometry.

A region-level query ("room 3" to "hall 1") runs Dijkstra on the region adjacency graph
(:func:`segmentation.graph.region_graph`), each edge weighted by the walk from one region's
inner point through the widest door to the other's. It costs microseconds and answers
"which rooms and doors": the hierarchical path query users ask for before any motion.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable
from dataclasses import dataclass

import networkx as nx

from planners.errors import InvalidQueryError, NoPathError
from segmentation.transitions import Transition


@dataclass(frozen=True)
class RegionRoute:
    """A route over regions.

    Attributes
    ----------
    regions
        Region ids from the first to the last.
    names
        Their names (the graph's ``name`` attribute, else the id).
    doors
        The door crossed between each two consecutive regions (the widest of their
        openings).
    length
        Estimated length in metres: inner point, door centres, inner point.
    """

    regions: tuple[int, ...]
    names: tuple[str, ...]
    doors: tuple[Transition, ...]
    length: float


def resolve_region(graph: nx.Graph, query: int | str) -> int:
    """A region id from an id or a name (the nodes' ``name`` attribute).

    Raises
    ------
    InvalidQueryError
        No region with that id or name (the message lists the names).
    """
    if not isinstance(query, str) and query in graph:
        return int(query)
    for region, name in graph.nodes(data="name"):
        if name == query or str(region) == str(query):
            return int(region)
    names = sorted(str(n) for _, n in graph.nodes(data="name", default=None) if n is not None)
    raise InvalidQueryError(f"no region {query!r}; names: {', '.join(names) or 'none'}")


def region_route(
    graph: nx.Graph,
    source: int | str,
    target: int | str,
    *,
    closed: Iterable[tuple[int, int]] = (),
) -> RegionRoute:
    """The shortest sequence of regions and doors from ``source`` to ``target``.

    Parameters
    ----------
    graph
        Region adjacency graph: nodes with ``x``, ``y`` (a point inside) and optionally
        ``name``; edges with ``doors`` (:class:`~segmentation.transitions.Transition`).
    source, target
        Region ids or names.
    closed
        Region pairs whose doors are closed.

    Raises
    ------
    InvalidQueryError
        An unknown region.
    NoPathError
        No route through open doors.

    Examples
    --------
    >>> door = Transition(1, 2, (1.0, 0.0), (1.0, 1.0), (1.0, 0.5), 1.0)
    >>> graph = nx.Graph()
    >>> graph.add_node(1, x=0.5, y=0.5, name="room 1")
    >>> graph.add_node(2, x=1.5, y=0.5, name="hall 1")
    >>> graph.add_edge(1, 2, doors=(door,))
    >>> route = region_route(graph, "room 1", "hall 1")
    >>> route.regions, route.names, route.length
    ((1, 2), ('room 1', 'hall 1'), 1.0)
    """
    a, b = resolve_region(graph, source), resolve_region(graph, target)
    shut = {(min(u, v), max(u, v)) for u, v in closed}

    def weight(u: int, v: int, data: dict) -> float | None:
        if (min(u, v), max(u, v)) in shut or not data.get("doors"):
            return None
        return _through(graph, u, v, _widest(data))

    try:
        regions = nx.dijkstra_path(graph, a, b, weight=weight)
    except nx.NetworkXNoPath:
        raise NoPathError(f"no route from region {a} to region {b} through open doors") from None
    doors = tuple(_widest(graph.edges[u, v]) for u, v in itertools.pairwise(regions))
    length = sum(
        _through(graph, u, v, door)
        for (u, v), door in zip(itertools.pairwise(regions), doors, strict=True)
    )
    names = tuple(str(graph.nodes[r].get("name", r)) for r in regions)
    return RegionRoute(tuple(int(r) for r in regions), names, doors, float(length))


def _widest(data: dict) -> Transition:
    return max(data["doors"], key=lambda door: door.width)


def _through(graph: nx.Graph, u: int, v: int, door: Transition) -> float:
    pu = (graph.nodes[u]["x"], graph.nodes[u]["y"])
    pv = (graph.nodes[v]["x"], graph.nodes[v]["y"])
    return math.dist(pu, door.centre) + math.dist(door.centre, pv)
