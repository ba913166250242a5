"""A later map of the same building in a moved frame (a SLAM re-run, a loop closure, another
origin): ``TopoMap.update`` lays the previous map where it fits and carries ids onto the same
rooms."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import ndimage

from maps.grid import OccupancyGrid
from maps.registration import Placement
from tests.maps.moves import misplaced, moved
from topomap.cli.evaluate import floor_plans
from topomap.cli.main import main
from topomap.topomap import TopoMap

PLAN = "office_d.yaml"


def ids_at_cores(before: TopoMap, move: Placement, after: TopoMap) -> dict[int, int]:
    """Each previous region's id -> the id of the new region under its innermost cell (the one
    farthest from its border), carried by ``move``."""
    found = {}
    for region in before.regions.ids:
        depth = ndimage.distance_transform_edt(np.pad(before.regions.labels == region, 1))
        row, col = np.unravel_index(np.argmax(depth[1:-1, 1:-1]), before.regions.labels.shape)
        point = move.apply(np.column_stack(before.grid.cell_to_world(row, col)))
        r, c = after.grid.world_to_cell(*point.T)
        found[region] = int(after.regions.labels[r[0], c[0]])
    return found


@pytest.fixture(scope="module")
def snapshots(data_dir):
    """ROSE²'s snapshots 11 and 12 of one exploration (one frame), the first segmented, and
    the second segmented as its later map."""
    plans = {plan.name: plan for plan in floor_plans(data_dir / "rose2_partial")}
    before = TopoMap.from_grid(plans["map11"].grid())
    later = plans["map12"].grid()
    return before, later, before.update(later)


def test_a_later_map_laid_off_by_a_loop_closure_gets_the_ids_it_gets_in_frame(snapshots):
    """Laid 0.4 m off, the previous regions covered other pieces of the later map's partition:
    the frame check let it through (a quarter of the walls in free space) and some ids went to
    other regions."""
    before, later, in_frame = snapshots
    grid, move = moved(later, 0.4, 0.0, 0.0)
    after = before.update(grid)
    assert after.placement is not None
    assert misplaced(after.placement, move, before.grid) < grid.resolution / 2
    assert np.array_equal(after.regions.labels, in_frame.regions.labels)
    assert after.changes == in_frame.changes


@pytest.fixture(scope="module")
def plan(data_dir):
    """An ipa plan (an office floor) segmented."""
    return TopoMap.from_grid(OccupancyGrid.load(data_dir / "ipa" / PLAN))


@pytest.mark.parametrize("dx, dy, degrees", [(0.4, 0.0, 0.0), (3.0, -1.0, 4.0), (-0.3, 0.2, -2.5)])
def test_ids_land_on_the_same_rooms_of_a_moved_map(plan, dx, dy, degrees):
    """Each region's id is found under its innermost cell, carried by the move, in the moved
    map (3 m off and turned 4 degrees, the frame check alone refused it, or carried ids onto
    other rooms); the move is found within a cell and half a degree."""
    before = plan
    grid, move = moved(before.grid, dx, dy, degrees)
    after = before.update(grid)
    assert after.placement is not None
    assert misplaced(after.placement, move, before.grid) < grid.resolution
    assert abs(after.placement.degrees - move.degrees) < 0.5
    assert ids_at_cores(before, move, after) == {r: r for r in before.regions.ids}


def test_segment_previous_records_the_move_and_aligned_skips_it(snapshots, tmp_path, capsys):
    before, later, _ = snapshots
    before.save(tmp_path / "before")
    grid, _ = moved(later, -6.0, 3.5, 0.0)
    grid.save(tmp_path / "moved.yaml")
    argv = ["segment", str(tmp_path / "moved.yaml"), "--previous", str(tmp_path / "before")]
    capsys.readouterr()
    assert main([*argv, "--out", str(tmp_path / "after"), "--no-picture"]) == 0
    laid = json.loads((tmp_path / "after" / "summary.json").read_text())["previous_placement"]
    assert laid == pytest.approx({"x": -6.0, "y": 3.5, "degrees": 0.0}, abs=0.03)
    err = capsys.readouterr().err
    assert f"--previous {tmp_path / 'before'}: laid on this map shifted (-6.00, 3.50) m" in err
    aligned = [*argv, "--previous-aligned", "--out", str(tmp_path / "aligned")]
    assert main(aligned) == 2
    assert "only 38% of the previous map's free cells are free" in capsys.readouterr().err
    assert not (tmp_path / "aligned").exists()
    no_previous = ["segment", str(tmp_path / "moved.yaml"), "--previous-aligned", "--out", "x"]
    assert main(no_previous) == 2
    assert "--previous-aligned needs --previous DIR" in capsys.readouterr().err
