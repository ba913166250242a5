"""Hierarchical planning at the level of HPA*: a door graph precomputed over near-convex submaps.

Regions are first cut into near-convex parts (:mod:`planners.submaps`), the submaps; every
opening between two parts where the robot fits gets doors (one per metre of opening).
:meth:`HierarchicalPlanner.prepare` builds, once per map, the exact visibility graph of every
submap with its doors as extra nodes (:mod:`planners.door_graph`), so the shortest
door-to-door paths inside each part are known: together they are one sparse door graph, which
can be saved with the regions and read back (:mod:`planners.prepared`). A query joins start
and goal to the doors of their own parts (the corners and doors they see, plus the
precomputed distances from there), runs Dijkstra over the door graph (``scipy.sparse.csgraph``,
compiled), stitches the legs and tightens the result: skippable points are dropped and each
door crossing slides along its door line (string pulling through the portals,
:func:`planners.path.tighten`). Closing or opening a door only removes or restores its edges
in the door graph; nothing precomputed changes.
"""

from __future__ import annotations

import itertools
import logging
import math
import time
from dataclasses import dataclass

import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage, sparse
from scipy.sparse.csgraph import dijkstra

from maps.geometry import polyline_length
from maps.grid import OccupancyGrid
from planners.door_graph import (
    DoorGraph,
    Progress,
    build_door_graph,
    door_graph_key,
    part_space,
    plan_layout,
)
from planners.errors import InvalidQueryError, NoPathError
from planners.path import PlannedPath, shortcut, tighten
from planners.prepared import Prepared
from planners.workspace import Point, Workspace, sample_polyline
from segmentation.errors import RegionNotFoundError
from segmentation.names import find_region

log = logging.getLogger(__name__)

Goal = ArrayLike | int | str
#: Moves the final tightening tries per point and pass (the full move, then its halves).
TIGHTEN_TRIES = 2


@dataclass(frozen=True)
class Reach:
    """How a point joins the doors of its part: ``doors`` (door indices), ``dist`` (metres
    to each) and ``via`` (the first node of the part's visibility graph on the way)."""

    part: int
    point: Point
    doors: NDArray[np.intp]
    dist: NDArray[np.float64]
    via: NDArray[np.intp]


