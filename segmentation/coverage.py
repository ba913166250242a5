"""Every cell of the building in a region: furniture, thin rays and rooms seen through doors.

The regions are found in the robot's space (free cells a robot disc fits in, clutter counted as
free). People draw more: a room's furniture, the free cells between chairs, the laser rays that
reach into it. :func:`cover` gives each such cell the region it belongs to:

- the *building* is every free cell of the map and every clutter cell (free-standing
  obstacles that fit in ``clutter_size``, :func:`~segmentation.conditioning.find_clutter`);
- a piece of building left without a region (8-connected) that is at least ``min_area``,
  opens onto the regions over at most a door's width (the span of the cells where it meets
  them, jamb to jamb, :func:`opening_spans`) and shows walls (its cells beside occupied
  cells that are not clutter, where its rays ended: furniture is no wall) at least
  :data:`WALLS_SHOWN` times as long as that opening, and at most :data:`ROOM_ASPECT` times
  as long as wide (:func:`aspects`), is a room seen through its door (a fan of rays into an
  office nobody entered): a region of its own. Rays out through a window into unmapped space
  end on no wall, a pocket of a room behind its furniture or round a table meets the room
  over more than the walls it shows, and a strip of rays along a wall is long and thin: they
  join the room they leave from;
- every other cell joins the region it reaches first through the building (grown a ring at
  a time, :func:`~segmentation.working.grow`): the furniture of a room joins the room, a ray
  joins the room it leaves from.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.grid import OccupancyGrid
from segmentation.distinct import label_counts, nonzero_cells
from segmentation.regions import consecutive
from segmentation.working import ALL_AROUND, grow

#: The widest door (double doors), metres: a leftover piece meeting the regions over more
#: than this is not a room seen through a door.
DOOR_WIDTH = 2.0
#: A room seen through its door shows at least this many times the door's width of wall (the
#: far and side walls its rays reached, which the view widens past the door). On the ROSE²
#: maps every such room showed 3.4 times or more (tenth percentile) and the pieces that were
#: not rooms (ray fans out of windows, pockets behind furniture) 2.0 times or less (third
#: quartile): 2 keeps every room.
WALLS_SHOWN = 2.0
#: A room seen through its door is at most this many times as long as it is wide (the sides
#: of its smallest rectangle). A longer piece is a strip of rays along a wall, seen through
#: the wall's breaks: the room it lies in is the one it opens onto. Rooms are rarely over 2.5
#: times as long as wide; their fans of rays, which stop at furniture, widen that: on the
#: ROSE² maps every room so seen was 4.7 times or less, every such strip 5.0 or more.
ROOM_ASPECT = 5.0


@dataclass(frozen=True)
class Coverage:
    """The covered labels and what the covering did (counted in ``summary.json``)."""

    labels: NDArray[np.int32]
    filled_cells: int
    seen_rooms: int
    #: Pockets joined to the space they open onto (:mod:`segmentation.pockets`).
    pockets: int = 0


def cover(
    grid: OccupancyGrid,
    labels: NDArray[np.integer],
    clutter: NDArray[np.bool_],
    *,
    min_area: float = 1.0,
    door_width: float = DOOR_WIDTH,
) -> Coverage:
    """Regions ``labels`` (of ``grid``'s shape) grown over every building cell (see the module
    docstring).

    Examples
    --------
    >>> free = np.zeros((12, 30), bool)
    >>> free[1:11, 1:12] = True  # a room the robot drove through
    >>> free[5:7, 12:15] = True  # its door
    >>> free[1:11, 15:29] = True  # a room seen only through the door
    >>> labels = np.zeros((12, 30), np.int32)
    >>> labels[1:11, 1:12] = 1
    >>> clutter = np.zeros_like(free)
    >>> found = cover(OccupancyGrid.from_masks(free, 0.1), labels, clutter)
    >>> found.labels[3, 3], found.labels[5, 13], found.labels[3, 20], found.seen_rooms
    (np.int32(1), np.int32(2), np.int32(2), 1)

    The door's cells went with the room seen through it.
    """
    building = grid.free | clutter | (labels > 0)
    left = building & (labels == 0)
    seeds = labels.astype(np.int32, copy=True)
    seen = 0
    if left.any():
        pieces, count = ndimage.label(left, structure=np.ones((3, 3)))
        area = label_counts(pieces, count + 1) * grid.resolution**2
        touching = cv2.dilate((labels > 0).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        contact = np.bincount(pieces[touching & left], minlength=count + 1) * grid.resolution
        large = area >= min_area
        span = opening_spans(pieces, touching & left & large[pieces], count) * grid.resolution
        fixed = grid.occupied & ~clutter  # furniture is no wall: a pocket round it is no room
        walls = cv2.dilate(fixed.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
        beside = pieces[walls & left & ~clutter]
        shown = np.bincount(beside, minlength=count + 1) * grid.resolution
        rooms = large & (span <= door_width) & (shown >= WALLS_SHOWN * contact)
        rooms[0] = False
        rooms[rooms] = aspects(pieces, np.flatnonzero(rooms)) <= ROOM_ASPECT
        seen = int(rooms.sum())
        if seen:
            new_id = np.zeros(count + 1, np.int32)
            new_id[rooms] = int(seeds.max(initial=0)) + 1 + np.arange(seen, dtype=np.int32)
            seeds = np.where(rooms[pieces], new_id[pieces], seeds)
    grown = consecutive(grow(seeds, building, ALL_AROUND))  # the cost follows the cells filled
    return Coverage(grown, int(((grown > 0) & (labels == 0)).sum()), seen)


def opening_spans(
    pieces: NDArray[np.integer], contact: NDArray[np.bool_], count: int
) -> NDArray[np.float64]:
    """How wide each of the ``count`` labelled ``pieces`` opens onto its neighbours, in cells:
    the span (largest distance, plus a cell) of its ``contact`` cells, as a door's width is
    measured from jamb to jamb. The count of the touching cells reads a double door as wider
    than 2 m (its corner cells touch too) and a diagonal opening up to 1.4 times its width;
    it stays the measure of how long a piece meets the regions, against the walls it shows.

    Examples
    --------
    >>> pieces = np.array([[1, 1, 1, 0], [0, 0, 0, 2]])
    >>> contact = np.array([[True, False, True, False], [False, False, False, True]])
    >>> opening_spans(pieces, contact, 2).tolist()
    [0.0, 3.0, 1.0]
    """
    spans = np.zeros(count + 1)
    rows, cols = nonzero_cells(contact)
    which = pieces[rows, cols]
    order = np.argsort(which, kind="stable")
    rows, cols, which = rows[order], cols[order], which[order]
    starts = np.searchsorted(which, np.arange(count + 2))
    for piece in np.flatnonzero(np.diff(starts[1:]) > 0) + 1:
        at = slice(starts[piece], starts[piece + 1])
        points = np.column_stack([cols[at], rows[at]]).astype(np.int32)
        hull = cv2.convexHull(points).reshape(-1, 2).astype(np.float64)
        gaps = hull[:, None, :] - hull[None, :, :]
        spans[piece] = float(np.sqrt((gaps**2).sum(axis=2).max())) + 1.0
    return spans


def aspects(pieces: NDArray[np.integer], which: NDArray[np.integer]) -> NDArray[np.float64]:
    """How many times as long as wide each of the labelled ``pieces`` in ``which`` is: the
    sides of the smallest rectangle round its cells (:func:`cv2.minAreaRect`), a cell wide
    at least.

    Examples
    --------
    >>> pieces = np.zeros((10, 30), np.int32)
    >>> pieces[1:3, 1:29] = 1  # a strip 2 x 28 cells
    >>> pieces[4:9, 5:10] = 2  # a square of 5 x 5
    >>> aspects(pieces, np.array([1, 2])).round(1).tolist()
    [14.0, 1.0]
    """
    boxes = ndimage.find_objects(pieces)
    found = np.ones(len(which))
    for i, piece in enumerate(which.tolist()):
        rows, cols = np.nonzero(pieces[boxes[piece - 1]] == piece)
        points = np.column_stack([cols, rows]).astype(np.float32)
        _, sides, _ = cv2.minAreaRect(points)
        found[i] = (max(sides) + 1.0) / (min(sides) + 1.0)
    return found
