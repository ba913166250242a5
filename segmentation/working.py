"""A coarser working grid for the segmentation, and labels brought back to the map's cells.

Places and doors are metres wide; cells of a few centimetres only make the segmentation slower.
:func:`pool` merges ``factor x factor`` blocks of cells into one cell that is free only when
all of them are (walls stay closed, passages narrow by at most one coarse cell), and
:func:`unpool` brings labels back, every fine cell of the mask taking the label of its coarse
cell, or of a labelled cell nearby (through the kept cells) when its coarse cell has none.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import NDArray

from maps.grid import OccupancyGrid, clearance_of
from segmentation.distinct import distinct, nonzero_cells


def pool_factor(resolution: float, cell_size: float) -> int:
    """How many map cells per side make one working cell of about ``cell_size`` metres.

    Examples
    --------
    >>> pool_factor(0.05, 0.1), pool_factor(0.1, 0.1), pool_factor(0.02, 0.1)
    (2, 1, 5)
    """
    return max(1, math.floor(cell_size / resolution + 1e-9))


def block_phase(space: NDArray[np.bool_], factor: int) -> tuple[int, int]:
    """Where the working grid's ``factor x factor`` blocks fall on the map: the rows and
    columns of padding above and left of it (:func:`pool`'s ``phase``) that keep the most
    blocks whole in ``space``, the first of them on a tie. Chosen by what the map shows, the
    blocks fall alike on the building however its cells are laid: a map one cell over pools
    to the same working grid.

    Examples
    --------
    >>> space = np.zeros((8, 8), bool)
    >>> space[1:7, 1:5] = True  # 6 x 4 cells: three rows of two blocks, or fewer
    >>> block_phase(space, 2), block_phase(np.pad(space, ((0, 0), (1, 0))), 2)
    ((1, 1), (1, 0))
    """
    if factor == 1:
        return 0, 0
    whole = cv2.erode(
        space.astype(np.uint8),
        np.ones((factor, factor), np.uint8),
        anchor=(0, 0),
        borderType=cv2.BORDER_CONSTANT,
        borderValue=0,
    )  # 1 where the block from this cell down and right is all space
    counts = {
        (top, left): int(np.count_nonzero(whole[-top % factor :: factor, -left % factor :: factor]))
        for top in range(factor)
        for left in range(factor)
    }
    return max(counts, key=lambda phase: counts[phase])


def pool(
    space: NDArray[np.bool_],
    grid: OccupancyGrid,
    factor: int,
    *,
    fine_clearance: bool = False,
    phase: tuple[int, int] = (0, 0),
) -> OccupancyGrid:
    """The working grid: ``space`` pooled by ``factor`` (free where every cell is), with the
    map's frame; ``phase`` rows and columns of padding above and left of the map
    (:func:`block_phase`), the rest to whole blocks below and right of it.

    With ``fine_clearance``, the working grid's clearance
    (:meth:`~maps.grid.OccupancyGrid.free_clearance`) is measured on ``space`` itself, each
    working cell taking the least of its cells': to a map cell, not to a working cell, so
    the places and passages measured on it do not move with the way the blocks fall on the
    building (measured with ``topomap eval segment --shifts``: docs/segmentation.md).

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((3, 4), np.int8), 0.05, (1.0, 2.0, 0.0))
    >>> coarse = pool(grid.free, grid, 2)
    >>> coarse.shape, coarse.origin, coarse.free.tolist()
    ((2, 2), (1.0, 1.95, 0.0), [[True, True], [False, False]])
    >>> clearance = pool(grid.free, grid, 2, fine_clearance=True).free_clearance()
    >>> (clearance * 100).round().astype(int).tolist()  # centimetres: a map cell's, not 0.1 m
    [[5, 5], [0, 0]]
    """
    if factor == 1:
        return OccupancyGrid.from_masks(space, grid.resolution, grid.origin)
    height, width = space.shape
    top, left = phase
    rows, cols = math.ceil((top + height) / factor), math.ceil((left + width) / factor)
    padded = np.zeros((rows * factor, cols * factor), bool)
    padded[top : top + height, left : left + width] = space
    coarse = _block_min(padded.view(np.uint8), factor) > 0
    # the working grid's lower left corner: below the map and left of it
    drop, back = (rows * factor - height - top) * grid.resolution, left * grid.resolution
    ox, oy, yaw = grid.origin
    cos, sin = math.cos(yaw), math.sin(yaw)
    origin = (ox + sin * drop - cos * back, oy - cos * drop - sin * back, yaw)
    pooled = OccupancyGrid.from_masks(coarse, grid.resolution * factor, origin)
    if not fine_clearance:
        return pooled
    fine = _block_min(clearance_of(padded, grid.resolution), factor)
    return pooled.with_free_clearance(np.where(coarse, fine, 0.0))


def disc_cells(radius: float) -> NDArray[np.uint8]:
    """The cells at most ``radius`` cells from the middle one, as an OpenCV kernel, their
    distances measured as :func:`~maps.grid.clearance_of` measures them (the root of a whole
    number of cells squared, in single precision).

    Examples
    --------
    >>> disc_cells(1.5).tolist()
    [[1, 1, 1], [1, 1, 1], [1, 1, 1]]
    >>> disc_cells(1.0).tolist()
    [[0, 1, 0], [1, 1, 1], [0, 1, 0]]
    """
    reach = math.floor(radius)
    dy, dx = np.mgrid[-reach : reach + 1, -reach : reach + 1]
    return (np.sqrt((dx * dx + dy * dy).astype(np.float32)) <= radius).astype(np.uint8)


#: The finest cell, metres, on which a map's walls show as walls. A laser's rays 0.5-1 degree
#: apart end 3-9 cm apart on a wall 3-5 m away: on cells this size the cells they end in close
#: up along it; on finer cells a wall seen only where rays ended is a cell per ray with unknown
#: cells between, and a share of wall counted in cells falls short (ACES's log mapped on 0.025
#: m cells: its walls 40 % of its places' edges, against 65 % on 0.05 m cells).
RAY_CELL = 0.05


def block_max(values: NDArray, factor: int) -> NDArray:
    """The largest value of each ``factor x factor`` block of ``values`` (the last blocks
    padded with zeros): for a mask, whether any of the block's cells is set.

    Examples
    --------
    >>> block_max(np.eye(3, dtype=bool), 2).tolist()
    [[True, False], [False, True]]
    >>> block_max(np.arange(6).reshape(2, 3), 2).tolist()
    [[4, 5]]
    """
    if factor == 1:
        return values
    height, width = values.shape
    padded = np.pad(values, ((0, -height % factor), (0, -width % factor)))
    rows, cols = padded.shape[0] // factor, padded.shape[1] // factor
    return padded.reshape(rows, factor, cols, factor).max(axis=(1, 3))


def _block_min(values: NDArray, factor: int) -> NDArray:
    """The least value of each ``factor x factor`` block of ``values`` (whose sides are whole
    blocks): an erosion anchored at the block's corner, read every ``factor`` cells (OpenCV's,
    several times faster than numpy's reduction over a reshaped array)."""
    kernel = np.ones((factor, factor), np.uint8)
    return cv2.erode(values, kernel, anchor=(0, 0))[::factor, ::factor]


