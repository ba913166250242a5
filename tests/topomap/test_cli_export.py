"""`topomap export`: route graphs and a ROS 2 bag from a map and its saved regions."""

import json
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader

from maps.sim.floorplan import generate_floor_plan
from planners.nav2_route import read_nav2_route
from topomap.cli.main import main
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    plan = generate_floor_plan((16.0, 12.0), random_state=1)
    plan.grid.save(folder / "map.yaml")
    topo = TopoMap.from_grid(plan.grid, random_state=1)
    topo.save(folder / "regions")
    return folder, topo, ["export", str(folder / "map.yaml"), "--regions", str(folder / "regions")]


def test_export_route_graphs_from_saved_regions(saved, tmp_path, capsys):
    _, topo, arguments = saved
    out, fine = tmp_path / "route.geojson", tmp_path / "planner.geojson"
    assert main([*arguments, "--nav2-route", str(out), "--planner-graph", str(fine)]) == 0
    printed = capsys.readouterr().out
    graph = read_nav2_route(out)
    kinds = [meta["kind"] for _, meta in graph.nodes(data="metadata")]
    assert f"{kinds.count('door')} door nodes" in printed
    assert set(kinds) == {"door", "region", "corner"} and graph.number_of_edges() > 0
    names = {d["metadata"].get("name") for _, d in graph.nodes(data=True)}
    assert {topo.graph.nodes[r]["name"] for r in topo.graph.nodes} <= names
    portals = [d["metadata"]["kind"] for _, d in read_nav2_route(fine).nodes(data=True)]
    assert portals.count("portal") > kinds.count("door")
    assert main([*arguments, "--nav2-route", str(out)]) == 2  # never overwritten unasked
    assert json.loads(out.read_text())["type"] == "FeatureCollection"


def test_export_rosbag_with_a_planned_path(saved, tmp_path, capsys):
    _, topo, arguments = saved
    bag = tmp_path / "lab.mcap"
    first, last = (topo.graph.nodes[r]["name"] for r in (min(topo.graph), max(topo.graph)))
    assert main([*arguments, "--rosbag", str(bag), "--path", first, last]) == 0
    assert "1 paths" in capsys.readouterr().out
    with AnyReader([Path(bag)]) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
    assert topics["/topomap/path_0"] == "nav_msgs/msg/Path" and len(topics) == 5
    assert main([*arguments, "--rosbag", str(bag)]) == 2  # exists: refused before any work
    assert main([*arguments, "--rosbag", str(tmp_path / "b"), "--storage", "sqlite3"]) == 0
    assert (tmp_path / "b" / "b_0.db3").is_file()


def test_export_needs_an_output(saved, capsys):
    _, _, arguments = saved
    assert main(arguments) == 2
    assert "give --nav2-route" in capsys.readouterr().err
    assert main([*arguments, "--nav2-route", "x.geojson", "--path", "1", "2"]) == 2
    assert "--rosbag" in capsys.readouterr().err
