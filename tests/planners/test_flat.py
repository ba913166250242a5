"""The flat OMPL planners on the two-room map."""

import math

import numpy as np
import pytest

from maps.grid import OCCUPIED, OccupancyGrid
from planners.errors import InvalidQueryError, NoPathError, PlannerParameterError
from planners.flat import FlatPlanner
from planners.workspace import Workspace


@pytest.mark.parametrize("name", ["RRTConnect", "PRM"])
def test_flat_planner_goes_through_the_door(two_rooms, name):
    space = Workspace(two_rooms(door=1.0), robot_radius=0.2)
    planner = FlatPlanner(space, name, time_limit=5.0)
    for start, goal in (((1.0, 1.0), (7.5, 3.5)), ((7.0, 1.0), (1.5, 3.0))):
        path = planner.plan(start, goal)
        assert np.allclose(path.waypoints[[0, -1]], [start, goal])
        assert space.path_free(path.waypoints)
        assert space.collisions(path.waypoints) == 0
        # the wall is x in [4.1, 4.2] m, its door y in [1.6, 2.6] m: the path crosses the
        # wall's middle line once, inside the door
        assert _crossings(path.waypoints, 4.15) == pytest.approx([2.1], abs=0.5)


def _crossings(waypoints, x):
    """The y of every point where the polyline crosses the vertical line at ``x``."""
    a, b = waypoints[:-1], waypoints[1:]
    crossing = (a[:, 0] - x) * (b[:, 0] - x) < 0
    t = (x - a[crossing, 0]) / (b[crossing, 0] - a[crossing, 0])
    return list(a[crossing, 1] + t * (b[crossing, 1] - a[crossing, 1]))


def test_flat_planner_rejects_bad_names_and_queries(two_rooms):
    space = Workspace(two_rooms(), robot_radius=0.2)
    with pytest.raises(ValueError, match=r"unknown OMPL planner 'RRTX'.*RRTConnect"):
        FlatPlanner(space, "RRTX")
    roadmap = FlatPlanner(space, "PRM", time_limit=1.0)
    for seconds in (math.nan, -1.0, "x"):
        with pytest.raises(PlannerParameterError, match="time_limit must"):
            roadmap.grow_roadmap(seconds)
    planner = FlatPlanner(space, time_limit=1.0)
    with pytest.raises(InvalidQueryError, match=r"goal .* in a wall"):
        planner.plan((1.0, 1.0), (4.15, 0.5))


def test_closed_door_means_no_path_quickly(two_rooms):
    grid = two_rooms()
    cells = grid.cells.copy()
    cells[:, grid.shape[1] // 2 - 3 : grid.shape[1] // 2 + 3] = OCCUPIED
    space = Workspace(OccupancyGrid(cells, grid.resolution), robot_radius=0.2)
    with pytest.raises(NoPathError, match="different parts"):
        FlatPlanner(space, time_limit=30.0).plan((1.0, 1.0), (7.0, 1.0))
