"""The command line on ROS bags: scans placed by tf, maps read from /map."""

import json

import pytest

from maps.sim.floorplan import generate_floor_plan
from tests.maps.bags import Robot, map_bag, tf_bag
from topomap.cli.main import main
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def robot():
    return Robot()


def test_map_command_reports_the_chain(tmp_path, robot, capsys):
    bag = tf_bag(tmp_path, "mcap", robot)
    assert main(["map", str(bag), "--out", str(tmp_path / "in-map")]) == 0
    err = capsys.readouterr().err
    assert f"{len(robot.scans)} of {len(robot.scans)} scans placed in map" in err
    assert "map -> odom -> base_link -> laser" in err
    assert (tmp_path / "in-map" / "map.yaml").is_file()
    assert main(["map", str(bag), "--out", str(tmp_path / "odom"), "--fixed-frame", "odom"]) == 0
    assert "placed in odom by odom -> base_link -> laser" in capsys.readouterr().err


def test_bag_without_mount_exits_naming_the_transform(tmp_path, capsys):
    bag = tf_bag(tmp_path, "ros1", Robot(with_mount=False))
    assert main(["map", str(bag), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "robot.bag" in err and "'laser'" in err


def test_segment_a_bag_map(tmp_path, capsys):
    grid = generate_floor_plan("flat", random_state=1).grid
    bag = map_bag(tmp_path, False, [grid])
    out = tmp_path / "out"
    assert main(["segment", str(bag), "--map-topic", "/map", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["regions"] == TopoMap.from_grid(grid).graph.number_of_nodes()
    assert (out / "regions.png").is_file()
