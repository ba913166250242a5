"""Hierarchical planning for footprint robots: the region graph first, then OMPL in submaps.

A query searches the door graph of :class:`~planners.hierarchical.HierarchicalPlanner` built
for a disc as wide as the narrowest door this robot takes (the footprint's width plus
``door_margin``, by default what the configuration space grows it by: a narrower door is no
door), which gives the route's submaps (near-convex parts) and the doors between them. Along
the route OMPL runs in one of two modes:

- ``"legs"`` (the default): one query per leg, from a pose across one door to any valid pose
  across the next (:mod:`planners.legs`), each leg confined to its submap grown by the
  robot's reach; the legs join into one continuous path.
- ``"union"``: one query from start to goal confined to the union of the route's submaps.

A confined space is the whole map's configuration space with the cells outside the submaps
(grown by ``submap_margin``) blocked for the reference point; the footprint is checked against
the whole map. If a route fails, the region graph's routes over doors the robot fits are
tried (:func:`planners.region_route.region_routes`, shortest first; submaps whole regions), up
to ``routes`` in all, within one ``time_limit`` per query, before :class:`NoPathError`.
"""

from __future__ import annotations

import logging
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import partial
from typing import Any

import cv2
import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from maps.limits import MAX_LENGTH, finite_in
from maps.seeding import RandomState, as_generator
from planners.cspace import HeadingCSpace
from planners.errors import (
    InvalidQueryError,
    NoPathError,
    PlannerParameterError,
    PlanningError,
    checked_time_limit,
)
from planners.flat import _seed_once, check_planner
from planners.hierarchical import HierarchicalPlanner, regions_along
from planners.kinematic import KinematicOMPL, Pose, describe, end_poses
from planners.legs import Crossing, door_poses
from planners.path import PlannedPath
from planners.region_route import region_routes
from planners.workspace import Point, Workspace
from segmentation.names import find_region

log = logging.getLogger(__name__)

#: How OMPL runs along a route.
MODES = ("legs", "union")
#: Confined OMPL set-ups a planner keeps for the legs to come (a memory bound).
KEPT_SUBMAPS = 512


@dataclass(frozen=True)
class Budget:
    """The time a query has left: until ``deadline`` (``time.perf_counter()`` seconds), to
    share over ``shares`` routes (this one and those that may follow)."""

    deadline: float
    shares: int

    def until(self) -> float:
        """When one OMPL query started now must stop: its share of the time left."""
        now = time.perf_counter()
        return now + max(self.deadline - now, 0.0) / self.shares


@dataclass(frozen=True)
class Route:
    """A route to plan along: ``ids`` of ``labels`` (``kind``: ``"parts"`` or
    ``"regions"``) in the order it passes them (``boxes`` their bounding boxes), and the
    ``crossings`` between each two in a row."""

    what: str
    kind: str
    labels: NDArray[np.int32]
    boxes: list
    ids: list[int]
    crossings: list[Crossing]


def _check_routes(routes: object) -> None:
    if not (isinstance(routes, int) and not isinstance(routes, bool) and routes >= 1):
        raise PlannerParameterError(f"routes must be an integer >= 1, got {routes!r:.80}")


def _check_mode(mode: object) -> None:
    if not (isinstance(mode, str) and mode in MODES):
        raise PlannerParameterError(f"mode must be one of {', '.join(MODES)}, got {mode!r:.80}")


def _check_margin(name: str, margin: object) -> None:
    problem = None if margin is None else finite_in(margin, name, 0.0, MAX_LENGTH, unit="m")
    if problem is not None:
        raise PlannerParameterError(problem)


#: The check of each option of :class:`KinematicHierarchicalPlanner` but the configuration
#: space, the labels and the graph.
_OPTION_CHECKS: dict[str, Callable[[Any], object]] = {
    "planner": lambda planner: planner is None or check_planner(planner),
    "time_limit": checked_time_limit,
    "routes": _check_routes,
    "mode": _check_mode,
    "door_margin": partial(_check_margin, "door_margin"),
    "submap_margin": partial(_check_margin, "submap_margin"),
    "random_state": as_generator,
}


