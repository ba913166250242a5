"""Pockets behind gaps narrower than a door join the space they open onto; rooms stay."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from maps.grid import OccupancyGrid
from segmentation.pockets import NARROWEST_DOOR, SMALLEST_ROOM, join_pockets


def _room_and_side(gap_cells: int, resolution: float = 0.05) -> tuple[OccupancyGrid, np.ndarray]:
    """A 4 x 4 m room (region 1) with a 2 x 2 m space (region 2) beside it, behind a 0.1 m
    wall with an opening ``gap_cells`` wide in it."""
    free = np.zeros((90, 130), bool)
    free[5:85, 5:85] = True
    free[25:65, 87:127] = True
    middle = 45
    free[middle - gap_cells // 2 : middle - gap_cells // 2 + gap_cells, 85:87] = True
    labels = np.where(free, 1, 0).astype(np.int32)
    labels[:, 86:] *= 2
    return OccupancyGrid.from_masks(free, resolution), labels


def test_a_space_behind_a_gap_narrower_than_any_door_joins_the_room():
    grid, labels = _room_and_side(9)  # 0.45 m: between furniture, no door
    joined, count = join_pockets(grid, labels, {1, 2})
    assert count == 1
    assert joined[45, 100] == joined[45, 40] == 1


def test_a_closet_behind_a_narrow_door_stays_a_room():
    grid, labels = _room_and_side(15)  # 0.75 m: a closet's door
    joined, count = join_pockets(grid, labels, {1, 2})
    assert count == 0
    assert joined[45, 100] == 2 and joined[45, 40] == 1


def test_a_space_the_robot_cannot_enter_is_a_room_seen_not_a_pocket():
    # on a coarse map the rays through a half-open door fill the cells behind it: robot
    # space, reached only through a gap narrower than the robot
    grid, labels = _room_and_side(6)  # 0.3 m
    joined, count = join_pockets(grid, labels, {1, 2}, robot_radius=0.2)
    assert count == 0 and joined[45, 100] == 2
    grid, labels = _room_and_side(9)  # 0.45 m: the robot passes between the furniture
    joined, count = join_pockets(grid, labels, {1, 2}, robot_radius=0.2)
    assert count == 1 and joined[45, 100] == 1


def _room_and_corner(side_cells: int, gap_cells: int) -> tuple[OccupancyGrid, np.ndarray]:
    """A 4 x 4 m room (region 1, 0.05 m cells) and a square space ``side_cells`` across
    (region 2) beside it, open onto it over ``gap_cells``."""
    free = np.zeros((90, 130), bool)
    free[5:85, 5:85] = True
    free[45 - side_cells // 2 : 45 + side_cells - side_cells // 2, 87 : 87 + side_cells] = True
    free[45 - gap_cells // 2 : 45 + gap_cells - gap_cells // 2, 85:87] = True
    labels = np.where(free, 1, 0).astype(np.int32)
    labels[:, 86:] *= 2
    return OccupancyGrid.from_masks(free, 0.05), labels


def test_a_space_the_robot_enters_too_small_for_a_room_joins_the_room():
    # a 1.2 x 1.2 m corner behind desks, open over 0.9 m (wider than any closet's door)
    grid, labels = _room_and_corner(24, 18)
    joined, count = join_pockets(grid, labels, {1, 2}, robot_radius=0.2)
    assert count == 1 and joined[45, 95] == 1
    # reached only through a gap narrower than the robot: a room seen, not a pocket
    grid, labels = _room_and_corner(24, 6)
    joined, count = join_pockets(grid, labels, {1, 2}, robot_radius=0.2)
    assert count == 0 and joined[45, 95] == 2
    # a 1.6 x 1.6 m closet (2.6 m^2) behind the same 0.9 m door stays a room
    grid, labels = _room_and_corner(32, 18)
    joined, count = join_pockets(grid, labels, {1, 2}, robot_radius=0.2)
    assert count == 0 and joined[45, 95] == 2
    assert 1.5 <= SMALLEST_ROOM <= 2.25  # under the smallest enterable room people drew


def test_a_room_seen_through_a_door_gap_is_not_a_pocket():
    grid, labels = _room_and_side(9)
    joined, count = join_pockets(grid, labels, {1})  # region 2 is not of the robot's space
    assert count == 0
    assert joined[45, 100] == 2


def test_the_threshold_is_a_door_in_metres_at_any_resolution():
    # the same 0.45 m and 0.75 m openings on 0.025 m cells
    for gap, joins in ((18, True), (30, False)):
        free = np.zeros((180, 260), bool)
        free[10:170, 10:170] = True
        free[50:130, 174:254] = True
        free[90 - gap // 2 : 90 - gap // 2 + gap, 170:174] = True
        labels = np.where(free, 1, 0).astype(np.int32)
        labels[:, 172:] *= 2
        _, count = join_pockets(OccupancyGrid.from_masks(free, 0.025), labels, {1, 2})
        assert (count == 1) is joins
    assert 0.5 < NARROWEST_DOOR <= 0.7


def test_a_door_on_a_coarse_map_is_no_pocket():
    # a 0.7 m door on 0.1 m cells, its jambs' cells occupied where beams ended in them: six
    # free cells across, a clear width of 0.5 m measured (0.6 m on 0.05 m cells: a door)
    free = np.zeros((45, 65), bool)
    free[3:42, 3:42] = True
    free[13:32, 44:63] = True
    free[19:25, 42:44] = True
    labels = np.where(free, 1, 0).astype(np.int32)
    labels[:, 43:] *= 2
    _, count = join_pockets(OccupancyGrid.from_masks(free, 0.1), labels, {1, 2})
    assert count == 0
    free[19:25, 42:44] = False
    free[20:24, 42:44] = True  # four cells, 0.3 m measured: between furniture
    _, count = join_pockets(OccupancyGrid.from_masks(free, 0.1), labels * free, {1, 2})
    assert count == 1


@settings(max_examples=30, deadline=None)
@given(
    st.integers(1, 4),
    st.lists(st.integers(1, 4), min_size=12 * 12, max_size=12 * 12),
    st.sets(st.integers(1, 4)),
)
def test_joining_keeps_every_cell_labelled_and_counts_the_regions_lost(
    regions: int, values: list[int], candidates: set[int]
) -> None:
    labels = np.minimum(np.array(values, np.int32).reshape(12, 12), regions)
    free = np.ones((12, 12), bool)
    joined, count = join_pockets(OccupancyGrid.from_masks(free, 0.1), labels, candidates)
    assert ((joined > 0) == (labels > 0)).all()
    assert count == len(np.unique(labels)) - len(np.unique(joined))
    # regions are unions of the old ones: cells of one old region stay together
    for old in np.unique(labels):
        assert len(np.unique(joined[labels == old])) == 1
