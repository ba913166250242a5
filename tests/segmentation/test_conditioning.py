"""Map conditioning and the pipeline on constructed cases, real maps and odd inputs."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage

import maps
from maps.grid import OCCUPIED, UNKNOWN, OccupancyGrid
from segmentation.conditioning import condition, find_clutter
from segmentation.errors import ParameterError, SegmentationError
from segmentation.export import read_label_image
from segmentation.metrics import score
from segmentation.pipeline import MapSegmenter, Segmentation
from segmentation.spectral import SpectralSegmenter
from segmentation.working import pool, unpool


def segment(grid: OccupancyGrid, **options) -> np.ndarray:
    pipeline = MapSegmenter(spectral=SpectralSegmenter(random_state=0), **options)
    return pipeline.segment(grid).regions.labels


def region_count(labels: np.ndarray) -> int:
    return len(np.unique(labels[labels > 0]))


def walled(
    width_m: float, height_m: float, resolution: float = 0.05, pad: float = 0.5
) -> np.ndarray:
    """Cells of a walled rectangle (0.1 m walls), ``pad`` metres of unknown around it."""
    pad = round(pad / resolution)
    wall = max(1, round(0.1 / resolution))
    h, w = round(height_m / resolution), round(width_m / resolution)
    cells = np.full((h + 2 * pad, w + 2 * pad), UNKNOWN, np.int8)
    cells[pad - wall : pad + h + wall, pad - wall : pad + w + wall] = OCCUPIED
    cells[pad : pad + h, pad : pad + w] = 0
    return cells


def test_a_ray_through_a_wall_gap_is_not_robot_space_but_belongs_to_its_room():
    cells = walled(4.0, 4.0)
    middle = cells.shape[0] // 2
    cells[middle, 8:] = 0  # a one-cell free ray out through the east wall, 2 m into the unknown
    conditioned = condition(OccupancyGrid(cells, 0.05))
    ray = np.zeros_like(conditioned.free)
    ray[middle, 92:] = True  # the part beyond the wall
    assert not (conditioned.free & ray).any()
    assert conditioned.dropped["thin"] >= ray.sum()
    labels = segment(OccupancyGrid(cells, 0.05))
    room = labels[middle, 40]
    # a ray too thin and small to be a room: it belongs to the room it leaves from
    assert region_count(labels) == 1 and room > 0 and (labels[ray] == room).all()


def _room_and_fan(far_wall: bool) -> tuple[np.ndarray, np.ndarray, Segmentation]:
    """A 6 x 5 m room whose laser rays fan out 3 m through a 1 m opening in its north wall,
    ending on the far wall of a room nobody entered, or in space nobody mapped; its labels,
    the fan's cells (short of its end) and the segmentation."""
    cells = walled(6.0, 5.0, pad=3.0)
    rows, cols = np.mgrid[0 : cells.shape[0], 0 : cells.shape[1]]
    height = 60 - rows  # cells above the room's first row (row 60)
    fan = (height > 0) & (np.abs(cols - 120) < 10 + 0.6 * height)
    cells[fan] = 0
    if far_wall:
        cells[fan & (height >= 59)] = 100
    found = MapSegmenter(spectral=SpectralSegmenter(random_state=0)).segment(
        OccupancyGrid(cells, 0.05)
    )
    return found.regions.labels, fan & (height > 10) & (height < 59), found


def test_a_fan_of_rays_into_a_room_seen_through_its_door_is_a_region_beside_the_room():
    labels, fan, _ = _room_and_fan(far_wall=True)
    room = np.unique(labels[61:159, 61:179])
    seen = np.unique(labels[fan])
    # what a laser saw of a room through its door: a region of its own, as people draw it;
    # the room itself stays whole
    assert len(room) == 1 and room[0] > 0 and len(seen) == 1 and seen[0] not in (0, room[0])
    assert region_count(labels) == 2


def test_a_fan_of_rays_out_into_unmapped_space_belongs_to_the_room():
    labels, fan, found = _room_and_fan(far_wall=False)
    assert found.conditioned.dropped["outside"] > 0  # no robot space out there
    room = labels[100, 100]
    # rays out through a window end on no wall: people draw them in the room they leave
    assert region_count(labels) == 1 and room > 0 and (labels[fan] == room).all()
    assert found.coverage.seen_rooms == 0


