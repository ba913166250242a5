"""Places joined across corridors: one place per corridor the basins cut, never across a door."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from maps.grid import OccupancyGrid
from segmentation.corridors import _corridor_on, corridor_cuts, join_corridor_cuts
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


def test_places_meeting_at_a_corridor_cut_and_elsewhere_are_joined():
    # a 1.5 m corridor and, 3 m beyond it on the same line, a 5 m room: both split at x = 10 m
    # between places 1 and 2. The room's boundary is the more open one but no corridor cut,
    # and lies too far along the corridor cut's line to be one dotted wall with it.
    free = np.zeros((110, 202), bool)
    free[10:25, 1:201] = True
    free[55:105, 80:120] = True
    places = np.where(free, 1 + (np.arange(202) >= 100), 0)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])
    free[30:50, 80:120] = True  # the room reaches to 0.5 m of the corridor's wall line
    places = np.where(free, 1 + (np.arange(202) >= 100), 0)
    a, _ = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert len(a) == 0  # the two boundaries are on one line, a dotted wall's gaps: no cut


def test_a_corridor_a_cell_under_the_least_width_is_still_one_place():
    # 1.1 m between walls: a 1.2 m corridor whose walls a mapper's coarse cells thickened; 6 m
    # long, too short to be a corridor entering or crossing another (its width holds for 2 m)
    free = np.zeros((13, 62), bool)
    free[1:12, 1:61] = True
    places = np.where(free, 1 + (np.arange(62) >= 31), 0)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])


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


def _hall_with_arm(arm_length: int) -> tuple[np.ndarray, np.ndarray]:
    """A 6 x 6 m hall and, off its side, an arm 1.1 m wide (under building codes' 1.2 m, as
    on SLAM maps whose walls are jagged) of ``arm_length`` cells, split in two places."""
    free = np.zeros((80, 100 + arm_length), bool)
    free[10:70, 10:70] = True
    free[35:46, 70 : 70 + arm_length] = True
    places = np.where(free, 1 + (np.arange(free.shape[1]) >= 73), 0)
    return free, places


def test_a_corridor_that_opens_into_a_hall_is_one_with_the_cut_off_piece():
    # 8 m of corridor, cut 0.3 m from the hall: the corridor keeps its width over 4 times
    # its width on one side, the hall never narrows on the other
    free, places = _hall_with_arm(80)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])


def test_a_narrow_room_entered_through_its_full_width_stays_apart():
    free, places = _hall_with_arm(30)  # 3 m deep: a room, under 4 times its width
    a, _ = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert len(a) == 0


def test_a_corridor_with_doors_along_it_that_opens_into_a_hall_is_joined():
    # 8 m of corridor with double doors (2 m) into rooms on either side: a door along a
    # corridor is no room opening onto it
    free, places = _hall_with_arm(80)
    free[10:35, 90:110] = free[46:70, 120:140] = True  # the rooms behind
    places = np.where(free, 1 + (np.arange(free.shape[1]) >= 73), 0)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])


def test_a_corridor_whose_wall_is_open_for_more_than_double_doors_is_no_corridor():
    free, places = _hall_with_arm(80)
    free[10:35, 85:125] = True  # a 4 m opening: a room beside it, not a door
    places = np.where(free, 1 + (np.arange(free.shape[1]) >= 73), 0)
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


def test_a_door_in_a_rooms_corner_is_no_corridor_cut():
    # a 1.1 m door flush with the room's wall: through it, the line into the room runs
    # along that wall at the door's half width for metres, but the room opens beside it
    free = np.zeros((130, 130), bool)
    free[10:60, 10:80] = True  # a 7 x 5 m room
    free[49:60, 80:85] = True  # the door, in its corner
    free[0:130, 85:115] = True  # a 3 m corridor
    places = np.where(free, 1 + (np.arange(130) >= 83), 0)
    a, _ = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert len(a) == 0


def test_a_gently_curving_corridor_into_a_hall_is_joined_too():
    # the arm of the hall bends: the straight line from the cut leaves its middle near the
    # far end, where a sample or two read it narrower (one in eight may)
    free, places = _hall_with_arm(80)
    free[30:60, 70:] = False
    for col in range(70, free.shape[1]):
        centre = 40 + round(0.001 * (col - 70) ** 2)
        free[centre - 5 : centre + 6, col] = True
    a, b = corridor_cuts(places * free, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])


def test_a_corridor_cut_at_a_slightly_narrower_spot_is_joined():
    # 1.6 m wide, 7 m long, the basins meeting where its walls come 0.2 m closer (as a
    # jagged SLAM wall does): a cell of slack on the widths, walls on both hands
    free = np.zeros((40, 200), bool)
    free[12:28, 65:135] = True
    free[12:14, 99:102] = free[26:28, 99:102] = False
    places = np.where(free, 1 + (np.arange(200) >= 100), 0)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])


def _turned(cells: np.ndarray, degrees: float) -> np.ndarray:
    return ndimage.rotate(cells, degrees, order=0, mode="constant", cval=0, prefilter=False)


@settings(max_examples=25, deadline=None)
@given(st.floats(0, 90))
def test_a_slanted_corridor_cut_along_the_cells_is_joined(degrees):
    # basins meet on a corridor's plateau along a row or a column of cells, whatever the
    # corridor's slant: its way is read from its walls, not from that boundary
    free = np.zeros((24, 160), bool)
    free[2:22, 20:140] = True  # 2 m wide, 12 m long
    free = _turned(free, degrees)
    rows, columns = np.indices(free.shape)
    half = (
        (rows >= free.shape[0] / 2) if 45 < degrees % 180 < 135 else (columns >= free.shape[1] / 2)
    )
    places = np.where(free, 1 + half, 0)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])


@settings(max_examples=15, deadline=None)
@given(st.floats(0, 90))
def test_rooms_behind_a_slanted_door_stay_apart(degrees):
    rooms = np.zeros((100, 210), np.int32)
    rooms[10:90, 10:100], rooms[10:90, 110:200] = 1, 2
    rooms[45:54, 100:110] = 3  # a 0.9 m door, 1 m deep
    rooms = _turned(rooms, degrees)
    free = rooms > 0
    joined = join_corridor_cuts(_places(free), OccupancyGrid.from_masks(free, RESOLUTION))
    # each room is most of one place (a watershed may leave a jagged corner's cells over the
    # door), and not the same one
    first, second = (np.bincount(joined[rooms == room]).argmax() for room in (1, 2))
    assert first > 0 and second > 0 and first != second


def _corridor_turning_into(across_rows: slice, arm_columns: slice) -> tuple:
    """A corridor across the top (its rows), another running down from it (its columns),
    places split where the second meets the first; 0.1 m cells."""
    free = np.zeros((120, 120), bool)
    free[across_rows, 2:118] = True
    free[across_rows.stop : 118, arm_columns] = True
    places = np.where(free, 1 + (np.arange(120) >= across_rows.stop)[:, None], 0)
    return places, OccupancyGrid.from_masks(free, 0.1)


def test_a_corridor_turning_into_a_wider_one_is_one_place_with_it():
    places, grid = _corridor_turning_into(slice(2, 20), slice(2, 16))  # 1.4 m into 1.8 m
    assert [v.tolist() for v in corridor_cuts(places, grid)] == [[1], [2]]
    places, grid = _corridor_turning_into(slice(2, 20), slice(40, 54))  # a T, not an L
    assert [v.tolist() for v in corridor_cuts(places, grid)] == [[1], [2]]


def test_a_corridor_ending_at_a_narrower_channel_across_it_stays_apart():
    # 1.9 m of corridor meeting a 1.5 m row of open bays across its end (ipa lab_c)
    places, grid = _corridor_turning_into(slice(2, 17), slice(40, 59))
    assert [v.tolist() for v in corridor_cuts(places, grid)] == [[], []]


def test_a_corridor_is_followed_along_its_own_walls_not_the_cuts_leaning_way():
    # at a junction the walls round a cut lean the way across it (ACES's round hub: 5
    # degrees); 8.8 m along, 8 degrees off, a straight line would leave a 2.2 m corridor
    free = np.zeros((120, 260), bool)
    free[50:72, 2:258] = True
    clearance = ndimage.distance_transform_edt(free).astype(np.float32) * RESOLUTION
    start = np.array([20.0, 60.5])
    for degrees in (-8, 8):
        way = np.array([np.cos(np.radians(degrees)), np.sin(np.radians(degrees))])
        assert _corridor_on(start, way, 2.2, clearance, RESOLUTION)
    way = np.array([np.cos(np.radians(40)), np.sin(np.radians(40))])  # no corridor that way
    assert not _corridor_on(start, way, 2.2, clearance, RESOLUTION)


def test_places_meeting_on_both_arms_of_a_ring_are_joined_beside_a_dotted_wall():
    # a ring of 2 m corridors round a 22 x 22 m block, its two places parted across both
    # arms at y = 15 m; beside the west cut, beyond a 0.2 m wall, a niche parted on the same
    # line: a dotted wall's gap with the west cut, but no part of the east cut 22 m away
    free = np.zeros((300, 300), bool)
    free[20:40, 20:280] = free[260:280, 20:280] = True
    free[20:280, 20:40] = free[20:280, 260:280] = True
    free[140:160, 42:46] = True  # the niche
    places = np.where(free, 1 + (np.arange(300)[:, None] >= 150), 0)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])


@settings(max_examples=20, deadline=None)
@given(st.floats(0, 10))
def test_a_corridor_at_the_least_width_a_few_degrees_off_the_cells_is_one_place(degrees):
    # 1.0 m between walls on 0.1 m cells (the least corridor less a cell off each wall), its
    # places parted along a column of cells: the cut is as long whatever the slant
    turned = np.radians(degrees)
    rows, columns = np.mgrid[0:60, 0:200]
    off = np.abs((rows - 29.5) * np.cos(turned) - (columns - 100) * np.sin(turned))
    free = off * RESOLUTION < 0.5
    free[:, :2] = free[:, -2:] = False
    places = np.where(free, 1 + (columns >= 100), 0)
    a, b = corridor_cuts(places, OccupancyGrid.from_masks(free, RESOLUTION))
    assert (a.tolist(), b.tolist()) == ([1], [2])
