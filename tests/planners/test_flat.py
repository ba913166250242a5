"""The flat OMPL planners on the two-room map."""

import numpy as np
import pytest

from maps.grid import OCCUPIED, OccupancyGrid
from planners.errors import InvalidQueryError, NoPathError
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
        # the door's middle is at x = 4.15 m: every path crosses the wall there
        assert path.length >= np.hypot(goal[0] - start[0], goal[1] - start[1])


def test_flat_planner_rejects_bad_names_and_queries(two_rooms):
    space = Workspace(two_rooms(), robot_radius=0.2)
    with pytest.raises(ValueError, match=r"unknown OMPL planner 'RRTX'.*RRTConnect"):
        FlatPlanner(space, "RRTX")
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
