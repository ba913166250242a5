"""Grid benchmark maps of square rooms joined by one-cell doors, in the style of the Moving AI
'room' maps (Sturtevant, "Benchmarks for Grid-Based Pathfinding", 2012): a square grid divided
into square rooms by walls one cell thick, each wall between two neighbouring rooms with one
door one cell wide at a random position."""

from __future__ import annotations

import itertools

import numpy as np

from maps.errors import InvalidMapError
from maps.grid import FREE, OCCUPIED, OccupancyGrid
from maps.seeding import RandomState, as_generator

#: Room sizes of the Moving AI room maps, cells from wall to wall.
ROOM_SIZES = (8, 16, 32)


def generate_rooms(
    size: int = 512,
    room: int = 16,
    *,
    resolution: float = 0.5,
    random_state: RandomState = None,
) -> OccupancyGrid:
    """A ``size`` x ``size`` grid of square rooms ``room`` cells apart, walls one cell thick,
    one door one cell wide at a random position in each wall between two rooms.

    Walls lie on the rows and columns whose index is a multiple of ``room`` and on the last
    row and column, so a room is ``room - 1`` cells across (the last row and column of rooms
    ``room - 2`` when ``size`` is a multiple of ``room``). Every room reaches every other.

    Parameters
    ----------
    size
        Cells along each side (at least 3).
    room
        Cells from one wall to the next (at least 3, at most ``size - 1``).
    resolution
        Cell size, metres. A disc robot passes a one-cell door when its radius is below half
        a cell (the rule of :meth:`OccupancyGrid.inflate`): 0.5 m cells for a 0.2 m disc.
    random_state
        Seed or Generator; the same seed gives the same doors.

    Raises
    ------
    InvalidMapError
        ``size``, ``room`` or ``resolution`` out of range, named with its value.

    Examples
    --------
    >>> grid = generate_rooms(16, 8, random_state=0)
    >>> grid.cells.shape, grid.resolution
    ((16, 16), 0.5)
    >>> rooms = generate_rooms(512, 16, random_state=0)
    >>> int((rooms.cells[16, 1:16] == 0).sum())  # the wall between the first two rooms
    1
    """
    if isinstance(size, bool) or not isinstance(size, int | np.integer) or size < 3:
        raise InvalidMapError(f"a rooms map must be at least 3 cells across, got {size!r}")
    if isinstance(room, bool) or not isinstance(room, int | np.integer) or not 3 <= room < size:
        raise InvalidMapError(f"room size must lie in [3, {size - 1}] cells, got {room!r}")
    if not (np.isfinite(resolution) and resolution > 0):
        raise InvalidMapError(f"resolution must be > 0 metres, got {resolution}")
    rng = as_generator(random_state)
    cells = np.full((size, size), FREE, np.int8)
    walls = [*range(0, size - 1, room), size - 1]
    cells[walls, :] = OCCUPIED
    cells[:, walls] = OCCUPIED
    spans = list(itertools.pairwise(walls))  # rooms along one axis
    for wall in walls[1:-1]:  # an inner wall line, across every span of rooms
        for lo, hi in spans:
            if hi - lo < 2:
                continue
            door = int(rng.integers(lo + 1, hi))
            cells[wall, door] = FREE  # between the rooms above and below
            door = int(rng.integers(lo + 1, hi))
            cells[door, wall] = FREE  # between the rooms left and right
    return OccupancyGrid(cells, resolution)
