"""Faster implementations give exactly what the plain ones they replaced gave (random inputs)."""

import math

import cv2
import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import ndimage, sparse
from shapely import affinity

from maps.grid import OccupancyGrid, clearance_of
from maps.scan import Keyframe, LaserScan
from segmentation.conditioning import wall_share
from segmentation.distinct import distinct, label_counts, nonzero_cells
from segmentation.regions import Regions, boundary_pairs, consecutive, fill_enclosed
from segmentation.views import SharedView, view_cells, views_cells
from segmentation.virtual import most_open_cells

label_images = arrays(
    np.int32, st.tuples(st.integers(1, 20), st.integers(1, 20)), elements=st.integers(0, 6)
)


def most_open_cells_plain(clearance, labels, wanted):
    """Label by label: the first cell (row-major) of the label's largest clearance."""
    rows, cols = [], []
    for label in sorted(set(np.unique(labels)) & set(wanted.tolist()) - {0}):
        flat = int(np.argmax(np.where(labels == label, clearance, -np.inf)))
        rows.append(flat // labels.shape[1])
        cols.append(flat % labels.shape[1])
    return np.array(rows, np.intp), np.array(cols, np.intp)


@settings(max_examples=200, deadline=None)
@given(label_images, st.data())
def test_most_open_cells_equals_the_plain_one(labels, data):
    # few distinct clearances, so that ties (the first cell in row-major order wins) are common
    clearance = data.draw(
        arrays(np.float32, labels.shape, elements=st.sampled_from([0.0, 0.5, 1.0, 2.5]))
    )
    wanted = np.array(data.draw(st.lists(st.integers(1, 7), max_size=6, unique=True)), int)
    found = most_open_cells(clearance, labels, wanted)
    plain = most_open_cells_plain(clearance, labels, wanted)
    for got, expected in zip(found, plain, strict=True):
        assert got.tolist() == expected.tolist()


def polygons_plain(regions):
    """The union of one box per run of cells along a row, which
    :attr:`~segmentation.regions.Regions.polygons` replaced (by the coverage union of
    rectangles of runs cut at each other's corners), over the same cells: the regions with
    the furniture they enclose."""
    labels = regions.enclosing
    height = labels.shape[0]
    padded = np.pad(labels, ((0, 0), (1, 1)), constant_values=-1)
    change = padded[:, 1:] != padded[:, :-1]
    rows, cols = np.nonzero(change[:, :-1])
    ends = np.nonzero(change[:, 1:])[1] + 1
    values = labels[rows, cols]
    keep = values > 0
    rows, cols, ends, values = rows[keep], cols[keep], ends[keep], values[keep]
    res = regions.grid.resolution
    boxes = shapely.box(cols * res, (height - 1 - rows) * res, ends * res, (height - rows) * res)
    ox, oy, yaw = regions.grid.origin
    c, s = np.cos(yaw), np.sin(yaw)
    return {
        int(region): shapely.transform(
            affinity.affine_transform(
                shapely.union_all(boxes[values == region]), [c, -s, s, c, ox, oy]
            ),
            lambda xy: np.round(xy, 9),
        )
        for region in np.unique(values)
    }


@settings(max_examples=150, deadline=None)
@given(label_images, st.sampled_from([0.05, 0.1, 0.5]), st.sampled_from([0.0, 0.7, -2.0]))
def test_polygons_equal_the_union_of_row_runs(labels, resolution, yaw):
    grid = OccupancyGrid(np.zeros(labels.shape, np.int8), resolution, origin=(1.5, -3.0, yaw))
    regions = Regions(grid, labels)
    found, plain = regions.polygons, polygons_plain(regions)
    assert sorted(found) == sorted(plain)
    for region, shape in found.items():
        # the same region: the same geometry (the vertices along straight edges may differ,
        # and off the axes they are straight to the nanometre the coordinates are rounded to)
        assert shape.geom_type == plain[region].geom_type
        assert shapely.get_num_interior_rings(shape) == shapely.get_num_interior_rings(
            plain[region]
        )
        assert shapely.hausdorff_distance(shape, plain[region]) < 1e-8
        assert shapely.get_num_geometries(shape) == shapely.get_num_geometries(plain[region])
        if yaw == 0.0:  # unrotated, the corners are the same floating-point numbers
            assert shapely.equals(shape, plain[region])
        assert shape.area == pytest.approx(plain[region].area, rel=1e-6)


@given(label_images)
def test_ids_are_the_labels_present(labels):
    grid = OccupancyGrid(np.zeros(labels.shape, np.int8), 0.1)
    assert Regions(grid, labels).ids == [int(v) for v in np.unique(labels) if v > 0]


def shared_view_plain(view, keyframes):
    """The overlaps with the views' cells numbered by ``np.unique`` of all of them, which
    :meth:`~segmentation.views.SharedView.affinity` replaced (by their index on the views'
    bounding box)."""
    n = len(keyframes)
    views = [view_cells(k, view.resolution, view.reach) for k in keyframes]
    owner = np.repeat(np.arange(n), [len(v) for v in views])
    cells = np.concatenate(views) if n else np.zeros((0, 2), np.int64)
    key = (cells[:, 0] << 32) + (cells[:, 1] & 0xFFFFFFFF)
    _, column = np.unique(key, return_inverse=True)
    incidence = sparse.csr_matrix(
        (np.ones(len(owner)), (owner, column)), shape=(n, int(column.max(initial=-1)) + 1)
    )
    shared = (incidence @ incidence.T).tocoo()
    size = np.sqrt(np.maximum(np.bincount(owner, minlength=n), 1).astype(float))
    off = shared.row != shared.col
    values = shared.data[off] / (size[shared.row[off]] * size[shared.col[off]])
    return sparse.csr_matrix(
        (np.minimum(values, 1.0), (shared.row[off], shared.col[off])), shape=(n, n)
    )


poses = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-math.pi, math.pi))


