"""Rooms seen through their doors whose fans of rays are robot space."""

import numpy as np

from maps.grid import OccupancyGrid
from segmentation.conditioning import condition
from segmentation.coverage import cover
from segmentation.fans import cut_fans, seen_fans


def _corridor_and_fan() -> OccupancyGrid:
    # 0.1 m cells: a corridor 11.6 m long whose wall on the doors' side is seen in pieces
    # (0.8 m of wall, 0.3 m unknown), a door 0.8 m wide in it and the fan of dense rays into
    # the office behind it, bounded by unknown space on its sides, to its far wall 3 m away
    cells = np.full((70, 120), -1, np.int8)
    cells[5, 2:118] = 100
    cells[6:25, 2:118] = 0
    cells[6:25, [2, 117]] = 100
    for start in range(2, 118, 11):
        cells[25, start : start + 8] = 100
    cells[25:27, 36:44] = 0
    rows, cols = np.mgrid[0:70, 0:120]
    cells[(np.abs(cols - 39.5) < 4 + (rows - 26) * 0.35) & (rows >= 25) & (rows < 56)] = 0
    cells[56, 10:70] = 100
    return OccupancyGrid(cells, 0.1)


def test_an_office_seen_in_dense_rays_is_a_region_of_its_own_not_the_corridors():
    grid = _corridor_and_fan()
    conditioned = condition(grid)
    fans = seen_fans(conditioned, np.zeros(grid.shape, bool), 1)
    assert fans.max() == 1 and fans[45, 40] == 1 and fans[15, 40] == 0
    joined = np.where(conditioned.free, 1, 0).astype(np.int32)  # the office in the corridor's
    found = cover(grid, cut_fans(joined, fans), conditioned.clutter)
    assert found.seen_rooms == 1
    assert found.labels[45, 40] != found.labels[15, 40] == found.labels[15, 100]


def test_a_map_with_its_walls_drawn_unknown_has_no_fans():
    # walls as unknown cells (a plan read with thresholds that make them so): an edge on
    # unknown space says nothing about the outside
    cells = _corridor_and_fan().cells.copy()
    cells[cells == 100] = -1
    grid = OccupancyGrid(cells, 0.1)
    assert not seen_fans(condition(grid), np.zeros(grid.shape, bool), 1).any()
