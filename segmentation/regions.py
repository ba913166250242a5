"""From clustered keyframes to a dense segmentation of the free space into regions."""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage
from shapely import affinity
from shapely.geometry.base import BaseGeometry

from maps.grid import OccupancyGrid
from maps.limits import finite_in
from segmentation.distinct import distinct, label_counts, nonzero_cells
from segmentation.errors import ParameterError, SegmentationError


def boundary_pairs(labels: NDArray[np.integer]) -> tuple[NDArray[np.int64], ...]:
    """Cells on both sides of every 4-neighbour boundary between two different labels > 0.

    Returns
    -------
    tuple of ndarray
        ``(row_a, col_a, row_b, col_b)`` with ``labels[a] < labels[b]``.
    """
    width = labels.shape[1]
    flat = np.ascontiguousarray(labels).ravel()
    found: list[NDArray[np.int64]] = []
    for down in (True, False):  # the cell below, the cell to the right
        step = width if down else 1
        # the few cells whose neighbour differs, then those between two labels, row by row
        at = np.flatnonzero(flat[:-step] != flat[step:])
        if not down:
            at = at[at % width != width - 1]  # not across the end of a row
        at = at[(flat[at] > 0) & (flat[at + step] > 0)]
        rows, cols = np.divmod(at, width)
        beside = (rows + 1, cols) if down else (rows, cols + 1)
        found.append(np.stack([rows, cols, *beside]))
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
    sizes = label_counts(labels)
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
    against 5.7 on the 88 places of a 768 x 864 map). Labels already ``1..N`` (the regions
    grown over a map, most often) are returned as they are, not looked up cell by cell.

    Examples
    --------
    >>> consecutive(np.array([[0, 7, 7], [3, 0, 9]])).tolist()
    [[0, 2, 2], [1, 0, 3]]
    >>> consecutive(np.array([[0, 2, -1], [1, 0, 2]])).tolist()
    [[0, 2, 0], [1, 0, 2]]
    """
    labels = np.maximum(labels, 0)
    present = label_counts(labels) > 0
    present[0] = False
    if present[1:].all():
        return labels.astype(np.int32, copy=False)
    rank = np.cumsum(present).astype(np.int32)
    rank[0] = 0
    return rank[labels]


def relabelled(labels: NDArray[np.integer], table: NDArray[np.integer]) -> NDArray[np.int32]:
    """``consecutive(table[labels])`` for ``labels`` >= 0 (ids into ``table``): the table
    made consecutive over the values ``labels`` holds, then looked up once, so no map of
    ``table``'s values is made and relabelled whole (a third of the time on a campus).

    Examples
    --------
    >>> relabelled(np.array([[0, 3, 3], [1, 0, 2]]), np.array([0, 9, 9, 4])).tolist()
    [[0, 1, 1], [2, 0, 2]]
    """
    present = label_counts(labels, len(table)) > 0
    values = np.maximum(table, 0)
    kept = np.zeros(int(values.max(initial=0)) + 1, bool)
    kept[values[present]] = True
    kept[0] = False
    rank = np.cumsum(kept).astype(np.int32)
    rank[0] = 0
    return rank[values][labels]


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
    from skimage.segmentation import watershed  # imported here: reading regions needs none

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


def pieces(
    grid: OccupancyGrid,
    labels: NDArray[np.integer],
    min_area: float,
    *,
    claim_unlabelled: bool = True,
) -> NDArray[np.int32]:
    """Regions made connected: free cells without a label get one per connected piece (with
    ``claim_unlabelled``, else they stay 0), each label is split into its 4-connected pieces,
    and pieces under ``min_area`` square metres merge into a neighbour (0 if they have none).

    Examples
    --------
    >>> free = np.ones((1, 6), bool)
    >>> labels = np.array([[1, 1, 0, 0, 2, 2]])
    >>> pieces(OccupancyGrid.from_masks(free, 1.0), labels, 1.0).tolist()
    [[1, 1, 2, 2, 3, 3]]
    >>> pieces(OccupancyGrid.from_masks(free, 1.0), labels, 1.0, claim_unlabelled=False).tolist()
    [[1, 1, 0, 0, 2, 2]]
    """
    from skimage.measure import label as connected_pieces  # as in dense_labels

    free = grid.free
    labels = np.where(free, labels, 0)
    if claim_unlabelled:
        unreached, _ = ndimage.label(free & (labels == 0))
        labels = np.where(unreached > 0, unreached + labels.max(), labels)
    labels = connected_pieces(labels, background=0, connectivity=1)
    min_cells = max(1, round(min_area / grid.resolution**2))
    return consecutive(merge_small(labels.astype(np.int32), min_cells))


#: Unknown space farther than this from every known cell is no part of the map, metres: the
#: canvas a SLAM package allocates before it maps (gmapping's 200 x 200 m by default) round a
#: building that fills a corner of it. Maps are segmented, and their regions measured, on
#: their known cells and this margin round them (:meth:`~maps.grid.OccupancyGrid.known_box`),
#: in the time of the building rather than of the canvas, and a canvas of any size round
#: them gives the same regions. Wider than the margins maps are saved or drawn with (the ipa
#: plans and ROSE²'s maps: up to 13.6 m), which are segmented as given.
CANVAS_MARGIN = 15.0

#: The largest piece of furniture, m^2 (a conference table, a row of shelves): an unlabelled
#: piece of the map (cells drawn as walls, cells nobody saw) no larger that one region
#: encloses is in it (:meth:`Regions.at`).
FURNITURE_M2 = 4.0


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

    def known_part(self) -> Regions:
        """These regions on their map's known cells and :data:`CANVAS_MARGIN` round them
        (:meth:`~maps.grid.OccupancyGrid.known_box`; itself if that is the whole map): every
        measure of them the same, in the time of the building rather than of the canvas.

        Examples
        --------
        >>> cells = np.full((1000, 1000), -1, np.int8)
        >>> cells[:10, :20] = 0  # a 1 x 2 m room in a corner of a 100 x 100 m canvas
        >>> labels = np.zeros((1000, 1000), np.int32)
        >>> labels[:10, :20] = 1
        >>> part = Regions(OccupancyGrid(cells, 0.1), labels).known_part()
        >>> part.grid.shape, round(part.area(1), 6)
        ((160, 170), 2.0)
        """
        rows, cols = self.grid.known_box(CANVAS_MARGIN)
        if (rows.stop - rows.start, cols.stop - cols.start) == self.grid.shape:
            return self
        return Regions(self.grid.cropped(rows, cols), self.labels[rows, cols])

    @property
    def ids(self) -> list[int]:
        """Region ids present, ascending."""
        return (np.flatnonzero(self.cell_counts[1:]) + 1).tolist()

    @cached_property
    def cell_counts(self) -> NDArray[np.int64]:
        """Cells per region id (index 0 = unlabelled cells)."""
        return label_counts(self.labels)

    def area(self, region: int) -> float:
        """Area of ``region`` in square metres (cells times cell area)."""
        return float(self.cell_counts[region]) * self.grid.resolution**2

    def at(self, x: float, y: float) -> int:
        """The region at map point ``(x, y)`` (or the region round it, :attr:`enclosing`), 0 if
        none.

        Raises
        ------
        ParameterError
            ``x`` or ``y`` is not a finite number (NaN is nowhere, not "no region").
        """
        for name, value in (("x", x), ("y", y)):
            problem = finite_in(value, name, -math.inf, math.inf)
            if problem is not None:
                raise ParameterError(f"a point is two finite numbers in metres: {problem}")
        row, col = self.grid.world_to_cell(x, y)
        if not self.grid.contains(row, col):
            return 0
        return int(self.labels[row, col] or self.enclosing[row, col])

    def at_points(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.int64]:
        """The region at each map point (or round it, :attr:`enclosing`), 0 where there is
        none."""
        rows, cols = self.grid.world_to_cell(x, y)
        inside = self.grid.contains(rows, cols)
        found = np.zeros(np.shape(rows), np.int64)
        found[inside] = self.labels[rows[inside], cols[inside]]
        off = inside & (found == 0)  # on no region's cells: furniture, an unseen patch?
        if off.any():
            found[off] = self.enclosing[rows[off], cols[off]]
        return found

    @cached_property
    def enclosing(self) -> NDArray[np.int32]:
        """:attr:`labels` with the unlabelled pieces a region encloses, up to
        :data:`FURNITURE_M2` (furniture drawn as walls, patches nobody saw), given to it
        (:func:`fill_enclosed`): the region a point inside the building is in. The labels
        leave them out, as people drawing rooms on a map do."""
        return fill_enclosed(self.labels, round(FURNITURE_M2 / self.grid.resolution**2))

    @cached_property
    def polygons(self) -> dict[int, BaseGeometry]:
        """Outline of each region in map-frame metres, along cell edges: the outline of its
        :attr:`enclosing` cells, so furniture and unseen patches inside a room are covered;
        larger holes (a courtyard, a block of rooms a ring corridor goes round) are kept.

        Built from the region's rectangles of cells (its runs of cells along each row, a run
        joined with the same run in the rows below), each rectangle's top and bottom edges cut
        at the corners of the region's rectangles on the other side: the rectangles then
        share their edges exactly and their union is a coverage union, which joins them along
        the shared edges without a general overlay (2-4 times faster on ragged SLAM maps; the
        same outline). Coordinates are rounded to the nanometre.
        """
        labels = self.enclosing
        height, width = labels.shape
        value, top, bottom, left, right = _rectangles(labels)
        if len(value) == 0:
            return {}
        # every rectangle corner on each horizontal line of cell edges of each region, sorted
        lines = _line_key(np.tile(value, 4), np.concatenate([top, top, bottom, bottom]), height)
        corners = distinct(lines * (width + 1) + np.concatenate([left, right, left, right]))

        def inner_corners(line: NDArray[np.int64]) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
            """Where the corners strictly between each rectangle's two ends on ``line`` lie
            in ``corners``: ``[start, stop)``."""
            base = _line_key(value, line, height) * (width + 1)
            return (
                np.searchsorted(corners, base + left, side="right"),
                np.searchsorted(corners, base + right, side="left"),
            )

        bottom_start, bottom_stop = inner_corners(bottom)
        top_start, top_stop = inner_corners(top)
        corner_x = corners % (width + 1)
        # each ring: bottom-left, the bottom edge's cuts left to right, bottom-right, top-right,
        # the top edge's cuts right to left, top-left, bottom-left again
        n_bottom, n_top = bottom_stop - bottom_start, top_stop - top_start
        size = 5 + n_bottom + n_top
        begin = np.cumsum(size) - size
        x = np.empty(int(size.sum()), np.int64)
        y = np.empty(len(x), np.int64)
        for offset, xs, ys in (
            (0, left, bottom),
            (1 + n_bottom, right, bottom),
            (2 + n_bottom, right, top),
            (3 + n_bottom + n_top, left, top),
            (4 + n_bottom + n_top, left, bottom),
        ):
            x[begin + offset], y[begin + offset] = xs, ys
        at = _ranges(begin + 1, n_bottom)
        x[at], y[at] = corner_x[_ranges(bottom_start, n_bottom)], np.repeat(bottom, n_bottom)
        at = _ranges(begin + 3 + n_bottom, n_top)
        from_right = _ranges(np.zeros_like(n_top), n_top)
        x[at], y[at] = corner_x[np.repeat(top_stop - 1, n_top) - from_right], np.repeat(top, n_top)
        res = self.grid.resolution
        ring = np.repeat(np.arange(len(value)), size)
        boxes = shapely.polygons(shapely.linearrings(x * res, (height - y) * res, indices=ring))
        ox, oy, yaw = self.grid.origin
        c, s = np.cos(yaw), np.sin(yaw)
        result: dict[int, BaseGeometry] = {}
        bounds = np.searchsorted(value, np.arange(1, int(value.max()) + 2))
        for region in range(1, len(bounds)):
            chosen = slice(bounds[region - 1], bounds[region])
            if chosen.start == chosen.stop:
                continue
            shape = affinity.affine_transform(
                shapely.coverage_union_all(boxes[chosen]), [c, -s, s, c, ox, oy]
            )
            # nanometre coordinates: text exports (WKT, JSON) then read back the same numbers
            result[region] = shapely.transform(shape, lambda xy: np.round(xy, 9))
        return result


def _rectangles(labels: NDArray[np.integer]) -> tuple[NDArray[np.int64], ...]:
    """``(value, top, bottom, left, right)`` of the rectangles of cells of equal label > 0,
    in cell edges (rows ``top..bottom - 1``, columns ``left..right - 1``), ordered by label:
    the runs of each row, a run joined with the same run in the rows below."""
    padded = np.pad(labels, ((0, 0), (1, 1)), constant_values=-1)
    change = padded[:, 1:] != padded[:, :-1]
    rows, cols = nonzero_cells(change[:, :-1])  # a run of equal labels starts at (row, col)
    ends = nonzero_cells(change[:, 1:])[1] + 1  # ... and ends before this column
    values = labels[rows, cols].astype(np.int64)
    keep = values > 0
    rows, cols, ends, values = rows[keep], cols[keep], ends[keep], values[keep]
    order = np.lexsort((rows, ends, cols, values))
    rows, cols, ends, values = rows[order], cols[order], ends[order], values[order]
    # in order of label, then columns, then row: a run continues the one before it when it
    # spans the same columns in the next row
    new = np.ones(len(rows), bool)
    new[1:] = (
        (values[1:] != values[:-1])
        | (cols[1:] != cols[:-1])
        | (ends[1:] != ends[:-1])
        | (rows[1:] != rows[:-1] + 1)
    )
    first = np.flatnonzero(new)
    last = np.append(first[1:] - 1, len(rows) - 1) if len(first) else first
    return values[first], rows[first], rows[last] + 1, cols[first], ends[first]


def _line_key(value: NDArray[np.int64], line: NDArray[np.int64], height: int) -> NDArray[np.int64]:
    """One number per (label, horizontal line of cell edges ``0..height``), in their order."""
    return value * (height + 1) + line


def _ranges(starts: NDArray[np.integer], counts: NDArray[np.integer]) -> NDArray[np.int64]:
    """``starts[i] + arange(counts[i])`` for every ``i``, concatenated."""
    total = int(counts.sum())
    offsets = np.repeat(np.cumsum(counts) - counts, counts)
    return np.repeat(starts, counts) + np.arange(total) - offsets


def fill_enclosed(labels: NDArray[np.int32], most: int) -> NDArray[np.int32]:
    """``labels`` with every piece of unlabelled cells (8-connected) of at most ``most`` cells
    that one region encloses (its every neighbour that region's, off the map's edge) given to
    that region: furniture drawn as walls and unseen patches inside a room are the room's.

    The pieces and their boxes come from one labelling of the map; only the few small pieces
    off its edge are then looked at, each on its box.

    Examples
    --------
    >>> labels = np.ones((7, 9), np.int32)
    >>> labels[:, 5:] = 2
    >>> labels[2:4, 1:3] = 0  # a table in room 1
    >>> labels[2:4, 4:6] = 0  # a pillar between rooms 1 and 2
    >>> labels[6, 7] = 0  # a notch at the map's edge
    >>> fill_enclosed(labels, 4)[[2, 2, 6], [1, 4, 7]].tolist()
    [1, 0, 0]
    """
    empty = (labels == 0).astype(np.uint8)
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(empty, connectivity=8, ltype=cv2.CV_32S)
    left, top = stats[:, cv2.CC_STAT_LEFT], stats[:, cv2.CC_STAT_TOP]
    right = left + stats[:, cv2.CC_STAT_WIDTH]
    bottom = top + stats[:, cv2.CC_STAT_HEIGHT]
    height, width = labels.shape
    off_edge = (left > 0) & (top > 0) & (right < width) & (bottom < height)
    small = off_edge & (stats[:, cv2.CC_STAT_AREA] <= most)
    small[0] = False  # OpenCV's background: the labelled cells
    filled = labels
    for piece in np.flatnonzero(small).tolist():
        box = np.s_[top[piece] - 1 : bottom[piece] + 1, left[piece] - 1 : right[piece] + 1]
        region = _enclosing_region(pieces[box] == piece, labels[box])
        if region > 0:
            if filled is labels:
                filled = labels.astype(np.int32, copy=True)
            filled[box][pieces[box] == piece] = region
    return filled


def _enclosing_region(cells: NDArray[np.bool_], labels: NDArray[np.integer]) -> int:
    """The region of ``labels`` all round ``cells`` (their 8-neighbours outside them, which
    lie inside the box), 0 if the neighbours are of more than one region."""
    ring = cv2.dilate(cells.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    around = labels[ring & ~cells]
    return int(around[0]) if around.min() == around.max() else 0
