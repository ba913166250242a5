import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from skimage.measure import label as connected

import maps
from maps.grid import OccupancyGrid
from segmentation.errors import ParameterError, SegmentationError
from segmentation.refine import basins, merge_open_boundaries
from segmentation.regions import Regions, dense_labels
from segmentation.transitions import find_transitions
from segmentation.virtual import MAX_VIRTUAL_KEYFRAMES, virtual_poses


@st.composite
def maps_with_keyframes(draw):
    free = draw(arrays(bool, st.tuples(st.integers(3, 25), st.integers(3, 25))))
    free[0, 0] = True
    rows, cols = np.nonzero(free)
    picks = draw(st.lists(st.integers(0, len(rows) - 1), min_size=1, max_size=8))
    labels = draw(st.lists(st.integers(0, 3), min_size=len(picks), max_size=len(picks)))
    grid = maps.OccupancyGrid.from_masks(free, 0.5)
    return grid, rows[picks], cols[picks], np.array(labels)


@given(maps_with_keyframes(), st.sampled_from([0.25, 1.0, 3.0]))
def test_regions_partition_the_free_space_into_connected_pieces(case, min_area):
    grid, rows, cols, keyframe_labels = case
    labels = dense_labels(grid, rows, cols, keyframe_labels, min_area=min_area)
    assert np.all(labels[~grid.free] == 0)
    ids = np.unique(labels[labels > 0])
    assert ids.tolist() == list(range(1, len(ids) + 1))
    for region in ids:
        assert connected(labels == region, connectivity=1).max() == 1
    # free cells are dropped only as islands too small to be a region
    dropped = grid.free & (labels == 0)
    if dropped.any():
        pieces = connected(grid.free, connectivity=1)
        for piece in np.unique(pieces[dropped]):
            assert (pieces == piece).sum() * 0.25 < min_area
    regions = Regions(grid, labels)
    for region, polygon in regions.polygons.items():
        covered = np.count_nonzero(regions.enclosing == region) * grid.resolution**2
        assert polygon.area == pytest.approx(covered)


def test_a_rooms_polygon_covers_its_furniture_but_not_a_courtyard():
    free = np.zeros((60, 60), bool)
    free[1:-1, 1:-1] = True
    free[10:14, 10:16] = False  # a table, 0.24 m^2
    free[25:50, 25:50] = False  # a courtyard, 6.25 m^2: more than furniture
    grid = maps.OccupancyGrid.from_masks(free, 0.1)
    regions = Regions(grid, free.astype(np.int32))
    (polygon,) = regions.polygons.values()
    assert regions.at(1.2, 4.8) == 1  # on the table
    assert len(polygon.interiors) == 1  # the courtyard's hole; none for the table
    assert polygon.area == pytest.approx((58 * 58 - 25 * 25) * 0.01)
    assert regions.area(1) == pytest.approx(free.sum() * 0.01)  # the floor: without the table


def test_the_places_meet_at_the_door(two_rooms):
    grid = two_rooms(door=1.0)
    places = basins(grid)
    left = places[grid.world_to_cell(2.0, 2.0)]
    right = places[grid.world_to_cell(6.0, 2.0)]
    assert left != right and len(np.unique(places[places > 0])) == 2
    door = find_transitions(grid, places)
    assert len(door) == 1
    assert door[0].width == pytest.approx(1.0, abs=0.06)
    assert abs(door[0].centre[0] - 4.15) < 0.2  # in the wall, not in a room


def test_open_cuts_merge_but_doors_do_not(two_rooms):
    grid = two_rooms(door=1.0)
    labels = np.zeros(grid.shape, np.int32)
    rows, cols = np.nonzero(grid.free)
    x, _ = grid.cell_to_world(rows, cols)
    labels[rows, cols] = np.select([x < 2.0, x < 4.1], [1, 2], 3)  # the left room cut in two
    merged = merge_open_boundaries(grid, labels)
    assert len(np.unique(merged[merged > 0])) == 2
    assert merged[grid.world_to_cell(1.0, 2.0)] == merged[grid.world_to_cell(3.0, 2.0)]


def test_virtual_poses_cover_every_room_and_avoid_walls():
    plan = maps.generate_floor_plan("flat", random_state=2)
    poses = virtual_poses(plan.grid, spacing=0.8)
    rows, cols = plan.grid.world_to_cell(poses[:, 0], poses[:, 1])
    assert np.all(plan.grid.clearance()[rows, cols] >= 0.2)
    assert set(plan.labels[rows, cols]) == set(range(1, plan.n_rooms + 1))


def test_a_lattice_of_too_many_virtual_keyframes_is_refused():
    grid = maps.OccupancyGrid(np.zeros((200, 200), np.int8), 0.05)  # 10 x 10 m, all free
    with pytest.raises(ParameterError, match=r"spacing 0.05 m would put \d+ virtual keyframes"):
        virtual_poses(grid, spacing=0.05)
    assert len(virtual_poses(grid, spacing=0.1)) <= MAX_VIRTUAL_KEYFRAMES


def test_a_map_without_free_space_is_an_error():
    grid = maps.OccupancyGrid(np.full((10, 10), 100, np.int8), 0.05)
    with pytest.raises(SegmentationError, match="no free cell"):
        virtual_poses(grid)
    with pytest.raises(SegmentationError, match="no free cell"):
        dense_labels(grid, np.array([1]), np.array([1]), np.array([0]))


def test_a_point_on_furniture_or_an_unseen_patch_is_in_the_room_round_it():
    # 0.05 m cells: two 5 x 5 m rooms and a wall between them with a door. In room 1 a
    # 2 x 1 m table drawn as wall (too big for clutter) and a 1 x 1 m patch nobody saw; a
    # 3 x 3 m block drawn as wall stands in room 2: larger than any furniture, it stays out.
    cells = np.full((110, 212), 100, np.int8)
    cells[5:105, 5:105] = cells[5:105, 107:207] = 0  # the rooms
    cells[50:70, 105:107] = 0  # the door
    cells[30:50, 30:70] = 100  # the table
    cells[70:90, 30:50] = -1  # the unseen patch
    cells[20:80, 130:190] = 100  # the block
    grid = OccupancyGrid(cells, 0.05)
    labels = np.where(grid.free, 1 + (np.arange(212) >= 106), 0).astype(np.int32)
    regions = Regions(grid, labels)
    x, y = grid.cell_to_world(np.array([40, 80, 50, 0]), np.array([50, 40, 160, 100]))
    assert regions.at_points(x, y).tolist() == [1, 1, 0, 0]  # table, patch; block, outer wall
    assert regions.at(float(x[0]), float(y[0])) == 1
    assert (regions.labels[30:50, 30:70] == 0).all()  # the regions' cells stay the floor
