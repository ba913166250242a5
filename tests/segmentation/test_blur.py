"""The mapper's blur taken off the walls (segmentation/blur.py)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage
from sklearn.metrics import adjusted_rand_score

from maps.grid import OccupancyGrid
from segmentation.blur import sharpened, wall_band
from segmentation.pipeline import MapSegmenter
from tests.strategies import map_cells


def _room(wall: int, resolution: float = 0.05) -> OccupancyGrid:
    """A room of 80 x 80 cells whose walls are ``wall`` cells thick, unknown outside."""
    cells = np.full((80, 80), -1, np.int8)
    cells[10:70, 10:70] = 100
    cells[10 + wall : 70 - wall, 10 + wall : 70 - wall] = 0
    return OccupancyGrid(cells, resolution)


def test_a_band_four_cells_thick_loses_a_cell_on_each_side_and_a_thinner_one_none():
    assert wall_band(_room(4)) == 4.0 and wall_band(_room(1)) == 1.0
    sharp, blur = sharpened(_room(4))  # 0.2 m: 0.075 m of blur on each side
    assert blur == 1
    ring = np.zeros((80, 80), bool)  # the band's middle cells stay the wall
    ring[11:69, 11:69] = True
    ring[13:67, 13:67] = False
    assert (sharp.occupied == ring).all()
    assert (sharp.free == np.pad(np.ones((54, 54), bool), 13)).all()  # the room a cell larger
    assert (sharp.unknown == ~ring & ~sharp.free).all()  # the outer cell went to the outside
    # a laser's own blur stays: 0.05 m a side or less (three cells of 0.05 m, or of 0.025 m)
    assert sharpened(_room(3))[1] == 0 and sharpened(_room(3, 0.025))[1] == 0
    assert sharpened(_room(7, 0.025))[1] == 3
    # a band thicker than 0.25 m is a wall's own thickness (a drawn plan's outer walls)
    assert wall_band(_room(6)) == 0.0 and sharpened(_room(6))[1] == 0


@settings(max_examples=60, deadline=None)
@given(st.integers(4, 24), st.integers(4, 24), st.data())
def test_sharpening_only_opens_obstacles_and_never_removes_one(
    height: int, width: int, data: st.DataObject
) -> None:
    cells = map_cells(data, height, width)
    grid = OccupancyGrid(cells, 0.05)
    sharp, blur = sharpened(grid)
    assert blur >= 0 and (blur == 0) == (sharp is grid)
    assert not (sharp.occupied & ~grid.occupied).any()  # no cell becomes occupied
    kept = ~grid.occupied
    assert (sharp.cells[kept] == cells[kept]).all()  # free and unknown cells as they were
    pieces, count = ndimage.label(grid.occupied, np.ones((3, 3)))
    assert set(np.unique(pieces[sharp.occupied])) >= set(range(1, count + 1))  # none vanishes


def test_a_slam_map_drawn_with_walls_a_cell_thicker_comes_out_in_the_same_regions(data_dir):
    # ROSE² map7 with every wall a cell thicker: an office's door measured 0.59 m instead of
    # 0.73 m, under the pockets' line, and the office was joined to the corridor
    from topomap.cli.evaluate import floor_plans, thickened

    (plan,) = [p for p in floor_plans(data_dir / "rose2_partial") if p.name == "map7"]
    given_labels = MapSegmenter().segment(plan.grid(), random_state=0).regions.labels
    grown, _ = thickened(plan.grid(), plan.rooms(), 1)
    found = MapSegmenter().segment(grown, random_state=0)
    labels = found.regions.labels
    assert found.conditioned.blur == 1
    both = (given_labels > 0) & (labels > 0)
    assert adjusted_rand_score(given_labels[both], labels[both]) > 0.85  # 0.64 before
    office, corridor = labels[230, 462], labels[290, 462]
    assert office > 0 and corridor > 0 and office != corridor
    assert not (labels[grown.occupied & ~found.conditioned.clutter] > 0).any()  # walls unlabelled
