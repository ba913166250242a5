"""OMPL planners for footprint robots (SE(2), Dubins, Reeds-Shepp) on a configuration space.

:class:`KinematicOMPL` is one OMPL set-up: the robot's state space bounded by a
:class:`~planners.cspace.HeadingCSpace` (the whole map, or the crop of a few submaps), a state
valid when the configuration space says so, motions checked by OMPL's discrete motion
validator at states whose footprint points are at most a cell apart (the configuration space
is grown by half a cell, so a checked motion is collision-free between its states). Both the
flat baseline (:class:`FlatKinematicPlanner`) and the hierarchical planner
(:mod:`planners.kinematic_hierarchical`) plan with it, so they share the state space, the
validity and motion checks, the planner and the simplification.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from maps.seeding import RandomState
from planners.cspace import HeadingCSpace
from planners.errors import (
    InvalidQueryError,
    NoPathError,
    PlannerParameterError,
    checked_time_limit,
)
from planners.flat import (
    ROADMAP_PLANNERS,
    _seed_once,
    check_planner,
    make_planner,
    plane_bounds,
    solve_query,
)
from planners.path import PlannedPath

log = logging.getLogger(__name__)

Pose = tuple[float, float, float]
#: Largest distance between two poses of a returned path, metres.
POSE_SPACING = 0.05
#: Steps of OMPL's B-spline smoothing in a simplification (OMPL's ``simplify`` uses 3).
SMOOTHING_STEPS = 3


class KinematicOMPL:
    """One OMPL geometric planner on a robot's state space over ``cspace``.

    Parameters
    ----------
    cspace
        Valid poses; the state space's bounds are its grid's.
    planner
        Name of an OMPL geometric planner (:data:`planners.flat.PLANNERS`).
    random_state
        Seeds OMPL's process-wide generator (only the first planner made in a process
        does).

    Raises
    ------
    PlannerParameterError
        An unknown planner, or a roadmap planner (PRM, PRM*) on a state space whose motions
        are not reversible (Dubins).
    """

    def __init__(
        self, cspace: HeadingCSpace, planner: str = "RRTConnect", random_state: RandomState = 0
    ) -> None:
        check_planner(planner)
        ou.setLogLevel(ou.LOG_WARN)
        _seed_once(random_state)
        self.cspace = cspace
        self._space = cspace.robot.state_space()
        if planner in ROADMAP_PLANNERS and not self._space.hasSymmetricInterpolate():
            raise PlannerParameterError(
                f"{planner} travels its roadmap's edges both ways, but a forward-only car's "
                "motion from a to b is not that from b to a reversed (its paths went through "
                "walls): use a tree planner (RRT, RRTConnect, RRTstar, BITstar, KPIECE1)"
            )
        xmin, ymin, xmax, ymax = cspace.grid.bounds()
        self._space.setBounds(plane_bounds(xmin, ymin, xmax, ymax))
        self._si = ob.SpaceInformation(self._space)
        valid = cspace.valid
        self._si.setStateValidityChecker(lambda s: valid(s.getX(), s.getY(), s.getYaw()))
        step = cspace.robot.motion_step(cspace.grid.resolution)
        self._si.setStateValidityCheckingResolution(step / self._space.getMaximumExtent())
        self._si.setup()
        self._planner, self.keeps_roadmap = make_planner(self._si, planner)

    def grow_roadmap(self, seconds: float) -> None:
        """Grow a roadmap planner's graph for ``seconds`` before any query."""
        if not self.keeps_roadmap:
            raise PlannerParameterError("only PRM planners keep a roadmap")
        self._planner.growRoadmap(seconds)

    def solve(
        self,
        start: Pose | list[Pose],
        goal: Pose | list[Pose],
        time_limit: float,
        simplify: bool = True,
    ) -> tuple[NDArray[np.float64] | None, dict[str, float]]:
        """Poses ``(n, 3)`` from ``start`` to ``goal`` (each a pose, or a list of poses any of
        which will do: the path starts and ends on one of them), at most
        :data:`POSE_SPACING` apart, or None when no exact solution was found in
        ``time_limit`` seconds; and the seconds of
        planning and simplification (:meth:`search`, then :meth:`smooth`)."""
        vertices, seconds = self.search(start, goal, time_limit)
        if vertices is None:
            return None, seconds
        poses, seconds["simplification"] = self.smooth(vertices, simplify)
        return poses, seconds

    def direct(
        self, start: Pose | list[Pose], goal: Pose | list[Pose]
    ) -> NDArray[np.float64] | None:
        """The vertices ``(2, 3)`` of the motion from the start straight to the goal (each a
        valid pose, or a list of poses) when it is valid (OMPL's motion validator: the goal
        valid and in bounds, the states between checked at the motion step), else None. For
        a car the motion is its shortest path between the two poses in free space, so a
        valid one is the best path there is. Each start tries only the goal nearest it by
        the state space's distance, the starts in the order of that distance: a farther goal
        reached directly may be a detour (a turn about to cross a door backwards) that a
        planner would not take."""
        goals = [(pose, self._state(pose)) for pose in _listed(goal)]
        pairs = []
        for pose in _listed(start):
            a = self._state(pose)
            far, (q, b) = min(
                ((self._space.distance(a, g[1]), g) for g in goals), key=lambda d: d[0]
            )
            pairs.append((far, pose, a, q, b))
        for _, p, a, q, b in sorted(pairs, key=lambda item: item[0]):
            if self._si.checkMotion(a, b):
                return np.array([p, q], float)
        return None

    def search(
        self,
        start: Pose | list[Pose],
        goal: Pose | list[Pose],
        time_limit: float,
        direct: bool = True,
    ) -> tuple[NDArray[np.float64] | None, dict[str, float]]:
        """The planner's solution from ``start`` to ``goal`` (as for :meth:`solve`) as its
        vertices ``(n, 3)`` after OMPL's ``reduceVertices`` (the vertices it can skip), or
        None; and the seconds of planning. Every planner stops at its first exact
        solution. A motion straight from ``start`` to a goal (the state space's own curve:
        a line, a Dubins or Reeds-Shepp path) is tried first when ``direct``: when it is
        valid it is the solution, with no planner run."""
        clock = time.perf_counter()
        if direct:
            found = self.direct(start, goal)
            if found is not None:
                return found, {"planning": time.perf_counter() - clock}
        goals = (
            [self._state(pose) for pose in goal] if isinstance(goal, list) else self._state(goal)
        )
        starts = (
            [self._state(pose) for pose in start] if isinstance(start, list) else self._state(start)
        )
        problem = solve_query(
            self._si,
            self._planner,
            self.keeps_roadmap,
            starts,
            goals,
            time_limit,
            first=True,
        )
        if not problem.hasExactSolution():
            return None, {"planning": time.perf_counter() - clock}
        path = problem.getSolutionPath()
        og.PathSimplifier(self._si).reduceVertices(path)
        return _poses(path), {"planning": time.perf_counter() - clock}

    def admits(self, pose: Pose) -> bool:
        """Whether ``pose`` is a valid state of this set-up (valid and within its bounds)."""
        return self.cspace.valid(*pose) and bool(self._space.satisfiesBounds(self._state(pose)))

    def smooth(
        self, vertices: NDArray[np.float64], simplify: bool = True
    ) -> tuple[NDArray[np.float64], float]:
        """The path through ``vertices`` (valid motions of this space between them),
        simplified when ``simplify`` by one pass of OMPL's ``PathSimplifier``
        (``reduceVertices``, ``partialShortcutPath``, ``smoothBSpline`` of
        :data:`SMOOTHING_STEPS`; ``simplifyMax`` repeats such passes until nothing changes,
        3-4 times the cost for paths under 1 % shorter on the office), as poses a
        motion-check step apart (no footprint point moves more than a cell between two; OMPL's
        ``interpolate()``) and at most :data:`POSE_SPACING`; and the seconds it took."""
        clock = time.perf_counter()
        path = og.PathGeometric(self._si)
        for vertex in vertices:
            path.append(self._state((vertex[0], vertex[1], vertex[2])))
        if simplify:
            simplifier = og.PathSimplifier(self._si)
            simplifier.reduceVertices(path)
            simplifier.partialShortcutPath(path)
            shortcut = og.PathGeometric(path)
            simplifier.smoothBSpline(path, SMOOTHING_STEPS)
            # OMPL's B-spline smoothing subdivides the path and checks only the motions onto
            # the states it moves, not the path it returns: on a Dubins space that path went
            # through walls (1 of 30 office queries, 209 poses in collision by the sweep).
            # Keep it only when every state and motion passes the checks, else the shortcut
            # path (every motion of it checked)
            if not path.check():
                log.debug("B-spline smoothing left an invalid path: kept the shortcut one")
                path = shortcut
        # states a motion-check step apart: a step moves no footprint point more than a cell
        path.interpolate()
        poses = _poses(path)
        if len(poses) > 1 and np.hypot(*np.diff(poses[:, :2], axis=0).T).max() > POSE_SPACING:
            poses = self._densify(path)  # cells coarser than the spacing
        return poses, time.perf_counter() - clock

    def _densify(self, path: Any) -> NDArray[np.float64]:
        """Poses along ``path`` with states inserted so that none is more than
        :data:`POSE_SPACING` of the state space's distance (so also of position) from the
        next."""
        out, between = [], self._space.allocState()
        for i in range(path.getStateCount() - 1):
            a, b = path.getState(i), path.getState(i + 1)
            pieces = max(1, math.ceil(self._space.distance(a, b) / POSE_SPACING))
            for k in range(pieces):
                self._space.interpolate(a, b, k / pieces, between)
                out.append((between.getX(), between.getY(), between.getYaw()))
        last = path.getState(path.getStateCount() - 1)
        return np.array([*out, (last.getX(), last.getY(), last.getYaw())])

    def _state(self, pose: Pose) -> Any:
        state = self._space.allocState()
        state.setXY(pose[0], pose[1])
        state.setYaw(ompl_yaw(pose[2]))
        return state


