"""Hierarchical planning: search the region graph over doors, then plan legs inside submaps.

Regions are first cut into near-convex parts (:mod:`planners.submaps`), the submaps. A query
joins start and goal to the doors of their parts and runs A* over door nodes with the
straight-line distance to the goal as heuristic. Edge weights are leg lengths inside one
part; a leg not planned yet counts as its straight-line length (a lower bound), and the
search is repeated after planning the legs of the route it found, until every leg on the
route is planned (lazy shortest path). A leg is a straight motion when that is valid, else
an OMPL plan inside the part's submap. Door-to-door legs are cached for later queries (or
all planned up front by :meth:`HierarchicalPlanner.prepare`).
The stitched route is finally shortened in the whole free space: skippable points are
dropped, each door crossing slides along its door line to where the path is shortest and the
other corners are pulled tight (:func:`planners.path.tighten`).
"""

from __future__ import annotations

import heapq
import logging
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass

import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from planners.errors import InvalidQueryError, NoPathError
from planners.flat import FlatPlanner
from planners.path import Path, polyline_length, shortcut, tighten
from planners.submaps import convex_parts
from planners.workspace import Point, Workspace, sample_polyline
from segmentation.regions import boundary_pairs
from segmentation.transitions import Transition, find_transitions

log = logging.getLogger(__name__)

Goal = ArrayLike | int
#: Longest stretch of an opening one door stands for, metres.
DOOR_SPACING = 1.0
#: Metres a submap reaches beyond its part, so legs can pass the doorways they end in.
SUBMAP_MARGIN = 0.5
_START, _GOAL = -1, -2


@dataclass(frozen=True)
class Door:
    """A passable opening between submaps (parts) ``a`` and ``b``: ``portal`` spans the part
    of the opening the robot fits through, ``point`` is its middle."""

    a: int
    b: int
    point: Point
    portal: tuple[Point, Point]


@dataclass
class _Leg:
    waypoints: NDArray[np.float64]
    length: float


#: Marks a leg not planned yet.
_UNPLANNED = _Leg(np.zeros((0, 2)), math.nan)


