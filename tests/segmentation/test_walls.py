"""Gaps of straight walls: closed where a wall goes on past them, never elsewhere."""

from unittest import mock

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy import ndimage

from maps.grid import OccupancyGrid
from segmentation import pipeline, walls
from segmentation.pipeline import MapSegmenter, parted
from segmentation.spectral import SpectralSegmenter
from segmentation.walls import _runs, hall_mouths, seen_walls, wall_gaps


def _wall_with_gap(gap_cells: int) -> np.ndarray:
    walls = np.zeros((60, 80), bool)
    walls[30, :30] = walls[30, 30 + gap_cells :] = True
    return walls


def test_a_gap_between_walls_on_one_line_is_closed_but_for_a_hole():
    walls = _wall_with_gap(15)  # 1.5 m at 0.1 m cells
    closed = wall_gaps(walls, ~walls, 0.1)
    assert closed[29:32, 31:34].any() and not closed[:25].any() and not closed[36:].any()
    # the hole keeps the two sides one space: a passage, not a wall
    assert ndimage.label(~walls & ~closed)[1] == 1
    assert not closed[30, 37]  # the middle of the gap


def test_wider_gaps_and_short_walls_stay_open():
    wide = _wall_with_gap(25)  # 2.5 m: wider than double doors
    assert not wall_gaps(wide, ~wide, 0.1).any()
    short = np.zeros((60, 80), bool)
    short[30, 22:30] = short[30, 45:53] = True  # 0.8 m stubs: a door frame, not a wall
    assert not wall_gaps(short, ~short, 0.1).any()


@settings(max_examples=25, deadline=None)
@given(
    st.integers(5, 20),
    st.integers(0, 2**31 - 1),
)
def test_only_free_cells_are_closed_and_the_space_never_falls_apart(gap, seed):
    rng = np.random.default_rng(seed)
    walls = _wall_with_gap(gap)
    walls |= rng.random(walls.shape) < 0.01  # specks
    free = ~walls
    closed = wall_gaps(walls, free, 0.1)
    assert not (closed & ~free).any()
    before = ndimage.label(free)[0]
    after = ndimage.label(free & ~closed)[0]
    # every piece of free space left is still one piece where it was one (the holes)
    for piece in np.unique(before[before > 0]):
        inside = after[(before == piece) & (after > 0)]
        big = np.bincount(inside)
        assert (big >= 20).sum() <= 1


def test_a_corridor_beside_a_wide_opening_is_not_the_room_behind_it():
    free = np.zeros((150, 300), bool)  # 0.1 m cells
    free[20:35, 10:290] = True  # a 1.5 m corridor, 28 m long
    free[36:100, 100:180] = True  # a 6.4 x 8 m room below it
    free[35, 130:148] = True  # a 1.8 m opening in the corridor's straight wall
    grid = OccupancyGrid.from_masks(free, 0.1)
    found = MapSegmenter(spectral=SpectralSegmenter(random_state=0)).segment(grid)
    labels = found.regions.labels
    corridor, room = labels[27, 50], labels[70, 140]
    assert corridor > 0 and room > 0 and corridor != room
    assert labels[27, 250] == corridor  # the corridor stays whole on both sides of the opening


def test_a_corridor_crossing_the_line_of_the_rooms_walls_is_not_cut():
    free = np.zeros((120, 200), bool)  # 0.1 m cells
    free[50:65, 5:195] = True  # a 1.5 m corridor
    for rows in (np.s_[5:49], np.s_[66:115]):  # rooms above and below it, two by two,
        free[rows, 20:99] = free[rows, 101:180] = True  # their walls on one line across it
    assert not wall_gaps(~free, free, 0.1).any()


def test_a_corridor_with_doors_beside_the_crossing_is_not_cut():
    free = np.zeros((120, 200), bool)  # 0.1 m cells
    free[50:65, 5:195] = True  # a 1.5 m corridor
    for rows in (np.s_[5:49], np.s_[66:115]):  # rooms above and below it, two by two,
        free[rows, 20:99] = free[rows, 101:180] = True  # their walls on one line across it
    for row in (49, 65):  # and each room's 0.9 m door 0.8 m from the crossing
        free[row, 82:91] = free[row, 109:118] = True
    closed = wall_gaps(~free, free, 0.1)
    assert not closed[50:65, 95:106].any()  # the corridor, where the rooms' walls cross it
    assert closed[49, 82:91].any()  # the doors are gaps of the corridor's straight walls


