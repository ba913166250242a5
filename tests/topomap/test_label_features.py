"""Corridor features and default rules on hand-made buildings, against values worked out by
hand: a 20 x 2 m corridor with four rooms on its side, a hall, a ring, a hub and laser rays."""

import networkx as nx
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage

from maps.grid import OccupancyGrid
from segmentation.graph import region_graph
from segmentation.regions import Regions
from topomap.classifiers import rule_classifier
from topomap.features import (
    FEATURES,
    _fill_small_holes,
    _shape,
    region_features,
    skeleton_shape,
)

CELL = 0.05  # m


def _cells(metres: float) -> int:
    return round(metres / CELL)


def _building(labels: np.ndarray) -> tuple[Regions, nx.Graph]:
    grid = OccupancyGrid(np.where(labels > 0, 0, 100).astype(np.int8), CELL)
    regions = Regions(grid, labels)
    return regions, region_graph(regions)


def _corridor_with_rooms(doors_at: tuple[float, ...] = (2.5, 7.5, 12.5, 17.5)) -> np.ndarray:
    """A 20 x 2 m corridor (id 1) and, above it behind a 10 cm wall, 4 x 5 m rooms (ids 2...)
    each opening onto the corridor through a 1 m door centred at ``doors_at`` (m from the
    corridor's west end)."""
    top, wall = _cells(1), _cells(0.1)
    corridor_top = top + _cells(4) + wall
    labels = np.zeros((corridor_top + _cells(2) + top, _cells(22)), np.int32)
    west = _cells(1)
    labels[corridor_top : corridor_top + _cells(2), west : west + _cells(20)] = 1
    for k, x in enumerate(doors_at):
        left = west + _cells(x - 2.5)
        labels[top : top + _cells(4), left : left + _cells(5) - wall] = k + 2
        door = west + _cells(x - 0.5)
        labels[top + _cells(4) : corridor_top, door : door + _cells(1)] = k + 2
    return labels


@settings(max_examples=30, deadline=None)
@given(st.integers(10, 80), st.integers(0, 200), st.booleans())
def test_medial_axis_of_any_rectangle(short, extra, upright):
    # a w x l rectangle (w <= l): axis l - w long (within four cells), w wide, no branch point
    rows, cols = (short + extra, short) if upright else (short, short + extra)
    mask = np.zeros((rows + 4, cols + 4), bool)
    mask[2 : 2 + rows, 2 : 2 + cols] = True
    axis, width, branches = skeleton_shape(mask, ndimage.distance_transform_edt(mask), 0.1)
    assert axis == pytest.approx(0.1 * extra, abs=0.4)
    assert width == pytest.approx(0.1 * short, abs=0.1 + 0.05 * 0.1 * short)
    assert branches == 0


def test_medial_axis_of_a_tee():
    # a T of 2 m wide bars: 12 m across (y 1-3 m), a stem down to y = 9 m -> one branch
    # point; axis: the bar's 12 - 2 = 10 m, the stem's from the bar's axis (y 2) to 1 m short
    # of its end (y 8), 6 m: 16 m
    mask = np.zeros((_cells(10), _cells(14)), bool)
    mask[_cells(1) : _cells(3), _cells(1) : _cells(13)] = True
    mask[_cells(1) : _cells(9), _cells(6) : _cells(8)] = True
    axis, width, branches = skeleton_shape(mask, ndimage.distance_transform_edt(mask), CELL)
    assert branches == 1
    assert axis == pytest.approx(16.0, abs=0.6)
    assert width == pytest.approx(2.0, abs=0.3)


