"""From clustered keyframes to a dense segmentation of the free space into regions."""

from __future__ import annotations

import heapq
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage
from shapely import affinity
from shapely.geometry.base import BaseGeometry
from skimage.measure import label as connected_pieces
from skimage.segmentation import watershed

from maps.grid import OccupancyGrid
from segmentation.errors import SegmentationError


def boundary_pairs(labels: NDArray[np.integer]) -> tuple[NDArray[np.int64], ...]:
    """Cells on both sides of every 4-neighbour boundary between two different labels > 0.

    Returns
    -------
    tuple of ndarray
        ``(row_a, col_a, row_b, col_b)`` with ``labels[a] < labels[b]``.
    """
    found: list[NDArray[np.int64]] = []
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


def merge_small(labels: NDArray[np.int32], min_cells: int) -> NDArray[np.int32]:
    """Merge regions under ``min_cells`` cells into the neighbour they share most boundary with.

    Smallest first, one at a time, on the region adjacency (boundary lengths updated as regions
    merge); a small region with no neighbour is dropped (set to 0).

    Examples
    --------
    >>> labels = np.array([[1, 1, 1, 2], [1, 1, 1, 3], [4, 0, 0, 0]])
    >>> merge_small(labels, 2).tolist()
    [[1, 1, 1, 1], [1, 1, 1, 1], [1, 0, 0, 0]]
    """
    sizes = np.bincount(labels.ravel()).astype(np.int64)
    small = [int(r) for r in np.flatnonzero((sizes > 0) & (sizes < min_cells)) if r > 0]
    if not small:
        return labels
    ra, ca, rb, cb = boundary_pairs(labels)
    pairs, shared = np.unique(
        np.stack([labels[ra, ca], labels[rb, cb]]), axis=1, return_counts=True
    )
    around: dict[int, dict[int, int]] = {}
    for a, b, n in zip(pairs[0].tolist(), pairs[1].tolist(), shared.tolist(), strict=True):
        around.setdefault(a, {})[b] = n
        around.setdefault(b, {})[a] = n
    target = np.arange(len(sizes))
    queue = [(int(sizes[r]), r) for r in small]
    heapq.heapify(queue)
    while queue:
        size, region = heapq.heappop(queue)
        if target[region] != region or size != sizes[region] or size >= min_cells:
            continue  # merged away, or grown since it was queued
        neighbours = around.pop(region, {})
        if not neighbours:
            target[region] = 0
            continue
        into = max(neighbours, key=lambda r: (neighbours[r], -r))
        target[region] = into
        sizes[into] += size
        for other, n in neighbours.items():
            links = around[other]
            del links[region]
            if other != into:
                links[into] = links.get(into, 0) + n
                around[into][other] = around[into].get(other, 0) + n
        if sizes[into] < min_cells:
            heapq.heappush(queue, (int(sizes[into]), into))
    for region in range(len(target)):  # follow chains of merges to their end
        while target[target[region]] != target[region]:
            target[region] = target[target[region]]
    return target[labels].astype(np.int32)


def consecutive(labels: NDArray[np.integer]) -> NDArray[np.int32]:
    """Relabel to ``1..N`` keeping the order of the values, and 0 (negative values become 0).

    scikit-image's ``relabel_sequential`` gives the same labels at twice the time (12 ms
    against 5.7 on the 88 places of a 768 x 864 map).

    Examples
    --------
    >>> consecutive(np.array([[0, 7, 7], [3, 0, 9]])).tolist()
    [[0, 2, 2], [1, 0, 3]]
    """
    labels = np.maximum(labels, 0)
    present = np.bincount(labels.ravel()) > 0
    present[0] = False
    rank = np.cumsum(present).astype(np.int32)
    rank[0] = 0
    return rank[labels]


def dense_labels(
    grid: OccupancyGrid,
    rows: NDArray[np.int64],
    cols: NDArray[np.int64],
    keyframe_labels: NDArray[np.int64],
    *,
    min_area: float = 1.0,
) -> NDArray[np.int32]:
    """Give every free cell the cluster of the geodesically nearest keyframe.

    Parameters
    ----------
    grid
        The map.
    rows, cols
        Cells of the keyframes; those outside the grid or not free are ignored.
    keyframe_labels
        Cluster of each keyframe, ``>= 0``.
    min_area
        Connected pieces under this many square metres merge into a neighbour.

    Returns
    -------
    ndarray of int32
        ``labels`` of the grid's shape: 0 for non-free cells, ``1..N`` for the regions, each one
        connected (4-neighbour) piece of free space.
    """
    free = grid.free
    if not free.any():
        raise SegmentationError("the map has no free cell to segment")
    inside = grid.contains(rows, cols)
    rows, cols, keyframe_labels = rows[inside], cols[inside], keyframe_labels[inside]
    on_free = free[rows, cols]
    markers = np.zeros(grid.shape, np.int32)
    markers[rows[on_free], cols[on_free]] = keyframe_labels[on_free] + 1
    labels = watershed(np.zeros(grid.shape), markers, mask=free, connectivity=1)
    return pieces(grid, labels, min_area)


