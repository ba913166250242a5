"""A simulated robot's survey of a generated building: the route it drives through every room,
the keyframes its laser keeps, and the map it builds from them."""

from __future__ import annotations

from dataclasses import dataclass

from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import Keyframe
from maps.sim.exploration import Route, wander
from maps.sim.floorplan import FloorPlan
from maps.sim.laser import LaserModel, simulate_keyframes

#: The surveying robot's laser: 180 degrees, 1 cm of range noise, 1 % of the beams lost.
SURVEY_LASER = LaserModel(noise=0.01, dropout=0.01)


@dataclass(frozen=True)
class Survey:
    """What a robot's run through a building gives: its route, its keyframes (a keyframe
    every 0.5 m or 30 degrees) and the map built from them on the plan's cells."""

    route: Route
    keyframes: list[Keyframe]
    grid: OccupancyGrid


def survey(plan: FloorPlan, seed: int = 0, laser: LaserModel = SURVEY_LASER) -> Survey:
    """A robot wandering through every room of ``plan`` it can reach (seeded by ``seed``).

    Examples
    --------
    >>> from maps.sim.floorplan import generate_floor_plan
    >>> plan = generate_floor_plan("flat", random_state=3)
    >>> run = survey(plan, seed=3)
    >>> len(run.route.visited) == plan.n_rooms, bool(run.grid.free.any())
    (True, True)
    """
    route = wander(plan.grid, plan.labels, random_state=seed)
    keyframes = simulate_keyframes(plan.grid, route.poses, laser, random_state=seed)
    return Survey(route, keyframes, grid_from_keyframes(keyframes, plan.grid.resolution))