def test_a_room_full_of_tables_stays_one_room():
    cells = walled(8.0, 6.0)
    rng = np.random.default_rng(3)
    for row in range(20, 110, 24):
        for col in range(20, 140, 40):  # 1.2 x 0.6 m tables, 0.4 m or more apart
            r, c = row + rng.integers(-2, 3), col + rng.integers(-2, 3)
            cells[r : r + 12, c : c + 24] = OCCUPIED
    grid = OccupancyGrid(cells, 0.05)
    clutter = find_clutter(grid)
    walls = OccupancyGrid(walled(8.0, 6.0), 0.05).occupied
    assert np.array_equal(clutter, grid.occupied & ~walls)
    labels = segment(grid)
    assert region_count(labels) == 1
    # the tables belong to the room: a point on a table is in it
    assert (labels[clutter] == labels[10, 10]).all() and labels[10, 10] > 0


def test_a_dotted_wall_stays_a_wall():
    """A SLAM wall drawn as specks 0.1 m apart still divides two rooms; a speck alone is clutter."""
    cells = walled(8.0, 4.0)
    middle = cells.shape[1] // 2
    cells[:, middle - 1 : middle + 1] = 0
    cells[::2, middle - 1 : middle + 1] = OCCUPIED  # specks every other cell
    cells[40:60, middle - 1 : middle + 1] = 0  # a 1 m door
    cells[30, 30] = OCCUPIED  # one speck in the left room
    grid = OccupancyGrid(cells, 0.05)
    clutter = find_clutter(grid)
    assert clutter[30, 30] and not clutter[20, middle]
    labels = segment(grid)
    assert region_count(labels) == 2
    assert labels[50, 30] != labels[50, cells.shape[1] - 30]


def test_a_stretch_of_wall_between_two_doors_is_wall_not_furniture():
    """A 1.8 m stretch of wall between two doors stands as free as a table; read as clutter,
    the room behind it opened onto the corridor over 3.6 m and was joined to it."""
    cells = walled(12.0, 6.0)
    row = 88  # the wall between the room (above) and a 1.6 m corridor (below)
    cells[row : row + 3, :] = OCCUPIED
    for start, end in ((4.0, 4.9), (6.7, 7.6)):  # two 0.9 m doors
        cells[row : row + 3, round(start / 0.05) : round(end / 0.05)] = 0
    grid = OccupancyGrid(cells, 0.05)
    assert not find_clutter(grid)[row, round(5.8 / 0.05)]
    table = walled(12.0, 6.0)
    table[40:56, 100:132] = OCCUPIED  # a 1.6 x 0.8 m table in the room, not on a wall line
    assert find_clutter(OccupancyGrid(table, 0.05))[48, 110]
    labels = segment(grid)
    room, corridor = labels[30, 120], labels[row + 15, 120]
    assert region_count(labels) == 2 and room != corridor


def test_a_corridor_with_side_doors_and_a_junction_is_one_region():
    resolution = 0.05
    cells = np.full((400, 400), OCCUPIED, np.int8)
    cells[180:220, 20:380] = 0  # a 2 m x 18 m corridor
    cells[20:180, 180:220] = 0  # a corridor branching north: a T junction
    for col in (60, 250, 340):  # rooms south of the corridor, each behind a 0.9 m door
        cells[230:330, col - 40 : col + 40] = 0
        cells[220:230, col - 9 : col + 9] = 0
    grid = OccupancyGrid(cells, resolution)
    labels = segment(grid)
    corridor = labels[200, 100]
    assert labels[200, 370] == corridor and labels[30, 200] == corridor
    rooms = {int(labels[300, col]) for col in (60, 250, 340)}
    assert len(rooms) == 3 and corridor not in rooms
    assert region_count(labels) == 4


def test_furnished_floor_plan_agrees_with_people(data_dir):
    grid = maps.OccupancyGrid.load(data_dir / "ipa" / "office_b_furnitures.yaml")
    truth = read_label_image(data_dir / "ipa" / "office_b_gt_labels.png")
    assert score(segment(grid), truth).mcc > 0.9


@pytest.mark.parametrize("resolution", [0.02, 0.05, 0.1])
def test_the_same_building_at_any_resolution(resolution, two_rooms):
    grid = two_rooms(door=0.9, resolution=resolution)
    labels = segment(grid)
    assert region_count(labels) == 2
    left, right = grid.world_to_cell(np.array([1.0, 7.0]), np.array([2.0, 2.0]))
    assert labels[left[0], right[0]] != labels[left[1], right[1]]


def test_a_rotated_origin_changes_nothing_but_the_frame(two_rooms):
    grid = two_rooms()
    turned = OccupancyGrid(grid.cells, grid.resolution, (-3.0, 5.0, math.radians(45)))
    assert np.array_equal(segment(grid), segment(turned))