def test_a_corridor_branching_off_stays_open_but_a_room_opening_of_its_width_is_closed():
    free = np.zeros((120, 200), bool)  # 0.1 m cells
    free[50:65, 5:195] = True  # a 1.5 m corridor
    free[5:50, 40:55] = True  # a corridor of 1.5 m branching north from it, 4.5 m long
    free[66:110, 120:180] = True  # a 6 x 4.4 m room south of it
    free[65, 140:155] = True  # behind a 1.5 m opening
    closed = wall_gaps(~free, free, 0.1)
    assert not closed[40:60, 38:57].any()  # the branch's mouth
    assert closed[64:67, 140:155].any()  # the room's opening


def test_a_keyframe_in_a_closed_gap_stands_in_the_place_beside_it():
    from maps.scan import Keyframe, LaserScan
    from segmentation.affinity import PassageAffinity

    free = np.zeros((60, 80), bool)
    free[5:30, 5:75] = free[31:55, 5:75] = True  # two rooms, a 1.5 m gap in the wall between
    free[30, 30:45] = True
    closed = wall_gaps(~free, free, 0.1)
    space = OccupancyGrid.from_masks(free & ~closed, 0.1)
    places = np.where(space.free, 1 + (np.arange(60)[:, None] > 30), 0).astype(np.int32)
    affinity = PassageAffinity(space, places, contrast=2.0)
    scan = LaserScan(np.ones(4), 0.0, np.pi / 2)
    row, col = np.argwhere(closed)[0]
    x, y = space.cell_to_world(np.array([row]), np.array([col]))
    found = affinity.keyframe_places([Keyframe((float(x[0]), float(y[0]), 0.0), scan)])
    assert found[0] in (1, 2)


def test_a_passage_leaving_a_hall_through_its_wall_is_closed():
    free = np.zeros((160, 200), bool)  # 0.1 m cells
    free[10:100, 10:190] = True  # an 18 x 9 m hall
    free[101:150, 90:100] = True  # a 1 m passage leaving it south, 5 m long
    free[100, 90:100] = True
    closed = wall_gaps(~free, free, 0.1)
    assert closed[99:102, 90:100].any()


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 1), st.integers(0, 1))
@example(162797, 1, 0)  # one cell over, the probabilistic Hough line was one cell more tilted
def test_a_gap_is_closed_alike_one_cell_over(seed, left, top):
    # a SLAM wall at 0.05 m: its face wanders a cell, a cell in seven is missing; a 1.2 m door
    rng = np.random.default_rng(seed)
    walls = np.zeros((120, 160), bool)
    rows = 60 + rng.integers(0, 2, 160)
    walls[rows, np.arange(160)] = rng.random(160) > 1 / 7
    walls[:, 70:94] = False
    moved = np.pad(walls, ((top, 0), (left, 0)))
    closed = wall_gaps(walls, ~walls, 0.05)
    closed_moved = wall_gaps(moved, ~moved, 0.05)
    back = closed_moved[top:, left:]
    assert closed[55:66, 70:94].any()  # the door is closed but for its hole
    assert (closed == back).all()  # the same cells: lines and closures measured from the walls


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**31 - 1))
@example(2)  # the probabilistic Hough transform drew its points otherwise: another line
def test_a_gap_is_closed_alike_whatever_lies_beyond_the_walls_reach(seed):
    # a SLAM wall at 0.05 m with a 1.2 m door; then clutter 4.5 m past its end, beyond the
    # widest gap a wall line bridges: the wall's lines, and so its gap, stay as they were
    rng = np.random.default_rng(seed)
    walls = np.zeros((120, 400), bool)
    rows = 60 + rng.integers(0, 2, 160)
    walls[rows, np.arange(160)] = rng.random(160) > 1 / 7
    walls[:, 70:94] = False
    cluttered = walls.copy()
    cluttered[rng.integers(0, 120, 300), rng.integers(250, 400, 300)] = True
    closed = wall_gaps(walls, ~walls, 0.05)
    assert closed[55:66, 70:94].any()
    assert (closed[:, :160] == wall_gaps(cluttered, ~cluttered, 0.05)[:, :160]).all()