#: The cells beside a cell: labels grow through sides, never through a corner between walls.
AROUND = ((-1, 0), (1, 0), (0, -1), (0, 1))
#: The cells beside a cell and at its corners.
ALL_AROUND = (*AROUND, (-1, -1), (-1, 1), (1, -1), (1, 1))


def grow(
    labels: NDArray[np.int32],
    keep: NDArray[np.bool_],
    around: tuple[tuple[int, int], ...] = AROUND,
) -> NDArray[np.int32]:
    """``labels`` (changed in place and returned) grown over the unlabelled cells of ``keep``,
    a ring at a time: a cell next to labelled ones (through ``around``) takes the largest of
    their labels, so every kept cell takes a label that reaches it first through the kept
    cells; cells no label reaches stay 0. Each ring looks only at the cells beside the last
    one, so the cost follows the cells filled, not the map.

    Examples
    --------
    >>> keep = np.ones((3, 5), bool); keep[:2, 2] = False  # a wall with a gap at the bottom
    >>> labels = np.zeros((3, 5), np.int32); labels[0, 0] = 1; labels[0, 4] = 2
    >>> grow(labels, keep).tolist()
    [[1, 1, 0, 2, 2], [1, 1, 0, 2, 2], [1, 1, 2, 2, 2]]
    >>> labels = np.zeros((3, 3), np.int32); labels[0, 0] = 1
    >>> grow(labels, np.eye(3, dtype=bool), ALL_AROUND).tolist()  # through corners
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    """
    height, width = keep.shape
    missing = keep & (labels == 0)
    rows, cols = nonzero_cells(missing)
    while len(rows):
        grown = np.zeros(len(rows), np.int32)
        for dr, dc in around:
            r, c = np.clip(rows + dr, 0, height - 1), np.clip(cols + dc, 0, width - 1)
            grown = np.maximum(grown, labels[r, c])
        rows, cols, grown = rows[grown > 0], cols[grown > 0], grown[grown > 0]
        labels[rows, cols] = grown
        missing[rows, cols] = False
        beside = [
            (np.clip(rows + dr, 0, height - 1), np.clip(cols + dc, 0, width - 1))
            for dr, dc in around
        ]
        r, c = np.concatenate([b[0] for b in beside]), np.concatenate([b[1] for b in beside])
        ahead = missing[r, c]
        rows, cols = np.divmod(distinct(r[ahead].astype(np.int64) * width + c[ahead]), width)
    return labels


def unpool(
    labels: NDArray[np.integer],
    factor: int,
    keep: NDArray[np.bool_],
    phase: tuple[int, int] = (0, 0),
) -> NDArray[np.int32]:
    """Fine labels for the cells of ``keep`` from coarse ``labels`` (see the module docstring),
    pooled with ``phase`` (:func:`pool`).

    The kept cells whose coarse cell has no label take one from a labelled cell nearby through
    the kept cells (never across a wall, :func:`grow`); cells no label reaches stay 0.

    Examples
    --------
    >>> keep = np.ones((3, 4), bool)
    >>> unpool(np.array([[1, 2], [0, 0]]), 2, keep).tolist()
    [[1, 1, 2, 2], [1, 1, 2, 2], [1, 1, 2, 2]]
    >>> keep[:, 1] = False  # a wall: the cells behind it take the label from their side
    >>> unpool(np.array([[1, 0], [0, 0]]), 2, keep).tolist()
    [[1, 0, 0, 0], [1, 0, 0, 0], [1, 0, 0, 0]]
    """
    height, width = keep.shape
    coarse = np.ascontiguousarray(labels, np.int32)
    size = (coarse.shape[1] * factor, coarse.shape[0] * factor)
    fine = np.asarray(cv2.resize(coarse, size, interpolation=cv2.INTER_NEAREST), np.int32)
    top, left = phase
    fine = fine[top : top + height, left : left + width]
    fine[~keep] = 0
    return grow(fine, keep)