@settings(max_examples=150, deadline=None)
@given(
    st.lists(
        st.tuples(poses, st.lists(st.floats(0.05, 12.0), min_size=3, max_size=40)), max_size=8
    ),
    st.sampled_from([1.0, 30.0]),  # views overlapping, or far apart (cells numbered by unique)
    st.sampled_from([0.1, 0.2, 0.5]),
    st.sampled_from([2.0, 10.0]),
)
def test_shared_view_equals_the_plain_one(frames, spread, resolution, reach):
    keyframes = [
        Keyframe(
            (x * spread, y * spread, yaw),
            LaserScan(np.array(ranges), -math.pi, 2 * math.pi / len(ranges), 0.0, 10.0),
        )
        for (x, y, yaw), ranges in frames
    ]
    view = SharedView(resolution, reach)
    found, plain = view.affinity(keyframes), shared_view_plain(view, keyframes)
    assert found.shape == plain.shape
    for name in ("indptr", "indices", "data"):
        assert np.array_equal(getattr(found, name), getattr(plain, name))


def test_the_free_cells_distance_transform_is_computed_once_per_grid(monkeypatch):
    # the graph, the openings, the passages and the basins share OccupancyGrid.free_clearance
    import cv2

    from maps.sim.floorplan import generate_floor_plan
    from topomap.topomap import TopoMap

    grid = generate_floor_plan("flat", random_state=0).grid
    seen = []
    transform = cv2.distanceTransform

    def counted(image, *args):
        seen.append(image.copy())
        return transform(image, *args)

    monkeypatch.setattr(cv2, "distanceTransform", counted)
    topo = TopoMap.from_grid(grid)
    for space in (grid.free, topo.regions.grid.free):
        # the transform is of the box round the space, an outside cell added round it
        rows, cols = np.flatnonzero(space.any(axis=1)), np.flatnonzero(space.any(axis=0))
        box = space[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
        padded = np.pad(box, 1).astype(np.uint8)
        assert sum(np.array_equal(image, padded) for image in seen) == 1


@given(
    arrays(
        st.sampled_from([np.int32, np.int64]),
        st.tuples(st.integers(0, 30), st.integers(1, 3)),
        elements=st.integers(-(2**31), 2**31 - 1),
    )
)
def test_distinct_is_numpys_unique(values):
    found = distinct(values)
    expected = np.unique(values)
    assert found.dtype == values.dtype and np.array_equal(found, expected)


def view_cells_plain(keyframe, resolution, reach):
    """The scan's polygon drawn on the whole square its reach spans, which
    :func:`~segmentation.views.view_cells` replaced (by the polygon's own box)."""
    scan = keyframe.scan
    length = np.where(
        scan.valid, np.minimum(scan.ranges, reach), np.where(scan.no_return, reach, 0.0)
    )
    x, y, yaw = keyframe.pose
    angles = scan.angles + yaw
    corner = np.floor((np.array([x, y]) - reach) / resolution).astype(np.int64) - 1
    size = int(math.ceil(2 * reach / resolution)) + 3
    ends = np.column_stack([x + length * np.cos(angles), y + length * np.sin(angles)])
    polygon = np.vstack([[x, y], ends]) / resolution - corner - 0.5
    seen = np.zeros((size, size), np.uint8)
    pixels = np.round(polygon * 16).astype(np.int32)
    cv2.fillPoly(seen, [pixels], 1, lineType=cv2.LINE_8, shift=4)
    j, i = np.nonzero(seen)
    return np.column_stack([i, j]).astype(np.int64) + corner


@settings(max_examples=200, deadline=None)
@given(
    x=st.floats(-50, 50),
    y=st.floats(-50, 50),
    yaw=st.floats(-4, 4),
    ranges=st.lists(
        st.one_of(st.floats(0.0, 20.0), st.just(math.inf), st.just(math.nan)),
        min_size=3,
        max_size=90,
    ),
    fov=st.floats(0.5, 2 * math.pi),
    resolution=st.sampled_from([0.05, 0.1, 0.2]),
    reach=st.floats(1.0, 12.0),
)
def test_view_cells_on_the_polygons_box_are_the_cells_on_the_whole_square(
    x, y, yaw, ranges, fov, resolution, reach
):
    scan = LaserScan(np.array(ranges), -fov / 2, fov / len(ranges), 0.0, 15.0)
    keyframe = Keyframe((x, y, yaw), scan)
    found = view_cells(keyframe, resolution, reach)
    assert np.array_equal(found, view_cells_plain(keyframe, resolution, reach))


@given(label_images)
def test_label_counts_are_numpys_bincount(labels):
    found = label_counts(labels, minlength=9)
    expected = np.bincount(labels.ravel(), minlength=9)
    assert found.dtype == np.int64 and np.array_equal(found, expected)


def consecutive_plain(labels):
    """Every value looked up in the table of ranks, which
    :func:`~segmentation.regions.consecutive` replaced (by the labels as they are, when they
    are already ``1..N``)."""
    labels = np.maximum(labels, 0)
    present = np.bincount(labels.ravel()) > 0
    present[0] = False
    rank = np.cumsum(present).astype(np.int32)
    rank[0] = 0
    return rank[labels]


@given(label_images.map(lambda labels: labels - 1))
def test_consecutive_equals_the_plain_one(labels):
    found = consecutive(labels)
    assert found.dtype == np.int32 and np.array_equal(found, consecutive_plain(labels))


def boundary_pairs_plain(labels):
    """Both neighbours of every cell compared on the whole image, which
    :func:`~segmentation.regions.boundary_pairs` replaced (by the cells whose neighbour
    differs, along the flattened image)."""
    found = []
    for axis in (0, 1):
        a = labels[:-1, :] if axis == 0 else labels[:, :-1]
        b = labels[1:, :] if axis == 0 else labels[:, 1:]
        rows, cols = np.nonzero((a != b) & (a > 0) & (b > 0))
        step = (1, 0) if axis == 0 else (0, 1)
        found.append(np.stack([rows, cols, rows + step[0], cols + step[1]]))
    pairs = np.concatenate(found, axis=1)
    swap = labels[pairs[0], pairs[1]] > labels[pairs[2], pairs[3]]
    pairs[:, swap] = pairs[[2, 3, 0, 1]][:, swap]
    return tuple(pairs.astype(np.int64))


@given(label_images, st.booleans())
def test_boundary_pairs_equal_the_plain_ones(labels, transposed):
    labels = labels.T if transposed else labels
    for found, expected in zip(boundary_pairs(labels), boundary_pairs_plain(labels), strict=True):
        assert found.dtype == np.int64 and np.array_equal(found, expected)


def fill_enclosed_plain(labels, most):
    """The largest and smallest region beside every cell of the whole map, reduced per piece,
    which :func:`~segmentation.regions.fill_enclosed` replaced (by each small piece off the
    map's edge looked at on its box)."""
    empty = labels == 0
    pieces, count = ndimage.label(empty, structure=np.ones((3, 3)))
    if count == 0:
        return labels
    sizes = np.bincount(pieces.ravel(), minlength=count + 1)
    big = float(2**24)
    ring = np.ones((3, 3), np.uint8)
    ids = labels.astype(np.float32)
    highest = cv2.dilate(ids, ring, borderType=cv2.BORDER_CONSTANT, borderValue=big)
    lowest = cv2.erode(
        np.where(empty, big, ids), ring, borderType=cv2.BORDER_CONSTANT, borderValue=big
    )
    small = sizes <= most
    small[0] = False
    at = small[pieces]
    high, low = np.full(count + 1, -1.0), np.full(count + 1, big)
    np.maximum.at(high, pieces[at], highest[at])
    np.minimum.at(low, pieces[at], lowest[at])
    enclosed = small & (high == low) & (high > 0) & (high < big)
    if not enclosed.any():
        return labels
    region = np.where(enclosed, high, 0).astype(np.int32)
    return np.where(empty & enclosed[pieces], region[pieces], labels).astype(np.int32)


@settings(max_examples=300, deadline=None)
@given(
    arrays(np.int32, st.tuples(st.integers(1, 20), st.integers(1, 20)), elements=st.integers(0, 3)),
    st.integers(0, 12),
)
def test_fill_enclosed_equals_the_plain_one(labels, most):
    found = fill_enclosed(labels, most)
    assert found.dtype == np.int32 and np.array_equal(found, fill_enclosed_plain(labels, most))


def clearance_plain(space, resolution):
    """The distance transform of the whole image, which :func:`~maps.grid.clearance_of`
    replaced (by that of the box round the space)."""
    padded = np.pad(space, 1).astype(np.uint8)
    distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    np.multiply(distance, distance, out=distance)
    np.sqrt(np.rint(distance, out=distance), out=distance)
    return distance[1:-1, 1:-1] * np.float32(resolution)


@given(arrays(bool, st.tuples(st.integers(1, 25), st.integers(1, 25))), st.sampled_from([0.05, 1]))
def test_clearance_of_the_box_is_that_of_the_whole_image(space, resolution):
    found = clearance_of(space, resolution)
    assert found.dtype == np.float32 and np.array_equal(found, clearance_plain(space, resolution))


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.tuples(poses, st.lists(st.floats(0.0, 14.0), min_size=1, max_size=30)),
        min_size=1,
        max_size=6,
    ),
    st.sampled_from([0.05, 0.2]),
    st.floats(1.0, 12.0),
)
def test_views_cells_are_each_scans_view_cells(frames, resolution, reach):
    keyframes = [
        Keyframe((x * 20, y * 20, yaw), LaserScan(np.array(ranges), yaw, 0.1, 0.1, 10.0))
        for (x, y, yaw), ranges in frames
    ]
    for found, keyframe in zip(views_cells(keyframes, resolution, reach), keyframes, strict=True):
        assert np.array_equal(found, view_cells_plain(keyframe, resolution, reach))


