import itertools

import numpy as np
import pytest
from scipy import ndimage

from maps.errors import InvalidMapError
from maps.grid import OccupancyGrid
from maps.sim.rooms import generate_rooms
from planners.workspace import Workspace


@pytest.mark.parametrize(("size", "room"), [(512, 8), (512, 16), (512, 32), (50, 7)])
def test_every_wall_between_two_rooms_has_one_door_one_cell_wide(size, room):
    grid = generate_rooms(size, room, random_state=3)
    free = grid.cells == 0
    walls = [*range(0, size - 1, room), size - 1]
    for wall in walls:
        for lo, hi in itertools.pairwise(walls):
            doors = int(free[wall, lo + 1 : hi].sum()), int(free[lo + 1 : hi, wall].sum())
            inner = wall not in (0, size - 1)
            assert doors == ((1, 1) if inner else (0, 0))
    interiors = np.ones((size, size), bool)
    interiors[walls, :] = interiors[:, walls] = False
    assert free[interiors].all()  # rooms are empty
    assert ndimage.label(free)[1] == 1  # every room reaches every other


def test_a_disc_under_half_a_cell_passes_every_door():
    grid = generate_rooms(64, 8, resolution=0.5, random_state=0)
    space = Workspace(grid, 0.2)
    np.testing.assert_array_equal(space.free, grid.cells == 0)
    assert Workspace(grid, 0.3).free.sum() < space.free.sum()  # no door for a wider disc


def test_the_same_seed_gives_the_same_doors():
    a, b, c = (generate_rooms(128, 16, random_state=s) for s in (5, 5, 6))
    assert isinstance(a, OccupancyGrid)
    np.testing.assert_array_equal(a.cells, b.cells)
    assert (a.cells != c.cells).any()


@pytest.mark.parametrize(
    ("kwargs", "shown"),
    [
        ({"size": 2}, "2"),
        ({"size": 16.0}, "16.0"),
        ({"room": 2}, "2"),
        ({"room": 16, "size": 16}, "16"),
        ({"resolution": 0.0}, "0.0"),
        ({"resolution": float("nan")}, "nan"),
    ],
)
def test_bad_sizes_are_typed_errors_naming_the_value(kwargs, shown):
    with pytest.raises(InvalidMapError, match=shown):
        generate_rooms(**{"size": 64, "room": 8, **kwargs})
