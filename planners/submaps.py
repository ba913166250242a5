"""Near-convex submaps for planning: regions cut until each part is about convex.

A corridor network is one place to a person but a poor submap: legs between its doors bend
around corners. Inside a near-convex part almost every leg between two of its doors is one
straight motion, so planning a leg is one exact line test. A region whose solidity (area over
the area of its convex hull) is below a threshold is cut in two by the line through its
centroid across its principal axis, and each connected piece is cut again until it is convex
enough or small.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage


def convex_parts(
    labels: NDArray[np.integer], *, min_solidity: float = 0.85, min_cells: int = 400
) -> tuple[NDArray[np.int32], dict[int, int]]:
    """Split the regions of ``labels`` into near-convex parts.

    Parameters
    ----------
    labels
        Region id per cell (0 = none).
    min_solidity
        Parts at or above this solidity are kept whole.
    min_cells
        Parts smaller than this are kept whole.

    Returns
    -------
    parts, region_of
        Part id per cell (0 = none) and the region each part belongs to.

    Examples
    --------
    >>> ell = np.zeros((40, 40), int)
    >>> ell[:, :10] = ell[30:, :] = 7
    >>> parts, region_of = convex_parts(ell, min_cells=50)
    >>> len(region_of) > 1, set(region_of.values())
    (True, {7})
    """
    parts = np.zeros(labels.shape, np.int32)
    region_of: dict[int, int] = {}
    for index, box in enumerate(ndimage.find_objects(np.asarray(labels, np.int32)), start=1):
        if box is None:
            continue
        stack = [(box, labels[box] == index)]
        while stack:
            where, mask = stack.pop()
            pieces = _cut(mask) if _needs_cut(mask, min_solidity, min_cells) else [mask]
            if len(pieces) == 1:
                part = len(region_of) + 1
                parts[where][pieces[0]] = part
                region_of[part] = index
                continue
            stack.extend(_cropped(where, piece) for piece in pieces)
    return parts, region_of


def _cropped(
    where: tuple[slice, slice], mask: NDArray[np.bool_]
) -> tuple[tuple[slice, slice], NDArray[np.bool_]]:
    """``mask`` cut to its bounding box, and that box in the coordinates of the map."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    box = (
        slice(where[0].start + r0, where[0].start + r1),
        slice(where[1].start + c0, where[1].start + c1),
    )
    return box, mask[r0:r1, c0:c1]


def _needs_cut(mask: NDArray[np.bool_], min_solidity: float, min_cells: int) -> bool:
    cells = int(mask.sum())
    return cells >= min_cells and cells < min_solidity * _hull_area(mask)


def _hull_area(mask: NDArray[np.bool_]) -> float:
    """Area (in cells) of the convex hull of the cells' corners: at least the number of cell
    centres in it, so a part kept whole has at least the solidity asked for."""
    contours, _ = cv2.findContours(
        mask.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE
    )
    centres = np.concatenate([c.reshape(-1, 2) for c in contours]).astype(np.float32)
    corners = centres[:, None, :] + np.array(
        [[-0.5, -0.5], [-0.5, 0.5], [0.5, -0.5], [0.5, 0.5]], np.float32
    )
    return float(cv2.contourArea(cv2.convexHull(corners.reshape(-1, 2))))


def _cut(mask: NDArray[np.bool_]) -> list[NDArray[np.bool_]]:
    """Connected pieces of ``mask`` on either side of the line through its centroid across
    its principal axis."""
    rows, cols = np.nonzero(mask)
    points = np.column_stack([rows, cols]).astype(float)
    centred = points - points.mean(axis=0)
    axis = np.linalg.eigh(centred.T @ centred)[1][:, -1]
    side = np.zeros(mask.shape, np.int8)
    side[rows, cols] = np.where(centred @ axis > 0, 1, 2)
    pieces: list[NDArray[np.bool_]] = []
    for value in (1, 2):
        found, count = ndimage.label(side == value)
        pieces.extend(found == k for k in range(1, count + 1))
    return pieces