def test_corridor_with_four_side_doors():
    regions, graph = _building(_corridor_with_rooms())
    f = region_features(regions, graph)
    assert list(f["doors"]) == [4, 1, 1, 1, 1]
    # every path between two of the four rooms passes the corridor: C(4, 2) of C(4, 2) pairs
    assert list(f["betweenness"]) == pytest.approx([1.0, 0, 0, 0, 0])
    # outermost door centres 2.5 m and 17.5 m along: 15 m apart; a room's single door: 0
    assert f["door_span_m"][0] == pytest.approx(15.0, abs=0.1)
    assert f["door_span_m"][1] == 0.0
    assert f["skeleton_length_m"][0] == pytest.approx(18.0, abs=0.4)
    assert f["skeleton_width_m"][0] == pytest.approx(2.0, abs=0.15)
    assert rule_classifier(f) == ["corridor", "room", "room", "room", "room"]


def test_room_with_one_door_and_a_hall():
    labels = _corridor_with_rooms(doors_at=(2.5,))
    hall = np.zeros((_cells(17), _cells(22)), np.int32)
    hall[_cells(1) : _cells(16), _cells(1) : _cells(21)] = 3  # 20 x 15 m, alone
    regions, graph = _building(np.vstack([labels, hall]))
    f = region_features(regions, graph)
    assert f["area_m2"] == pytest.approx([40.0, 4 * 4.9 + 0.1, 300.0], rel=0.02)
    assert rule_classifier(f) == ["corridor", "room", "hall"]


def test_a_space_that_is_the_only_way_into_three_rooms_is_circulation():
    # a 5 x 5 m space that rooms open onto and nothing else: rooms are reached from
    # circulation space, so with three such rooms or more (corridor_served_rooms) it is a
    # corridor, whatever its length; with two (a room with a store room and an office off
    # it) a room
    size = _cells(5)

    def hub(rooms: int) -> tuple[float, str]:
        labels = np.zeros((_cells(11), _cells(11)), np.int32)
        inner = slice(_cells(3), _cells(3) + size)
        labels[inner, inner] = 1
        spots = [
            (slice(0, _cells(3)), slice(_cells(3), _cells(5.4))),
            (slice(0, _cells(3)), slice(_cells(5.6), _cells(8))),
            (slice(_cells(8), None), slice(_cells(3), _cells(5.4))),
            (slice(_cells(8), None), slice(_cells(5.6), _cells(8))),
            (inner, slice(0, _cells(3))),
            (inner, slice(_cells(8), None)),
        ]
        for k, (rows, cols) in enumerate(spots[:rooms]):
            labels[rows, cols] = k + 2
        f = region_features(*_building(labels))
        assert f["slenderness"][0] < 2  # not long for its width
        return f["doors"][0], rule_classifier(f)[0]

    assert hub(6) == (6, "corridor")
    assert hub(3) == (3, "corridor")
    assert hub(2) == (2, "room")


def test_a_fan_of_laser_rays_is_no_corridor():
    # a 0.5 m wide, 8 m long strip (rays through a door into a room nobody entered) beside a
    # 2 m wide corridor of the same length: too narrow to walk, so a room; the corridor stays
    labels = np.zeros((_cells(6), _cells(10)), np.int32)
    labels[_cells(1) : _cells(3), _cells(1) : _cells(9)] = 1
    labels[_cells(3) : _cells(3.5), _cells(1) : _cells(9)] = 2
    f = region_features(*_building(labels))
    assert f["width_m"][1] < 0.6 < 1.8 < f["width_m"][0]
    assert rule_classifier(f) == ["corridor", "room"]


