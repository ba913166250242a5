"""Map conditioning: which free space belongs to the building, and which obstacles are clutter.

Real SLAM maps carry more than rooms: thin free rays that beams leave through doors, windows
and glass into unknown space, small free islands, specks left by people, tables and chairs as
many small occupied blobs inside rooms. Every rule here is in metres of the robot and of the
furniture, never in cells, so it holds at any resolution:

0. **Blur.** Walls drawn thicker than the mapper's blur allows lose the whole cells of it on
   each side (:func:`~segmentation.blur.sharpened`): what follows is measured on the walls'
   surfaces, whichever mapper drew them.
1. **Clutter.** Obstacles closer than ``robot_radius`` to each other form one obstacle (the
   robot cannot pass between them: a dotted SLAM wall is one wall). An obstacle that stands
   free of the map edge and fits in a box of ``clutter_size`` metres (a table with its chairs,
   a pillar, a speck, a small unknown patch; measured by the cells the laser hit on it, not
   its unseen inside and shadow, :func:`find_clutter`) is clutter: it is furniture inside a
   room, not a wall, so the geometry of places and doors ignores it; unless it is a stretch
   of wall on the line of the walls between two doors (as free-standing as a table, as long
   as one).
   Clutter cells are never labelled.
2. **Robot space.** A free cell belongs to the building when a disc of ``robot_radius`` that
   covers it fits in the free space (a morphological opening): free rays thinner than the robot
   go. Connected pieces of that space under ``min_area`` square metres (islands) go too.
3. **Outside** (:func:`drop_outside`, once the space is cut into places): in a map that draws
   its walls as occupied cells, a place whose edge is less than ``min_wall_share`` wall and the
   rest unknown space is not a room but the fan of rays that beams leave through a window, a
   glass wall or an open door into space nobody mapped; it goes too.

Nothing is dropped silently: :attr:`ConditionedMap.dropped` counts the cells of each kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from maps.grid import OccupancyGrid, clearance_of
from maps.limits import MAX_LENGTH, MAX_ROBOT_RADIUS, finite_in
from segmentation.blur import sharpened
from segmentation.distinct import nonzero_cells
from segmentation.errors import ParameterError
from segmentation.walls import wall_stubs
from segmentation.working import RAY_CELL, block_max, disc_cells, pool_factor


def _disc(radius_cells: float) -> NDArray[np.uint8]:
    size = 2 * math.floor(radius_cells) + 1
    return np.asarray(cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size)), np.uint8)


@dataclass(frozen=True, eq=False)
class ConditionedMap:
    """A map's free space split into what a robot uses and what it does not.

    Attributes
    ----------
    grid
        The map, its walls' blur taken off (:func:`~segmentation.blur.sharpened`).
    space
        Cells of the building's geometry: robot space plus the clutter inside it. Places,
        doors and clearance are measured in this space.
    free
        The cells to label: ``space`` without the clutter (free cells of the map only).
    clutter
        Occupied or unknown cells taken for furniture, specks and small unknown patches.
    dropped
        Free cells left out, by reason: ``thin`` (no robot disc fits), ``islands`` (pieces
        under ``min_area``), ``outside`` (places bounded by unknown space, see
        :func:`drop_outside`).
    blur
        Cells of the mapper's blur taken off each side of the walls (0: the walls are sharp).
    """

    grid: OccupancyGrid
    space: NDArray[np.bool_]
    free: NDArray[np.bool_]
    clutter: NDArray[np.bool_]
    dropped: dict[str, int]
    blur: int = 0

    def __repr__(self) -> str:
        return f"ConditionedMap({self.summary()})"

    def summary(self) -> dict[str, int]:
        """Counts of cells kept, clutter and dropped, for reports."""
        return {
            "free_cells": int(self.grid.free.sum()),
            "kept_cells": int(self.free.sum()),
            "clutter_cells": int(self.clutter.sum()),
            **{f"dropped_{k}_cells": v for k, v in self.dropped.items()},
            "wall_blur_cells": self.blur,
        }


#: How far past ``clutter_size`` an obstacle's unknown cells may reach (the box round all its
#: cells) and it still be measured by what the laser hit on it, metres: the shadow a robot
#: driving past leaves behind a desk.
SHADOW = 0.5


def find_clutter(
    grid: OccupancyGrid, robot_radius: float = 0.2, clutter_size: float = 2.0
) -> NDArray[np.bool_]:
    """Non-free cells that belong to free-standing obstacles smaller than ``clutter_size``.

    Obstacles within ``robot_radius`` of each other count as one; an obstacle touching the map
    edge is never clutter, nor a stretch of wall between two doors
    (:func:`~segmentation.walls.wall_stubs`). An obstacle's size is the diagonal of the box
    round the cells the laser hit on it (occupied): the unknown cells inside it and in its
    shadow are no part of its size (a 1.6 x 0.8 m desk and the shadow a robot's run leaves
    behind it measure 2.1 m), unless the box round all its cells is over ``clutter_size``
    plus :data:`SHADOW` (a stub of wall with unexplored space behind it), when it is that box.

    Examples
    --------
    >>> cells = np.zeros((40, 40), np.int8)
    >>> cells[[0, -1], :] = cells[:, [0, -1]] = 100  # walls
    >>> cells[20, 20] = 100  # a speck
    >>> clutter = find_clutter(OccupancyGrid(cells, 0.1))
    >>> bool(clutter[20, 20]), bool(clutter[0, 5])
    (True, False)
    """
    blocked = (~grid.free).astype(np.uint8)
    gap = robot_radius / grid.resolution
    half = math.ceil((gap - 1) / 2)  # each obstacle grows by this many cells: gaps < gap close
    grouped = cv2.dilate(blocked, _disc(half)) if half >= 1 else blocked
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(grouped, connectivity=8)
    x, y, w, h = (stats[:, i] for i in range(4))
    height, width = grid.shape
    inside = (x > 0) & (y > 0) & (x + w < width) & (y + h < height)
    grow = 2 * max(half, 0)
    size = np.hypot(w - grow, h - grow) * grid.resolution
    # the obstacles within the shadow's reach, measured again by their hit (occupied) cells
    near = size <= clutter_size + SHADOW
    near[0] = False
    rows, cols = nonzero_cells(grid.occupied & near[pieces])
    which = pieces[rows, cols].astype(np.intp)
    first = np.full((2, len(size)), np.iinfo(np.int64).max)
    last = np.full((2, len(size)), -1)
    for axis, cells in enumerate((rows, cols)):
        np.minimum.at(first[axis], which, cells)
        np.maximum.at(last[axis], which, cells)
    hit = last[0] >= 0
    size[hit] = np.hypot(*(last[:, hit] - first[:, hit] + 1)) * grid.resolution
    small = inside & (size <= clutter_size)
    small[0] = False
    clutter = small[pieces] & blocked.astype(bool)
    return clutter & ~wall_stubs(grid, clutter)


#: The widest disc :func:`farther_than` erodes by, in cells each side: on the campus (24
#: million cells) an erosion by a disc of 4 cells took 0.06 s, of 16 cells 0.4 s, of 24 cells
#: 0.9 s, about what the distance transform takes whatever the disc (1 s).
ERODE_REACH = 16


def farther_than(space: NDArray[np.bool_], radius: float) -> NDArray[np.bool_]:
    """The cells of ``space`` farther than ``radius`` cells from every cell outside it, the
    map edge counting as outside: ``clearance_of(space, 1.0) > radius``, found as an erosion
    by the cells nearer than that (the clearance is the root of a whole number of cells
    squared, in single precision), which costs a twentieth of the distance transform on a
    large map; for a disc reaching more than :data:`ERODE_REACH` cells, the distance
    transform itself.

    Examples
    --------
    >>> space = np.ones((5, 7), bool)
    >>> farther_than(space, 1.5).astype(int).tolist()[2]
    [0, 1, 1, 1, 1, 1, 0]
    >>> space = np.random.default_rng(0).random((60, 80)) > 0.01
    >>> [bool((farther_than(space, r) == (clearance_of(space, 1.0) > r)).all()) for r in (2.5, 20)]
    [True, True]
    """
    if math.floor(radius) + 1 > ERODE_REACH:
        return clearance_of(space, 1.0) > radius
    eroded = cv2.erode(
        space.astype(np.uint8),
        disc_cells(radius),
        borderType=cv2.BORDER_CONSTANT,
        borderValue=0,
    )
    return np.asarray(eroded, bool)


def condition(
    grid: OccupancyGrid,
    robot_radius: float = 0.2,
    clutter_size: float = 2.0,
    min_area: float = 1.0,
) -> ConditionedMap:
    """Condition ``grid`` for segmentation (see the module docstring).

    Parameters
    ----------
    grid
        The map.
    robot_radius
        Radius of the robot in metres: free space thinner than its disc is dropped, obstacles
        closer than it form one obstacle.
    clutter_size
        Free-standing obstacles that fit in a box of this diagonal (metres) are clutter.
    min_area
        Pieces of robot space under this many square metres are dropped.

    Examples
    --------
    >>> cells = np.full((30, 60), 100, np.int8)
    >>> cells[5:25, 5:25] = 0  # a 2 x 2 m room
    >>> cells[14, 25:60] = 0  # a one-cell ray out of it
    >>> conditioned = condition(OccupancyGrid(cells, 0.1))
    >>> int(conditioned.free[5:25, 5:25].sum()), conditioned.dropped["thin"]
    (392, 42)
    """
    for name, value, most in (
        ("robot_radius", robot_radius, MAX_ROBOT_RADIUS),
        ("clutter_size", clutter_size, MAX_LENGTH),
    ):
        problem = finite_in(value, name, 0.0, most, unit="m", low_open=True)
        if problem is not None:
            raise ParameterError(problem)
    if not (isinstance(min_area, int | float) and min_area >= 0):
        raise ParameterError(f"min_area must be >= 0 square metres, got {min_area!r}")
    grid, blur = sharpened(grid)
    free = grid.free
    clutter = find_clutter(grid, robot_radius, clutter_size)
    open_space = free | clutter
    radius = robot_radius / grid.resolution
    centres = farther_than(open_space, radius)
    opened = open_space & cv2.dilate(centres.astype(np.uint8), _disc(radius)).astype(bool)
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(opened.astype(np.uint8), connectivity=8)
    large = stats[:, cv2.CC_STAT_AREA] * grid.resolution**2 >= min_area
    large[0] = False
    space = large[pieces]
    kept = space & free
    dropped = {
        "thin": int((free & ~opened).sum()),
        "islands": int((free & opened & ~space).sum()),
        "outside": 0,
    }
    return ConditionedMap(grid, space, kept, clutter & space, dropped, blur)


def wall_share(grid: OccupancyGrid, labels: NDArray[np.integer]) -> NDArray[np.float64]:
    """For each label of ``labels`` (index = label), the share of its edge that is wall
    (occupied cells) rather than unknown space; edges with other labels do not count.
    Index 0 holds the share over all labels together. Measured on cells of at least
    :data:`~segmentation.working.RAY_CELL` (:func:`~segmentation.working.block_max`: a
    block is wall where a ray ended in it, unknown where no ray reached it, a label's where
    any of its cells is), on which the walls the rays end on close up.

    Examples
    --------
    >>> cells = np.full((5, 5), -1, np.int8)
    >>> cells[:, 0] = 100
    >>> cells[1:4, 1:4] = 0
    >>> labels = np.zeros((5, 5), np.int32)
    >>> labels[1:4, 1:4] = 1
    >>> wall_share(OccupancyGrid(cells, 0.1), labels).round(2).tolist()
    [0.25, 0.25]
    """
    count = int(labels.max(initial=0)) + 1
    wall, unknown = np.zeros(count), np.zeros(count)
    factor = pool_factor(grid.resolution, RAY_CELL)
    occupied = block_max(grid.occupied & (labels == 0), factor)  # furniture in a place: no wall
    labels = np.where(occupied, 0, block_max(labels, factor))
    unseen = ~block_max(~grid.unknown, factor).ravel()
    occupied = occupied.ravel()
    width = labels.shape[1]
    flat = np.ascontiguousarray(labels).ravel()
    for down in (True, False):  # a cell and the one below it, a cell and the one to its right
        step = width if down else 1
        at = np.flatnonzero(flat[:-step] != flat[step:])  # an edge is between two labels
        if not down:
            at = at[at % width != width - 1]  # not across the end of a row
        for inner, outer in ((at, at + step), (at + step, at)):
            own = flat[inner]
            edge = (own > 0) & (flat[outer] == 0)
            wall += np.bincount(own[edge & occupied[outer]], minlength=count)
            unknown += np.bincount(own[edge & unseen[outer]], minlength=count)
    wall[0], unknown[0] = wall.sum(), unknown.sum()
    return np.divide(wall, wall + unknown, out=np.ones(count), where=wall + unknown > 0)


def drop_outside(
    conditioned: ConditionedMap, places: NDArray[np.integer], min_wall_share: float = 0.25
) -> ConditionedMap:
    """``conditioned`` without the places (labels of the map's shape) whose edge is less than
    ``min_wall_share`` wall (see the module docstring).

    Only in maps that draw walls as occupied cells (at least 60 % of all the places'
    edges): where walls are drawn grey, as unknown (floor plans read with thresholds that make
    them so), an unknown edge says nothing about the outside, and nothing is dropped.
    """
    share = wall_share(conditioned.grid, places)
    if share[0] < 0.6:
        return conditioned
    low = share < min_wall_share
    low[0] = False
    outside = low[places]
    if not outside.any():
        return conditioned
    dropped = dict(conditioned.dropped)
    dropped["outside"] = dropped.get("outside", 0) + int((conditioned.free & outside).sum())
    return ConditionedMap(
        conditioned.grid,
        conditioned.space & ~outside,
        conditioned.free & ~outside,
        conditioned.clutter & ~outside,
        dropped,
        conditioned.blur,
    )
