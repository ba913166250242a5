"""Every building cell covered; rooms seen only through their doors apart."""

import numpy as np

from maps.grid import OccupancyGrid
from segmentation.coverage import cover


def test_a_room_seen_through_a_diagonal_door_is_a_region_of_its_own():
    # 0.05 m cells: a room the robot drove through, a wall at 45 degrees with a door 1.84 m
    # wide along it, a room behind it nobody entered. Counted cell by cell, the door's
    # stepped edge reads wider than double doors; measured jamb to jamb it is a door.
    n = 240
    r, c = np.mgrid[0:n, 0:n]
    inside = (r > 2) & (c > 2) & (r < n - 3) & (c < n - 3)
    wall = (r + c >= 238) & (r + c <= 241)
    free = inside & (~wall | ((c >= 100) & (c < 126)))
    labels = np.where(free & (r + c < 238), 1, 0).astype(np.int32)
    found = cover(OccupancyGrid.from_masks(free, 0.05), labels, np.zeros_like(free))
    assert found.seen_rooms == 1
    assert found.labels[200, 200] != found.labels[50, 50] == 1