def test_a_room_is_measured_by_its_floor_not_the_rays_out_of_it():
    # a 4 x 3 m room (id 2) off a 12 m corridor (id 1), a 1 m door between, and rays out of its
    # far wall's window: a dozen 0.1 m strips 8 m long into unknown space, which the cover
    # gives the room. Its shape is its floor's: a room, not a 12 m long corridor
    height, width = _cells(8), _cells(24)
    cells = np.full((height, width), 100, np.int8)
    labels = np.zeros((height, width), np.int32)
    corridor = (slice(_cells(1), _cells(3)), slice(_cells(1), _cells(13)))
    room = (slice(_cells(3.1), _cells(7.1)), slice(_cells(2), _cells(5)))
    labels[corridor], labels[room] = 1, 2
    labels[_cells(3) : _cells(3.1), _cells(3) : _cells(4)] = 2  # the door
    cells[labels > 0] = 0
    cells[_cells(3.1) : _cells(7.1), _cells(13.1) :] = -1  # unknown east of the room ...
    cells[_cells(3.1) : _cells(7.1), _cells(5) : _cells(13.1)] = -1
    for row in range(_cells(3.2), _cells(7), _cells(0.3)):  # ... its rays, through a window
        cells[row : row + _cells(0.1), _cells(5) : _cells(13)] = 0
        labels[row : row + _cells(0.1), _cells(5) : _cells(13)] = 2
    grid = OccupancyGrid(cells, CELL)
    regions = Regions(grid, labels)
    f = region_features(regions, region_graph(regions))
    assert 11 <= f["area_m2"][1] <= 12.5  # the 12 m^2 floor, not the 3.2 m^2 of rays beside
    assert f["slenderness"][1] < 2.5 and f["skeleton_length_m"][1] < 5
    assert rule_classifier(f) == ["corridor", "room"]
    cells[cells == -1] = 100  # the same strips between walls (shelves): floor, so measured
    walled = Regions(OccupancyGrid(cells, CELL), labels)
    assert region_features(walled, region_graph(walled))["area_m2"][1] > 14


def test_a_ring_of_corridors_is_no_hall_and_an_open_floor_with_shelves_is():
    # a 2 m corridor around a 16 x 16 m block: 144 m^2 of floor in a 400 m^2 hull
    ring = np.zeros((_cells(22), _cells(22)), np.int32)
    ring[_cells(1) : _cells(21), _cells(1) : _cells(21)] = 1
    ring[_cells(3) : _cells(19), _cells(3) : _cells(19)] = 0
    f = region_features(*_building(ring))
    assert f["solidity"][0] == pytest.approx(144 / 400, abs=0.03)
    assert rule_classifier(f) == ["corridor"]
    # a 30 x 20 m floor with three 1 x 12 m shelves (holes larger than furniture): a hall
    floor = np.zeros((_cells(22), _cells(32)), np.int32)
    floor[_cells(1) : _cells(21), _cells(1) : _cells(31)] = 1
    for x in (8, 15, 22):
        floor[_cells(5) : _cells(17), _cells(x) : _cells(x + 1)] = 0
    f = region_features(*_building(floor))
    assert f["extent_m"][0] == pytest.approx(20.0, abs=0.2)
    assert rule_classifier(f) == ["hall"]


@given(arrays(bool, st.tuples(st.integers(1, 40), st.integers(1, 40))), st.integers(0, 30))
def test_small_holes_are_filled_as_scipy_fills_them(mask, most):
    holes, _ = ndimage.label(ndimage.binary_fill_holes(mask) & ~mask)
    sizes = np.bincount(holes.ravel())
    small = (sizes <= most) & (np.arange(len(sizes)) > 0)
    assert np.array_equal(_fill_small_holes(mask, most), mask | small[holes])


@given(arrays(bool, st.tuples(st.integers(1, 30), st.integers(1, 30))))
def test_axis_neighbours_are_the_3x3_sums_scipy_gives(axis):
    from topomap.features import _axis_neighbours

    ones = np.ones((3, 3), np.int64)
    expected = ndimage.convolve(axis.astype(np.int64), ones, mode="constant") - 1
    assert np.array_equal(_axis_neighbours(axis), expected)


def _drawn(rectangles: list[tuple[int, float, float, float, float]], cell: float) -> np.ndarray:
    """A label image at ``cell`` metres of ``(id, x0, y0, x1, y1)`` rectangles in metres
    (x along columns, y along rows), later ones drawn over earlier ones."""
    width = max(r[3] for r in rectangles) + 1
    height = max(r[4] for r in rectangles) + 1
    labels = np.zeros((round(height / cell), round(width / cell)), np.int32)
    for region, x0, y0, x1, y1 in rectangles:
        labels[round(y0 / cell) : round(y1 / cell), round(x0 / cell) : round(x1 / cell)] = region
    return labels


