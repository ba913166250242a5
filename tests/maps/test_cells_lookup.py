"""``cells_from_image`` looks grey values up in a table: the same cells as the arithmetic on
every pixel that it replaced (random images, every mode)."""

import cv2
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from maps.errors import MapFormatError
from maps.map_server import FREE, OCCUPIED, UNKNOWN, cells_from_image, load_map, read_image


def cell_plain(grey, alpha, mode, negate, occupied_thresh, free_thresh):
    """map_server's rule for one pixel of mean grey value ``grey`` (the arithmetic that the
    table lookup replaced, written for one pixel as map_server's C++ loop does)."""
    if negate:
        grey = 255 - grey
    if mode == "raw":
        return grey if grey <= OCCUPIED else UNKNOWN
    occ = (255 - grey) / 255.0
    if occ > occupied_thresh:
        return OCCUPIED
    if occ < free_thresh:
        return FREE
    if mode == "scale" and alpha > 0:
        return int(1 + 98 * (occ - free_thresh) / (occupied_thresh - free_thresh))
    return UNKNOWN


def cells_plain(image, *, mode, negate, occupied_thresh, free_thresh):
    pixels = np.asarray(image, int)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    channels = pixels.shape[2]
    has_alpha = channels in (2, 4)
    averaged = channels - 1 if has_alpha else channels
    cells = np.zeros(pixels.shape[:2], np.int8)
    for row, col in np.ndindex(cells.shape):
        pixel = pixels[row, col]
        grey = sum(pixel[:averaged]) // averaged
        alpha = pixel[-1] if has_alpha else 255
        cells[row, col] = cell_plain(grey, alpha, mode, negate, occupied_thresh, free_thresh)
    return cells


shapes = st.tuples(st.integers(1, 8), st.integers(1, 8)).flatmap(
    lambda hw: st.sampled_from([hw, (*hw, 1), (*hw, 2), (*hw, 3), (*hw, 4)])
)


@settings(max_examples=300, deadline=None)
@given(
    arrays(np.uint8, shapes, elements=st.sampled_from([0, 1, 50, 100, 101, 127, 205, 254, 255])),
    st.sampled_from(["trinary", "scale", "raw"]),
    st.booleans(),
    st.sampled_from([(0.65, 0.196), (0.65, 0.05), (0.9, 0.1), (0.5, 0.5)]),
)
def test_cells_equal_the_arithmetic_on_every_pixel(image, mode, negate, thresholds):
    assume(mode != "scale" or thresholds[0] != thresholds[1])  # refused: no range to scale
    options = dict(
        mode=mode, negate=negate, occupied_thresh=thresholds[0], free_thresh=thresholds[1]
    )
    found = cells_from_image(image, **options)
    assert found.dtype == np.int8
    assert found.tolist() == cells_plain(image, **options).tolist()


@pytest.mark.parametrize("channels", [3, 4])
def test_colour_images_are_read_in_rgb_order(tmp_path, channels):
    bgr = np.random.default_rng(channels).integers(0, 256, (7, 9, channels), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "map.png"), bgr)
    order = [2, 1, 0, 3][:channels]
    assert read_image(tmp_path / "map.png").tolist() == bgr[:, :, order].tolist()


@pytest.mark.parametrize("threshold", [0.0, 0.2, 1.0])
def test_a_scale_map_with_equal_thresholds_is_refused(tmp_path, threshold):
    # a grey exactly on both (white, 204, black) would be scaled by 0 / 0: map_server's
    # undefined cast, NumPy's free cell with a warning
    options = dict(mode="scale", occupied_thresh=threshold, free_thresh=threshold)
    with pytest.raises(MapFormatError, match=r"free_thresh.*no range to scale"):
        cells_from_image(np.array([[0, 204, 255]], np.uint8), **options)
    cv2.imwrite(str(tmp_path / "map.pgm"), np.zeros((2, 2), np.uint8))
    (tmp_path / "map.yaml").write_text(
        f"image: map.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\nmode: scale\n"
        f"occupied_thresh: {threshold}\nfree_thresh: {threshold}\n"
    )
    with pytest.raises(MapFormatError, match=r"map\.yaml, field 'free_thresh'.*no range"):
        load_map(tmp_path / "map.yaml")
    options["mode"] = "trinary"  # the grey on them is unknown
    on_both = np.array([[round(255 * (1 - threshold))]], np.uint8)
    assert cells_from_image(on_both, **options).tolist() == [[UNKNOWN]]


@pytest.mark.parametrize(
    "image",
    [
        np.array([[0, 1000]]),  # a table index out of range, a 16-bit grey
        np.array([[65535]], np.uint16),
        np.array([[-5]], np.int16),
        np.array([[0.5, np.nan]]),  # read as black (occupied) with a warning
        np.array([[True, False]]),
        np.array([[None]], object),
    ],
)
def test_an_image_array_that_is_not_8_bit_is_refused(image):
    with pytest.raises(MapFormatError, match=f"image array must be uint8, got {image.dtype}"):
        cells_from_image(image)
