"""Corridors the places cut across: where two clearance basins meet in a corridor, nothing
narrows the space, so they are one place.

A corridor's clearance is a plateau between its junctions and wide spots, each of which
raises a peak and seeds a basin (:func:`~segmentation.refine.basins`); the basins meet
somewhere on the plateau, at a cut that is no door. Compared with the basins' peaks (a
crossing of two corridors rises to sqrt(2) times their half width) such a cut looks like one,
so the places, and the partition that votes with them, would cut the corridor system at every
junction. :func:`join_corridor_cuts` joins two places where their boundary is a cut across a
channel: straight across the free space from wall to wall, at least a corridor wide
(:data:`CORRIDOR_WIDTH`), the space keeping that width (its clearance within
:data:`~segmentation.refine.OPEN` of the cut's, and the inverse, with a cell of slack for
jagged walls) between walls on both hands for :data:`~segmentation.walls.CHANNEL` metres on
both sides; or where a corridor enters a wider space: on one side the space keeps the cut's
width so for
:data:`CORRIDOR_LENGTH` times that width (longer than a room is for its width), and on the
other it never narrows. A door, a room opening onto a corridor, a narrow room entered through
its full width: the space widens or narrows within those metres, and the places stay apart
for the partition to decide.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from maps.grid import OccupancyGrid
from segmentation.refine import OPEN
from segmentation.regions import boundary_pairs, consecutive
from segmentation.walls import CHANNEL

#: The narrowest corridor, metres: building codes' least (1.1-1.2 m); a narrower passage is a
#: door or a gap between furniture.
CORRIDOR_WIDTH = 1.2
#: Where the width is checked on each side of a cut, as shares of :data:`CHANNEL`.
STEPS = (0.25, 0.5, 0.75, 1.0)
#: A corridor is at least this many times as long as it is wide; a room is rarely over 2.5
#: times (the names' ``corridor_length``, :class:`topomap.classifiers.RuleClassifier`).
CORRIDOR_LENGTH = 4.0


def corridor_cuts(
    places: NDArray[np.integer], grid: OccupancyGrid
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Pairs ``a < b`` of touching places of ``grid`` whose boundary is a cut across a
    corridor (see the module docstring).

    Examples
    --------
    >>> free = np.zeros((22, 102), bool)
    >>> free[1:21, 1:101] = True  # a 2 m wide, 10 m long corridor (0.1 m cells)
    >>> places = np.where(free, 1 + (np.arange(102) >= 50), 0)
    >>> corridor_cuts(places, OccupancyGrid.from_masks(free, 0.1))
    (array([1]), array([2]))
    >>> free[1:21, 48:52] = False; free[10:12, 48:52] = True  # a 0.2 m slot between two rooms
    >>> corridor_cuts(places * free, OccupancyGrid.from_masks(free, 0.1))
    (array([], dtype=int64), array([], dtype=int64))
    """
    clearance, resolution = grid.free_clearance(), grid.resolution
    ra, ca, rb, cb = boundary_pairs(places)
    first = places[ra, ca].astype(np.int64)
    second = places[rb, cb].astype(np.int64)
    count = int(places.max(initial=0)) + 1
    pair, index, cells = np.unique(first * count + second, return_inverse=True, return_counts=True)
    order = np.argsort(index, kind="stable")
    ends = np.cumsum(cells)
    middle = np.column_stack([(ca + cb) / 2.0, (ra + rb) / 2.0])[order]  # x, y
    open_at = np.minimum(clearance[ra, ca], clearance[rb, cb])[order]
    found = [
        p
        for p, end, n in zip(pair.tolist(), ends.tolist(), cells.tolist(), strict=True)
        if n >= 3
        and _across_corridor(middle[end - n : end], open_at[end - n : end], clearance, resolution)
    ]
    a, b = np.divmod(np.array(found, np.int64), count)
    return a, b


def join_corridor_cuts(places: NDArray[np.int32], grid: OccupancyGrid) -> NDArray[np.int32]:
    """``places`` of ``grid`` with the places of every :func:`corridor_cuts` pair made one
    (consecutive ids; 0 stays 0)."""
    a, b = corridor_cuts(places, grid)
    if len(a) == 0:
        return places
    count = int(places.max()) + 1
    links = sparse.coo_matrix((np.ones(len(a)), (a, b)), shape=(count, count))
    _, component = connected_components(links, directed=False)
    return consecutive(np.where(places > 0, component[places] + 1, 0))