@given(arrays(bool, st.tuples(st.integers(1, 25), st.integers(1, 25))), st.booleans())
def test_nonzero_cells_are_numpys_nonzero(mask, transposed):
    mask = mask.T if transposed else mask
    for found, expected in zip(nonzero_cells(mask), np.nonzero(mask), strict=True):
        assert found.dtype == expected.dtype and np.array_equal(found, expected)


def wall_share_plain(grid, labels):
    """Every cell and its four neighbours compared on the whole image, which
    :func:`~segmentation.conditioning.wall_share` replaced (by the cells whose neighbour
    differs, along the flattened image)."""
    count = int(labels.max(initial=0)) + 1
    wall, unknown = np.zeros(count), np.zeros(count)
    for inner, outer in (
        (np.s_[1:, :], np.s_[:-1, :]),
        (np.s_[:-1, :], np.s_[1:, :]),
        (np.s_[:, 1:], np.s_[:, :-1]),
        (np.s_[:, :-1], np.s_[:, 1:]),
    ):
        own = labels[inner]
        edge = (own > 0) & (labels[outer] == 0)
        wall += np.bincount(own[edge & grid.occupied[outer]], minlength=count)
        unknown += np.bincount(own[edge & grid.unknown[outer]], minlength=count)
    wall[0], unknown[0] = wall.sum(), unknown.sum()
    return np.divide(wall, wall + unknown, out=np.ones(count), where=wall + unknown > 0)


@given(label_images, st.data())
def test_wall_share_equals_the_plain_one(labels, data):
    cells = data.draw(arrays(np.int8, labels.shape, elements=st.sampled_from([-1, 0, 100])))
    grid = OccupancyGrid(cells, 0.1)
    assert np.array_equal(wall_share(grid, labels), wall_share_plain(grid, labels))
