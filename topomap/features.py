"""The feature table of regions: what a classifier (a function or an estimator) receives.

:func:`region_features` measures every region of a segmentation; the table is a dict of
columns, one value per region in ascending id order. ``"id"`` holds the region ids and is not a
feature; the features, in the column order an estimator's ``predict`` gets them
(:func:`feature_matrix`), are :data:`FEATURES`, with the units of :data:`FEATURE_UNITS`.
``"links"`` is not a feature either: one row ``(region a, region b, widest opening m)`` per
pair of touching regions, for classifiers that look at a region's neighbours.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import cv2
import networkx as nx
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.grid import OccupancyGrid, clearance_of
from segmentation.distinct import label_counts
from segmentation.regions import FURNITURE_M2, Regions

#: Region features, in the column order given to estimators, with their units and meaning.
FEATURE_UNITS = {
    "area_m2": "m^2, floor area (furniture holes filled, see below)",
    "width_m": "m, twice the 95th percentile of the distance to the region's edge",
    "slenderness": "1, area / width^2 (length over width for a strip)",
    "compactness": "1, 4 pi area / perimeter^2 (1 for a disc)",
    "elongation": "1, long / short side of the minimum-area rectangle",
    "doors": "count, neighbours in the region graph",
    "door_width_max_m": "m, widest opening to a neighbour",
    "door_width_mean_m": "m, mean opening to a neighbour",
    "perimeter_m": "m, length of the region's outline",
    "skeleton_length_m": "m, length of the medial axis, spurs cut",
    "skeleton_width_m": "m, mean width along the medial axis",
    "skeleton_slenderness": "1, skeleton length / skeleton width",
    "branch_points": "count, junctions of the medial axis",
    "betweenness": "1, betweenness centrality in the region graph",
    "door_span_m": "m, largest distance between two door centres",
    "solidity": "1, area / area of the convex hull",
    "extent_m": "m, short side of the minimum-area rectangle",
    "axis_width_median_m": "m, median width along the medial axis",
    "axis_width_cv": "1, spread of the width along the medial axis (std / mean; 0: constant)",
    "corridor_axis_m": "m, length of the medial axis where the space is 1.2-3 m wide",
    "width_median_m": "m, twice the median distance to the region's edge over its floor",
    "dead_ends": "count, neighbours that open onto this region only",
    "opening_share": "1, summed width of the openings / perimeter",
}
FEATURES = tuple(FEATURE_UNITS)
#: Half the width a robot (the library's default radius) or a person needs to stand, metres:
#: a region's strips narrower than twice this that run along unknown space (laser rays out
#: through its doors and windows) are no floor, and its shape is its floor's (:func:`floor_of`).
FLOOR_RADIUS_M = 0.2
#: The medial axis is traced on cells of about this size (m), coarser cells being given as is.
SKELETON_CELL_M = 0.1
#: At most this many cells of a region's box are given to the medial axis: a larger region
#: (a hall over 100 x 100 m) has its axis traced on cells coarser than :data:`SKELETON_CELL_M`
#: (its widths along the axis read up to two such cells narrow), in seconds, not minutes.
MAX_AXIS_CELLS = 1_000_000
#: Notches (furniture against a wall) narrower than twice this (m) are closed, too.
FURNITURE_GAP_M = 0.5
#: Widths (m) of a corridor by building practice: 1.2 m (codes' least) to 3 m (wide ones).
CORRIDOR_WIDTHS_M = (1.2, 3.0)


def region_features(regions: Regions, graph: nx.Graph) -> dict[str, NDArray[np.float64]]:
    """The feature table: :data:`FEATURES` and ``"id"`` as columns, one value per region of
    ``graph``, regions in ascending id order, and ``"links"`` (the graph's edges as rows
    ``(a, b, widest opening m)``).

    Shape is measured on the region's floor (:func:`floor_of`: the laser rays out through its
    doors and windows left out) after filling furniture holes up to
    :data:`~segmentation.regions.FURNITURE_M2` and closing notches narrower than twice
    :data:`FURNITURE_GAP_M` (furniture along walls); :data:`FEATURE_UNITS` says what each
    column is.

    Examples
    --------
    >>> from maps.grid import OccupancyGrid
    >>> from segmentation.graph import region_graph
    >>> labels = np.zeros((60, 220), np.int32)
    >>> labels[10:50, 10:210] = 1  # a 10 x 2 m strip at 5 cm
    >>> grid = OccupancyGrid(np.where(labels > 0, 0, 100).astype(np.int8), 0.05)
    >>> regions = Regions(grid, labels)
    >>> table = region_features(regions, region_graph(regions))
    >>> table["id"].tolist(), round(float(table["area_m2"][0])), round(float(table["extent_m"][0]))
    ([1.0], 20, 2)
    >>> round(float(table["axis_width_median_m"][0]), 1), round(float(table["corridor_axis_m"][0]))
    (2.0, 8)
    """
    ids = sorted(int(n) for n in graph.nodes)
    between = nx.betweenness_centrality(graph) if len(graph) > 2 else {}
    degree = dict(graph.degree())
    boxes = ndimage.find_objects(regions.labels)
    rays = ray_zone(regions.grid)
    columns: dict[str, list[float]] = {name: [] for name in ("id", *FEATURES)}
    for region in ids:
        box = boxes[region - 1]
        shape = _shape(
            floor_of(regions.labels[box] == region, rays[box], regions.grid.resolution),
            regions.grid.resolution,
        )
        values = {
            "id": float(region),
            **shape,
            **_connections(graph, region, degree, shape["perimeter_m"]),
            "betweenness": float(between.get(region, 0.0)),
        }
        for name, value in values.items():
            columns[name].append(value)
    table = {name: np.asarray(values, float) for name, values in columns.items()}
    links = [(a, b, w) for a, b, w in graph.edges(data="width")]
    table["links"] = np.asarray(links, float).reshape(-1, 3)
    return table


def floor_of(
    mask: NDArray[np.bool_], along_unknown: NDArray[np.bool_], res: float
) -> NDArray[np.bool_]:
    """The floor of a region's ``mask`` (cells of ``res`` metres): without its strips narrower
    than a disc of :data:`FLOOR_RADIUS_M` that lie ``along_unknown`` space (:func:`ray_zone`:
    laser rays out through its doors and windows), with those along walls and furniture (a
    chair's gap beside a desk); the whole mask when it is all rays.

    Examples
    --------
    >>> cells = np.full((40, 60), -1, np.int8)  # unknown around
    >>> cells[4:36, 4:36] = 100; cells[5:35, 5:35] = 0  # a 1.5 m room at 5 cm, walled ...
    >>> cells[18:21, 35:60] = 0  # ... a ray 0.15 m wide out through its wall
    >>> cells[5:35, 8] = 100  # a shelf 0.15 m off the west wall
    >>> grid = OccupancyGrid(cells, 0.05)
    >>> floor = floor_of(grid.free, ray_zone(grid), 0.05)
    >>> bool(floor[19, 50]), bool(floor[20, 6]), int(floor[:, :35].sum()) == 30 * 29
    (False, True, True)
    """
    from skimage.morphology import disk

    radius = max(1, round(FLOOR_RADIUS_M / res))
    body = (
        cv2.morphologyEx(
            np.pad(mask, radius).astype(np.uint8), cv2.MORPH_OPEN, disk(radius).astype(np.uint8)
        )[radius:-radius, radius:-radius]
        > 0
    )
    floor = body | (mask & ~along_unknown)
    return floor if floor.any() else mask


def ray_zone(grid: OccupancyGrid) -> NDArray[np.bool_]:
    """The cells of ``grid`` within :data:`FLOOR_RADIUS_M` of unknown space not across a wall
    (grown a cell at a time round occupied cells): where a thin strip of free cells is a laser
    ray, not floor (:func:`floor_of`). A strip between a wall and furniture is not."""
    zone = grid.unknown
    ring = np.ones((3, 3), np.uint8)
    for _ in range(max(1, round(FLOOR_RADIUS_M / grid.resolution))):
        zone = (cv2.dilate(zone.astype(np.uint8), ring) > 0) & ~grid.occupied
    return zone


def _shape(mask: NDArray[np.bool_], res: float) -> dict[str, float]:
    """The shape columns of one region's mask (cells of ``res`` metres)."""
    from skimage.morphology import disk  # imported here: planning on saved regions needs none

    gap = max(1, round(FURNITURE_GAP_M / res))
    # the holes off the box's edge are those off the padded mask's: filled before padding
    filled = np.pad(_fill_small_holes(mask, int(FURNITURE_M2 / res**2)), 2 * gap + 1)
    kernel = disk(gap).astype(np.uint8)
    filled = cv2.morphologyEx(filled.astype(np.uint8), cv2.MORPH_CLOSE, kernel).astype(bool)
    step = max(1, int(SKELETON_CELL_M / res), math.ceil(math.sqrt(filled.size / MAX_AXIS_CELLS)))
    filled, (top, left) = _trimmed(filled, step)
    area = float(filled.sum()) * res**2
    distance = clearance_of(filled, 1.0).astype(np.float64)  # cells; the mask is padded
    # to the edge: half a cell nearer than the nearest outside cell's centre
    floor = (distance[filled] - 0.5) * res
    width = 2 * float(np.percentile(floor, 95))
    coarse, cell = distance[::step, ::step] / step, res * step
    axis = medial_axis(filled[::step, ::step], coarse)
    length, mean_width, branches = skeleton_shape(filled[::step, ::step], coarse, cell, axis)
    widths = 2 * coarse[axis] * cell if axis.any() else np.array([mean_width])
    narrow, wide = CORRIDOR_WIDTHS_M
    edge = float(perimeter(filled)) * res
    outline, _ = cv2.findContours(
        filled.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE
    )
    points = np.vstack(outline) + np.array([left, top], np.int32)  # as on the padded mask
    (_, _), (w, h), _ = cv2.minAreaRect(points)
    hull = float(cv2.contourArea(cv2.convexHull(points))) * res**2
    return {
        "area_m2": area,
        "width_m": width,
        "slenderness": area / width**2 if width else 0.0,
        "compactness": 4 * math.pi * area / edge**2 if edge else 1.0,
        "elongation": max(w, h) / max(min(w, h), 1.0),
        "perimeter_m": edge,
        "skeleton_length_m": length,
        "skeleton_width_m": mean_width,
        "skeleton_slenderness": length / mean_width if mean_width else 0.0,
        "branch_points": float(branches),
        "solidity": min(1.0, area / hull) if hull else 1.0,
        "extent_m": (min(w, h) + 1) * res,
        "axis_width_median_m": float(np.median(widths)),
        "axis_width_cv": float(widths.std() / widths.mean()) if widths.mean() else 0.0,
        "corridor_axis_m": float(((widths >= narrow) & (widths <= wide)).sum()) * cell,
        "width_median_m": 2 * float(np.median(floor)),
    }


def _trimmed(mask: NDArray[np.bool_], step: int) -> tuple[NDArray[np.bool_], tuple[int, int]]:
    """``mask`` cut to its box and a margin of one cell or more, the cut starting on a
    multiple of ``step`` (the medial axis's cells keep their place), and where the cut
    starts ``(row, column)``: the shape read on it is the shape read on the whole mask,
    in less time (a region's mask is padded by twice the furniture gap for its closing)."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    top, left = (rows[0] - 1) // step * step, (cols[0] - 1) // step * step
    top, left = max(top, 0), max(left, 0)
    return mask[top : rows[-1] + 2, left : cols[-1] + 2], (int(top), int(left))


def _connections(
    graph: nx.Graph, region: int, degree: Mapping[int, int], perimeter_m: float
) -> dict[str, float]:
    """The door columns of one region of ``graph`` (``degree``: every region's number of
    neighbours; ``perimeter_m``: the region's outline)."""
    widths = [float(d) for _, _, d in graph.edges(region, data="width")]
    doors = [door for _, _, ds in graph.edges(region, data="doors") for door in ds]
    opening = sum(door.width for door in doors)
    return {
        "doors": float(degree[region]),
        "dead_ends": float(sum(degree[n] == 1 for n in graph[region])),
        "opening_share": opening / perimeter_m if perimeter_m else 0.0,
        "door_width_max_m": max(widths, default=0.0),
        "door_width_mean_m": float(np.mean(widths)) if widths else 0.0,
        "door_span_m": _span(np.asarray([d.centre for d in doors], float).reshape(-1, 2)),
    }


def skeleton_shape(
    mask: NDArray[np.bool_],
    distance: NDArray[np.float64],
    resolution: float,
    axis: NDArray[np.bool_] | None = None,
) -> tuple[float, float, int]:
    """``(length m, mean width m, branch points)`` of the medial axis of ``mask``
    (:func:`medial_axis`, or ``axis`` when given; ``distance`` is the distance to the edge in
    cells).

    The length counts axis cells (a straight axis of n cells is n cells long), the width is
    twice the mean ``distance`` along the axis, and branch points are the clusters of axis
    cells with three or more axis neighbours. A ``w`` x ``l`` rectangle (``w < l``) has an
    axis about ``l - w`` long and ``w`` wide, with no branch point.

    Examples
    --------
    >>> mask = np.zeros((60, 220), bool)
    >>> mask[10:50, 10:210] = True  # 10 x 2 m at 5 cm
    >>> length, width, branches = skeleton_shape(mask, ndimage.distance_transform_edt(mask), 0.05)
    >>> round(length), round(width), branches
    (8, 2, 0)
    """
    axis = medial_axis(mask, distance) if axis is None else axis
    if not axis.any():
        return 0.0, 2 * float(distance.max()) * resolution, 0
    _, branches = ndimage.label(axis & (_axis_neighbours(axis) >= 3), np.ones((3, 3), bool))
    length = float(axis.sum()) * resolution
    return length, 2 * float(distance[axis].mean()) * resolution, int(branches)


def medial_axis(mask: NDArray[np.bool_], distance: NDArray[np.float64]) -> NDArray[np.bool_]:
    """The medial axis of ``mask``: :func:`skimage.morphology.skeletonize` with its spurs cut.

    A piece between an end and a branch point shorter than the space is wide at that branch
    point (twice ``distance`` there, ``distance`` being the distance to the edge in cells) is
    a corner or a notch, not a way through.

    Examples
    --------
    >>> mask = np.zeros((7, 20), bool)
    >>> mask[1:6, 1:19] = True
    >>> medial_axis(mask, ndimage.distance_transform_edt(mask)).sum(axis=0).tolist()[5:15]
    [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]
    """
    from skimage.morphology import skeletonize  # as in _shape

    axis = skeletonize(mask)
    for _ in range(2):  # cutting spurs can leave a new, shorter one at a former branch point
        neighbours = _axis_neighbours(axis)
        junctions = axis & (neighbours >= 3)
        near = cv2.dilate(junctions.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        pieces, count = ndimage.label(axis & ~near, np.ones((3, 3), bool))
        if count == 0 or not junctions.any():
            break
        ends = axis & (neighbours == 1)
        sizes = label_counts(pieces, minlength=count + 1)
        has_end = np.bincount(pieces[ends], minlength=count + 1) > 0
        # the width where each piece meets the rest: the largest distance along the piece
        reach = np.zeros(count + 1)
        np.maximum.at(reach, pieces[axis], distance[axis])
        spur = has_end & (sizes < 2 * reach) & (np.arange(count + 1) > 0)
        if not spur.any():
            break
        axis = axis & ~spur[pieces]
    return axis


def _axis_neighbours(axis: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Axis neighbours of every cell (8-connected; the 3 x 3 sum by OpenCV, 0 off the map)."""
    ones = np.ones((3, 3), np.float32)
    found = cv2.filter2D(axis.astype(np.uint8), -1, ones, borderType=cv2.BORDER_CONSTANT)
    return found.astype(np.int64) - 1


#: :func:`perimeter`'s weights of the outline cells by the code of their neighbours.
_PERIMETER_WEIGHTS = np.zeros(50)
_PERIMETER_WEIGHTS[[5, 7, 15, 17, 25, 27]] = 1
_PERIMETER_WEIGHTS[[21, 33]] = math.sqrt(2)
_PERIMETER_WEIGHTS[[13, 23]] = (1 + math.sqrt(2)) / 2
_PERIMETER_CODES = np.array([[10, 2, 10], [2, 1, 2], [10, 2, 10]], np.float32)
_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))


def perimeter(mask: NDArray[np.bool_]) -> float:
    """Length of the outline of ``mask`` in cells: scikit-image's ``measure.perimeter``
    (4-neighbourhood, the map's edge outside), its erosion and 3 x 3 codes computed by OpenCV
    (three times faster on the region masks; the same number)."""
    image = mask.astype(np.uint8)
    inner = cv2.erode(image, _CROSS, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    codes = cv2.filter2D(image - inner, -1, _PERIMETER_CODES, borderType=cv2.BORDER_CONSTANT)
    # counted from the runs of codes (mostly 0, off the outline): 2x np.bincount
    return float(label_counts(np.asarray(codes, np.uint8), minlength=50) @ _PERIMETER_WEIGHTS)


def _span(points: NDArray[np.float64]) -> float:
    """The largest distance between two of ``points`` (0 for fewer than two)."""
    if len(points) < 2:
        return 0.0
    return float(np.max(np.linalg.norm(points[:, None] - points[None], axis=2)))


def _fill_small_holes(mask: NDArray[np.bool_], most: int) -> NDArray[np.bool_]:
    """``mask`` with its enclosed holes of at most ``most`` cells filled: the pieces of the
    rest (4-connected, as :func:`scipy.ndimage.binary_fill_holes` sees them) that do not
    touch the border (OpenCV's labelling: 10x faster than SciPy's fill on these masks)."""
    _, holes, stats, _ = cv2.connectedComponentsWithStats((~mask).astype(np.uint8), connectivity=4)
    border = np.unique(np.concatenate([holes[0], holes[-1], holes[:, 0], holes[:, -1]]))
    small = stats[:, cv2.CC_STAT_AREA] <= most
    small[border] = False
    small[0] = False  # the mask itself
    return mask | small[holes] if small.any() else mask


def feature_matrix(features: Mapping[str, NDArray[np.float64]]) -> NDArray[np.float64]:
    """The feature columns as an ``(n_regions, len(FEATURES))`` matrix, ``id`` and ``links``
    left out.

    Examples
    --------
    >>> table = {name: np.zeros(3) for name in ("id", *FEATURES)}
    >>> feature_matrix(table).shape == (3, len(FEATURES))
    True
    """
    return np.column_stack([features[name] for name in FEATURES])