def test_a_corridor_going_on_past_an_open_area_beside_it_is_not_cut():
    # rooms' walls on one line across a corridor that has an open area along its south side
    # on one side of the line: its north wall, broken by a door, goes on past the line
    free = np.zeros((140, 200), bool)  # 0.1 m cells
    free[50:65, 5:195] = True  # a 1.5 m corridor
    free[5:49, 20:99] = free[5:49, 101:180] = True  # rooms north, their wall at column 99-100
    free[49, 60:70] = True  # a 1 m door into the west room
    free[65:130, 20:99] = True  # an open area along the corridor's west half, no wall between
    free[66:130, 101:180] = True  # a room south of the east half, its wall on the same line
    free[65, 130:140] = True  # behind a door
    closed = wall_gaps(~free, free, 0.1)
    assert not closed[50:65, 95:105].any()  # the corridor across the line stays open
    assert closed[48:51, 60:70].any() or closed[64:67, 130:140].any()  # doors still close


def _two_rooms(wall: int) -> OccupancyGrid:
    """Two 3 x 4 m rooms (0.05 m cells) with a 0.1 m wall between them drawn as ``wall``
    cells (occupied, or unknown as a floor plan's grey line reads), a 1.5 m gap in its
    middle, and unknown space all round."""
    cells = np.full((90, 130), -1, np.int8)
    cells[5:85, 2:62] = cells[5:85, 64:124] = 0
    cells[5:85, 62:64] = wall
    cells[30:60, 62:64] = 0  # the gap
    return OccupancyGrid(cells, 0.05)


def test_a_gap_in_a_wall_drawn_grey_is_closed_as_in_a_wall_drawn_black():
    for wall in (100, -1):
        grid = _two_rooms(wall)
        clutter = np.zeros(grid.shape, bool)
        walls = seen_walls(grid, grid.free, clutter)
        assert walls[8:30, 62:64].all() and walls[60:82, 62:64].all()
        closed = wall_gaps(walls, grid.free, grid.resolution)
        assert closed[30:60, 62:64].any(), wall


def test_unexplored_space_and_the_streaks_between_rays_are_no_walls():
    grid = _two_rooms(-1)
    walls = seen_walls(grid, grid.free, np.zeros(grid.shape, bool))
    assert not walls[:5].any() and not walls[85:].any()  # unknown beside one room only
    # a fan of thin free rays (one cell each, 0.15 m apart) into unknown space: not robot
    # space, so the unknown between them is not between robot space
    cells = np.full((40, 80), -1, np.int8)
    cells[5:35, 2:40] = 0
    cells[8:32:3, 40:78] = 0  # the rays
    fan = OccupancyGrid(cells, 0.05)
    space = np.zeros(fan.shape, bool)
    space[5:35, 2:40] = True
    walls = seen_walls(fan, space, np.zeros(fan.shape, bool))
    assert not walls[:, 44:].any()
    # cells no beam crossed inside a room (a map built from scans): specks, not a wall
    cells = np.zeros((60, 60), np.int8)
    cells[10:50:7, 10:50:5] = -1
    cells[30, 20:26] = -1  # 0.3 m of unseen cells in a row
    room = OccupancyGrid(cells, 0.05)
    walls = seen_walls(room, room.free, np.zeros(room.shape, bool))
    assert room.unknown.sum() > 40 and not walls.any()


def test_the_strip_between_two_dropped_fans_of_rays_is_no_wall(monkeypatch):
    # 0.05 m cells: a 6 m room walled all round; through two 0.6 m gaps in its east wall, two
    # 1.4 m wide fans of rays into unknown space, a 0.2 m unseen strip between them. The fans
    # are places bounded by unknown space, dropped; the walls are then found between the
    # robot space left, where the strip lies beside no robot space.
    cells = np.full((140, 220), -1, np.int8)
    cells[8:134, 8:136] = 100
    cells[10:132, 10:132] = 0
    cells[40:68, 136:200] = cells[72:100, 136:200] = 0  # the fans
    cells[50:62, 132:136] = cells[78:90, 132:136] = 0  # their gaps in the wall
    grid = OccupancyGrid(cells, 0.05)
    seen: list[np.ndarray] = []
    real = pipeline.wall_gaps

    def spy(walls: np.ndarray, *args: object, **kwargs: object) -> np.ndarray:
        seen.append(walls.copy())
        return real(walls, *args, **kwargs)

    monkeypatch.setattr(pipeline, "wall_gaps", spy)
    segmenter = MapSegmenter()
    conditioned, _, _ = segmenter.places(segmenter.condition(grid))
    assert not conditioned.space[:, 137:].any()  # the fans were dropped
    assert seen[0][69:71, 140:195].all()  # between robot space at first: a wall
    assert len(seen) == 2 and not seen[-1][69:71, 140:195].any()