def _table(rectangles: list[tuple[int, float, float, float, float]], cell: float = CELL) -> dict:
    labels = _drawn(rectangles, cell)
    grid = OccupancyGrid(np.where(labels > 0, 0, 100).astype(np.int8), cell)
    regions = Regions(grid, labels)
    return region_features(regions, region_graph(regions))


def test_a_rectangle_measures_its_analytic_values_in_metres():
    # a lone 10 x 2 m strip
    f = _table([(1, 1, 1, 11, 3)])
    # the medial axis: l - w = 8 m long, all of it 2 m wide (a corridor's width)
    assert f["area_m2"][0] == pytest.approx(20.0)
    assert f["perimeter_m"][0] == pytest.approx(24.0, rel=0.03)
    assert f["extent_m"][0] == pytest.approx(2.0, abs=0.06)
    assert f["elongation"][0] == pytest.approx(5.0, rel=0.03)
    assert f["solidity"][0] == pytest.approx(1.0, abs=0.01)
    assert f["skeleton_length_m"][0] == pytest.approx(8.0, abs=0.4)  # 4 axis cells
    assert f["axis_width_median_m"][0] == pytest.approx(2.0, abs=0.1)
    assert f["axis_width_cv"][0] == pytest.approx(0.0, abs=0.05)
    assert f["corridor_axis_m"][0] == pytest.approx(8.0, abs=0.4)
    # half the floor is farther than d from the edge when (2 - 2d)(10 - 2d) = 10: d = 0.4505
    assert f["width_median_m"][0] == pytest.approx(2 * 0.4505, abs=0.05)
    assert (f["doors"][0], f["dead_ends"][0], f["opening_share"][0]) == (0, 0, 0)
    assert f["links"].shape == (0, 3)


def test_doors_dead_ends_and_opening_share():
    # a 10 x 2 m corridor (1) and two 4 x 4 m rooms (2, 3) above it, each through a 1 m door
    f = _table(
        [
            (1, 1, 5.1, 11, 7.1),
            (2, 1, 1, 5, 5),
            (2, 2.5, 5, 3.5, 5.1),
            (3, 6, 1, 10, 5),
            (3, 7.5, 5, 8.5, 5.1),
        ]
    )
    assert f["doors"].tolist() == [2, 1, 1]
    assert f["dead_ends"].tolist() == [2, 0, 0]  # both rooms open onto the corridor only
    # two 1 m doors on the corridor's 24 m outline; one on a room's 4 x 4 m one (+ 0.2 m)
    assert f["opening_share"][0] == pytest.approx(2 / 24, rel=0.05)
    assert f["opening_share"][1] == pytest.approx(1 / 16.2, rel=0.05)
    assert sorted(f["links"][:, :2].astype(int).tolist()) == [[1, 2], [1, 3]]
    assert f["links"][:, 2] == pytest.approx([1.0, 1.0], abs=0.06)


_OFFICE_FLOOR = [
    (1, 1, 5.1, 31, 7.1),  # a 30 x 2 m corridor
    *[(k + 2, 1 + 5 * k, 1, 5 + 5 * k, 5) for k in range(6)],  # 4 x 4 m offices above it
    *[(k + 2, 2.5 + 5 * k, 5, 3.5 + 5 * k, 5.1) for k in range(6)],  # their 1 m doors
    (8, 1, 7.2, 31, 27.2),  # a 30 x 20 m open floor below it
    (8, 15, 7.1, 16.5, 7.2),  # through a 1.5 m door
]


def test_a_corridor_offices_and_an_open_floor():
    f = _table(_OFFICE_FLOOR)
    assert rule_classifier(f) == ["corridor", *["room"] * 6, "hall"]


@pytest.fixture(scope="module")
def office_at_two_cell_sizes():
    return _table(_OFFICE_FLOOR, 0.05), _table(_OFFICE_FLOOR, 0.1)


