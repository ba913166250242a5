"""A later, larger map of the same building: TopoMap.update and ``segment --previous``."""

from __future__ import annotations

import json

import networkx as nx
import numpy as np
import pytest

import maps
from maps.grid import OccupancyGrid
from segmentation.errors import ParameterError
from segmentation.growing import MapMismatchError
from topomap.cli.main import main
from topomap.labels import carry_names, find_region
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def building():
    """A generated office and the map of its left 60 % (the rest not yet explored)."""
    plan = maps.generate_floor_plan("office", random_state=1)
    cells = plan.grid.cells.copy()
    cells[:, int(cells.shape[1] * 0.6) :] = -1
    return plan.grid, OccupancyGrid(cells, plan.grid.resolution, plan.grid.origin)


@pytest.fixture(scope="module")
def explored(building):
    whole, part = building
    before = TopoMap.from_grid(part)
    before.rename(before.regions.ids[0], "kitchen")
    return before, before.update(whole)


def test_rooms_the_robot_had_mapped_keep_their_ids_and_names(building, explored):
    part = building[1]
    before, after = explored
    left = int(part.shape[1] * 0.55)  # regions wholly left of the frontier did not change
    unchanged = [
        r for r in before.regions.ids if np.all(np.nonzero(before.regions.labels == r)[1] < left)
    ]
    assert len(unchanged) >= 10
    for region in unchanged:
        mask = before.regions.labels == region
        assert np.bincount(after.regions.labels[mask]).argmax() == region
        if before.graph.nodes[region]["label"] == after.graph.nodes[region]["label"]:
            assert after.graph.nodes[region]["name"] == before.graph.nodes[region]["name"]
    assert after.graph.nodes[before.regions.ids[0]]["name"] == "kitchen"
    names = [n for _, n in after.graph.nodes(data="name")]
    assert len(names) == len(set(names))


def test_new_rooms_get_ids_no_region_had_and_every_change_is_an_event(explored):
    before, after = explored
    created = [e["region"] for e in after.changes if e["event"] in ("created", "split")]
    assert created and min(created) >= before.next_id
    assert after.next_id > max(after.regions.ids)
    listed = {e["region"] for e in after.changes if e["event"] != "removed"}
    assert listed == set(after.regions.ids)


def test_the_next_id_survives_save_and_load(explored, tmp_path):
    _, after = explored
    after.save(tmp_path / "saved")
    assert TopoMap.load(tmp_path / "saved").next_id == after.next_id


def test_a_carried_name_written_otherwise_is_no_other_region_s_name_too():
    previous, graph = nx.Graph(), nx.Graph()
    previous.add_node(1, label="corridor", name="Aisle 2", name_given=True)
    graph.add_node(1, label="room", name="room 1")
    graph.add_node(2, label="corridor", name="corridor 2")  # the name queries read "Aisle 2" as
    carry_names(graph, previous)
    assert dict(graph.nodes(data="name")) == {1: "Aisle 2", 2: "corridor 1"}
    assert find_region(graph, "corridor 2") == 1


def test_a_map_of_another_building_is_refused_and_one_with_coarser_cells_laid_on_it(explored):
    before, _ = explored
    other = maps.generate_floor_plan("flat", random_state=5).grid
    with pytest.raises(MapMismatchError, match=r"free cells .* \(laid where it fits best: "):
        before.update(other)
    coarse = OccupancyGrid(before.grid.cells[1::2, ::2], 2 * before.grid.resolution)
    after = before.update(coarse)  # cells twice as large, its origin at the frame's
    assert after.placement is not None
    assert (after.placement.x, after.placement.y) == pytest.approx((0.5, 0.5), abs=0.1)
    kept = [e["region"] for e in after.changes if e["event"] == "kept"]
    assert len(kept) >= 0.8 * len(before.regions.ids)


def test_segment_previous_writes_changes_and_refuses_an_incomplete_folder(
    building, tmp_path, capsys
):
    whole, part = building
    part.save(tmp_path / "part.yaml")
    whole.save(tmp_path / "whole.yaml")
    assert main(["segment", str(tmp_path / "part.yaml"), "--out", str(tmp_path / "a")]) == 0
    before = json.loads((tmp_path / "a" / "summary.json").read_text())["names"]
    argv = ["segment", str(tmp_path / "whole.yaml"), "--out", str(tmp_path / "b")]
    assert main([*argv, "--previous", str(tmp_path / "a")]) == 0
    changes = json.loads((tmp_path / "b" / "changes.json").read_text())
    kept = [e["region"] for e in changes if e["event"] == "kept"]
    after = json.loads((tmp_path / "b" / "summary.json").read_text())["names"]
    assert len(kept) >= 10 and sum(after[str(r)] == before[str(r)] for r in kept) >= 10
    other = maps.generate_floor_plan("flat", random_state=5).grid
    other.save(tmp_path / "other.yaml")
    capsys.readouterr()
    other_argv = ["segment", str(tmp_path / "other.yaml"), "--out", str(tmp_path / "c")]
    assert main([*other_argv, "--previous", str(tmp_path / "a")]) == 2
    assert f"--previous {tmp_path / 'a'}: only" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()
    (tmp_path / "a" / "graph.graphml").unlink()
    capsys.readouterr()
    assert main([*argv, "--previous", str(tmp_path / "a"), "--force"]) == 2
    assert "graph.graphml" in capsys.readouterr().err
    assert json.loads((tmp_path / "b" / "changes.json").read_text()) == changes  # untouched


def test_the_same_building_in_another_frame_is_laid_back_on_it(explored):
    """Shifted 3.3 m and -1.7 m, the office's rooms still overlap themselves (88 % of the free
    cells stay free) but its walls lie in its rooms: laid back where its walls fit, each region
    keeps its id."""
    before, _ = explored
    grid = before.grid
    x, y, yaw = grid.origin
    shifted = OccupancyGrid(grid.cells, grid.resolution, (x + 3.3, y - 1.7, yaw))
    after = before.update(shifted)
    assert after.placement is not None
    assert after.placement.as_dict() == {"x": 3.3, "y": -1.7, "degrees": 0.0}
    assert np.array_equal(after.regions.labels, before.regions.labels)
    assert {e["event"] for e in after.changes} == {"kept"}
    with pytest.raises(MapMismatchError, match="walls lie in this one's free space"):
        before.update(shifted, aligned=True)
    with pytest.raises(ParameterError, match="aligned must be True or False, got 'no'"):
        before.update(shifted, aligned="no")