def ompl_yaw(yaw: float) -> float:
    """``yaw`` in OMPL's SO(2) range ``[-pi, pi)``: a heading of exactly ``pi`` (west, as a
    door pose or a start may face) is out of OMPL's bounds, so such a state was never valid
    in a set-up and a leg from or to it always failed.

    Examples
    --------
    >>> ompl_yaw(math.pi), ompl_yaw(-math.pi), ompl_yaw(3 * math.pi / 2)
    (-3.141592653589793, -3.141592653589793, -1.5707963267948966)
    """
    wrapped = math.remainder(yaw, math.tau)
    return -math.pi if wrapped >= math.pi else wrapped


def _listed(poses: Pose | list[Pose]) -> list[Pose]:
    return poses if isinstance(poses, list) else [poses]


def _poses(path: Any) -> NDArray[np.float64]:
    """The states of an OMPL path as poses ``(n, 3)``."""
    states = (path.getState(i) for i in range(path.getStateCount()))
    return np.array([(s.getX(), s.getY(), s.getYaw()) for s in states])


def check_pose(cspace: HeadingCSpace, pose: ArrayLike, what: str) -> Pose:
    """``pose`` as ``(x, y, yaw)`` if the robot may stand there. Two numbers ``(x, y)`` take
    the valid heading nearest 0.

    Raises
    ------
    InvalidQueryError
        Not two or three finite numbers, or a pose (or every heading at a point) in
        collision.
    """
    try:
        p = np.asarray(pose, float).ravel()
    except (TypeError, ValueError):  # strings, a dict, complex numbers
        p = np.zeros(0)
    if p.shape not in ((2,), (3,)) or not np.all(np.isfinite(p)):
        raise InvalidQueryError(f"{what} must be finite (x, y) or (x, y, yaw), got {pose!r}")
    x, y = float(p[0]), float(p[1])
    if len(p) == 3:
        yaw = ompl_yaw(float(p[2]))  # a heading of many turns is checked where OMPL puts it
        if not cspace.valid(x, y, yaw):
            raise InvalidQueryError(
                f"{what} ({x:g}, {y:g}, {p[2]:g}) puts the footprint in collision or off the map"
            )
        return x, y, yaw
    yaws = cspace.free_headings(x, y)
    if len(yaws) == 0:
        raise InvalidQueryError(
            f"{what} ({x:g}, {y:g}): the footprint collides at every heading or is off the map"
        )
    wrapped = np.angle(np.exp(1j * yaws))
    return x, y, float(wrapped[np.argmin(np.abs(wrapped))])


