"""Topological routes: the regions and doors between two regions, without geometry.

A region-level query ("room 3" to "hall 1") runs Dijkstra on the region adjacency graph
(:func:`segmentation.graph.region_graph`), each edge weighted by the walk from one region's
inner point through the widest door to the other's. It costs microseconds and answers
"which rooms and doors": the hierarchical path query users ask for before any motion.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import networkx as nx

from maps.limits import MAX_LENGTH, finite_in
from planners.errors import InvalidQueryError, NoPathError
from segmentation.names import find_region
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


def region_route(
    graph: nx.Graph,
    source: int | str,
    target: int | str,
    *,
    closed: Iterable[tuple[int, int]] = (),
    min_width: float = 0.0,
) -> RegionRoute:
    """The shortest sequence of regions and doors from ``source`` to ``target``.

    Parameters
    ----------
    graph
        Region adjacency graph: nodes with ``x``, ``y`` (a point inside) and optionally
        ``name``; edges with ``doors`` (:class:`~segmentation.transitions.Transition`).
    source, target
        Region ids or names (:func:`segmentation.names.find_region`).
    closed
        Region pairs whose doors are closed.
    min_width
        Metres the robot is wide: a door must be wider (its
        :attr:`~segmentation.transitions.Transition.passable` width, from the clearance
        where it was measured).

    Raises
    ------
    RegionNotFoundError
        An unknown region.
    InvalidQueryError
        A width that is not a number >= 0, a closed pair that is not two regions with a door.
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
    >>> region_route(graph, 1, 2, min_width=1.2)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    planners.errors.NoPathError: no route from region 1 to region 2 ... at least 1.2 m wide
    """
    return next(region_routes(graph, source, target, closed=closed, min_width=min_width))


def region_routes(
    graph: nx.Graph,
    source: int | str,
    target: int | str,
    *,
    closed: Iterable[tuple[int, int]] = (),
    min_width: float = 0.0,
) -> Iterator[RegionRoute]:
    """Routes from ``source`` to ``target``, shortest first, each visiting a region at most
    once (the next-best routes, for when the best one fails); arguments as for
    :func:`region_route`, which is the first of them.

    Raises
    ------
    RegionNotFoundError
        An unknown region (when the first route is asked for).
    NoPathError
        No route at all through open doors wide enough.
    """
    a, b = find_region(graph, source), find_region(graph, target)
    problem = finite_in(min_width, "the robot's width (twice its radius)", 0, MAX_LENGTH, unit="m")
    if problem is not None:
        raise InvalidQueryError(problem)
    try:
        pairs = list(closed)
    except TypeError:  # None, a number
        raise InvalidQueryError(f"closed is a list of region pairs, got {closed!r:.80}") from None
    shut = set()
    for pair in pairs:
        try:
            u, v = pair
            shared = graph.has_edge(u, v)
        except (TypeError, ValueError):  # not a pair, or not hashable
            shared = False
        if not shared:
            raise InvalidQueryError(f"{pair!r} is not two regions that share a door to close")
        shut.add((min(u, v), max(u, v)))

    def usable(u: int, v: int) -> Transition | None:
        doors = [d for d in graph.edges[u, v].get("doors") or () if d.passable > min_width]
        if (min(u, v), max(u, v)) in shut or not doors:
            return None
        return max(doors, key=lambda door: door.passable)

    def weight(u: int, v: int, data: dict) -> float | None:
        door = usable(u, v)
        return None if door is None else _through(graph, u, v, door)

    paths = nx.shortest_simple_paths(graph, a, b, weight=weight)
    found = False
    while True:
        try:
            regions = next(paths)
        except (nx.NetworkXNoPath, StopIteration):
            if found:
                return
            wide = f" at least {min_width:g} m wide" if min_width > 0 else ""
            raise NoPathError(
                f"no route from region {a} to region {b} through open doors{wide}"
            ) from None
        found = True
        doors = tuple(usable(u, v) for u, v in itertools.pairwise(regions))
        length = sum(
            _through(graph, u, v, door)
            for (u, v), door in zip(itertools.pairwise(regions), doors, strict=True)
            if door is not None
        )
        names = tuple(str(graph.nodes[r].get("name", r)) for r in regions)
        yield RegionRoute(
            tuple(int(r) for r in regions),
            names,
            tuple(d for d in doors if d is not None),
            float(length),
        )


def _through(graph: nx.Graph, u: int, v: int, door: Transition) -> float:
    pu = (graph.nodes[u]["x"], graph.nodes[u]["y"])
    pv = (graph.nodes[v]["x"], graph.nodes[v]["y"])
    return math.dist(pu, door.centre) + math.dist(door.centre, pv)