class HierarchicalPlanner:
    """Plans on a segmented map: region graph first, OMPL inside each submap.

    Parameters
    ----------
    space
        The free space (inflated map).
    labels
        Region id of every cell (0 = none), aligned with ``space.grid``.
    graph
        The region adjacency graph (:func:`segmentation.graph.region_graph`): its nodes are
        the region ids, its edges the doors that can be closed.
    leg_planner
        OMPL planner for legs that are not straight.
    leg_time_limit
        Seconds allowed per leg.
    random_state
        Seed of the leg planners.
    """

    name = "hierarchical"

    def __init__(
        self,
        space: Workspace,
        labels: NDArray[np.integer],
        graph: nx.Graph,
        *,
        leg_planner: str = "RRTConnect",
        leg_time_limit: float = 2.0,
        random_state: int = 0,
    ) -> None:
        clock = time.perf_counter()
        labels = np.asarray(labels)
        if labels.shape != space.grid.shape:
            raise ValueError(f"labels have shape {labels.shape}, the map {space.grid.shape}")
        self.space, self.graph = space, graph
        self.leg_planner, self.leg_time_limit = leg_planner, leg_time_limit
        self.random_state = random_state
        self.labels = _fill_unlabelled(labels, space.grid.free)
        self.parts, self.region_of = convex_parts(self.labels)
        self.doors = _find_doors(space, self.parts, find_transitions(space.grid, self.parts))
        self._doors_of: dict[int, list[int]] = {}
        for index, door in enumerate(self.doors):
            self._doors_of.setdefault(door.a, []).append(index)
            self._doors_of.setdefault(door.b, []).append(index)
        self._part_boxes = ndimage.find_objects(self.parts)
        self._region_boxes = ndimage.find_objects(self.labels)
        self._closed: set[tuple[int, int]] = set()
        self._legs: dict[tuple[int, int, int], _Leg | None] = {}
        self._submaps: dict[int, tuple[Workspace, NDArray[np.int32]]] = {}
        self._leg_planners: dict[int, FlatPlanner] = {}
        self._centres: dict[int, Point] = {}
        self.build_seconds = time.perf_counter() - clock

    def prepare(self) -> float:
        """Plan every door-to-door leg now rather than on first use; returns the seconds
        taken (preprocessing, like the segmentation)."""
        clock = time.perf_counter()
        for part, doors in self._doors_of.items():
            for i, a in enumerate(doors):
                for b in doors[i + 1 :]:
                    if self._leg((part, a, b), {}) is _UNPLANNED:
                        self._plan_leg((part, a, b), {}, {})
        return time.perf_counter() - clock

    # ------------------------------------------------------------------ queries on the map
    def region_at(self, x: float, y: float) -> int:
        """Region id at map point ``(x, y)`` (0 when off the map or in no region)."""
        row, col = self.space.grid.world_to_cell(x, y)
        if not self.space.grid.contains(row, col):
            return 0
        return int(self.labels[row, col])

    def centre(self, region: int) -> Point:
        """The free point of ``region`` farthest from its walls (where a region goal leads)."""
        if region not in self._centres:
            sub = self._crop(self.labels, self._region_boxes, region)
            depth = ndimage.distance_transform_edt(sub.free)
            row, col = np.unravel_index(np.argmax(depth), depth.shape)
            if depth[row, col] == 0:
                raise InvalidQueryError(f"region {region} has no room for the robot")
            x, y = sub.grid.cell_to_world(row, col)
            self._centres[region] = (float(x), float(y))
        return self._centres[region]

    # ------------------------------------------------------------------ doors
    def close_door(self, a: int, b: int) -> None:
        """Close every opening between regions ``a`` and ``b`` for later plans."""
        self._closed.add(self._edge(a, b))

    def open_door(self, a: int, b: int) -> None:
        """Reopen the openings between regions ``a`` and ``b``."""
        self._closed.discard(self._edge(a, b))

    def _edge(self, a: int, b: int) -> tuple[int, int]:
        if not self.graph.has_edge(a, b):
            raise InvalidQueryError(f"regions {a} and {b} share no door")
        return (min(a, b), max(a, b))

    def _open(self, door: int) -> bool:
        a, b = self.region_of[self.doors[door].a], self.region_of[self.doors[door].b]
        return (min(a, b), max(a, b)) not in self._closed

    # ------------------------------------------------------------------ planning
    def plan(self, start: ArrayLike, goal: Goal) -> Path:
        """Plan from ``start`` to ``goal``: a point, or a region id (its most open point).

        Raises
        ------
        InvalidQueryError
            A start or goal a robot cannot stand on, or an unknown region id.
        NoPathError
            No route: disconnected free space, or every route needs a closed door.
        """
        seconds = {"graph_search": 0.0, "local_planning": 0.0, "smoothing": 0.0}
        s = self.space.check(start, "start")
        if isinstance(goal, int | np.integer):
            if goal not in self.graph:
                raise InvalidQueryError(f"no region {goal}; ids: {sorted(self.graph.nodes)}")
            g = self.centre(int(goal))
        else:
            g = self.space.check(goal, "goal")
        if self.space.component_at(s) != self.space.component_at(g):
            raise NoPathError(f"start {s} and goal {g} lie in different parts of the free space")
        ends = {_START: (s, self._part_at(s)), _GOAL: (g, self._part_at(g))}
        query_legs: dict[tuple[int, int, int], _Leg | None] = {}
        while True:
            clock = time.perf_counter()
            route = self._search(ends, query_legs)
            seconds["graph_search"] += time.perf_counter() - clock
            if route is None:
                raise NoPathError(f"no route from {s} to {g} through open doors")
            pending = [step for step in route if self._leg(step, query_legs) is _UNPLANNED]
            if not pending:
                break
            clock = time.perf_counter()
            for step in pending:
                self._plan_leg(step, query_legs, ends)
            seconds["local_planning"] += time.perf_counter() - clock
        clock = time.perf_counter()
        waypoints, crossings = self._stitch(route, query_legs, ends)
        kept = shortcut(self.space, waypoints)
        portals = {i: self.doors[crossings[k]].portal for i, k in enumerate(kept) if k in crossings}
        waypoints = tighten(self.space, waypoints[kept], portals)
        waypoints = waypoints[shortcut(self.space, waypoints)]
        seconds["smoothing"] = time.perf_counter() - clock
        return Path(waypoints, self.name, self._regions_along(waypoints), seconds)

    def _point(self, node: int, ends: dict[int, tuple[Point, int]]) -> Point:
        return ends[node][0] if node < 0 else self.doors[node].point

    def _neighbours(
        self, node: int, ends: dict[int, tuple[Point, int]]
    ) -> Iterator[tuple[int, int]]:
        """``(part, next node)`` for every leg leaving ``node``."""
        parts = (ends[node][1],) if node < 0 else (self.doors[node].a, self.doors[node].b)
        for part in parts:
            if part == ends[_GOAL][1]:
                yield part, _GOAL
            for door in self._doors_of.get(part, ()):
                if door != node and self._open(door):
                    yield part, door

    def _search(
        self, ends: dict[int, tuple[Point, int]], query_legs: dict
    ) -> list[tuple[int, int, int]] | None:
        """A* from start to goal over door nodes; returns legs ``(part, from, to)``."""
        goal = np.asarray(ends[_GOAL][0])
        best = {_START: 0.0}
        parent: dict[int, tuple[int, int]] = {}
        frontier = [(0.0, 0.0, _START)]
        done = set()
        while frontier:
            _, cost, node = heapq.heappop(frontier)
            if node == _GOAL:
                route = []
                while node != _START:
                    part, previous = parent[node]
                    route.append((part, previous, node))
                    node = previous
                return route[::-1]
            if node in done:
                continue
            done.add(node)
            here = self._point(node, ends)
            for part, nxt in self._neighbours(node, ends):
                if nxt in done:
                    continue
                leg = self._leg((part, node, nxt), query_legs)
                if leg is None:
                    continue
                there = self._point(nxt, ends)
                step = leg.length if leg is not _UNPLANNED else math.dist(here, there)
                new = cost + step
                if new < best.get(nxt, math.inf):
                    best[nxt] = new
                    parent[nxt] = (part, node)
                    heapq.heappush(frontier, (new + math.dist(there, goal), new, nxt))
        return None

    def _leg(self, step: tuple[int, int, int], query_legs: dict) -> _Leg | None:
        """The planned leg (None if impossible), or ``_UNPLANNED``."""
        part, a, b = step
        store = query_legs if min(a, b) < 0 else self._legs
        return store.get((part, min(a, b), max(a, b)), _UNPLANNED)

    def _plan_leg(self, step: tuple[int, int, int], query_legs: dict, ends: dict) -> None:
        part, a, b = step
        lo, hi = min(a, b), max(a, b)
        store = query_legs if lo < 0 else self._legs
        p, q = np.asarray(self._point(lo, ends)), np.asarray(self._point(hi, ends))
        sub, pieces = self._submap(part)
        leg: _Leg | None
        if sub.segment_free(p, q):
            leg = _Leg(np.array([p, q]), math.dist(p, q))
        elif not _same_piece(sub, pieces, p, q):
            leg = None
        else:
            leg = self._ompl_leg(part, sub, p, q)
        store[(part, lo, hi)] = leg

    def _ompl_leg(self, part: int, sub: Workspace, p: NDArray, q: NDArray) -> _Leg | None:
        if part not in self._leg_planners:
            self._leg_planners[part] = FlatPlanner(
                sub,
                self.leg_planner,
                time_limit=self.leg_time_limit,
                bounds=sub.grid.bounds(),
                random_state=self.random_state,
            )
        try:
            planned = self._leg_planners[part].plan(p, q)
        except (NoPathError, InvalidQueryError):
            log.debug("no leg found in part %d from %s to %s", part, p, q)
            return None
        waypoints = tighten(sub, planned.waypoints[shortcut(sub, planned.waypoints)])
        return _Leg(waypoints, polyline_length(waypoints))

    def _part_at(self, point: Point) -> int:
        row, col = self.space.grid.world_to_cell(*point)
        return int(self.parts[row, col])

    def _submap(self, part: int) -> tuple[Workspace, NDArray[np.int32]]:
        """The part's workspace (its cells and a margin) and its connected pieces."""
        if part not in self._submaps:
            sub = self._crop(self.parts, self._part_boxes, part)
            self._submaps[part] = (sub, ndimage.label(sub.free)[0].astype(np.int32))
        return self._submaps[part]

    def _crop(self, labels: NDArray[np.int32], boxes: list, index: int) -> Workspace:
        """Workspace of the cells labelled ``index`` and a margin around them."""
        box = boxes[index - 1]
        h, w = labels.shape
        m = max(1, round(SUBMAP_MARGIN / self.space.grid.resolution))
        rows = slice(max(box[0].start - m, 0), min(box[0].stop + m, h))
        cols = slice(max(box[1].start - m, 0), min(box[1].stop + m, w))
        inside = ndimage.binary_dilation(labels[rows, cols] == index, iterations=m)
        return self.space.crop(rows, cols, inside)

    def _stitch(
        self, route: list, query_legs: dict, ends: dict
    ) -> tuple[NDArray[np.float64], dict[int, int]]:
        """The route's legs joined into one polyline, and waypoint index -> door crossed."""
        pieces: list[NDArray[np.float64]] = []
        crossings: dict[int, int] = {}
        count = 0
        for part, a, b in route:
            leg = self._leg((part, a, b), query_legs)
            assert isinstance(leg, _Leg)
            points = leg.waypoints if a < b else leg.waypoints[::-1]
            points = points if not pieces else points[1:]
            pieces.append(points)
            count += len(points)
            if b >= 0:
                crossings[count - 1] = b
        return np.vstack(pieces), crossings

    def _regions_along(self, waypoints: NDArray[np.float64]) -> tuple[int, ...]:
        """Regions a polyline passes through, in order."""
        points = sample_polyline(waypoints, self.space.grid.resolution)
        rows, cols = self.space.grid.world_to_cell(points[:, 0], points[:, 1])
        found = self.labels[rows, cols]
        found = found[found > 0]
        keep = np.concatenate([[len(found) > 0], found[1:] != found[:-1]])
        return tuple(int(r) for r in found[keep[: len(found)]])