@pytest.mark.slow
def test_an_open_field_wider_than_the_laser_range_is_one_region():
    """150 x 150 m with no wall: keyframes in the middle see nothing within 15 m and are left
    out of the clustering instead of failing it."""
    labels = segment(OccupancyGrid(np.zeros((3000, 3000), np.int8), 0.05))
    assert region_count(labels) == 1 and (labels > 0).mean() > 0.99


def test_free_space_touching_the_map_edge_is_segmented():
    cells = np.zeros((80, 120), np.int8)  # all free: the edge is the only wall
    labels = segment(OccupancyGrid(cells, 0.05))
    assert region_count(labels) == 1
    assert (labels > 0).sum() > 0.95 * labels.size


def test_no_free_space_is_a_clear_error():
    with pytest.raises(SegmentationError, match="no free space"):
        segment(OccupancyGrid(np.full((50, 50), OCCUPIED, np.int8), 0.05))
    with pytest.raises(ParameterError, match="robot_radius"):
        condition(OccupancyGrid(np.zeros((5, 5), np.int8), 0.05), robot_radius=-1)


def test_same_seed_same_regions():
    plan = maps.generate_floor_plan("flat", furniture=0.3, random_state=1)
    assert np.array_equal(segment(plan.grid), segment(plan.grid))


def blocks(mask: np.ndarray, factor: int, shape: tuple[int, int]) -> np.ndarray:
    """Coarse ``mask`` blown up to fine cells, cut to ``shape``."""
    return np.kron(mask, np.ones((factor, factor), bool))[: shape[0], : shape[1]]


