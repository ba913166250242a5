"""OMPL geometric planners on a workspace: the flat baseline, and the local planner of legs."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from maps.limits import MAX_COORDINATE, finite_in
from maps.seeding import RandomState, as_generator
from planners.errors import (
    InvalidQueryError,
    NoPathError,
    PlannerParameterError,
    checked_time_limit,
)
from planners.path import PlannedPath
from planners.workspace import Workspace

#: OMPL geometric planners that solve a single start/goal query.
PLANNERS = (
    "AORRTC",
    "BFMT",
    "BITstar",
    "BKPIECE1",
    "FMT",
    "InformedRRTstar",
    "KPIECE1",
    "LBKPIECE1",
    "PRM",
    "PRMstar",
    "RRT",
    "RRTConnect",
    "RRTstar",
    "SORRTstar",
)
#: Planners whose roadmap is kept between queries.
ROADMAP_PLANNERS = ("PRM", "PRMstar")


def check_planner(planner: object) -> str:
    """``planner`` once it is the name of one of :data:`PLANNERS`.

    Examples
    --------
    >>> check_planner("RRT")
    'RRT'
    >>> check_planner(["RRT"])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    planners.errors.PlannerParameterError: unknown OMPL planner ['RRT']; known: AORRTC, ...
    """
    if not isinstance(planner, str) or planner not in PLANNERS:
        raise PlannerParameterError(
            f"unknown OMPL planner {planner!r:.80}; known: {', '.join(PLANNERS)}"
        )
    return planner


class _ExactMotion(ob.MotionValidator):
    """OMPL motion validator that defers to the workspace's exact straight-motion test."""

    def __init__(self, si: ob.SpaceInformation, space: Workspace) -> None:
        super().__init__(si)
        self._space = space

    def checkMotion(self, s1: Any, s2: Any, *last_valid: Any) -> bool:  # noqa: N802 (OMPL API)
        if last_valid:
            raise NotImplementedError("motion checks reporting the last valid state")
        return self._space.segment_free((s1[0], s1[1]), (s2[0], s2[1]))


def plane_bounds(xmin: float, ymin: float, xmax: float, ymax: float) -> Any:
    """OMPL bounds of the plane part of a state space: ``x`` in ``[xmin, xmax]``, ``y`` in
    ``[ymin, ymax]`` (metres)."""
    box = ob.RealVectorBounds(2)
    box.setLow(0, xmin)
    box.setLow(1, ymin)
    box.setHigh(0, xmax)
    box.setHigh(1, ymax)
    return box


def make_planner(si: Any, name: str) -> tuple[Any, bool]:
    """The OMPL planner ``name`` on space information ``si``, and whether it keeps a roadmap
    between queries (PRM planners: then its problem definition is set up already)."""
    planner = getattr(og, name)(si)
    keeps_roadmap = name in ROADMAP_PLANNERS
    if keeps_roadmap:
        planner.setProblemDefinition(ob.ProblemDefinition(si))
        planner.setup()
    return planner, keeps_roadmap


def solve_query(
    si: Any,
    planner: Any,
    keeps_roadmap: bool,
    start: Any,
    goal: Any,
    time_limit: float,
    *,
    first: bool = False,
) -> Any:
    """One query of ``planner`` from ``start`` to ``goal`` (each a state, or a list of
    states any of which will do): its problem definition, after solving for at most
    ``time_limit`` seconds. A roadmap planner keeps its roadmap (only the query is cleared)
    and accepts the first path it finds, as does any planner when ``first``; any other
    starts afresh. A roadmap planner is given the first goal state alone: OMPL 2.0.1's PRM
    and PRM* given a goal set wait forever on a lock (seen from Python, no CPU used)."""
    if keeps_roadmap and isinstance(goal, list):
        goal = goal[0]
    problem = ob.ProblemDefinition(si)
    if isinstance(goal, list) or isinstance(start, list):
        goals = ob.GoalStates(si)
        for state in goal if isinstance(goal, list) else [goal]:
            goals.addState(state)
        for state in start if isinstance(start, list) else [start]:
            problem.addStartState(state)
        problem.setGoal(goals)
    else:
        problem.setStartAndGoalStates(start, goal)
    if keeps_roadmap or first:
        problem.setOptimizationObjective(_first_solution(si))
    if keeps_roadmap:
        planner.clearQuery()
    else:
        planner.clear()
    planner.setProblemDefinition(problem)
    planner.solve(time_limit)
    return problem


