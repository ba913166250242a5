"""A planned path, the query of the search planners, and shortening a valid polyline without
leaving the free space."""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.geometry import polyline_length
from planners.workspace import Point, PointLike, Workspace


@dataclass(frozen=True)
class PlannedPath:
    """A collision-free path from start to goal.

    Attributes
    ----------
    waypoints
        ``(n, 2)`` map-frame points, start first, goal last.
    planner
        Name of the planner that made it.
    regions
        Regions crossed, in order (empty for planners that do not know regions).
    seconds
        Time per stage of the query, e.g. ``graph_search``, ``local_planning``, ``smoothing``.
    headings
        ``(n,)`` yaw of the robot at each waypoint, radians, for robots with a footprint
        (None for a disc, which has no heading).
    """

    waypoints: NDArray[np.float64]
    planner: str
    regions: tuple[int, ...] = ()
    seconds: dict[str, float] = field(default_factory=dict)
    headings: NDArray[np.float64] | None = None

    @classmethod
    def from_poses(
        cls,
        poses: ArrayLike,
        planner: str,
        regions: tuple[int, ...] = (),
        seconds: dict[str, float] | None = None,
    ) -> PlannedPath:
        """A path of ``(n, 3)`` poses ``(x, y, yaw)``."""
        p = np.asarray(poses, float).reshape(-1, 3)
        return cls(p[:, :2], planner, regions, dict(seconds or {}), p[:, 2])

    @property
    def poses(self) -> NDArray[np.float64]:
        """``(n, 3)`` poses ``(x, y, yaw)``; a disc's path has yaw 0."""
        yaw = np.zeros(len(self.waypoints)) if self.headings is None else self.headings
        return np.column_stack([self.waypoints, yaw])

    @property
    def length(self) -> float:
        """Length in metres."""
        return polyline_length(self.waypoints)

    @property
    def total_seconds(self) -> float:
        """Whole query time."""
        return float(sum(self.seconds.values()))

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready description (with ``poses`` ``[x, y, yaw]`` for a footprint robot)."""
        found: dict[str, Any] = {
            "planner": self.planner,
            "length_m": round(self.length, 4),
            "waypoints": [[round(float(x), 4), round(float(y), 4)] for x, y in self.waypoints],
            "regions": list(self.regions),
            "seconds": {k: round(v, 6) for k, v in self.seconds.items()},
        }
        if self.headings is not None:
            found["poses"] = [[round(float(v), 4) for v in pose] for pose in self.poses]
        return found


class SearchPlanner(ABC):
    """A planner whose query is one search on its :attr:`space` (the grid and visibility
    planners): :meth:`plan` checks the start and goal, runs :meth:`_search` and times it as
    the path's ``search`` seconds."""

    name: str
    space: Workspace

    def plan(self, start: ArrayLike, goal: ArrayLike) -> PlannedPath:
        """The path from ``start`` to ``goal``, as the class describes it.

        Raises
        ------
        InvalidQueryError
            A start or goal a robot cannot stand on.
        NoPathError
            No path joins them.
        """
        clock = time.perf_counter()
        s, g = self.space.check(start, "start"), self.space.check(goal, "goal")
        waypoints = self._search(s, g)
        return PlannedPath(waypoints, self.name, seconds={"search": time.perf_counter() - clock})

    @abstractmethod
    def _search(self, start: Point, goal: Point) -> NDArray[np.float64]:
        """The ``(n, 2)`` waypoints from ``start`` to ``goal`` (both valid), start and goal
        included; raises :class:`~planners.errors.NoPathError` when none joins them."""


def shortcut(space: Workspace, waypoints: ArrayLike) -> NDArray[np.intp]:
    """Indices of the points of a valid polyline worth keeping: from each kept point, go
    straight to the last point of the run of later points it sees. The kept polyline is
    valid."""
    p = np.asarray(waypoints, float).reshape(-1, 2)
    kept = [0]
    while kept[-1] < len(p) - 1:
        i = kept[-1]
        j = i + 1
        while j + 1 < len(p) and space.segment_free(p[i], p[j + 1]):
            j += 1
        kept.append(j)
    return np.array(kept)


