"""The exact motion test against dense sampling, and the query checks."""

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from maps.grid import OCCUPIED, UNKNOWN, OccupancyGrid
from planners.errors import InvalidQueryError
from planners.workspace import Workspace


def _random_space(seed: int, yaw: float = 0.0) -> Workspace:
    rng = np.random.default_rng(seed)
    cells = np.where(rng.random((30, 40)) < 0.1, OCCUPIED, 0).astype(np.int8)
    return Workspace(OccupancyGrid(cells, 0.1, (1.0, -2.0, yaw)), robot_radius=0.0)


@given(
    seed=st.integers(0, 50),
    yaw=st.sampled_from([0.0, 0.4]),
    ends=st.lists(st.floats(0.05, 0.95), min_size=4, max_size=4),
)
def test_exact_motion_check_agrees_with_dense_sampling(seed, yaw, ends):
    """Away from grid lines (where sampling sees only one side) the two must agree."""
    lattice = np.array(ends) * [40, 30, 40, 30]
    assume(np.all(np.abs(lattice - np.round(lattice)) > 1e-6))
    space = _random_space(seed, yaw)
    a, b = space.from_lattice(lattice.reshape(2, 2))
    dense = a + np.linspace(0, 1, 20_000)[:, None] * (b - a)
    sampled = bool(space.points_free(dense).all())
    assert space.segment_free(a, b) == sampled
    assert bool(space.segments_free([a], [b])[0]) == sampled
    if sampled:
        assert space.collisions([a, b]) == 0


@given(seed=st.integers(0, 50), cells=st.lists(st.integers(0, 29), min_size=4, max_size=4))
def test_scalar_and_batch_checks_agree_on_grid_lines(seed, cells):
    """Motions between lattice vertices (along grid lines, through corners) are the hard
    cases: both implementations must give the same answer."""
    space = _random_space(seed)
    a, b = space.from_lattice([cells[:2], cells[2:]])
    flat = space.from_lattice([[cells[0], cells[1]], [cells[2], cells[1]]])
    for start, end in ((a, b), (flat[0], flat[1])):
        assert space.segment_free(start, end) == bool(space.segments_free([start], [end])[0])


def test_motion_along_a_wall_edge_is_free_from_either_side():
    cells = np.zeros((10, 10), np.int8)
    cells[:5, 2:8] = OCCUPIED  # a block in the upper half
    space = Workspace(OccupancyGrid(cells, 1.0), robot_radius=0.0)
    # y = 5 is the block's lower edge: the cells below are free
    assert space.segment_free((0.5, 5.0), (9.5, 5.0))
    assert not space.segment_free((0.5, 5.5), (9.5, 5.5))


def test_check_names_the_problem():
    cells = np.zeros((40, 40), np.int8)
    cells[:, 20] = OCCUPIED
    cells[:5, :5] = UNKNOWN
    space = Workspace(OccupancyGrid(cells, 0.1), robot_radius=0.2)
    assert space.check((1.0, 1.0), "start") == (1.0, 1.0)
    with pytest.raises(InvalidQueryError, match=r"start .* outside the map"):
        space.check((9.0, 1.0), "start")
    with pytest.raises(InvalidQueryError, match=r"goal .* in a wall"):
        space.check((2.05, 1.0), "goal")
    with pytest.raises(InvalidQueryError, match="unknown cell"):
        space.check((0.2, 3.8))
    with pytest.raises(InvalidQueryError, match="within the robot radius"):
        space.check((1.9, 1.0))
    with pytest.raises(InvalidQueryError, match="two finite numbers"):
        space.check((np.nan, 1.0))


@given(
    seed=st.integers(0, 50),
    yaw=st.sampled_from([0.0, 0.4, 1.3]),
    ends=st.lists(st.integers(0, 4 * 150), min_size=4, max_size=4),
)
def test_long_motions_checked_band_by_band_agree_with_the_cell_walk(seed, yaw, ends):
    """Motions crossing many grid lines take the banded numpy test; on a sparse map (most
    are free) and through lattice vertices (quarter-cell ends) it must agree with the batch
    cell walk."""
    rng = np.random.default_rng(seed)
    cells = np.where(rng.random((120, 150)) < 0.002, OCCUPIED, 0).astype(np.int8)
    space = Workspace(OccupancyGrid(cells, 0.05, (1.0, -2.0, yaw)), robot_radius=0.0)
    lattice = np.array(ends, float).reshape(2, 2) / 4 * [1, 0.8]
    a, b = space.from_lattice(lattice)
    assert space.segment_free(a, b) == bool(space.segments_free([a], [b])[0])


def test_batch_motion_checks_agree_with_the_cell_walk_on_grid_lines_and_vertices():
    """The batch check (one run of cells per unit band, looked up in running counts) and
    the scalar cell walk agree on motions that start, end or pass on grid lines and
    vertices, points, flat and vertical motions, and motions off the grid."""
    rng = np.random.default_rng(3)
    cells = np.where(rng.random((20, 30)) < 0.15, OCCUPIED, 0).astype(np.int8)
    space = Workspace(OccupancyGrid(cells, 1.0), 0.0)
    ends = np.round(rng.uniform(-2, 32, (3000, 4)) * 2) / 2
    ends[::5, 2:] = ends[::5, :2]
    ends[1::5, 3] = ends[1::5, 1]
    batch = space.lattice_segments_free(ends[:, :2], ends[:, 2:])
    walk = [space.segment_free(a, b) for a, b in zip(ends[:, :2], ends[:, 2:], strict=True)]
    assert batch.tolist() == walk