class FlatPlanner:
    """An OMPL geometric planner over the whole workspace (or a box of it).

    The state space is ``RealVectorStateSpace(2)`` in ``bounds``; a state is valid when the
    workspace says so, and motions are checked exactly (see :mod:`planners.workspace`); the
    validity checking resolution is one cell. Only exact solutions count; the solution is
    simplified by OMPL's ``PathSimplifier``.

    Parameters
    ----------
    space
        The free space.
    planner
        Name of an OMPL geometric planner (:data:`PLANNERS`).
    time_limit
        Seconds allowed per query.
    bounds
        ``(xmin, ymin, xmax, ymax)`` of the state space; the map's bounds by default.
    simplify
        Simplify solutions with ``PathSimplifier.simplifyMax``.
    random_state
        Seeds OMPL's random number generator. OMPL has one seed per process: only the
        first planner made in a process makes runs repeatable.
    """

    def __init__(
        self,
        space: Workspace,
        planner: str = "RRTConnect",
        *,
        time_limit: float = 10.0,
        bounds: tuple[float, float, float, float] | None = None,
        simplify: bool = True,
        random_state: RandomState = 0,
    ) -> None:
        check_planner(planner)
        time_limit = checked_time_limit(time_limit)
        if bounds is not None and not (
            len(bounds) == 4
            and all(finite_in(v, "bound", -MAX_COORDINATE, MAX_COORDINATE) is None for v in bounds)
            and bounds[0] < bounds[2]
            and bounds[1] < bounds[3]
        ):
            raise PlannerParameterError(
                "bounds are (xmin, ymin, xmax, ymax) with xmin < xmax and ymin < ymax, "
                f"got {bounds!r}"
            )
        ou.setLogLevel(ou.LOG_WARN)  # OMPL's console: warnings and errors only, once planning
        _seed_once(random_state)
        self.space, self.time_limit, self.simplify = space, float(time_limit), simplify
        self.name = f"flat_{planner.lower()}"
        xmin, ymin, xmax, ymax = space.grid.bounds() if bounds is None else bounds
        self._state_space = ob.RealVectorStateSpace(2)
        self._state_space.setBounds(plane_bounds(xmin, ymin, xmax, ymax))
        self._si = ob.SpaceInformation(self._state_space)
        free = space.point_free
        self._si.setStateValidityChecker(lambda s: free(s[0], s[1]))
        self._motion = _ExactMotion(self._si, space)
        self._si.setMotionValidator(self._motion)
        extent = max(xmax - xmin, ymax - ymin, space.grid.resolution)
        self._si.setStateValidityCheckingResolution(space.grid.resolution / extent)
        self._si.setup()
        self._planner, self._keeps_roadmap = make_planner(self._si, planner)

    def grow_roadmap(self, seconds: float) -> None:
        """Grow a roadmap planner's graph for ``seconds`` before any query (preprocessing)."""
        if not self._keeps_roadmap:
            raise PlannerParameterError(f"{self.name} keeps no roadmap")
        self._planner.growRoadmap(checked_time_limit(seconds))

    def plan(self, start: ArrayLike, goal: ArrayLike) -> PlannedPath:
        """Plan from ``start`` to ``goal``.

        Raises
        ------
        InvalidQueryError
            A start or goal a robot cannot stand on, or outside the planner's bounds.
        NoPathError
            No exact solution within the time limit, or start and goal are not connected.
        """
        clock = time.perf_counter()
        s, g = self.space.check(start, "start"), self.space.check(goal, "goal")
        if self.space.component_at(s) != self.space.component_at(g):
            raise NoPathError(f"start {s} and goal {g} lie in different parts of the free space")
        start_state, goal_state = self._state(s, "start"), self._state(g, "goal")
        problem = solve_query(
            self._si, self._planner, self._keeps_roadmap, start_state, goal_state, self.time_limit
        )
        if not problem.hasExactSolution():
            raise NoPathError(f"{self.name} found no path from {s} to {g} in {self.time_limit:g} s")
        solution = problem.getSolutionPath()
        planned = time.perf_counter()
        if self.simplify:
            og.PathSimplifier(self._si).simplifyMax(solution)
        waypoints = np.array(
            [
                (solution.getState(i)[0], solution.getState(i)[1])
                for i in range(solution.getStateCount())
            ]
        )
        done = time.perf_counter()
        return PlannedPath(
            waypoints,
            self.name,
            seconds={"planning": planned - clock, "simplification": done - planned},
        )

    def _state(self, point: tuple[float, float], what: str) -> Any:
        state = self._state_space.allocState()
        state[0], state[1] = point
        if not self._state_space.satisfiesBounds(state):
            raise InvalidQueryError(f"{what} {point} lies outside the planner's bounds")
        return state


_seeded = False


def _seed_once(random_state: RandomState) -> None:
    """Seed OMPL's process-wide generator the first time a planner is made; OMPL warns and
    ignores later seeds once sampling has started."""
    global _seeded
    generator = as_generator(random_state)  # refused though the seed is set: it is no seed
    if not _seeded and random_state is not None:
        ou.RNG.setSeed(int(generator.integers(1, 2**31 - 1)))
        _seeded = True


def _first_solution(si: ob.SpaceInformation) -> ob.OptimizationObjective:
    objective = ob.PathLengthOptimizationObjective(si)
    objective.setCostThreshold(ob.Cost(float("inf")))
    return objective