class HierarchicalPlanner:
    """Plans on a segmented map: a door graph over near-convex submaps, then string pulling.

    Parameters
    ----------
    space
        The free space (inflated map).
    labels
        Region id of every cell (0 = none), aligned with ``space.grid``; any segmentation.
    graph
        The region adjacency graph (:func:`segmentation.graph.region_graph`): its nodes are
        the region ids, its edges the doors that can be closed.
    prepared
        The submaps and door graph made before for this map, these labels and this robot
        (:meth:`prepared`, read back with :func:`planners.prepared.read_prepared`); checked,
        not trusted (:attr:`restored` says it was given).

    Raises
    ------
    PlannerParameterError
        Labels of another shape than the map, or that give no region to a free cell.
    StaleDoorGraphError
        ``prepared`` was made from another map, other labels or another robot radius.

    Examples
    --------
    >>> from maps.grid import OccupancyGrid
    >>> cells = np.zeros((40, 80), np.int8)
    >>> cells[:, 39:41] = 100
    >>> cells[18:26, 39:41] = 0  # a doorway
    >>> grid = OccupancyGrid(cells, resolution=0.1)
    >>> labels = np.where(np.arange(80) < 40, 1, 2)[None].repeat(40, 0)
    >>> graph = nx.Graph([(1, 2)])
    >>> planner = HierarchicalPlanner(Workspace(grid, 0.1), labels, graph)
    >>> path = planner.plan((1.0, 3.5), (7.0, 0.5))
    >>> path.regions, round(path.length, 2)
    ((1, 2), 6.71)
    """

    name = "hierarchical"

    def __init__(
        self,
        space: Workspace,
        labels: NDArray[np.integer],
        graph: nx.Graph,
        *,
        prepared: Prepared | None = None,
    ) -> None:
        clock = time.perf_counter()
        self.space, self.graph, self._given = space, graph, labels
        if prepared is None:
            layout, self._door_graph = plan_layout(space, labels), None
        else:
            prepared.check(space, labels)
            layout, self._door_graph = prepared.layout, prepared.door_graph
        self._layout, self.restored = layout, prepared is not None
        self.labels, self.parts = layout.labels, layout.parts
        self.region_of, self.doors = layout.region_of, layout.doors
        self._doors_of = layout.doors_of()
        self._door_regions = np.array(
            [sorted((self.region_of[d.a], self.region_of[d.b])) for d in self.doors], np.int64
        ).reshape(-1, 2)
        self._part_boxes = ndimage.find_objects(self.parts)
        self._region_boxes = ndimage.find_objects(self.labels)
        self._closed: set[tuple[int, int]] = set()
        self._centres: dict[int, Point] = {}
        self._matrices: dict[frozenset[tuple[int, int]], sparse.csr_matrix] = {}
        self.build_seconds = time.perf_counter() - clock
        self.prepare_seconds: float | None = None
        if self._door_graph is not None:
            self._use(self._door_graph)

    def prepare(self, progress: Progress = iter) -> float:
        """Build the door graph now rather than at the first query: every submap's visibility
        graph with its doors, and the shortest door-to-door distance inside each part
        (:func:`~planners.door_graph.build_door_graph`, the parts passed through
        ``progress``). Returns the seconds building it took (preprocessing, like the
        segmentation; for a door graph read back, the seconds it took when it was built)."""
        if self._door_graph is None:
            self._use(build_door_graph(self.space, self._layout, progress))
        assert self.prepare_seconds is not None
        return self.prepare_seconds

    def prepared(self, progress: Progress = iter) -> Prepared:
        """The prepared door graph (:meth:`prepare`) and what it was made from, to save with
        the regions (:func:`planners.prepared.write_prepared`)."""
        self.prepare(progress)
        assert self._door_graph is not None
        key = door_graph_key(self.space, self._given)
        return Prepared(key, self.space.robot_radius, self._layout, self._door_graph)

    def _use(self, door_graph: DoorGraph) -> None:
        self._door_graph = door_graph
        self._part_graphs = door_graph.part_graphs
        self._edges = (door_graph.a, door_graph.b)
        self._costs = door_graph.costs
        self._edge_part = {
            (int(i), int(j)): int(p)
            for i, j, p in zip(door_graph.a, door_graph.b, door_graph.part, strict=True)
        }
        self.prepare_seconds = door_graph.seconds

    # ------------------------------------------------------------------ queries on the map
    def region_at(self, x: float, y: float) -> int:
        """Region id at map point ``(x, y)`` (0 when off the map or in no region)."""
        row, col = self.space.grid.world_to_cell(x, y)
        if not self.space.grid.contains(row, col):
            return 0
        return int(self.labels[row, col])

    def centre(self, region: int) -> Point:
        """The free point of ``region`` farthest from its walls (where a region goal leads)."""
        self._region(region)
        if region not in self._centres:
            sub = self.region_space(region)
            depth = ndimage.distance_transform_edt(sub.free)
            row, col = np.unravel_index(np.argmax(depth), depth.shape)
            if depth[row, col] == 0:
                raise InvalidQueryError(f"region {region} has no room for the robot")
            x, y = sub.grid.cell_to_world(row, col)
            self._centres[region] = (float(x), float(y))
        return self._centres[region]

    def _end(self, end: Goal, what: str) -> Point:
        """A query's end as a point: a region's most open point, or the point checked."""
        if isinstance(end, int | np.integer | str):
            return self.centre(find_region(self.graph, end))
        return self.space.check(end, what)

    def region_space(self, region: int) -> Workspace:
        """The free space of ``region`` and :data:`~planners.door_graph.SUBMAP_MARGIN` around
        it (so paths can pass the doorways at its edge)."""
        return part_space(self.space, self.labels, self._region_boxes, self._region(region))

    def _region(self, region: object) -> int:
        """``region`` if it is a region id of this planner's map, else
        :class:`RegionNotFoundError` (an id not in the graph, 0, a list, a name)."""
        if not isinstance(region, int | np.integer) or isinstance(region, bool):
            raise RegionNotFoundError(f"a region is an integer id, got {region!r:.80}")
        if region not in self.graph:
            raise RegionNotFoundError(f"no region {region!r} in this planner's map")
        return int(region)

    # ------------------------------------------------------------------ doors
    def close_door(self, a: int, b: int) -> None:
        """Close every opening between regions ``a`` and ``b`` for later plans."""
        self._closed.add(self._edge(a, b))

    def open_door(self, a: int, b: int) -> None:
        """Reopen the openings between regions ``a`` and ``b``."""
        self._closed.discard(self._edge(a, b))

    def _edge(self, a: int, b: int) -> tuple[int, int]:
        a, b = self._region(a), self._region(b)
        if not self.graph.has_edge(a, b):
            raise InvalidQueryError(f"regions {a} and {b} share no door")
        return (min(a, b), max(a, b))

    def _open_doors(self) -> NDArray[np.bool_]:
        """Whether each door is open now."""
        is_open = np.ones(len(self.doors), bool)
        for a, b in self._closed:
            is_open &= ~((self._door_regions[:, 0] == a) & (self._door_regions[:, 1] == b))
        return is_open

    def door_matrix(self) -> sparse.csr_matrix:
        """The door graph now (closed doors have no edges) as a symmetric sparse matrix of
        door-to-door path lengths, metres."""
        self.prepare()
        key = frozenset(self._closed)
        if key not in self._matrices:
            a, b = self._edges
            is_open = self._open_doors()
            keep = is_open[a] & is_open[b]
            n = len(self.doors)
            rows, cols = np.concatenate([a[keep], b[keep]]), np.concatenate([b[keep], a[keep]])
            weights = np.concatenate([self._costs[keep], self._costs[keep]])
            self._matrices = {
                key: sparse.csr_matrix((weights, (rows, cols)), shape=(n, n))
            }  # one door state kept: edits never pile up
        return self._matrices[key]

    # ------------------------------------------------------------------ planning
    def plan(self, start: Goal, goal: Goal) -> PlannedPath:
        """Plan from ``start`` to ``goal``: each a point, or a region (an id or a name,
        :func:`segmentation.names.find_region`) standing for its most open point.

        Raises
        ------
        InvalidQueryError
            A start or goal a robot cannot stand on.
        RegionNotFoundError
            An unknown region.
        NoPathError
            No route: disconnected free space, or every route needs a closed door.
        """
        s, g = self._end(start, "start"), self._end(goal, "goal")
        self.door_matrix()  # the door graph, built on first use: preprocessing, not the query
        clock = time.perf_counter()
        ends, direct, doors, local = self._route(s, g)
        searched = time.perf_counter()
        crossings: dict[int, int] = {}
        if doors is not None:
            waypoints = self._stitch(doors, *ends, crossings)
        else:
            assert direct is not None  # _route raised otherwise
            waypoints = direct
        kept = shortcut(self.space, waypoints)
        portals = {i: self.doors[crossings[k]].portal for i, k in enumerate(kept) if k in crossings}
        # legs are shortest paths: only door crossings and points whose neighbours changed
        # (a skipped point between them) can move at first
        skipped = np.flatnonzero(np.diff(kept) > 1)
        first = {*portals, *skipped, *(skipped + 1)}
        waypoints = tighten(self.space, waypoints[kept], portals, first=first, tries=TIGHTEN_TRIES)
        waypoints = waypoints[shortcut(self.space, waypoints)]
        seconds = {
            "local_planning": local - clock,
            "graph_search": searched - local,
            "smoothing": time.perf_counter() - searched,
        }
        crossed = regions_along(self.space.grid, self.labels, waypoints)
        return PlannedPath(waypoints, self.name, crossed, seconds)

    def door_route(self, start: Goal, goal: Goal) -> tuple[list[int], list[int]]:
        """The doors of the shortest route from ``start`` to ``goal`` (indices into
        :attr:`doors`, in order) and the parts it passes through (one more than the doors;
        one part and no door when the shortest path stays in the part holding both ends).

        Raises
        ------
        InvalidQueryError, RegionNotFoundError, NoPathError
            As :meth:`plan`.
        """
        s, g = self._end(start, "start"), self._end(goal, "goal")
        ends, _, doors, _ = self._route(s, g)
        if doors is None:
            return [], [ends[0].part]
        inner = [self._edge_part[(min(a, b), max(a, b))] for a, b in itertools.pairwise(doors)]
        return doors, [ends[0].part, *inner, ends[1].part]

    def _route(
        self, s: Point, g: Point
    ) -> tuple[tuple[Reach, Reach], NDArray[np.float64] | None, list[int] | None, float]:
        """How ``s`` and ``g`` join their parts' doors, the direct path when both lie in one
        part, the doors of the shortest route (None when the direct path is shorter) and the
        clock when the ends were joined."""
        if self.space.component_at(s) != self.space.component_at(g):
            raise NoPathError(f"start {s} and goal {g} lie in different parts of the free space")
        matrix = self.door_matrix()
        ends = self.reach(s), self.reach(g)
        direct = self._direct(s, g) if ends[0].part == ends[1].part else None
        local = time.perf_counter()
        bound = math.inf if direct is None else polyline_length(direct)
        doors = self._search(matrix, *ends, bound)
        if doors is None and direct is None:
            raise NoPathError(f"no route from {s} to {g} through open doors")
        return ends, direct, doors, local

    def reach(self, point: Point) -> Reach:
        """The open doors of ``point``'s part and the shortest distances to them inside the
        part (from the part's visibility graph: the nodes the point sees, then the
        precomputed distances from those nodes to every door)."""
        point = self.space.check(point)
        self.prepare()
        part = self._part_at(point)
        graph = self._part_graphs[part]
        nodes, weights = graph.sight(point)
        doors = np.asarray(self._doors_of[part], np.intp)
        if len(nodes) == 0 or len(doors) == 0:
            empty = np.zeros(0, np.intp)
            return Reach(part, point, empty, np.zeros(0), empty)
        total = graph.site_distances()[:, nodes] + weights
        best = np.argmin(total, axis=1)
        dist = total[np.arange(len(doors)), best]
        keep = np.isfinite(dist) & self._open_doors()[doors]
        return Reach(part, point, doors[keep], dist[keep], nodes[best[keep]])

    def _direct(self, s: Point, g: Point) -> NDArray[np.float64] | None:
        """The shortest path inside the part holding both ends, if any."""
        try:
            return self._part_graphs[self._part_at(s)].plan(s, g).waypoints
        except NoPathError:
            return None

    def _search(
        self, matrix: sparse.csr_matrix, start: Reach, goal: Reach, bound: float
    ) -> list[int] | None:
        """Doors of the shortest route from ``start`` to ``goal`` through the door graph, or
        None when no route is shorter than ``bound``."""
        if len(start.doors) == 0 or len(goal.doors) == 0:
            return None
        n = matrix.shape[0]
        graph = sparse.csr_matrix(
            (
                np.concatenate([matrix.data, start.dist]),
                np.concatenate([matrix.indices, start.doors]),
                np.append(matrix.indptr, matrix.indptr[-1] + len(start.doors)),
            ),
            shape=(n + 1, n + 1),
        )
        dist, parent = dijkstra(graph, indices=n, return_predecessors=True, limit=bound)
        total = dist[goal.doors] + goal.dist
        best = int(np.argmin(total))
        if not total[best] < bound:
            return None
        doors = [int(goal.doors[best])]
        while parent[doors[-1]] != n:
            doors.append(int(parent[doors[-1]]))
        return doors[::-1]

    def _stitch(
        self, doors: list[int], start: Reach, goal: Reach, crossings: dict[int, int]
    ) -> NDArray[np.float64]:
        """The route's legs joined into one polyline; fills waypoint index -> door crossed."""
        first = int(np.flatnonzero(start.doors == doors[0])[0])
        last = int(np.flatnonzero(goal.doors == doors[-1])[0])
        legs = [
            np.vstack(
                [[start.point], self.path_in_part(start.part, doors[0], start.via[first])[::-1]]
            )
        ]
        for a, b in itertools.pairwise(doors):
            part = self._edge_part[(min(a, b), max(a, b))]
            legs.append(self.leg(part, a, b))
        legs.append(
            np.vstack([self.path_in_part(goal.part, doors[-1], goal.via[last]), [goal.point]])
        )
        pieces, count = [], 0
        for k, leg in enumerate(legs):
            piece = leg if k == 0 else leg[1:]
            pieces.append(piece)
            count += len(piece)
            if k < len(doors):
                crossings[count - 1] = doors[k]
        return np.vstack(pieces)

    def _site(self, part: int, door: int) -> int:
        """The place of ``door`` among ``part``'s doors; :class:`InvalidQueryError` for a
        part or a door that is not there (the part graphs are made once prepared)."""
        self.prepare()
        try:
            return self._doors_of[part].index(door)
        except (KeyError, IndexError, TypeError, ValueError):
            raise InvalidQueryError(f"door {door!r} is not a door of part {part!r}") from None

    def door_edges(self) -> dict[tuple[int, int], int]:
        """Edges ``(door a, door b)`` (``a < b``) of the door graph with every door open, and
        the part whose shortest path joins them."""
        self.prepare()
        return dict(self._edge_part)

    def leg(self, part: int, a: int, b: int) -> NDArray[np.float64]:
        """Shortest polyline inside ``part`` from door ``a`` to door ``b`` (both its doors)."""
        site = self._site(part, b)
        return self.path_in_part(part, a, len(self._part_graphs[part].corners) + site)

    def path_in_part(self, part: int, door: int, node: int) -> NDArray[np.float64]:
        """Shortest polyline inside ``part`` from ``door`` to ``node`` of the part's visibility
        graph (e.g. a :class:`Reach`'s ``via``)."""
        site = self._site(part, door)
        graph = self._part_graphs[part]
        if not (
            isinstance(node, int | np.integer) and 0 <= node < len(graph.corners) + len(graph.sites)
        ):
            raise InvalidQueryError(f"node {node!r} is not a node of part {part}'s graph")
        leg = graph.site_path(site, int(node))
        leg[0] = self.doors[door].point
        return leg

    def _part_at(self, point: Point) -> int:
        row, col = self.space.grid.world_to_cell(*point)
        return int(self.parts[row, col])


def regions_along(
    grid: OccupancyGrid, labels: NDArray[np.integer], waypoints: ArrayLike
) -> tuple[int, ...]:
    """Regions of ``labels`` (aligned with ``grid``) a polyline passes through, in order."""
    points = sample_polyline(waypoints, grid.resolution)
    rows, cols = grid.world_to_cell(points[:, 0], points[:, 1])
    found = labels[rows, cols]
    found = found[found > 0]
    keep = np.concatenate([[len(found) > 0], found[1:] != found[:-1]])
    return tuple(int(r) for r in found[keep[: len(found)]])
