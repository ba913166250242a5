"""Rooms seen through their doors whose rays merged into robot space.

A room nobody entered shows in a map as the fan of rays the laser sent into it through its
door. Thin fans are no robot space: :func:`~segmentation.coverage.cover` finds them left
without a region and makes a room of its own of each that passes its test. Where the rays are
dense (a room seen many times, or the map's cells 0.1 m, so that every ray is a cell wide)
the fan is robot space a robot's disc fits in: the clearance basin of the corridor it was seen
from runs into it, and the room joins the corridor's region. :func:`seen_fans` finds such
fans, to be put through the same test:

- the robot space is cut into basins of its clearance measured to the walls alone (the
  occupied cells that are no clutter, and the closed wall gaps): unknown space, which bounds
  a fan on its sides, is no wall, so the room behind a door rises to a peak of its own and
  the basins meet at the door, the narrowest passage between walls;
- a basin whose edge is less than :data:`FAN_WALL_SHARE` wall (the rest unknown space) is
  part of a fan; touching ones are one fan (a room's fan splits where a desk narrows it);
- a fan that opens onto the rest of the robot space over at least a door
  (:data:`~segmentation.pockets.NARROWEST_DOOR`: a corner of a room behind furniture opens
  over less) and passes the cover's test for a room seen through its door
  (:func:`~segmentation.coverage.seen_rooms`) is one.

Only in maps that draw their walls as occupied cells
(:data:`~segmentation.conditioning.WALLS_DRAWN`), as for the drop of places outside.
:func:`cut_fans` takes such fans out of the regions they joined when they are a small part
of them, for the cover to test again with their thin rays.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from segmentation.conditioning import WALLS_DRAWN, ConditionedMap, wall_share
from segmentation.coverage import DOOR_WIDTH, seen_rooms
from segmentation.pockets import NARROWEST_DOOR
from segmentation.refine import PLACE_DEPTH, basins
from segmentation.working import pool, unpool

#: A basin of the walls' clearance whose edge is less than this share wall (the rest unknown
#: space) is part of a fan of rays. Measured with the cover's test after it (2026-12-07):
#: 0.5 / 0.6 gave the maps built from the CARMEN logs MCC 0.455 / 0.450 (0.429 without),
#: ROSE²'s maps as given 0.801 / 0.801 (0.802), on 0.1 m cells 0.647 / 0.677 (0.631).
FAN_WALL_SHARE = 0.6
#: A fan is taken out of the region it joined only when it is at most this share of it (a
#: room seen from a corridor): a part of a room that is a region of its own stays with it,
#: and so does a corridor's dead end (a third of its region on ROSE²'s map3).
FAN_OF_REGION = 0.25


def seen_fans(
    conditioned: ConditionedMap,
    closed: NDArray[np.bool_],
    factor: int,
    *,
    phase: tuple[int, int] = (0, 0),
    depth: float = PLACE_DEPTH,
    min_area: float = 1.0,
    door_width: float = DOOR_WIDTH,
) -> NDArray[np.int32]:
    """The fans of robot space that are rooms seen through their doors (labels of the map's
    shape, 0 elsewhere; see the module docstring), found on the working grid of ``factor``
    and ``phase`` (:func:`~segmentation.working.pool`) with the wall gaps ``closed``; ``depth``
    as for the places
    (:func:`~segmentation.refine.basins`). ``tests/segmentation/test_fans.py`` draws one.
    """
    grid = conditioned.grid
    walls = (grid.occupied & ~conditioned.clutter) | closed
    free = conditioned.space & ~closed
    space = pool(free, grid, factor, fine_clearance=True, phase=phase, open_cells=~walls)
    pieces = unpool(basins(space, depth), factor, conditioned.space, phase)
    share = wall_share(grid, pieces)
    if share[0] < WALLS_DRAWN:
        return np.zeros(grid.shape, np.int32)
    open_edge = share < FAN_WALL_SHARE
    open_edge[0] = False
    fans, count = ndimage.label(open_edge[pieces], structure=np.ones((3, 3)))
    rest = conditioned.space & (fans == 0)
    rooms, span = seen_rooms(grid, fans, count, rest, conditioned.clutter, min_area, door_width)
    rooms &= span >= NARROWEST_DOOR
    ids = np.where(rooms, np.cumsum(rooms), 0).astype(np.int32)
    return ids[fans]


def cut_fans(labels: NDArray[np.integer], fans: NDArray[np.integer]) -> NDArray[np.int32]:
    """``labels`` (regions) without the ``fans`` (:func:`seen_fans`) that are at most
    :data:`FAN_OF_REGION` of the region most of their cells are in, nor the pieces of that
    region they cut off from its largest one: the cover tests them.

    Examples
    --------
    >>> labels = np.ones((4, 10), np.int32)
    >>> fans = np.zeros((4, 10), np.int32)
    >>> fans[:, 8] = 1  # a fan in a corridor cuts its end off
    >>> cut_fans(labels, fans)[0].tolist()
    [1, 1, 1, 1, 1, 1, 1, 1, 0, 0]
    >>> fans[:, 3:8] = 1  # half the region: it stays
    >>> cut_fans(labels, fans)[0].tolist()
    [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]
    """
    cut = labels.astype(np.int32, copy=True)
    for fan in range(1, int(fans.max(initial=0)) + 1):
        cells = fans == fan
        under = labels[cells]
        under = under[under > 0]
        if len(under) == 0:
            continue
        region = labels == np.bincount(under).argmax()
        if (cells & region).sum() > FAN_OF_REGION * region.sum():
            continue
        parts, count = ndimage.label(region & ~cells, structure=np.ones((3, 3)))
        if count > 1:
            largest = np.bincount(parts.ravel())[1:].argmax() + 1
            cells |= (parts > 0) & (parts != largest)
        cut[cells] = 0
    return cut