def pieces(grid: OccupancyGrid, labels: NDArray[np.integer], min_area: float) -> NDArray[np.int32]:
    """Regions made connected: free cells without a label get one per connected piece, each
    label is split into its 4-connected pieces, and pieces under ``min_area`` square metres
    merge into a neighbour."""
    free = grid.free
    unreached, _ = ndimage.label(free & (labels == 0))
    labels = np.where(unreached > 0, unreached + labels.max(), np.where(free, labels, 0))
    labels = connected_pieces(labels, background=0, connectivity=1)
    min_cells = max(1, round(min_area / grid.resolution**2))
    return consecutive(merge_small(labels.astype(np.int32), min_cells))


@dataclass(frozen=True, eq=False)
class Regions:
    """A segmentation of a grid's free space: ``labels[r, c]`` is the region of a cell.

    Parameters
    ----------
    grid
        The map.
    labels
        int32 array of the grid's shape, 0 = no region, ``1..N`` = regions.
    """

    grid: OccupancyGrid
    labels: NDArray[np.int32]

    def __repr__(self) -> str:
        return f"Regions({len(self.ids)} regions on {self.grid!r})"

    def __post_init__(self) -> None:
        if self.labels.shape != self.grid.shape:
            raise SegmentationError(
                f"labels shape {self.labels.shape} differs from the grid's {self.grid.shape}"
            )

    @property
    def ids(self) -> list[int]:
        """Region ids present, ascending."""
        return (np.flatnonzero(self.cell_counts[1:]) + 1).tolist()

    @cached_property
    def cell_counts(self) -> NDArray[np.int64]:
        """Cells per region id (index 0 = unlabelled cells)."""
        return np.bincount(self.labels.ravel())

    def area(self, region: int) -> float:
        """Area of ``region`` in square metres (cells times cell area)."""
        return float(self.cell_counts[region]) * self.grid.resolution**2

    def at(self, x: float, y: float) -> int:
        """The region at map point ``(x, y)``, 0 if none."""
        row, col = self.grid.world_to_cell(x, y)
        if not self.grid.contains(row, col):
            return 0
        return int(self.labels[row, col])

    def at_points(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.int64]:
        """The region at each map point, 0 where there is none."""
        rows, cols = self.grid.world_to_cell(x, y)
        inside = self.grid.contains(rows, cols)
        found = np.zeros(np.shape(rows), np.int64)
        found[inside] = self.labels[rows[inside], cols[inside]]
        return found

    @cached_property
    def polygons(self) -> dict[int, BaseGeometry]:
        """Outline of each region in map-frame metres, along cell edges, holes kept.

        Built as the union of the region's rectangles of cells: its runs of cells along each
        row, a run joined with the same run in the rows below (a room is then a few
        rectangles, not one per row: the union takes a third of the time); coordinates are
        rounded to the nanometre.
        """
        labels = self.labels
        height = labels.shape[0]
        padded = np.pad(labels, ((0, 0), (1, 1)), constant_values=-1)
        change = padded[:, 1:] != padded[:, :-1]
        rows, cols = np.nonzero(change[:, :-1])  # a run of equal labels starts at (row, col)
        ends = np.nonzero(change[:, 1:])[1] + 1  # ... and ends before this column
        values = labels[rows, cols]
        keep = values > 0
        rows, cols, ends, values = rows[keep], cols[keep], ends[keep], values[keep]
        order = np.lexsort((rows, ends, cols, values))
        rows, cols, ends, values = rows[order], cols[order], ends[order], values[order]
        # runs in order of region, then columns, then row: a run continues the one before it
        # when it spans the same columns in the next row
        new = np.ones(len(rows), bool)
        new[1:] = (
            (values[1:] != values[:-1])
            | (cols[1:] != cols[:-1])
            | (ends[1:] != ends[:-1])
            | (rows[1:] != rows[:-1] + 1)
        )
        if not len(new):
            return {}
        first = np.flatnonzero(new)
        last = np.append(first[1:], len(rows)) - 1
        res = self.grid.resolution
        boxes = shapely.box(
            cols[first] * res,
            (height - 1 - rows[last]) * res,
            ends[first] * res,
            (height - rows[first]) * res,
        )
        values = values[first]
        ox, oy, yaw = self.grid.origin
        c, s = np.cos(yaw), np.sin(yaw)
        result: dict[int, BaseGeometry] = {}
        bounds = np.searchsorted(values, np.arange(1, int(values.max(initial=0)) + 2))
        for region in range(1, len(bounds)):
            chosen = slice(bounds[region - 1], bounds[region])
            if chosen.start == chosen.stop:
                continue
            shape = affinity.affine_transform(
                shapely.union_all(boxes[chosen]), [c, -s, s, c, ox, oy]
            )
            # nanometre coordinates: text exports (WKT, JSON) then read back the same numbers
            result[region] = shapely.transform(shape, lambda xy: np.round(xy, 9))
        return result