def end_poses(cspace: HeadingCSpace, pose: ArrayLike, what: str) -> list[Pose]:
    """The poses a query's start or goal ``pose`` stands for: a pose ``(x, y, yaw)`` itself;
    a point ``(x, y)`` the valid heading nearest 0 (:func:`check_pose`) for a robot that
    turns in place, which can take any heading there; for a car (Dubins or Reeds-Shepp)
    every valid heading there (the middles of the configuration space's heading bins,
    nearest 0 first), any of which will do. A car cannot turn on the spot: at the heading
    nearest 0 a forward-only car may face a wall closer than it can turn away from (a start
    0.4 m from a wall at a 1 m turning radius) or have too little room behind it to arrive
    (a goal 1 m in front of a wall), and a car that reverses may stand wedged in a doorway
    (a campus start at 22.5 degrees across a door: no path in 5 s, 3 of 3 replays), so
    that one heading would make a query with an easy answer unsolvable.

    Raises
    ------
    InvalidQueryError
        As :func:`check_pose`.
    """
    first = check_pose(cspace, pose, what)
    if not getattr(cspace.robot, "turning_radius", 0.0) or np.asarray(pose, float).size == 3:
        return [first]
    yaws = np.array([ompl_yaw(float(a)) for a in cspace.free_headings(first[0], first[1])])
    return [(first[0], first[1], float(a)) for a in yaws[np.argsort(np.abs(yaws), kind="stable")]]


