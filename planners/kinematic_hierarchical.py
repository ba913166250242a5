"""Hierarchical planning for footprint robots: the region graph first, then OMPL in submaps.

A query finds the start's and the goal's regions and searches the region graph for routes over
the doors this robot fits through (a door narrower than the footprint's width plus
``door_margin`` is no door: :func:`planners.region_route.region_routes`). Along the best route
it runs one OMPL query confined to the union of the route's submaps, the regions grown by
``submap_margin`` (a state whose reference point lies outside is invalid; the footprint is
checked against the whole map's configuration space). If OMPL finds nothing within its time
limit, the next-best route is tried, up to ``routes`` of them, before :class:`NoPathError`.

One query over the union of the route's regions, not a query per leg between door poses:
a leg has to fix the robot's pose at each door (position and heading), which a car may only
reach by manoeuvring, and a leg that fails for a bad door pose fails the route; the union
keeps the search as free as the flat planner's inside a space a few rooms large.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator

import cv2
import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from maps.seeding import RandomState
from planners.cspace import HeadingCSpace
from planners.errors import InvalidQueryError, NoPathError, PlannerParameterError, PlanningError
from planners.flat import _seed_once
from planners.hierarchical import HierarchicalPlanner, regions_along
from planners.kinematic import KinematicOMPL, Pose, check_pose
from planners.path import PlannedPath
from planners.region_route import region_routes
from planners.workspace import Workspace, sample_polyline
from segmentation.names import find_region

log = logging.getLogger(__name__)

#: Metres a door must be wider than the footprint.
DOOR_MARGIN = 0.1
#: Metres a submap reaches beyond its part or region, so the robot can pass the doorways.
SUBMAP_MARGIN = 1.0


class KinematicHierarchicalPlanner:
    """Door-graph route first, then one OMPL query inside the route's submaps.

    Parameters
    ----------
    cspace
        Valid poses of the robot on the whole map.
    labels
        Region id of every cell (0 = none), aligned with ``cspace.grid``.
    graph
        The region adjacency graph; edges carry ``doors`` with their ``width``.
    planner
        OMPL planner name (:data:`planners.flat.PLANNERS`).
    time_limit
        Seconds OMPL may take per route.
    routes
        Routes tried, best first, before giving up.
    door_margin, submap_margin
        See :data:`DOOR_MARGIN`, :data:`SUBMAP_MARGIN`.
    random_state
        OMPL's seed (process-wide: only the first planner made in a process sets it).
    """

    name = "hierarchical"

    def __init__(
        self,
        cspace: HeadingCSpace,
        labels: NDArray[np.integer],
        graph: nx.Graph,
        *,
        planner: str = "RRTConnect",
        time_limit: float = 5.0,
        routes: int = 3,
        door_margin: float = DOOR_MARGIN,
        submap_margin: float = SUBMAP_MARGIN,
        random_state: RandomState = 0,
    ) -> None:
        clock = time.perf_counter()
        if not time_limit > 0:
            raise PlannerParameterError(f"time_limit must be > 0 seconds, got {time_limit}")
        if routes < 1:
            raise PlannerParameterError(f"routes must be >= 1, got {routes}")
        _seed_once(random_state)
        self.min_width = cspace.robot.width + door_margin
        # the door graph of a disc as wide as the narrowest door this robot may take
        self.doors = HierarchicalPlanner(Workspace(cspace.grid, self.min_width / 2), labels, graph)
        self.cspace, self.graph, self.planner = cspace, graph, planner
        self.labels = self.doors.labels
        self.time_limit, self.routes = float(time_limit), int(routes)
        self._grow = max(1, round(submap_margin / cspace.grid.resolution))
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
        valid heading nearest 0), or regions (an id or a name,
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
        start, goal = (
            self.doors.centre(find_region(self.graph, end))
            if isinstance(end, int | np.integer | str)
            else end
            for end in (start, goal)
        )
        s, g = check_pose(self.cspace, start, "start"), check_pose(self.cspace, goal, "goal")
        for what, pose in (("start", s), ("goal", g)):
            if self.region_at(pose[0], pose[1]) not in self.graph:
                raise InvalidQueryError(f"{what} {pose[:2]} lies in no region of the graph")
        seconds = {"route_search": 0.0, "submaps": 0.0, "planning": 0.0, "simplification": 0.0}
        routes = self._routes(s, g)
        tried: list[str] = []
        for _ in range(self.routes):
            clock = time.perf_counter()
            found = next(routes, None)
            seconds["route_search"] += time.perf_counter() - clock
            if found is None:
                break
            what, labels, boxes, ids = found
            tried.append(what)
            poses = self._inside(labels, boxes, ids, s, g, seconds)
            if poses is not None:
                crossed = regions_along(self.cspace.grid, self.labels, poses[:, :2])
                return PlannedPath.from_poses(poses, self.name, crossed, seconds)
        if not tried:
            raise NoPathError(
                f"no route from {s} to {g} through doors at least {self.min_width:g} m wide"
            )
        raise NoPathError(
            f"OMPL {self.planner} found no path from {s} to {g} in {self.time_limit:g} s "
            f"on any of the routes tried: {'; '.join(tried)}"
        )

    def _routes(self, s: Pose, g: Pose) -> Iterator[tuple[str, NDArray[np.int32], list, list[int]]]:
        """Routes best first, each as (description, label image, its boxes, the ids kept)."""
        try:
            guide = self.doors.plan(s[:2], g[:2])
        except PlanningError as err:
            log.debug("no door-graph route (%s): trying region routes", err)
        else:
            points = sample_polyline(guide.waypoints, self.cspace.grid.resolution)
            rows, cols = self.cspace.grid.world_to_cell(points[:, 0], points[:, 1])
            parts = [int(p) for p in dict.fromkeys(self.doors.parts[rows, cols]) if p > 0]
            yield f"door graph through submaps {parts}", self.doors.parts, self._part_boxes, parts
        ends = self.region_at(s[0], s[1]), self.region_at(g[0], g[1])
        try:
            for route in region_routes(self.graph, *ends, min_width=self.min_width):
                ids = list(route.regions)
                yield f"regions {ids}", self.labels, self._region_boxes, ids
        except NoPathError as err:
            log.debug("no region route: %s", err)

    def _inside(
        self,
        labels: NDArray[np.int32],
        boxes: list,
        ids: list[int],
        start: Pose,
        goal: Pose,
        seconds: dict[str, float],
    ) -> NDArray[np.float64] | None:
        """One OMPL query inside the cells labelled ``ids``, grown by the submap margin."""
        clock = time.perf_counter()
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
        inside = np.isin(labels[rows, cols], ids).astype(np.uint8)
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * self._grow + 1,) * 2)
        keep = cv2.dilate(inside, disc).astype(bool)
        ompl = KinematicOMPL(self.cspace.crop(rows, cols, keep), self.planner)
        seconds["submaps"] += time.perf_counter() - clock
        poses, spent = ompl.solve(start, goal, self.time_limit)
        for key, value in spent.items():
            seconds[key] += value
        return poses