@given(arrays(bool, st.tuples(st.integers(1, 30), st.integers(1, 30))), st.integers(1, 4))
def test_pooling_never_opens_a_wall_and_unpooling_never_crosses_one(fine_mask, factor):
    grid = OccupancyGrid.from_masks(fine_mask, 0.05)
    coarse = pool(fine_mask, grid, factor)
    assert not (blocks(coarse.free, factor, fine_mask.shape) & ~fine_mask).any()
    labels = np.where(coarse.free, np.arange(coarse.free.size).reshape(coarse.shape) + 1, 0)
    fine = unpool(labels, factor, fine_mask)
    # labelled: exactly the kept cells connected (through kept cells) to a pooled cell
    pieces, _ = ndimage.label(fine_mask)
    seeded = np.unique(pieces[blocks(coarse.free, factor, fine_mask.shape)])
    assert np.array_equal(fine > 0, fine_mask & np.isin(pieces, seeded[seeded > 0]))
    rows, cols = np.nonzero(blocks(coarse.free, factor, fine_mask.shape))
    assert np.array_equal(fine[rows, cols], labels[rows // factor, cols // factor])
    # a coarse cell keeps its place in the map frame
    if coarse.free.any():
        r, c = np.argwhere(coarse.free)[0]
        x, y = coarse.cell_to_world(r, c)
        fr, fc = grid.world_to_cell(x, y)
        assert (fr // factor, fc // factor) == (r, c)


def test_a_small_room_never_joins_a_region_across_a_wall():
    """A 1 m^2 room shrinks under min_area once pooled: it is no robot space, and covering the
    building makes it a region of its own, never the big room's through the wall."""
    cells = np.full((80, 120), OCCUPIED, np.int8)
    cells[5:75, 5:80] = 0
    cells[11:32, 87:108] = 0
    grid = OccupancyGrid(cells, 0.05)
    found = MapSegmenter(spectral=SpectralSegmenter(random_state=0)).segment(grid)
    labels = found.regions.labels
    small, big = np.unique(labels[11:32, 87:108]), np.unique(labels[5:75, 5:80])
    assert len(small) == len(big) == 1 and 0 < small[0] != big[0] > 0
    assert all(shape.geom_type == "Polygon" for shape in found.regions.polygons.values())
    counts = found.conditioned.summary()
    dropped = sum(v for k, v in counts.items() if k.startswith("dropped"))
    assert counts["kept_cells"] + dropped == counts["free_cells"]
    assert (labels[grid.free] > 0).all() and found.coverage.seen_rooms == 1


def test_obstacles_closer_than_the_robot_group_at_any_resolution():
    cells = np.zeros((60, 60), np.int8)
    cells[[0, -1], :] = cells[:, [0, -1]] = OCCUPIED
    cells[30, 1:59:2] = OCCUPIED  # a dotted wall, 0.1 m gaps, a 0.3 m robot cannot pass
    clutter = find_clutter(OccupancyGrid(cells, 0.1), robot_radius=0.15)
    assert not clutter[30].any()


@given(arrays(bool, st.tuples(st.integers(1, 20), st.integers(1, 20))), st.integers(1, 4))
def test_unpooled_cells_take_a_label_of_the_nearest_labelled_cells(fine_mask, factor):
    from collections import deque

    grid = OccupancyGrid.from_masks(fine_mask, 0.05)
    coarse = pool(fine_mask, grid, factor)
    labels = np.where(coarse.free, np.arange(coarse.free.size).reshape(coarse.shape) + 1, 0)
    fine = unpool(labels, factor, fine_mask)
    seeds = blocks(coarse.free, factor, fine_mask.shape)
    # an independent breadth-first search from every seeded cell: distance and labels there
    height, width = fine_mask.shape
    distance = np.full(fine_mask.shape, -1)
    reach: dict[tuple[int, int], set[int]] = {}
    queue = deque()
    for r, c in np.argwhere(seeds):
        distance[r, c] = 0
        reach[(r, c)] = {int(labels[r // factor, c // factor])}
        queue.append((r, c))
    while queue:
        r, c = queue.popleft()
        for nr, nc in ((r - 1, c), (r + 1, c), (r, c - 1), (r, c + 1)):
            if 0 <= nr < height and 0 <= nc < width and fine_mask[nr, nc]:
                if distance[nr, nc] == -1:
                    distance[nr, nc] = distance[r, c] + 1
                    queue.append((nr, nc))
                if distance[nr, nc] == distance[r, c] + 1:
                    reach.setdefault((nr, nc), set()).update(reach[(r, c)])
    for (r, c), found in reach.items():
        if not seeds[r, c]:
            assert int(fine[r, c]) in found


def _room_with(obstacle_cells: np.ndarray, shadow_cells: np.ndarray) -> OccupancyGrid:
    """A 10 x 8 m room (0.1 m cells) with an occupied outline and unknown cells in it."""
    cells = np.zeros((82, 102), np.int8)
    cells[[0, -1], :] = cells[:, [0, -1]] = OCCUPIED
    cells[shadow_cells] = UNKNOWN
    cells[obstacle_cells] = OCCUPIED
    return OccupancyGrid(cells, 0.1)


def test_furniture_is_measured_by_what_the_laser_hit_not_its_shadow():
    desk = np.zeros((82, 102), bool)
    desk[40:48, 40:56] = True  # 1.6 x 0.8 m
    outline = desk & ~ndimage.binary_erosion(desk)
    shadow = np.zeros_like(desk)
    shadow[41:47, 41:55] = True  # its unseen inside
    shadow[44:47, 55:62] = True  # and the shadow behind it: 2.1 m from end to end
    clutter = find_clutter(_room_with(outline, shadow))
    assert clutter[outline].all() and clutter[shadow].all()
    # a 1 m stub of wall with 2.5 x 1.2 m of unexplored space behind it (2.8 m across, over
    # the 2.5 m a desk and its shadow may reach) is measured whole: no furniture
    stub, unexplored = np.zeros_like(desk), np.zeros_like(desk)
    stub[30, 20:30] = True
    unexplored[31:43, 15:40] = True
    assert not find_clutter(_room_with(stub, unexplored))[stub].any()


@pytest.mark.parametrize("resolution", [0.025, 0.05])
def test_a_wall_drawn_a_cell_per_ray_is_wall_at_any_resolution(resolution):
    # a 2 x 2 m place, its walls seen by rays 0.05 m apart: a wall cell per ray, unknown
    # between. On 0.025 m cells that is every other cell; the wall is whole all the same.
    from segmentation.conditioning import wall_share

    side, step = round(2.0 / resolution), round(0.05 / resolution)
    cells = np.full((side + 4, side + 4), UNKNOWN, np.int8)
    cells[2:-2, 2:-2] = 0
    for line in (1, -2):
        cells[line, 2:-2:step] = cells[2:-2:step, line] = OCCUPIED
    labels = np.zeros(cells.shape, np.int32)
    labels[2:-2, 2:-2] = 1
    share = wall_share(OccupancyGrid(cells, resolution), labels)
    assert share[1] >= 0.9


@given(
    arrays(bool, st.tuples(st.integers(1, 40), st.integers(1, 40)), elements=st.booleans()),
    st.floats(0.0, 20.0),
)
def test_disc_centres_by_erosion_are_the_clearance_test(space, radius):
    # the robot's disc centres: the cells farther than its radius from every cell outside
    # the space (the map edge outside too), found by an erosion where the disc is small
    from maps.grid import clearance_of
    from segmentation.conditioning import farther_than

    assert (farther_than(space, radius) == (clearance_of(space, 1.0) > radius)).all()
