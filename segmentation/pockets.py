"""Pockets: regions open to the rest of the building only through gaps narrower than a door,
or too small to be a room.

A room is entered through a door, and the narrowest doors built (closets, WC stalls) are
:data:`NARROWEST_DOOR` wide. A region whose every opening onto other regions is narrower (its
clear width, the widest disc that crosses it:
:attr:`~segmentation.transitions.Transition.passable`, and what a map's cells take off it,
:data:`SHORT_BY`) is no room: it is a pocket of the
space it opens onto, reached between furniture or a cluttered wall's breaks, and people draw
it as part of that space. So is a region the robot can enter that is smaller than the
smallest room people draw that a robot can enter (:data:`SMALLEST_ROOM`): a corner of a
furnished room parted from the rest by its desks. :func:`join_pockets` joins each to the
neighbour across its widest opening.
"""

from __future__ import annotations

from collections.abc import Collection

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from maps.grid import OccupancyGrid
from segmentation.distinct import label_counts
from segmentation.regions import relabelled
from segmentation.transitions import find_transitions

#: The narrowest door, metres: door leaves of closets and WC stalls are 0.6-0.7 m. An opening
#: is narrower for certain when even its widest reading (:data:`SHORT_BY`) is: on the ipa and
#: ROSE² maps (0.05 m cells) every room's widest opening measured 0.65 m or more (a furnished
#: plan's door), every pocket's 0.55 m or less, so 0.6 m as measured there.
NARROWEST_DOOR = 0.7
#: Cells by which a clear width measured on a map may fall short of the opening: a jamb's
#: cell is occupied wherever a beam ended in it, so each jamb may stand a cell into the
#: opening. A door measures 0.1-0.15 m less on a 0.1 m map than on a 0.05 m map of the same
#: building (ROSE²'s maps, ``topomap eval segment --resolutions``).
SHORT_BY = 2.0
#: The smallest room a robot can enter, square metres (its cells: floor, furniture and the rays
#: in it): the smallest room with robot space that people drew on the ipa plans is a 2.25 m^2
#: closet, on ROSE²'s maps 2.7 m^2 (their smaller rooms, 0.5-2.5 m^2, are seen through doors:
#: the robot fits in none). A region of the robot's space under this, entered through an
#: opening wider than the robot, is a piece of a room: on the logs' maps, corners of furnished
#: rooms behind desks (1.4-2.0 m^2, openings 0.6-0.9 m).
SMALLEST_ROOM = 2.0


def join_pockets(
    grid: OccupancyGrid,
    labels: NDArray[np.integer],
    candidates: Collection[int],
    door: float = NARROWEST_DOOR,
    robot_radius: float = 0.0,
    smallest: float = SMALLEST_ROOM,
) -> tuple[NDArray[np.int32], int]:
    """``labels`` with every pocket among ``candidates`` joined to the neighbour across its
    widest opening, when that neighbour is larger, and the number of regions so lost. An
    opening's width is its clear width on ``grid``'s cells and :data:`SHORT_BY` cells: a
    region is a pocket when its widest opening is wide enough for a robot of
    ``robot_radius`` metres (the planner's rule) and either every opening is narrower than
    ``door`` for certain or the region covers less than ``smallest`` square metres. A space
    the robot cannot enter is a room seen through its door (on a coarse map, where the rays
    through a door fill the cells behind it), not a pocket it reaches between furniture.

    Only the ``candidates`` (the regions of the robot's space) may be pockets: a room seen
    through its door (:func:`~segmentation.coverage.cover`) is a room, however narrow the
    door's gap the laser saw it through. A pocket joins a larger space (a chain of pockets
    ends in the largest); regions that touch no other keep their label.

    Examples
    --------
    >>> free = np.zeros((10, 20), bool)
    >>> free[1:9, 1:12] = True  # a room
    >>> free[3:8, 13:18] = True  # a pocket behind furniture ...
    >>> free[5, 12] = True  # ... reached through a 0.1 m gap
    >>> grid = OccupancyGrid.from_masks(free, 0.1)
    >>> labels = np.where(free, 1, 0)
    >>> labels[:, 12:] *= 2
    >>> joined, count = join_pockets(grid, labels, candidates={1, 2})
    >>> np.unique(joined[free]).tolist(), count
    ([1], 1)

    A 1 x 1.5 m corner behind a desk, open over 0.8 m (wider than a closet's door), is too
    small to be a room:

    >>> free = np.zeros((40, 60), bool)
    >>> free[1:39, 1:39] = True  # a 3.8 x 3.8 m room ...
    >>> free[11:26, 41:51] = True  # ... a 1 x 1.5 m corner ...
    >>> free[14:22, 39:41] = True  # ... open over 0.8 m
    >>> labels = np.where(free, 1, 0)
    >>> labels[:, 40:] *= 2
    >>> joined, count = join_pockets(OccupancyGrid.from_masks(free, 0.1), labels, {1, 2})
    >>> np.unique(joined[free]).tolist(), count
    ([1], 1)
    """
    widest: dict[int, tuple[float, int]] = {}
    for opening in find_transitions(grid, labels):
        for region, other in ((opening.a, opening.b), (opening.b, opening.a)):
            if opening.passable > widest.get(region, (-1.0, 0))[0]:
                widest[region] = (opening.passable, other)
    sizes = label_counts(np.asarray(labels))
    short = SHORT_BY * grid.resolution
    least = smallest / grid.resolution**2  # cells
    pockets = {
        region: other
        for region, (width, other) in widest.items()
        if 2 * robot_radius < width
        and (width < door - short or sizes[region] < least)
        and region in candidates
        and sizes[region] < sizes[other]
    }
    if not pockets:
        return np.asarray(labels, np.int32), 0
    target = np.arange(len(sizes))
    for group in _chains(pockets, len(sizes)):
        target[group] = max(group, key=lambda region: (sizes[region], -region))
    lost = (target != np.arange(len(sizes))) & (sizes > 0)
    return relabelled(labels, target), int(lost[1:].sum())


def _chains(pockets: dict[int, int], count: int) -> list[list[int]]:
    """The regions joined through ``pockets`` (a pocket and the region it joins, of ids below
    ``count``; at least one), group by group: the connected pieces of those links."""
    regions, others = np.array(list(pockets.items())).T
    links = sparse.coo_matrix((np.ones(len(regions)), (regions, others)), shape=(count, count))
    _, piece = connected_components(links, directed=False)
    groups: dict[int, list[int]] = {}
    for region in sorted({*regions.tolist(), *others.tolist()}):
        groups.setdefault(int(piece[region]), []).append(region)
    return list(groups.values())