class FlatKinematicPlanner:
    """The flat baseline: one OMPL planner on the whole map's configuration space.

    Parameters
    ----------
    cspace
        Valid poses on the whole map.
    planner
        OMPL planner name.
    time_limit
        Seconds per query.
    random_state
        OMPL's seed (process-wide).
    """

    def __init__(
        self,
        cspace: HeadingCSpace,
        planner: str = "RRTConnect",
        *,
        time_limit: float = 10.0,
        random_state: RandomState = 0,
    ) -> None:
        time_limit = checked_time_limit(time_limit)
        self.cspace, self.time_limit = cspace, float(time_limit)
        self.name = f"flat_{check_planner(planner).lower()}"
        self.ompl = KinematicOMPL(cspace, planner, random_state)

    def plan(self, start: ArrayLike, goal: ArrayLike) -> PlannedPath:
        """Plan from ``start`` to ``goal`` (poses, or points: see :func:`end_poses`).

        Raises
        ------
        InvalidQueryError
            A start or goal in collision.
        NoPathError
            No exact solution within the time limit.
        """
        s, g = end_poses(self.cspace, start, "start"), end_poses(self.cspace, goal, "goal")
        poses, seconds = self.ompl.solve(_single(s), _single(g), self.time_limit)
        if poses is None:
            raise NoPathError(
                f"{self.name} found no path from {describe(s)} to {describe(g)} "
                f"in {self.time_limit:g} s"
            )
        return PlannedPath.from_poses(poses, self.name, seconds=seconds)


def _single(poses: list[Pose]) -> Pose | list[Pose]:
    """One pose as itself (OMPL's single start and goal), several as a list."""
    return poses[0] if len(poses) == 1 else poses


def describe(poses: list[Pose]) -> str:
    """An end of a query in messages: its pose, or its point and how many headings.

    Examples
    --------
    >>> describe([(1.0, 2.0, 0.0)]), describe([(1.0, 2.0, 0.0), (1.0, 2.0, 1.0)])
    ('(1.0, 2.0, 0.0)', '(1.0, 2.0) at any of 2 headings')
    """
    if len(poses) == 1:
        return str(tuple(poses[0]))
    return f"{tuple(poses[0][:2])} at any of {len(poses)} headings"
