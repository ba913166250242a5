"""Places and doors: the regions people draw, from the geometry of the free space.

- :func:`basins`: the free space is cut into basins of its clearance (distance to the
  nearest wall): a watershed from the open spaces meets at the narrowest passages, the doors.
- :func:`merge_open_boundaries`: places (or spectral clusters) also split long corridors and
  large rooms where nothing much narrows the space. Two touching regions stay apart only where
  the opening between them is a door: narrower than the open spaces on both sides of it.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage, sparse
from scipy.sparse.csgraph import connected_components
from skimage.segmentation import watershed

from maps.grid import OccupancyGrid
from segmentation.distinct import label_counts
from segmentation.errors import ParameterError
from segmentation.regions import boundary_pairs, consecutive, relabelled

#: A passage at least this share of the open space on both sides of it is no door.
OPEN = 0.8
#: A place's clearance peak rises at least this far above the passage to a higher one,
#: metres: the space is 0.4 m wider than the passage. Chosen by each data set alone, over
#: the four phases of ``topomap eval segment --shifts`` (2026-12-03): 0.2 over 0.25 and 0.3 on
#: the ROSE² maps (spectral MCC 0.744 / 0.737 / 0.710) and on the ipa plans (0.847 / 0.843 /
#: 0.843, empty and furnished); 0.15 was lower on both (one phase: 0.728; 0.845).
PLACE_DEPTH = 0.2


def basins(grid: OccupancyGrid, depth: float = PLACE_DEPTH) -> NDArray[np.int32]:
    """Watershed basins of the clearance whose peaks rise at least ``depth`` metres above the
    passage to any higher basin (the h-maxima basins, found by merging by dynamics).

    The clearance is measured with the map edge as an obstacle. Every local maximum (a plateau
    counts once) seeds a basin; then, from the highest passage down, a basin whose peak is less
    than ``depth`` above the passage to its neighbour joins that neighbour.

    Examples
    --------
    >>> free = np.zeros((10, 23), bool)
    >>> free[1:9, 1:10] = free[1:9, 13:22] = True  # two rooms
    >>> free[4:6, 10:13] = True  # a door between them
    >>> grid = OccupancyGrid.from_masks(free, resolution=0.1)
    >>> found = basins(grid)
    >>> len(np.unique(found[found > 0])), bool(found[2, 2] != found[2, 20])
    (2, True)
    """
    free = grid.free
    clearance = grid.free_clearance()
    peaks = (clearance == cv2.dilate(clearance, np.ones((3, 3), np.uint8))) & free
    markers, _ = ndimage.label(peaks, structure=np.ones((3, 3)))
    seeds = watershed(-clearance, markers, mask=free, connectivity=1).astype(np.int32)
    count = int(seeds.max(initial=0))
    if count < 2:
        return seeds
    peak = np.zeros(count + 1)
    # the values in the peaks' own type: np.maximum.at casting float32 is 20-30 times slower
    np.maximum.at(peak, seeds[free], clearance[free].astype(np.float64))
    ra, ca, rb, cb = boundary_pairs(seeds)
    # the passage between two basins: the most open of the cells where they meet
    pairs, where = np.unique(
        seeds[ra, ca].astype(np.int64) * (count + 1) + seeds[rb, cb], return_inverse=True
    )
    passage = np.zeros(len(pairs))
    np.maximum.at(
        passage, where, np.minimum(clearance[ra, ca], clearance[rb, cb]).astype(np.float64)
    )
    a, b = np.divmod(pairs, count + 1)
    parent = np.arange(count + 1)

    def root(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = int(parent[x])
        return x

    for edge in np.argsort(-passage, kind="stable"):
        ra_, rb_ = root(int(a[edge])), root(int(b[edge]))
        if ra_ == rb_:
            continue
        low, high = (ra_, rb_) if peak[ra_] < peak[rb_] else (rb_, ra_)
        if peak[low] - passage[edge] < depth:
            parent[low] = high
    roots = np.array([root(x) for x in range(count + 1)])
    return relabelled(seeds, roots)


def count_basins(grid: OccupancyGrid, basin: NDArray[np.int32], min_area: float = 1.0) -> int:
    """Number of ``basin`` labels (from :func:`basins`) of at least ``min_area`` square metres:
    a guess of the number of places (rooms, corridor pieces) for the spectral ``k``."""
    sizes = label_counts(basin)[1:]
    return max(1, int((sizes * grid.resolution**2 >= min_area).sum()))


def merge_open_boundaries(
    grid: OccupancyGrid,
    labels: NDArray[np.int32],
    basin: NDArray[np.int32] | None = None,
    ratio: float = OPEN,
    max_door: float = 2.5,
) -> NDArray[np.int32]:
    """Merge regions of ``labels`` that touch where nothing narrows the space.

    The opening between two regions is a door when its clearance (half its width, at its most
    open cell) is below ``ratio`` times the clearance of the open spaces on *both* sides (the
    peaks of the basins of :func:`basins` that touch the opening) and at most ``max_door``
    metres wide, to a cell (double doors included; a wider constriction is where a corridor
    narrows, not a door). Anything else (a cut across a corridor or a room, a corridor widening
    into a hall) is merged away.

    Examples
    --------
    >>> free = np.zeros((10, 33), bool)
    >>> free[1:9, 1:32] = True  # a corridor cut in three
    >>> labels = np.where(free, 1 + np.arange(33) // 11, 0).astype(np.int32)
    >>> grid = OccupancyGrid.from_masks(free, resolution=0.1)
    >>> np.unique(merge_open_boundaries(grid, labels)).tolist()
    [0, 1]
    """
    if not 0 < ratio <= 1:
        raise ParameterError(f"ratio must lie in (0, 1], got {ratio!r}")
    if int(labels.max(initial=0)) < 2:
        return labels
    basin = basins(grid) if basin is None else basin
    clearance = grid.free_clearance()
    peak = np.zeros(int(basin.max(initial=0)) + 1)
    inside = basin > 0
    np.maximum.at(peak, basin[inside], clearance[inside].astype(np.float64))
    ra, ca, rb, cb = boundary_pairs(labels)
    a, b = labels[ra, ca].astype(np.int64), labels[rb, cb].astype(np.int64)
    passage = np.minimum(clearance[ra, ca], clearance[rb, cb]).astype(np.float64)
    side_a, side_b = peak[basin[ra, ca]], peak[basin[rb, cb]]
    pair = a * (int(labels.max()) + 1) + b
    pairs, index = np.unique(pair, return_inverse=True)
    count = len(pairs)
    widest = np.zeros(count)
    open_a, open_b = np.zeros(count), np.zeros(count)
    np.maximum.at(widest, index, passage)
    np.maximum.at(open_a, index, side_a)
    np.maximum.at(open_b, index, side_b)
    # clearance runs to the wall cells' centres: the free width is a cell less than twice it
    merge = (widest >= ratio * np.minimum(open_a, open_b)) | (
        2 * widest - grid.resolution > max_door
    )
    first, second = np.divmod(pairs[merge], int(labels.max()) + 1)
    links = sparse.coo_matrix(
        (np.ones(len(first)), (first, second)), shape=(int(labels.max()) + 1,) * 2
    )
    _, component = connected_components(links, directed=False)
    return consecutive(np.where(labels > 0, component[labels] + 1, 0))