def _hall_beside_corridor(mouth_cells: int) -> np.ndarray:
    """0.05 m cells, walls as occupied cells: a 2 m wide, 21 m long corridor, and above it a
    10 m x 5 m hall opening onto it through a gap of ``mouth_cells`` in the wall between,
    whose two pieces slant 8 degrees up from the gap (off the building's main directions)."""
    cells = np.full((180, 440), 100, np.int8)
    cells[130:170, 10:430] = 0  # the corridor
    cells[30:130, 120:320] = 0  # the hall
    left = 220 - mouth_cells // 2
    right = left + mouth_cells
    slope = np.tan(np.radians(8))
    for x in [*range(120, left), *range(right, 320)]:
        off = left - 1 - x if x < left else x - right
        cells[127 - round(off * slope) : 130, x] = 100  # the wall, solid down to the corridor
    return cells


def test_a_hall_beside_a_corridor_is_a_place_of_its_own_and_the_corridor_stays_one():
    grid = OccupancyGrid(_hall_beside_corridor(60), 0.05)  # a 3 m mouth
    segmenter = MapSegmenter()
    _, space, places = segmenter.places(segmenter.condition(grid))
    hall, west, east = (
        places[space.world_to_cell(*grid.cell_to_world(row, column))]
        for row, column in ((60, 220), (150, 30), (150, 410))
    )
    assert hall > 0 and west > 0 and hall != west and west == east


def test_a_mouth_is_closed_only_between_a_hall_and_a_corridor():
    cells = _hall_beside_corridor(60)
    free = cells == 0
    closed, line = hall_mouths(cells == 100, free, 0.05)
    assert closed[120:135, 190:250].any() and line[120:135, 215:225].any()
    assert not closed[:115].any() and not closed[140:].any()
    # the same gap between two corridors of one width: a corridor going on, left open
    cells[30:125, 120:320] = 100
    cells[40:125, 190:250] = 0  # a 3 m wide corridor leaving the mouth
    assert not hall_mouths(cells == 100, cells == 0, 0.05)[0].any()
    # a gap of double doors or less in the corridor's straight wall: closed as a wall gap
    narrow = _hall_beside_corridor(36)
    gaps = wall_gaps(narrow == 100, narrow == 0, 0.05)
    assert gaps.any() and not hall_mouths(narrow == 100, (narrow == 0) & ~gaps, 0.05)[0].any()


@given(st.integers(0, 6), st.integers(1, 5))
def test_parting_along_a_line_cuts_only_the_places_it_crosses(column, width):
    places = np.zeros((12, 30), np.int32)
    places[1:11, 1:10], places[1:11, 12:29] = 1, 2  # two places apart
    whole = np.ones(places.shape, bool)
    whole[:, 14 + column : 14 + column + width] = False  # a mouth's line across place 2
    free = places > 0
    found = parted(places, whole, free)
    assert (found[places == 1] == 1).all()  # the place the line misses keeps its label
    left, right = found[5, 12], found[5, 28]
    assert {left, right} == {2, 3} and left < right  # pieces in reading order
    assert (found[free] > 0).all() and not found[~free].any()


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([walls.BLOCK, 7]))
def test_runs_are_each_rows_places_split_at_breaks(seed, block):
    rng = np.random.default_rng(seed)
    count = int(rng.integers(1, 80))
    ahead, own = rng.integers(0, 40, count) + rng.random(count), rng.integers(0, 6, count)
    across = own + 0.25  # rows from the points' first: own - own.min()
    with mock.patch.object(walls, "BLOCK", block):  # the rows a block of places at a time
        point, near, row, starts, stops, spread = _runs(ahead, across, 2, 3.0, 6.0)
    expected = []
    for at in range(own.min() - 2, own.max() + 3):  # each point in the rows within two
        places = np.flatnonzero(np.abs(own - at) <= 2)
        places = places[np.argsort(ahead[places])]
        for run in np.split(places, np.flatnonzero(np.diff(ahead[places]) > 3.0 + 1) + 1):
            cells = np.unique(np.floor(ahead[run[np.abs(own[run] - at) <= 1]]))
            if np.ptp(ahead[run]) >= 6.0 and len(cells) >= 3:
                expected.append((at - own.min(), run.tolist(), np.var(across[run])))
    found = []
    runs = zip(row.tolist(), starts.tolist(), stops.tolist(), spread.tolist(), strict=True)
    for at, first, stop, variance in runs:
        offset = own[point[first:stop]] - own.min() - at
        assert np.array_equal(near[first:stop], np.abs(offset) <= 1)
        found.append((at, point[first:stop].tolist(), pytest.approx(variance, abs=1e-9)))
    assert found == expected