@pytest.mark.parametrize("name", FEATURES)
def test_features_do_not_depend_on_the_cell_size(name, office_at_two_cell_sizes):
    fine, coarse = office_at_two_cell_sizes
    # the same building at 5 and 10 cm: the same values, to a cell or two of the coarse map
    tolerance = {"branch_points": 0, "doors": 0, "dead_ends": 0, "betweenness": 0}
    assert fine[name] == pytest.approx(coarse[name], rel=0.06, abs=tolerance.get(name, 0.2))


def test_a_corridor_cut_into_pieces_is_one_corridor_system():
    # a 20 x 2 m corridor cut (by the segmentation) into a 14 m piece (1) and a 6 x 2.8 m
    # piece (2), squat for a corridor and wider than a passage, that leads on to a 4 x 4 m
    # room (3) and has a 4 x 4 m room (4) on its side, each through a 1 m door
    pieces = [
        (1, 1, 5.1, 15, 7.1),
        (2, 15, 5.1, 21, 7.9),
        (3, 21.1, 5.1, 25.1, 9.1),
        (3, 21, 6, 21.1, 7),
        (4, 16, 1, 20, 5),
        (4, 17.5, 5, 18.5, 5.1),
    ]
    f = _table(pieces)
    assert f["slenderness"][1] < rule_classifier.corridor_length
    # no door between the two pieces (the 2 m cut): the corridor system goes on
    assert rule_classifier(f) == ["corridor", "corridor", "room", "room"]
    # (with room 4 the piece is the only way into three regions, 1, 3 and 4: circulation
    # by the first pass already); without room 4 the first pass alone calls it a room
    f = _table(pieces[:4])
    assert rule_classifier(f) == ["corridor", "corridor", "room"]
    assert rule_classifier({k: v for k, v in f.items() if k != "links"})[1] == "room"
    # behind a wall (10 cm) with a 1 m door, the piece is a room (with two doors) of its own;
    # the 14 m piece, a 4 x 4 m room (5) off it, stays a corridor
    walled = [pieces[0], (2, 15.1, 5.1, 21, 7.9), (2, 15, 5.6, 15.1, 6.6), *pieces[2:]]
    f = _table([*walled, (5, 4, 1, 8, 5), (5, 5.5, 5, 6.5, 5.1)])
    assert f["links"][0].tolist() == pytest.approx([1, 2, 1.0], abs=0.06)
    assert rule_classifier(f) == ["corridor", "room", "room", "room", "room"]


def _passage(width: float, length: float) -> dict:
    """Two 4 x 4 m rooms (1, 3) joined by a ``width`` x ``length`` m space (2) through a 1 m
    door at each end."""
    top, bottom = 3 - width / 2, 3 + width / 2
    return _table(
        [
            (1, 1, 1, 5, 5),
            (1, 5, 2.5, 5.1, 3.5),
            (2, 5.1, top, 5.1 + length, bottom),
            (3, 5.2 + length, 1, 9.2 + length, 5),
            (3, 5.1 + length, 2.5, 5.2 + length, 3.5),
        ]
    )


@pytest.mark.parametrize(
    ("width", "length", "expected"),
    [
        (2.0, 6.0, "corridor"),  # narrower than a room, walked through: a passage
        (2.0, 3.0, "room"),  # as narrow but squat: a small room between two (an anteroom)
        (3.0, 9.0, "room"),  # wider than a room must be, not 4 times as long: a room
    ],
)
def test_a_passage_narrower_than_a_room(width, length, expected):
    f = _passage(width, length)
    assert f["doors"][1] == 2 and f["dead_ends"][1] < rule_classifier.corridor_served_rooms
    assert rule_classifier(f)[1] == expected
    assert rule_classifier(f)[::2] == ["room", "room"]