def _across_corridor(
    middle: NDArray[np.float64],
    open_at: NDArray[np.float32],
    clearance: NDArray[np.float32],
    resolution: float,
) -> bool:
    """Whether a boundary (the midpoints of its cell pairs, x and y in cells, and the clearance
    there, metres) is a cut across a corridor of the map whose ``clearance`` is given."""
    centre = middle.mean(axis=0)
    _, axes = np.linalg.eigh(np.cov((middle - centre).T))
    along = axes[:, 1]
    extent = (middle - centre) @ along
    length = (float(extent.max() - extent.min()) + 1) * resolution
    most = int(np.argmax(open_at))
    width = 2 * float(open_at[most])  # the space's width at the cut's most open cell
    # not wall to wall, or narrower than a corridor even where a jagged wall took a cell off
    # each side (SLAM maps' corridors measure 1.1 m on the working cells)
    if length * OPEN > width or length < CORRIDOR_WIDTH - 2 * resolution:
        return False
    normal = np.array([-along[1], along[0]])
    steps = np.array(STEPS) * CHANNEL / resolution
    points = middle[most] + np.concatenate([steps, -steps])[:, None] * normal
    across = np.array([normal[1], -normal[0]]) * width / 2 / resolution
    holds = _keeps_width(clearance, points, across, width, resolution)
    half = len(STEPS)
    both_sides = holds.sum() >= 2 * half - 1 and holds[:half].any() and holds[half:].any()
    if length >= CORRIDOR_WIDTH and both_sides:
        return True
    return _corridor_into_wider(middle[most], normal, width, clearance, resolution)


def _corridor_into_wider(
    start: NDArray[np.float64],
    normal: NDArray[np.float64],
    width: float,
    clearance: NDArray[np.float32],
    resolution: float,
) -> bool:
    """Whether a cut ``width`` metres wide at ``start`` (x, y cells) is where a corridor
    enters a wider space: on one side along ``normal`` the space keeps the cut's width for
    :data:`CORRIDOR_LENGTH` times that width (a room is rarely over 2.5 times as long as wide,
    so this is a corridor, not a narrow room entered through its full width), on the other it
    never narrows over :data:`~segmentation.walls.CHANNEL` metres."""
    step = 0.25 / resolution  # a sample every 0.25 m
    across = np.array([normal[1], -normal[0]]) * width / 2 / resolution

    def along(sign: float, metres: float) -> NDArray[np.float64]:
        offsets = np.arange(1, int(metres / 0.25) + 1) * step * sign
        return start + offsets[:, None] * normal

    length = CORRIDOR_LENGTH * width
    for sign in (1.0, -1.0):
        holds = _keeps_width(clearance, along(sign, length), across, width, resolution)
        wider = _clearance_at(clearance, along(-sign, CHANNEL))
        # as across a cut (7 of 8 samples), one in eight may miss: a curved corridor leaves
        # the straight line
        if (
            holds.sum() >= len(holds) - len(holds) // 8
            and (wider >= OPEN * width / 2 - resolution).all()
        ):
            return True
    return False


def _keeps_width(
    clearance: NDArray[np.float32],
    points: NDArray[np.float64],
    across: NDArray[np.float64],
    width: float,
    resolution: float,
) -> NDArray[np.bool_]:
    """Whether the space at each of ``points`` (x, y cells) is ``width`` metres wide between
    walls on both hands (``across``, cells, reaches from the middle to a wall): the clearance
    in the middle is half the width, with a cell of slack (SLAM maps' walls are jagged), and
    at ``points ± across`` it is no more than that (no room opens along a wall)."""
    half = width / 2
    there = _clearance_at(clearance, points)
    walls = np.maximum(
        _clearance_at(clearance, points + across), _clearance_at(clearance, points - across)
    )
    holds = (there >= OPEN * half - resolution) & (there * OPEN <= half + resolution)
    return holds & (walls * OPEN <= half)


def _clearance_at(
    clearance: NDArray[np.float32], points: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``clearance`` at the cells nearest ``points`` (x, y in cells); 0 off the map."""
    cells = np.rint(points).astype(int)
    height, wide = clearance.shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < wide) & (cells[:, 1] >= 0) & (cells[:, 1] < height)
    there = np.zeros(len(cells))
    there[inside] = clearance[cells[inside, 1], cells[inside, 0]]
    return there