def tighten(
    space: Workspace,
    waypoints: ArrayLike,
    portals: Mapping[int, tuple[PointLike, PointLike]] | None = None,
    *,
    passes: int = 20,
    first: Iterable[int] | None = None,
    tries: int = 4,
) -> NDArray[np.float64]:
    """Shorten a valid polyline by moving its inner points, keeping every segment valid.

    Each pass moves every inner point, in turn, to where the polyline through its neighbours
    is shortest: a point with a portal (a door line it crosses) slides along it (to the
    straight line between the neighbours, or towards the neighbour mirrored in the portal,
    clamped to the segment); any other point is pulled towards the straight line between
    its neighbours. A move that would make a segment invalid is halved, up to ``tries - 1``
    times.
    A pass only tries the points next to one that moved in the pass before; passes stop when
    no point moves by more than a hundredth of a cell.

    Parameters
    ----------
    space
        The free space the polyline lies in.
    waypoints
        ``(n, 2)`` valid polyline.
    portals
        Waypoint index -> ``(end, end)`` of the segment that point may slide on.
    passes
        Most passes.
    first
        Inner points the first pass tries (all by default): points known to be taut (e.g.
        the corners of shortest legs) can be left to later passes, which try the
        neighbours of every point that moved.
    tries
        Moves tried per point and pass (the full move, then halves of it).
    """
    p = [(float(x), float(y)) for x, y in np.asarray(waypoints, float).reshape(-1, 2)]
    ends = {
        i: tuple((float(e[0]), float(e[1])) for e in portal)
        for i, portal in ({} if portals is None else portals).items()
    }
    tolerance = space.grid.resolution * 1e-2
    inner = range(1, len(p) - 1)
    todo = set(inner) if first is None else set(first) & set(inner)
    for _ in range(passes):
        moved: set[int] = set()
        for i in sorted(todo):
            if i in ends:
                best = _best_on_segment(p[i - 1], p[i + 1], *ends[i])
            else:
                best = _closest_on_segment(p[i], p[i - 1], p[i + 1])
            if math.hypot(best[0] - p[i][0], best[1] - p[i][1]) < tolerance:
                continue
            for _halving in range(tries):
                if space.segment_free(p[i - 1], best) and space.segment_free(best, p[i + 1]):
                    p[i] = best
                    moved.add(i)
                    break
                best = ((best[0] + p[i][0]) / 2, (best[1] + p[i][1]) / 2)
        todo = {j for i in moved for j in (i - 1, i, i + 1) if 0 < j < len(p) - 1}
        if not todo:
            break
    return np.array(p, float).reshape(-1, 2)


def _closest_on_segment(point: Point, a: Point, b: Point) -> Point:
    """The point of segment ``a b`` closest to ``point`` (plain floats: called per point)."""
    du, dv = b[0] - a[0], b[1] - a[1]
    span = du * du + dv * dv
    t = (
        0.0
        if span == 0
        else min(max(((point[0] - a[0]) * du + (point[1] - a[1]) * dv) / span, 0.0), 1.0)
    )
    return (a[0] + t * du, a[1] + t * dv)


def _best_on_segment(a: Point, c: Point, e1: Point, e2: Point) -> Point:
    """The point of segment ``e1 e2`` minimising the distance from ``a`` plus to ``c``."""
    du, dv = e2[0] - e1[0], e2[1] - e1[1]
    span = du * du + dv * dv
    if span == 0:
        return e1
    nu, nv = -dv, du  # the portal's normal
    side_a = (a[0] - e1[0]) * nu + (a[1] - e1[1]) * nv
    side_c = (c[0] - e1[0]) * nu + (c[1] - e1[1]) * nv
    if side_a * side_c > 0:  # same side: mirror c in the portal line
        c = (c[0] - 2 * side_c / span * nu, c[1] - 2 * side_c / span * nv)
        side_c = -side_c
    if side_a == side_c:
        t = ((a[0] - e1[0]) * du + (a[1] - e1[1]) * dv) / span
    else:
        f = side_a / (side_a - side_c)
        hu, hv = a[0] + f * (c[0] - a[0]), a[1] + f * (c[1] - a[1])
        t = ((hu - e1[0]) * du + (hv - e1[1]) * dv) / span
    t = min(max(t, 0.0), 1.0)
    return (e1[0] + t * du, e1[1] + t * dv)