def test_a_long_open_space_is_a_wide_corridor_an_open_one_a_hall():
    # a 9 m wide, 45 m long space with six 4 x 4 m offices off it, each through a 1 m door:
    # hall-sized, but 5 times as long as wide, walked along (ipa's Fr101 corridor is 8-11 m
    # wide); the same offices off a 20 x 16 m floor: a hall
    def floor(width: float, length: float) -> str:
        offices = [(k + 2, 1 + 5 * k, 1, 5 + 5 * k, 5) for k in range(6)]
        doors = [(k + 2, 2.5 + 5 * k, 5, 3.5 + 5 * k, 5.1) for k in range(6)]
        f = _table([(1, 1, 5.1, 1 + length, 5.1 + width), *offices, *doors])
        assert f["area_m2"][0] >= rule_classifier.hall_area_m2
        return rule_classifier(f)[0]

    assert floor(9.0, 45.0) == "corridor"
    assert floor(16.0, 30.0) == "hall"


def test_a_room_between_two_corridors_with_no_door_is_the_corridor():
    # two 12 x 2 m corridor pieces (1, 3) and a 5 x 3.4 m piece (2) between them, open to
    # both across their whole width (no door): its axis is wider than a corridor's (3.4 m,
    # the rays into the rooms beside widen it on a SLAM map), yet the corridor goes on; a
    # 4 x 4 m room (4) off piece 1 stays a room
    pieces = [
        (1, 1, 6, 13, 8),
        (2, 13, 5.3, 18, 8.7),
        (3, 18, 6, 30, 8),
        (4, 5, 1, 9, 5),
        (4, 6.5, 5, 7.5, 6),
    ]
    f = _table(pieces)
    assert f["axis_width_median_m"][1] > rule_classifier.corridor_axis_width_m
    assert rule_classifier(f) == ["corridor", "corridor", "corridor", "room"]
    # open onto one corridor only (piece 3 behind a 1 m door): an office open to a corridor
    doored = [*pieces[:2], (3, 18.1, 6, 30, 8), (3, 18, 6.5, 18.1, 7.5), pieces[3], pieces[4]]
    assert rule_classifier(_table(doored))[1] == "room"


@given(arrays(bool, st.tuples(st.integers(1, 30), st.integers(1, 30))))
def test_perimeter_is_scikit_images(mask):
    from skimage.measure import perimeter as skimage_perimeter

    from topomap.features import perimeter

    assert perimeter(mask) == skimage_perimeter(mask)


def test_a_region_too_large_for_the_axis_cells_is_traced_on_coarser_cells(monkeypatch):
    # a 20 x 2 m corridor, its axis traced on cells 3 times as coarse (0.3 m): its length
    # and its widths along it (sampled a coarse cell from the centre line at worst) hold
    labels = np.zeros((_cells(4), _cells(22)), np.int32)
    labels[_cells(1) : _cells(3), _cells(1) : _cells(21)] = 1
    fine = region_features(*_building(labels))
    monkeypatch.setattr("topomap.features.MAX_AXIS_CELLS", labels.size // 36)
    coarse = region_features(*_building(labels))
    for name in ("skeleton_length_m", "corridor_axis_m"):
        assert coarse[name][0] == pytest.approx(fine[name][0], rel=0.1), name
    assert fine["axis_width_median_m"][0] == pytest.approx(2.0, abs=0.1)
    assert coarse["axis_width_median_m"][0] == pytest.approx(2.0, abs=2 * 0.3)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 50), st.integers(0, 50), st.integers(3, 40), st.integers(3, 40)),
        min_size=1,
        max_size=4,
    ),
    st.integers(0, 6),
)
def test_the_shape_is_that_of_the_mask_in_a_wider_margin(boxes, margin):
    # the shape is read on the mask cut to its box (the medial axis's cells kept in place):
    # more empty cells round it change nothing
    mask = np.zeros((90, 90), bool)
    for row, col, height, width in boxes:
        mask[row : row + height, col : col + width] = True
    found, wider = _shape(mask, 0.05), _shape(np.pad(mask, 2 * margin), 0.05)
    assert found == wider
