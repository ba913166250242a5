import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from maps.errors import InvalidMapError, MapFileNotFoundError, MapFormatError
from maps.grid import OccupancyGrid
from maps.map_server import cells_from_image, load_map

cells_strategy = arrays(
    np.int8, st.tuples(st.integers(1, 12), st.integers(1, 12)), elements=st.integers(-1, 100)
)


@given(
    cells=cells_strategy,
    resolution=st.floats(0.001, 2.0),
    origin=st.tuples(st.floats(-100, 100), st.floats(-100, 100), st.floats(-math.pi, math.pi)),
)
def test_save_load_round_trip(tmp_path_factory, cells, resolution, origin):
    grid = OccupancyGrid(cells, resolution, origin)
    path = tmp_path_factory.mktemp("map") / "m.yaml"
    grid.save(path)
    assert OccupancyGrid.load(path) == grid


@given(
    x=st.floats(-5, 5),
    y=st.floats(-5, 5),
    yaw=st.floats(-math.pi, math.pi),
    row=st.integers(0, 19),
    col=st.integers(0, 29),
)
def test_cell_centre_maps_back_to_its_cell(x, y, yaw, row, col):
    grid = OccupancyGrid(np.zeros((20, 30), np.int8), 0.1, (x, y, yaw))
    wx, wy = grid.cell_to_world(row, col)
    assert grid.world_to_cell(wx, wy) == (row, col)


def test_row_zero_is_the_top_of_the_map():
    grid = OccupancyGrid(np.zeros((10, 4), np.int8), 0.5, (1.0, 2.0, 0.0))
    assert grid.cell_to_world(9, 0) == (1.25, 2.25)  # bottom-left cell sits at the origin
    assert grid.cell_to_world(0, 3) == (2.75, 6.75)
    assert grid.bounds() == (1.0, 2.0, 3.0, 7.0)


def test_yaw_rotates_the_grid_about_its_origin():
    grid = OccupancyGrid(np.zeros((2, 2), np.int8), 1.0, (0.0, 0.0, math.pi / 2))
    x, y = grid.cell_to_world(1, 1)  # local (1.5, 0.5) turned a quarter
    assert (x, y) == pytest.approx((-0.5, 1.5))


@given(
    yaw=st.floats(-math.pi, math.pi),
    left=st.integers(0, 3),
    top=st.integers(0, 3),
    row=st.integers(0, 19),
    col=st.integers(0, 29),
)
def test_a_padded_grid_keeps_every_cell_in_place(yaw, left, top, row, col):
    cells = np.random.default_rng(0).choice(np.array([-1, 0, 100], np.int8), (20, 30))
    grid = OccupancyGrid(cells, 0.1, (1.0, -2.0, yaw))
    moved = grid.padded(left, top)
    assert moved.shape == (20 + top, 30 + left)
    wx, wy = grid.cell_to_world(row, col)
    assert moved.world_to_cell(wx, wy) == (row + top, col + left)
    assert moved.cells[row + top, col + left] == grid.cells[row, col]
    assert (moved.cells[:top] == -1).all() and (moved.cells[:, :left] == -1).all()


@pytest.mark.parametrize(
    "clearance",
    [np.zeros((2, 3)), [[np.nan, 0.0]], [[-0.1, 0.0]], [[0.1, 0.1]]],  # shape, NaN, < 0, on a wall
)
def test_a_given_clearance_is_checked(clearance):
    grid = OccupancyGrid(np.array([[0, 100]], np.int8), 0.1)
    with pytest.raises(InvalidMapError, match="clearance"):
        grid.with_free_clearance(clearance)


@pytest.mark.parametrize("left, top", [(-1, 0), (0, 1.5), (0, None)])
def test_padding_must_be_whole_cells(left, top):
    with pytest.raises(InvalidMapError, match="whole cells"):
        OccupancyGrid(np.zeros((2, 2), np.int8), 0.1).padded(left, top)


def test_every_ipa_map_loads_with_the_benchmark_free_rule(data_dir):
    import cv2

    maps = sorted((data_dir / "ipa").glob("*.yaml"))
    assert len(maps) == 28
    for path in maps:
        grid = load_map(path)
        pixels = cv2.imread(str(path.with_suffix(".png")), cv2.IMREAD_GRAYSCALE)
        assert grid.free.sum() == (pixels >= 250).sum(), path.name
    assert load_map(data_dir / "ipa" / "lab_ipa.yaml").free.sum() == 121_861


def test_map_server_modes_and_thresholds():
    grey = np.array([[0, 50, 200, 254, 255]], np.uint8)  # occ = (255 - grey) / 255
    assert cells_from_image(grey).tolist() == [[100, 100, -1, 0, 0]]
    assert cells_from_image(grey, negate=True).tolist() == [[0, -1, 100, 100, 100]]
    scaled = cells_from_image(grey, mode="scale")
    assert scaled[0, 0] == 100 and scaled[0, 4] == 0 and 1 <= scaled[0, 2] <= 99
    raw = np.array([[0, 37, 100, 101, 255]], np.uint8)
    assert cells_from_image(raw, mode="raw").tolist() == [[0, 37, 100, -1, -1]]
    rgba = np.zeros((1, 2, 4), np.uint8)
    rgba[0, :, :3] = 150
    rgba[0, 0, 3] = 0  # transparent: unknown in scale mode
    rgba[0, 1, 3] = 255
    assert cells_from_image(rgba, mode="scale")[0, 0] == -1
    assert cells_from_image(rgba, mode="scale")[0, 1] > 0


