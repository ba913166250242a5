"""What a scan saw: the cells of the area its beams swept, and the overlap of two such areas.

A scan's *view* is the polygon of the sensor and its beams' end points (no-return beams
reaching ``reach``), rasterised on cells of ``resolution`` metres. Two keyframes in one room
see most of the same room, wherever they stand in it; through a door a keyframe sees a wedge of
the room beyond. :class:`SharedView` turns this into a similarity: the overlap of the views,
``|V_i & V_j| / sqrt(|V_i| |V_j|)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from maps.scan import Keyframe
from segmentation.errors import ParameterError

#: Sub-pixel bits of the scan polygons given to OpenCV.
SHIFT = 4


def view_cells(keyframe: Keyframe, resolution: float, reach: float) -> NDArray[np.int64]:
    """``(m, 2)`` cells ``(i, j)`` (x and y over ``resolution``, floored) inside the scan's
    polygon: the sensor and every beam's end, cut at ``reach`` metres; in row order, by ``j``
    and then ``i``.

    Examples
    --------
    >>> from maps.scan import LaserScan
    >>> scan = LaserScan(np.full(360, 1.0), -math.pi, 2 * math.pi / 360, 0.0, 10.0)
    >>> cells = view_cells(Keyframe((0.0, 0.0, 0.0), scan), 0.1, 5.0)
    >>> 314 < len(cells) < 400  # a disc of radius 1 m: 314 cells of 0.01 m^2 and its rim
    True
    """
    return views_cells([keyframe], resolution, reach)[0]


def views_cells(
    keyframes: Sequence[Keyframe], resolution: float, reach: float
) -> list[NDArray[np.int64]]:
    """:func:`view_cells` of every keyframe (see :func:`_stacked_views`)."""
    i, j, sizes = _stacked_views(keyframes, resolution, reach)
    return np.split(np.column_stack([i, j]), np.cumsum(sizes)[:-1]) if len(sizes) else []


def _stacked_views(
    keyframes: Sequence[Keyframe], resolution: float, reach: float
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """``(i, j, sizes)``: the cells of every keyframe's view (:func:`view_cells`) one view
    after the other, and how many each view has. The polygons of all the scans are computed
    in one pass over all their beams (the same numbers, beam by beam), each then drawn alone."""
    if len(keyframes) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    stacked, starts, corners = _view_polygons(keyframes, resolution, reach)
    # drawn on the polygon's own box, a whole number of cells in from the reach's square (a
    # scan in a room fills a fraction of it): the same cells, a tenth of the pixels to scan
    lows = (np.minimum.reduceat(stacked, starts) >> SHIFT) - 1
    boxes = (np.maximum.reduceat(stacked, starts) >> SHIFT) - lows + 2
    views = []
    for pixels, low, (width, height) in zip(
        np.split(stacked, starts[1:]), lows, boxes, strict=True
    ):
        seen = np.zeros((height, width), np.uint8)
        cv2.fillPoly(seen, [pixels - (low << SHIFT).astype(np.int32)], 1, cv2.LINE_8, shift=SHIFT)
        found = cv2.findNonZero(seen)  # (i, j) row by row, as np.nonzero: five times faster
        views.append(np.zeros((0, 2), np.int32) if found is None else found.reshape(-1, 2))
    sizes = np.array([len(view) for view in views], np.int64)
    cells = np.concatenate(views) + np.repeat(corners + lows, sizes, axis=0)  # on the map
    return cells[:, 0], cells[:, 1], sizes


def _view_polygons(
    keyframes: Sequence[Keyframe], resolution: float, reach: float
) -> tuple[NDArray[np.int32], NDArray[np.intp], NDArray[np.int64]]:
    """``(points, starts, corners)``: the polygons of the scans one after the other (the
    sensor, then every beam's end cut at ``reach``) in OpenCV's fixed-point pixels
    (:data:`SHIFT` bits) on the cells of ``resolution`` metres from the scan's corner, where
    each polygon starts, and the corners ``(n, 2)``: a cell off the low corner of the square
    the reach spans round the sensor."""
    scans = [k.scan for k in keyframes]
    beams = np.array([len(scan) for scan in scans])
    per_beam = [  # each scan's fields and pose, one value per beam
        np.repeat([getattr(scan, name) for scan in scans], beams)
        for name in ("angle_min", "angle_increment", "range_min", "range_max")
    ]
    angle_min, increment, range_min, range_max = per_beam
    poses = np.array([k.pose for k in keyframes], np.float64)
    x, y, yaw = (np.repeat(poses[:, i], beams) for i in range(3))
    ranges = np.concatenate([scan.ranges for scan in scans])
    with np.errstate(invalid="ignore"):  # as LaserScan.valid and .no_return
        valid = np.isfinite(ranges) & (ranges >= range_min) & (ranges <= range_max)
        open_ = np.isposinf(ranges) | (np.isfinite(ranges) & (ranges > range_max))
    length = np.where(valid, np.minimum(ranges, reach), np.where(open_, reach, 0.0))
    index = (np.arange(len(ranges)) - np.repeat(np.cumsum(beams) - beams, beams)).astype(float)
    angles = (angle_min + increment * index) + yaw  # LaserScan.angles, turned by the pose
    corners = np.floor((poses[:, :2] - reach) / resolution).astype(np.int64) - 1
    # the sensor, then its beams' ends; pixel centres at integers
    rows = np.empty((len(ranges) + len(scans), 2))
    first = np.cumsum(beams + 1) - beams - 1
    at_end = np.ones(len(rows), bool)
    at_end[first] = False
    rows[first] = poses[:, :2] / resolution - corners - 0.5
    ends = np.column_stack([x + length * np.cos(angles), y + length * np.sin(angles)])
    rows[at_end] = ends / resolution - np.repeat(corners, beams, axis=0) - 0.5
    return np.round(rows * (1 << SHIFT)).astype(np.int32), first, corners


@dataclass(frozen=True)
class SharedView:
    """The overlap of the areas two scans saw (see the module docstring).

    Parameters
    ----------
    resolution
        Cell size of the views, metres.
    reach
        Beams are cut at this range, metres (no-return beams reach it).

    Examples
    --------
    >>> from maps.scan import LaserScan
    >>> ring = LaserScan(np.full(360, 3.0), -math.pi, 2 * math.pi / 360, 0.0, 10.0)
    >>> frames = [Keyframe((x, 0.0, 0.0), ring) for x in (0.0, 1.0, 10.0)]
    >>> S = SharedView().affinity(frames).toarray()
    >>> bool(S[0, 1] > 0.5), S[0, 2]
    (True, np.float64(0.0))
    """

    resolution: float = 0.2
    reach: float = 10.0

    def __post_init__(self) -> None:
        for name in ("resolution", "reach"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise ParameterError(f"{name} must be a finite number > 0, got {value!r}")

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """Overlaps of all pairs, from one sparse product of the views' cell incidences.

        A view's cells come from :func:`view_cells` in row order (by ``j``, then ``i``), so
        their index on the grid of all views' bounding box is ascending and unique in each
        view: the incidence matrix is built as CSR directly, with no sort of all cells (unless
        the box is mostly cells no view saw).
        """
        n = len(keyframes)
        i, j, sizes = _stacked_views(keyframes, self.resolution, self.reach)
        low, span = np.zeros(2, np.int64), np.ones(2, np.int64)
        if len(i):
            low = np.array([i.min(), j.min()])
            span = np.array([i.max(), j.max()]) - low + 1
        column = (j - low[1]) * span[0] + (i - low[0])
        width = int(span[0] * span[1])
        if width > 4 * len(column):  # views far apart: number only the cells seen, in order
            _, column = np.unique(column, return_inverse=True)
            width = int(column.max(initial=-1)) + 1
        indptr = np.concatenate([[0], np.cumsum(sizes)])
        incidence = sparse.csr_matrix((np.ones(len(column)), column, indptr), shape=(n, width))
        shared = (incidence @ incidence.T).tocoo()
        size = np.sqrt(np.maximum(sizes, 1).astype(float))
        off = shared.row != shared.col
        values = shared.data[off] / (size[shared.row[off]] * size[shared.col[off]])
        return sparse.csr_matrix(
            (np.minimum(values, 1.0), (shared.row[off], shared.col[off])), shape=(n, n)
        )
