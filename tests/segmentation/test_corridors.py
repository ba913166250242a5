"""Places joined across corridors: one place per corridor the basins cut, never across a door."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from maps.grid import OccupancyGrid
from segmentation.corridors import corridor_cuts, join_corridor_cuts
from segmentation.refine import basins

RESOLUTION = 0.1


def _places(free: np.ndarray) -> np.ndarray:
    return basins(OccupancyGrid.from_masks(free, RESOLUTION))


def _cross() -> np.ndarray:
    """Two 2 m corridors crossing in a 30 x 30 m square: a '#' of four crossings."""
    free = np.zeros((300, 300), bool)
    for at in (80, 220):
        free[at - 10 : at + 10, 20:280] = True
        free[20:280, at - 10 : at + 10] = True
    return free


def test_the_basins_of_a_corridor_grid_are_joined_into_one_place():
    free = _cross()
    places = _places(free)
    assert len(np.unique(places[free])) > 1  # the crossings' peaks seed a basin each
    joined = join_corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert np.unique(joined[free]).tolist() == [1]
    assert (joined[~free] == 0).all()


def test_rooms_behind_doors_stay_apart():
    free = np.zeros((100, 210), bool)
    free[10:90, 10:100] = free[10:90, 110:200] = True  # two 8 x 9 m rooms
    free[45:54, 100:110] = True  # a 0.9 m door, 1 m deep
    places = _places(free)
    joined = join_corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert joined[50, 50] != joined[50, 150]


def test_a_passage_narrower_than_a_corridor_is_no_corridor_cut():
    free = np.zeros((22, 202), bool)
    free[1:21, 1:201] = True
    free[1:21, 98:104] = False
    free[6:16, 98:104] = True  # a 1 m passage in a 2 m corridor
    places = np.where(free, 1 + (np.arange(202) >= 101), 0)
    a, _ = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert len(a) == 0


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_joining_only_unites_whole_places(seed):
    rng = np.random.default_rng(seed)
    free = _cross()
    for _ in range(6):  # furniture and bays
        r, c = rng.integers(20, 280, 2)
        free[r : r + rng.integers(3, 30), c : c + rng.integers(3, 30)] ^= True
    free[[0, -1]] = free[:, [0, -1]] = False
    places = _places(free)
    joined = join_corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert ((joined > 0) == (places > 0)).all()
    for place in np.unique(places[places > 0]):
        assert len(np.unique(joined[places == place])) == 1  # a place is never split
    assert len(np.unique(joined[joined > 0])) <= len(np.unique(places[places > 0]))
