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
    scan = keyframe.scan
    valid, open_ = scan.valid, scan.no_return
    length = np.where(valid, np.minimum(scan.ranges, reach), np.where(open_, reach, 0.0))
    x, y, yaw = keyframe.pose
    angles = scan.angles + yaw
    corner = np.floor((np.array([x, y]) - reach) / resolution).astype(np.int64) - 1
    ends = np.column_stack([x + length * np.cos(angles), y + length * np.sin(angles)])
    polygon = np.vstack([[x, y], ends]) / resolution - corner - 0.5  # pixel centres at integers
    pixels = np.round(polygon * (1 << SHIFT)).astype(np.int32)
    # drawn on the polygon's own box, a whole number of cells in from the reach's square (a
    # scan in a room fills a fraction of it): the same cells, a tenth of the pixels to scan
    low = (pixels.min(axis=0) >> SHIFT) - 1
    width, height = (pixels.max(axis=0) >> SHIFT) - low + 2
    seen = np.zeros((height, width), np.uint8)
    cv2.fillPoly(seen, [pixels - (low << SHIFT).astype(np.int32)], 1, cv2.LINE_8, shift=SHIFT)
    j, i = np.nonzero(seen)
    return np.column_stack([i, j]).astype(np.int64) + corner + low


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
        views = [view_cells(k, self.resolution, self.reach) for k in keyframes]
        sizes = np.array([len(v) for v in views], np.int64)
        cells = np.concatenate(views) if n else np.zeros((0, 2), np.int64)
        low = cells.min(axis=0) if len(cells) else np.zeros(2, np.int64)
        span = cells.max(axis=0) - low + 1 if len(cells) else np.ones(2, np.int64)
        column = (cells[:, 1] - low[1]) * span[0] + (cells[:, 0] - low[0])
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