def test_inflation_keeps_a_robot_clear_of_walls():
    free = np.zeros((41, 41), bool)
    free[1:-1, 1:-1] = True
    grid = OccupancyGrid.from_masks(free, 0.05)
    inflated = grid.inflate(0.25)
    # a free cell's centre is more than 0.25 m + half a cell from every wall centre
    clear = grid.clearance()[inflated.free]
    assert clear.min() > 0.25 + 0.025
    assert inflated.free.sum() == (grid.clearance() > 0.275).sum() > 0


@given(
    height=st.integers(1, 30),
    width=st.integers(1, 30),
    resolution=st.sampled_from([0.02, 0.05, 0.1]),
)
def test_the_map_edge_is_an_obstacle(height, width, resolution):
    # an all-free map: each cell is as clear as the cell beyond the nearest edge is far,
    # counted here cell by cell (0.5 cells to the edge, 0.5 more to that cell's centre)
    grid = OccupancyGrid(np.zeros((height, width), np.int8), resolution)
    rows, cols = np.indices((height, width))
    cells_to_edge = np.minimum.reduce([rows + 1, cols + 1, height - rows, width - cols])
    np.testing.assert_allclose(grid.clearance(), cells_to_edge * resolution)


def test_a_robot_is_not_clear_next_to_the_map_edge():
    # 5 cm from the edge of an all-free 4 x 4 m map: no room for a 0.2 m robot
    grid = OccupancyGrid(np.zeros((80, 80), np.int8), 0.05)
    inflated = grid.inflate(0.2)
    assert not inflated.is_free(0.05, 2.0)
    assert not inflated.is_free(2.0, 3.95)
    assert inflated.is_free(2.0, 2.0)
    # a 0.2 m disc on the centre of column 3 (x = 0.175 m) crosses the edge, on column 4's
    # (x = 0.225 m) it stays 2.5 cm inside
    assert not inflated.is_free(0.175, 2.0)
    assert inflated.is_free(0.225, 2.0)


def _write(tmp_path, text, image=True):
    if image:
        OccupancyGrid(np.zeros((3, 3), np.int8), 0.1).save(tmp_path / "img.yaml", overwrite=True)
    path = tmp_path / "map.yaml"
    path.write_text(text)
    return path


GOOD = (
    "image: img.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\n"
    "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
)


@pytest.mark.parametrize(
    ("text", "field"),
    [
        (GOOD.replace("resolution: 0.1", "resolution: 0"), "resolution"),
        (GOOD.replace("resolution: 0.1", "resolution: abc"), "resolution"),
        (GOOD.replace("resolution: 0.1\n", ""), "resolution"),
        (GOOD.replace("origin: [0, 0, 0]", "origin: [0, 0]"), "origin"),
        (GOOD.replace("negate: 0", "negate: 2"), "negate"),
        (GOOD + "mode: fancy\n", "mode"),
        (GOOD.replace("free_thresh: 0.196", "free_thresh: 0.9"), "free_thresh"),
        (GOOD.replace("image: img.pgm", "image: 7"), "image"),
    ],
)
def test_bad_yaml_field_is_named(tmp_path, text, field):
    with pytest.raises(MapFormatError, match=field) as info:
        load_map(_write(tmp_path, text))
    assert info.value.field == field
    assert "map.yaml" in str(info.value)


def test_bad_files(tmp_path):
    with pytest.raises(MapFileNotFoundError):
        load_map(tmp_path / "nothing.yaml")
    with pytest.raises(MapFileNotFoundError, match=r"other\.pgm"):
        load_map(_write(tmp_path, GOOD.replace("img.pgm", "other.pgm")))
    (tmp_path / "img.pgm").write_text("not an image")
    with pytest.raises(MapFormatError, match="image"):
        load_map(_write(tmp_path, GOOD, image=False))
    with pytest.raises(MapFormatError, match="line 2"):
        load_map(_write(tmp_path, "image: a.pgm\nresolution: [0.1\n"))


def test_save_never_overwrites_without_asking(tmp_path):
    grid = OccupancyGrid(np.zeros((2, 2), np.int8), 0.1)
    path = grid.save(tmp_path / "m.yaml")
    before = path.read_text()
    with pytest.raises(FileExistsError):
        OccupancyGrid(np.full((2, 2), 100, np.int8), 0.1).save(path)
    assert path.read_text() == before and OccupancyGrid.load(path) == grid


@pytest.mark.parametrize(
    "kwargs",
    [
        {"cells": np.zeros((2, 2), np.int8), "resolution": 0.0},
        {"cells": np.zeros((2, 2), np.int8), "resolution": -1.0},
        {"cells": np.zeros((2, 2), np.int8), "resolution": float("nan")},
        {"cells": np.zeros(4, np.int8), "resolution": 0.1},
        {"cells": np.full((2, 2), 101), "resolution": 0.1},
        {"cells": np.zeros((2, 2), np.int8), "resolution": 0.1, "origin": (0, float("nan"), 0)},
    ],
)
def test_invalid_grids_are_rejected(kwargs):
    with pytest.raises(InvalidMapError):
        OccupancyGrid(**kwargs)


@given(st.integers(0, 2**32 - 1), st.integers(1, 40), st.integers(1, 40))
@settings(max_examples=50, deadline=None)
def test_clearance_is_scipys_exact_distance_transform(seed, rows, cols):
    from scipy import ndimage

    from maps.grid import clearance_of

    space = np.random.default_rng(seed).random((rows, cols)) < 0.8
    expected = ndimage.distance_transform_edt(np.pad(space, 1))[1:-1, 1:-1] * 0.05
    np.testing.assert_allclose(clearance_of(space, 0.05), expected, atol=1e-6)
    grid = OccupancyGrid(np.where(space, 0, 100).astype(np.int8), 0.05)
    np.testing.assert_allclose(grid.clearance(), expected, atol=1e-6)
