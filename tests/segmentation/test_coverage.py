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


def test_the_free_cells_round_a_table_join_the_room_they_are_in():
    # 0.1 m cells: a 4 m room with a 1 m table in it (clutter), the regions stopping 0.2 m
    # short of it. The ring round the table opens onto the room over less than double doors
    # and the table's edges are long beside it; a table is no wall, so it is no room.
    free = np.zeros((42, 42), bool)
    free[1:41, 1:41] = True
    table = np.zeros_like(free)
    table[16:26, 16:26] = True
    free &= ~table
    labels = np.where(free, 1, 0).astype(np.int32)
    labels[14:28, 14:28] = 0
    found = cover(OccupancyGrid.from_masks(free, 0.1), labels, table)
    assert found.seen_rooms == 0
    assert (found.labels[14:28, 14:28] == 1).all()


def test_a_strip_of_rays_along_a_corridor_wall_is_no_room():
    # 0.05 m cells: a corridor the robot drove along, its wall broken over 0.45 m, and
    # behind the break a strip 0.65 m by 13 m that the rays reached, ended by walls on
    # every side. It opens onto the corridor like a door and shows walls like a room, but
    # it is 20 times as long as wide: the corridor's own rays, not a room.
    free = np.zeros((60, 310), bool)
    free[10:41, 5:300] = True  # the corridor
    free[41:43, 100:109] = True  # the break in its wall
    free[43:56, 20:280] = True  # the strip behind it
    labels = np.where(free, 1, 0).astype(np.int32)
    labels[41:] = 0
    found = cover(OccupancyGrid.from_masks(free, 0.05), labels, np.zeros_like(free))
    assert found.seen_rooms == 0
    assert (found.labels[43:56, 20:280] == 1).all()


def test_rooms_seen_through_doors_on_a_map_of_fine_cells(data_dir):
    # ACES's log mapped on 0.025 m cells: its walls are a cell per ray, unknown cells between.
    # Counted in those cells they were 40 % of its places' edges, the map was taken for one
    # that draws its walls grey, no fan of rays out into unmapped space was dropped and no
    # fan into an office was a room seen through its door; measured on 0.05 m blocks, they are.
    from segmentation.pipeline import MapSegmenter
    from topomap.cli.label_sources import carmen_map

    _, grid = carmen_map(data_dir / "carmen" / "aces-corrected.log.gz", 0.025)
    found = MapSegmenter().segment(grid, random_state=0)
    assert found.conditioned.dropped["outside"] > 0
    assert found.coverage.seen_rooms >= 2
