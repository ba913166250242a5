"""Maps moved as a SLAM re-run moves them, and how far a found move is off."""

from __future__ import annotations

import numpy as np

from maps.grid import UNKNOWN, OccupancyGrid
from maps.registration import Placement
from topomap.cli.evaluate import rotated


def moved(
    grid: OccupancyGrid, dx: float, dy: float, degrees: float
) -> tuple[OccupancyGrid, Placement]:
    """``grid`` turned ``degrees`` about its centre (nearest cell) and shifted ``(dx, dy)``
    metres, and the move that lays ``grid`` on it."""
    cells = rotated(grid.cells, degrees, UNKNOWN)
    res, (x, y, _) = grid.resolution, grid.origin
    centre = np.array([x, y]) + np.array(grid.shape[::-1]) * res / 2
    origin = centre - np.array(cells.shape[::-1]) * res / 2 + (dx, dy)
    offset = centre - Placement(0.0, 0.0, degrees).apply(centre[None])[0] + (dx, dy)
    return OccupancyGrid(cells, res, (*origin, 0.0)), Placement(*offset, degrees)


def misplaced(found: Placement, move: Placement, grid: OccupancyGrid) -> float:
    """Metres the farthest corner of ``grid`` laid by ``found`` lies from where ``move`` lays
    it."""
    xmin, ymin, xmax, ymax = grid.bounds()
    corners = np.array([[xmin, ymin], [xmin, ymax], [xmax, ymin], [xmax, ymax]])
    return float(np.hypot(*(found.apply(corners) - move.apply(corners)).T).max())