def _same_piece(sub: Workspace, pieces: NDArray[np.int32], p: NDArray, q: NDArray) -> bool:
    rows, cols = sub.grid.world_to_cell([p[0], q[0]], [p[1], q[1]])
    inside = sub.grid.contains(rows, cols)
    if not inside.all():
        return False
    a, b = pieces[rows, cols]
    return bool(a and a == b)


def _point(xy: NDArray[np.float64]) -> Point:
    return (float(xy[0]), float(xy[1]))


def _fill_unlabelled(labels: NDArray[np.integer], free: NDArray[np.bool_]) -> NDArray[np.int32]:
    """Labels where free cells in no region take the label of the nearest labelled cell."""
    labels = labels.astype(np.int32)
    missing = free & (labels == 0)
    if missing.any() and (labels > 0).any():
        _, (rows, cols) = ndimage.distance_transform_edt(labels == 0, return_indices=True)
        labels = np.where(missing, labels[rows, cols], labels).astype(np.int32)
    return labels  # type: ignore[return-value]


def _find_doors(
    space: Workspace, labels: NDArray[np.int32], openings: list[Transition]
) -> list[Door]:
    """Doors of every opening where the robot fits (an opening too narrow gets none): one per
    stretch of at most :data:`DOOR_SPACING` metres of the opening's usable boundary, so the
    search sees where along a wide opening a path crosses. Each door's point is the boundary
    point nearest the middle of its stretch, its portal the stretch."""
    ra, ca, rb, cb = boundary_pairs(labels)
    usable = space.free[ra, ca] & space.free[rb, cb]
    ra, ca, rb, cb = ra[usable], ca[usable], rb[usable], cb[usable]
    xa, ya = space.grid.cell_to_world(ra, ca)
    xb, yb = space.grid.cell_to_world(rb, cb)
    middles = np.column_stack([(xa + xb) / 2, (ya + yb) / 2])
    pair_a, pair_b = labels[ra, ca], labels[rb, cb]
    doors = []
    for opening in openings:
        here = middles[(pair_a == opening.a) & (pair_b == opening.b)]
        gap = np.hypot(*(here - np.asarray(opening.centre)).T)
        points = here[gap <= opening.width / 2 + space.grid.resolution]
        if not len(points):
            continue
        axis = np.subtract(opening.end, opening.start)
        along = (points - points.mean(axis=0)) @ (axis / max(float(np.hypot(*axis)), 1e-12))
        order = np.argsort(along, kind="stable")
        stretches = max(1, math.ceil((along.max() - along.min()) / DOOR_SPACING))
        for piece in np.array_split(order, stretches):
            stretch = points[piece]
            middle = stretch[np.argmin(np.abs(along[piece] - along[piece].mean()))]
            ends = (_point(stretch[0]), _point(stretch[-1]))
            doors.append(Door(opening.a, opening.b, _point(middle), ends))
    return doors
