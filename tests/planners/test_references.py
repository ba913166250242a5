"""Grid A* and the exact visibility-graph reference on maps with known shortest paths."""

import math

import numpy as np
import pytest

from maps.grid import OCCUPIED, OccupancyGrid
from planners import visibility
from planners.errors import NoPathError
from planners.grid_astar import GridAStar
from planners.visibility import VisibilityGraph
from planners.workspace import Workspace


def _block_map() -> Workspace:
    """A 10 x 10 m room (1 dm cells) with a 2 x 6 m block standing in its middle."""
    cells = np.zeros((100, 100), np.int8)
    cells[20:80, 40:60] = OCCUPIED  # x 4..6 m, y 2..8 m
    return Workspace(OccupancyGrid(cells, 0.1), robot_radius=0.0)


def test_exact_path_wraps_the_block_corners():
    space = _block_map()
    path = VisibilityGraph(space).plan((1.0, 5.0), (9.0, 5.0))
    # round the block's top: (1,5) -> (4,8) -> (6,8) -> (9,5)
    expected = 2 * math.hypot(3.0, 3.0) + 2.0
    assert path.length == pytest.approx(expected, abs=1e-9)
    assert space.path_free(path.waypoints)


def test_exact_path_is_straight_when_nothing_is_in_the_way():
    space = _block_map()
    path = VisibilityGraph(space).plan((1.0, 1.0), (9.0, 1.5))
    assert path.length == pytest.approx(math.hypot(8.0, 0.5))
    assert len(path.waypoints) == 2


def test_grid_astar_is_octile_optimal_and_valid():
    space = _block_map()
    exact = VisibilityGraph(space).plan((1.0, 5.0), (9.0, 5.0)).length
    path = GridAStar(space).plan((1.0, 5.0), (9.0, 5.0))
    assert space.path_free(path.waypoints)
    assert space.collisions(path.waypoints) == 0
    assert exact <= path.length <= exact * (1 + (math.sqrt(4 - 2 * math.sqrt(2)) - 1)) + 0.3


def test_disconnected_start_and_goal_raise_no_path():
    cells = np.zeros((40, 80), np.int8)
    cells[:, 38:42] = OCCUPIED
    space = Workspace(OccupancyGrid(cells, 0.1), robot_radius=0.0)
    with pytest.raises(NoPathError):
        VisibilityGraph(space).plan((1.0, 1.0), (7.0, 1.0))
    with pytest.raises(NoPathError):
        GridAStar(space).plan((1.0, 1.0), (7.0, 1.0))


@pytest.mark.parametrize("seed", range(3))
def test_sight_walks_the_cells_or_checks_in_one_batch_alike(seed, monkeypatch):
    rng = np.random.default_rng(seed)
    cells = np.where(rng.random((60, 60)) < 0.08, OCCUPIED, 0).astype(np.int8)
    space = Workspace(OccupancyGrid(cells, 0.1, (-1.0, 2.0, 0.4)), 0.0)
    graph = VisibilityGraph(space)
    rows, cols = np.nonzero(space.free)
    points = np.column_stack(space.grid.cell_to_world(rows, cols))[::23]
    points += rng.uniform(-0.04, 0.04, points.shape)  # off the centres, inside the cells
    seen = {}
    for few in (0, 10**9):  # every sight in one batch, every sight walked
        monkeypatch.setattr(visibility, "FEW_SIGHTS", few)
        seen[few] = [graph.sight(p) for p in points]
    assert sum(len(nodes) for nodes, _ in seen[0]) > 10 * len(seen[0])
    for (a, da), (b, db) in zip(seen[0], seen[10**9], strict=True):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(da, db)
