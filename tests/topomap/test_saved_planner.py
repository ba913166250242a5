"""The planner saved with the regions: `TopoMap.save` writes those made, the first
`topomap plan --regions` keeps the one it prepared, `TopoMap.load` and later calls reuse it,
and a stale one is rebuilt with a message, never used."""

import json
import logging
import shutil

import numpy as np

from maps.sim.floorplan import generate_floor_plan
from topomap.cli.main import main
from topomap.saving import door_graph_name
from topomap.topomap import TopoMap


def _path(out):
    """The path of `topomap plan`'s output, without its timings."""
    found = json.loads(out)
    return found["waypoints"], found["regions"]


def _saved(folder, seed=4):
    topo = TopoMap.from_grid(generate_floor_plan("office", random_state=seed).grid, random_state=0)
    topo.planner(0.2)  # a planner made: saved with the regions
    topo.save(folder)
    return topo


def test_save_writes_the_planner_and_load_reuses_it(tmp_path):
    topo = _saved(tmp_path / "saved")
    assert (tmp_path / "saved" / "door_graph_r0.2.npz").is_file()
    again = TopoMap.load(tmp_path / "saved")
    planner = again.planner(0.2)
    assert planner.restored
    assert not again.planner(0.3).restored  # none saved for this robot: built
    expected = topo.planner(0.2).plan(1, max(topo.graph.nodes))
    found = planner.plan(1, max(topo.graph.nodes))
    assert np.array_equal(found.waypoints, expected.waypoints)
    # the saved door graph is a cache: not listed among the files whose digests are checked
    about = json.loads((tmp_path / "saved" / "topomap.json").read_text())
    assert door_graph_name(0.2) not in about["files"]


def test_a_door_graph_of_other_regions_is_rebuilt_with_a_warning(tmp_path, caplog):
    _saved(tmp_path / "a", seed=4)
    other = _saved(tmp_path / "b", seed=5)
    name = door_graph_name(0.2)
    shutil.copy(tmp_path / "a" / name, tmp_path / "b" / name)  # another map's planner
    with caplog.at_level(logging.WARNING, logger="topomap.saving"):
        planner = TopoMap.load(tmp_path / "b").planner(0.2)
    assert not planner.restored
    assert (
        "another map or other regions" in caplog.text
        and "preparing the planner again" in caplog.text
    )
    goal = max(other.graph.nodes)
    assert planner.plan(1, goal).regions[-1] == goal


def test_plan_keeps_the_planner_it_prepared_and_reuses_it(tmp_path, capsys, caplog):
    assert main(["generate", "--size", "flat", "--seed", "3", "--out", str(tmp_path / "g")]) == 0
    yaml = str(tmp_path / "g" / "map.yaml")
    seg = tmp_path / "seg"
    assert main(["segment", yaml, "--out", str(seg), "--no-picture"]) == 0
    assert not (seg / door_graph_name(0.2)).exists()  # segmenting stays fast
    capsys.readouterr()
    plan = ["plan", yaml, "--regions", str(seg), "--start", "1", "--goal", "2"]
    assert main(plan) == 0
    first = capsys.readouterr()
    assert f"kept the prepared planner in {seg / door_graph_name(0.2)}" in first.err
    assert main(plan) == 0
    second = capsys.readouterr()
    assert "preparing the planner" not in second.err  # reused, not rebuilt
    assert _path(second.out) == _path(first.out)
    assert main([*plan, "--robot-radius", "0.25"]) == 0
    built = capsys.readouterr()
    assert "preparing the planner for a 0.25 m robot" in built.err
    assert f"kept the prepared planner in {seg / door_graph_name(0.25)}" in built.err
    assert main([*plan, "--robot-radius", "0.25"]) == 0
    again = capsys.readouterr()
    assert "preparing the planner" not in again.err
    assert _path(again.out) == _path(built.out)
    # a damaged door graph: a warning, the planner prepared again and kept
    (seg / door_graph_name(0.25)).write_bytes(b"damaged")
    with caplog.at_level(logging.WARNING, logger="topomap.saving"):
        assert main([*plan, "--robot-radius", "0.25"]) == 0
    repaired = capsys.readouterr()
    assert "not a door graph file" in caplog.text and "kept the prepared planner" in repaired.err
    assert _path(repaired.out) == _path(built.out)


def test_plan_reads_the_folders_own_map_once_and_refuses_another_map(tmp_path, capsys, monkeypatch):
    from maps.grid import OccupancyGrid

    _saved(tmp_path / "seg")
    reads = []
    load = OccupancyGrid.load.__func__
    monkeypatch.setattr(
        OccupancyGrid, "load", classmethod(lambda c, p: reads.append(p) or load(c, p))
    )
    own = str(tmp_path / "seg" / "map.yaml")
    plan = ["plan", "--regions", str(tmp_path / "seg"), "--start", "1", "--goal", "2"]
    assert main(["-q", plan[0], own, *plan[1:]]) == 0
    assert len(reads) == 1  # the folder's map, read by TopoMap.load alone
    capsys.readouterr()
    other = generate_floor_plan("office", random_state=5).grid.save(tmp_path / "other.yaml")
    assert main(["-q", plan[0], str(other), *plan[1:]]) == 2
    assert "holds the regions of another map" in capsys.readouterr().err


def test_an_edited_door_graph_is_rebuilt_not_trusted(tmp_path, caplog):
    topo = _saved(tmp_path / "saved")
    path = tmp_path / "saved" / door_graph_name(0.2)
    with np.load(path) as found:
        arrays = {name: found[name] for name in found.files}
    np.savez_compressed(path, **{**arrays, "labels": np.zeros_like(arrays["labels"])})
    with caplog.at_level(logging.WARNING, logger="topomap.saving"):
        planner = TopoMap.load(tmp_path / "saved").planner(0.2)
    assert not planner.restored and "checksum" in caplog.text
    goal = max(topo.graph.nodes)
    assert planner.plan(1, goal).regions == topo.planner(0.2).plan(1, goal).regions