def check_options(**options: Any) -> None:
    """Raise a typed error naming the first of ``options`` that
    :class:`KinematicHierarchicalPlanner` does not take or that makes no sense, before
    anything is built or the options are a key (a list is no planner name, nor a key).

    Raises
    ------
    PlannerParameterError
        An unknown option or a value out of range or of the wrong kind.
    RandomStateError
        A ``random_state`` that is no seed.

    Examples
    --------
    >>> check_options(planner="RRT", routes=2, door_margin=None)
    >>> check_options(routes=[2])
    Traceback (most recent call last):
    ...
    planners.errors.PlannerParameterError: routes must be an integer >= 1, got [2]
    """
    for name, value in options.items():
        check = _OPTION_CHECKS.get(name)
        if check is None:
            known = ", ".join(_OPTION_CHECKS)
            raise PlannerParameterError(
                f"unknown option {name}={value!r:.80}; the options are {known}"
            )
        check(value)


class KinematicHierarchicalPlanner:
    """Door-graph route first, then OMPL inside the route's submaps (per leg or over their
    union).

    Parameters
    ----------
    cspace
        Valid poses of the robot on the whole map.
    labels
        Region id of every cell (0 = none), aligned with ``cspace.grid``.
    graph
        The region adjacency graph; edges carry ``doors`` with their ``width``.
    planner
        OMPL planner name (:data:`planners.flat.PLANNERS`); by default RRTConnect, or RRT
        for a robot whose motions are not symmetric (Dubins: RRTConnect grows its goal tree
        along motions reversed, which a forward-only car cannot drive, and stalls at a door
        pose facing a wall beyond the submap).
    time_limit
        Seconds OMPL may take per query, all routes and legs together (a leg, or the union's
        query, of route ``k`` of ``routes`` may take the time left over the routes left).
    routes
        Routes tried, best first, before giving up.
    mode
        ``"legs"`` or ``"union"`` (:data:`MODES`, see the module's description).
    door_margin
        Metres a door must be wider than the footprint; by default twice the configuration
        space's :attr:`~planners.cspace.HeadingCSpace.growth` (a narrower door has no valid
        pose: it is no door for this robot).
    submap_margin
        Metres a submap reaches beyond its part or region; by default the robot's
        :attr:`~planners.robots.Footprint.reach` (what passing a door needs).
    random_state
        OMPL's seed (process-wide: only the first planner made in a process sets it).

    Attributes
    ----------
    name
        ``"hierarchical"`` in the default mode, else ``"hierarchical_<mode>"``.
    """

    def __init__(
        self,
        cspace: HeadingCSpace,
        labels: NDArray[np.integer],
        graph: nx.Graph,
        *,
        planner: str | None = None,
        time_limit: float = 5.0,
        routes: int = 3,
        mode: str = "legs",
        door_margin: float | None = None,
        submap_margin: float | None = None,
        random_state: RandomState = 0,
    ) -> None:
        clock = time.perf_counter()
        check_options(
            planner=planner,
            time_limit=time_limit,
            routes=routes,
            mode=mode,
            door_margin=door_margin,
            submap_margin=submap_margin,
            random_state=random_state,
        )
        margin = cspace.robot.reach if submap_margin is None else float(submap_margin)
        _seed_once(random_state)
        fit = 2 * cspace.growth if door_margin is None else float(door_margin)
        self.min_width = cspace.robot.width + fit
        # the door graph of a disc as wide as the narrowest door this robot may take
        self.doors = HierarchicalPlanner(Workspace(cspace.grid, self.min_width / 2), labels, graph)
        if planner is None:
            symmetric = cspace.robot.state_space().hasSymmetricInterpolate()
            planner = "RRTConnect" if symmetric else "RRT"
        self.cspace, self.graph, self.planner, self.mode = cspace, graph, planner, mode
        self.name = "hierarchical" if mode == MODES[0] else f"hierarchical_{mode}"
        # the whole map's OMPL set-up: the joined path is simplified there
        self._whole = KinematicOMPL(cspace, planner)
        self._kept: OrderedDict[tuple[str, tuple[int, ...]], KinematicOMPL] = OrderedDict()
        self.labels = self.doors.labels
        self.time_limit, self.routes = float(time_limit), int(routes)
        self._grow = max(1, round(margin / cspace.grid.resolution))
        self._region_boxes = ndimage.find_objects(self.labels)
        self._part_boxes = ndimage.find_objects(self.doors.parts)
        self.build_seconds = time.perf_counter() - clock

    def prepare(self) -> float:
        """Build the door graph now rather than at the first query; returns its seconds."""
        return self.doors.prepare()

    def region_at(self, x: float, y: float) -> int:
        """Region id at map point ``(x, y)`` (0 when off the map or in no region)."""
        return self.doors.region_at(x, y)

    def plan(self, start: ArrayLike | int | str, goal: ArrayLike | int | str) -> PlannedPath:
        """Plan from ``start`` to ``goal``: poses ``(x, y, yaw)`` or points ``(x, y)`` (the
        valid heading nearest 0, or any valid heading for a forward-only car:
        :func:`planners.kinematic.end_poses`), or regions (an id or a name,
        :func:`segmentation.names.find_region`) standing for their most open points.

        The first route is the door graph's shortest path for a disc as wide as the
        narrowest door the robot takes, its submaps the near-convex parts it crosses; the next
        ones are the region graph's routes, shortest first, their submaps whole regions.

        Raises
        ------
        InvalidQueryError
            A start or goal in collision, off the map or in no region.
        RegionNotFoundError
            An unknown region.
        NoPathError
            No route through doors the robot fits, or OMPL failed on every route tried.
        """
        clock = time.perf_counter()
        deadline = clock + self.time_limit
        start, goal = (
            self.doors.centre(find_region(self.graph, end))
            if isinstance(end, int | np.integer | str)
            else end
            for end in (start, goal)
        )
        s, g = end_poses(self.cspace, start, "start"), end_poses(self.cspace, goal, "goal")
        for what, poses in (("start", s), ("goal", g)):
            if self.region_at(poses[0][0], poses[0][1]) not in self.graph:
                raise InvalidQueryError(f"{what} {poses[0][:2]} lies in no region of the graph")
        seconds = {"route_search": 0.0, "submaps": 0.0, "planning": 0.0, "simplification": 0.0}
        routes = self._routes(s[0], g[0])
        tried: list[str] = []
        for k in range(self.routes):
            clock = time.perf_counter()
            route = next(routes, None)
            seconds["route_search"] += time.perf_counter() - clock
            if route is None or clock >= deadline:
                break
            tried.append(route.what)
            along = self._legs if self.mode == "legs" else self._union
            found = along(route, s, g, Budget(deadline, self.routes - k), seconds)
            if found is not None:
                crossed = regions_along(self.cspace.grid, self.labels, found[:, :2])
                return PlannedPath.from_poses(found, self.name, crossed, seconds)
        if not tried:
            raise NoPathError(
                f"no route from {describe(s)} to {describe(g)} through doors at least "
                f"{self.min_width:g} m wide"
            )
        raise NoPathError(
            f"OMPL {self.planner} found no path from {describe(s)} to {describe(g)} in "
            f"{self.time_limit:g} s "
            f"on any of the routes tried: {'; '.join(tried)}"
        )

    def _routes(self, s: Pose, g: Pose) -> Iterator[Route]:
        """Routes best first: the door graph's, then the region graph's."""
        try:
            doors, parts = self.doors.door_route(s[:2], g[:2])
        except PlanningError as err:
            log.debug("no door-graph route (%s): trying region routes", err)
        else:
            crossings = [
                Crossing(door.point, (door.opening.start, door.opening.end), a, b)
                for door, a, b in zip(
                    (self.doors.doors[d] for d in doors), parts[:-1], parts[1:], strict=False
                )
            ]
            what = f"door graph through submaps {parts}"
            yield Route(what, "parts", self.doors.parts, self._part_boxes, parts, crossings)
        ends = self.region_at(s[0], s[1]), self.region_at(g[0], g[1])
        try:
            for found in region_routes(self.graph, *ends, min_width=self.min_width):
                ids = list(found.regions)
                crossings = [
                    Crossing(t.centre, (t.start, t.end), a, b)
                    for t, a, b in zip(found.doors, ids[:-1], ids[1:], strict=True)
                ]
                what = f"regions {ids}"
                yield Route(what, "regions", self.labels, self._region_boxes, ids, crossings)
        except NoPathError as err:
            log.debug("no region route: %s", err)

    def _union(
        self,
        route: Route,
        start: list[Pose],
        goal: list[Pose],
        budget: Budget,
        seconds: dict[str, float],
    ) -> NDArray[np.float64] | None:
        """One OMPL query inside the union of the route's submaps, simplified on the whole
        map: its poses."""
        vertices = self._solve(route, route.ids, start, goal, budget.until(), seconds)
        return None if vertices is None else self._smooth(vertices, seconds)

    def _legs(
        self,
        route: Route,
        start: list[Pose],
        goal: list[Pose],
        budget: Budget,
        seconds: dict[str, float],
    ) -> NDArray[np.float64] | None:
        """One OMPL query per leg between door poses, the legs joined end to end: their poses.
        Each leg may take the budget's share of the time left, so a leg that fails leaves
        time for the next routes, and a long route of easy legs may use the whole budget.
        The joined path is simplified on the whole map, as a flat planner's is: shortcuts
        may cut across the doors and drop their fixed poses and headings."""
        clock = time.perf_counter()
        ids: list[int] = [route.ids[0]]
        legs: list[tuple[list[int], list[Pose]]] = []
        points = [start[0][:2], *(c.point for c in route.crossings), goal[0][:2]]
        last = np.asarray(points[0], float)  # where the current leg starts
        for k, (crossing, after) in enumerate(zip(route.crossings, route.ids[1:], strict=True)):
            stop = self._ends(route, crossing) or self._room(last, crossing.point, points[k + 2])
            poses = door_poses(crossing, route.labels, self.cspace) if stop else []
            if poses:
                last = np.asarray(crossing.point, float)
                legs.append((ids, poses))
                ids = []
            ids.append(after)
        legs.append((ids, goal))
        seconds["submaps"] += time.perf_counter() - clock
        pieces: list[NDArray[np.float64]] = []
        froms: list[tuple[list[Pose], list[int]]] = []  # each planned leg's start, submaps
        pose = start
        for k, (leg, ends) in enumerate(legs):
            found = self._leg(route, k, len(legs), leg, pose, ends, budget, seconds)
            if found is None and pieces:
                # the previous leg's end (a pose across a door) may be one this leg cannot
                # leave at the car's turning radius: the two legs as one, from its start
                pieces.pop()
                pose, before = froms.pop()
                leg = before + leg
                found = self._leg(route, k, len(legs), leg, pose, ends, budget, seconds)
            if found is None:
                return None
            froms.append((pose, leg))
            pieces.append(found if not pieces else found[1:])
            pose = [(float(found[-1, 0]), float(found[-1, 1]), float(found[-1, 2]))]
        return self._smooth(np.vstack(pieces), seconds)

    def _leg(
        self,
        route: Route,
        k: int,
        count: int,
        leg: list[int],
        start: list[Pose],
        ends: list[Pose],
        budget: Budget,
        seconds: dict[str, float],
    ) -> NDArray[np.float64] | None:
        """Leg ``k`` of ``count``: :meth:`_solve` in submaps ``leg``, its share of the
        budget."""
        clock = time.perf_counter()
        found = self._solve(route, list(dict.fromkeys(leg)), start, ends, budget.until(), seconds)
        log.debug(
            "leg %d of %d (submaps %s, from %s to %s): %s in %.3f s",
            k + 1, count, leg, describe(start), describe(ends),
            "failed" if found is None else f"{len(found)} vertices",
            time.perf_counter() - clock,
        )  # fmt: skip
        return found

    def _ends(self, route: Route, crossing: Crossing) -> bool:
        """Whether a leg ends across ``crossing`` whatever its surroundings: always for a
        robot that reverses or turns in place; for a forward-only car at the doors between
        regions, since a cut between two parts of one region (along a corridor) may leave
        it too little room to turn, at its turning radius, into a side door just after it
        (such a cut ends a leg only where :meth:`_room` says so)."""
        if self.cspace.robot.reverses or route.kind == "regions":
            return True
        return self.doors.region_of[crossing.before] != self.doors.region_of[crossing.after]

    def _room(self, last: NDArray, here: Point, after: Point) -> bool:
        """Whether a forward-only car may end a leg at a cut ``here`` between two parts of
        one region: when the leg started (``last``) and the next crossing (or the goal)
        ``after`` lie at least a turn's room away, twice the turning radius plus the
        circumradius, so the fixed pose across the cut (heading along the corridor) leaves
        the car room to turn into a side door. Ending there splits a long corridor leg (86
        submaps of a campus corridor system in one RRT query: none found in 5 s) into short
        ones between poses the car can drive between."""
        robot = self.cspace.robot
        room = 2 * (getattr(robot, "turning_radius", 0.0) + robot.circumradius)
        p = np.asarray(here, float)
        return bool(
            np.hypot(*(p - last)) >= room and np.hypot(*(p - np.asarray(after, float))) >= room
        )

    def _smooth(self, vertices: NDArray[np.float64], seconds: dict[str, float]) -> NDArray:
        """The path through ``vertices`` simplified on the whole map, as poses."""
        poses, spent = self._whole.smooth(vertices)
        seconds["simplification"] += spent
        return poses

    def _solve(
        self,
        route: Route,
        ids: list[int],
        start: list[Pose],
        goal: list[Pose],
        until: float,
        seconds: dict[str, float],
    ) -> NDArray[np.float64] | None:
        """One OMPL query inside the cells of ``route.labels`` labelled ``ids``, grown by the
        submap margin, with the time left until ``until``: the solution's vertices."""
        clock = time.perf_counter()
        if clock >= until:
            return None
        # the motion straight to a goal first, on the whole map: when valid it needs no
        # submap set-up and no planner (most legs between the door poses of near-convex
        # submaps), and it is the shortest leg between the two poses
        starts = [pose for pose in start if self._whole.admits(pose)]
        direct = self._whole.direct(starts, goal) if starts else None
        if direct is not None:
            seconds["planning"] += time.perf_counter() - clock
            return direct
        clock = time.perf_counter()
        ompl = self._submaps(route, ids)
        goals = [pose for pose in goal if ompl.admits(pose)]
        starts = [pose for pose in start if ompl.admits(pose)]
        seconds["submaps"] += time.perf_counter() - clock
        if not (goals and starts):
            log.debug(
                "the ends %s, %s are not valid in submaps %s", describe(start), describe(goal), ids
            )
            return None
        poses, spent = ompl.search(
            starts, goals, max(until - time.perf_counter(), 1e-3), direct=False
        )
        for key, value in spent.items():
            seconds[key] += value
        return poses

    def _submaps(self, route: Route, ids: list[int]) -> KinematicOMPL:
        """The OMPL set-up confined to the submaps ``ids`` of ``route``, made once and kept
        (the :data:`KEPT_SUBMAPS` used last): legs through the same submaps recur."""
        key = (route.kind, tuple(ids))
        ompl = self._kept.pop(key, None)
        if ompl is None:
            ompl = KinematicOMPL(self._confined(route.labels, route.boxes, ids), self.planner)
        self._kept[key] = ompl
        while len(self._kept) > KEPT_SUBMAPS:
            self._kept.popitem(last=False)
        return ompl

    def _confined(self, labels: NDArray[np.int32], boxes: list, ids: list[int]) -> HeadingCSpace:
        """The configuration space inside the cells labelled ``ids``, grown by the margin."""
        h, w = labels.shape
        picked = [boxes[i - 1] for i in ids]
        rows = slice(
            max(min(b[0].start for b in picked) - self._grow, 0),
            min(max(b[0].stop for b in picked) + self._grow, h),
        )
        cols = slice(
            max(min(b[1].start for b in picked) - self._grow, 0),
            min(max(b[1].stop for b in picked) + self._grow, w),
        )
        outside = (~np.isin(labels[rows, cols], ids)).astype(np.uint8)
        away = cv2.distanceTransform(outside, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        return self.cspace.crop(rows, cols, away <= self._grow)
