"""The ROS 2 bag export, read back with rosbags and checked against the TopoMap."""

import errno
import itertools
from pathlib import Path

import numpy as np
import pytest
import shapely
from rosbags.highlevel import AnyReader

from maps.errors import OutputExistsError, OutputWriteError
from maps.grid import OccupancyGrid
from maps.sim.floorplan import generate_floor_plan
from planners.route_graph import building_route_graph
from topomap.errors import ExportError
from topomap.graph_layout import edge_segments, label_colour
from topomap.topomap import TopoMap

TYPES = {
    "/topomap/map": "nav_msgs/msg/OccupancyGrid",
    "/topomap/regions": "sensor_msgs/msg/Image",
    "/topomap/markers": "visualization_msgs/msg/MarkerArray",
    "/topomap/route_graph": "visualization_msgs/msg/MarkerArray",
    "/topomap/path_0": "nav_msgs/msg/Path",
}
STAMP = 1_700_000_000.25


@pytest.fixture(scope="module")
def topo():
    plan = generate_floor_plan((16.0, 12.0), random_state=3)
    return TopoMap.from_grid(plan.grid, random_state=3)


def _read(path):
    """topic -> (message type, bag time, message, QoS durability) of every message."""
    found = {}
    with AnyReader([Path(path)]) as reader:
        for connection, stamp, raw in reader.messages():
            assert connection.topic not in found  # one message per topic
            qos = connection.ext.offered_qos_profiles
            found[connection.topic] = (
                connection.msgtype,
                stamp,
                reader.deserialize(raw, connection.msgtype),
                [q.durability.name for q in qos],
            )
    return found


def _xy(points):
    return [(p.x, p.y) for p in points]


def _by(markers, ns):
    return {m.id: m for m in markers if m.ns == ns}


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_bag_reads_back_into_the_same_map_regions_names_doors_and_graph(topo, tmp_path, storage):
    names = {r: topo.graph.nodes[r]["name"] for r in topo.graph.nodes}
    path = topo.planner(0.2).plan(
        (topo.graph.nodes[1]["x"], topo.graph.nodes[1]["y"]), max(topo.graph.nodes)
    )
    out = topo.to_rosbag(tmp_path / "lab.mcap", storage=storage, paths=[path], stamp=STAMP)
    suffix = "mcap" if storage == "mcap" else "db3"
    assert sorted(p.name for p in out.iterdir()) == ["lab_0." + suffix, "metadata.yaml"]
    found = _read(out)
    assert {topic: v[0] for topic, v in found.items()} == TYPES
    for _, stamp, message, durability in found.values():
        assert stamp == round(STAMP * 1e9) and durability == ["TRANSIENT_LOCAL"]
        headers = [message.header] if hasattr(message, "header") else []
        headers += [m.header for m in getattr(message, "markers", [])]
        headers += [p.header for p in getattr(message, "poses", [])]
        for header in headers:
            assert header.frame_id == "map"
            assert header.stamp.sec + header.stamp.nanosec * 1e-9 == pytest.approx(STAMP)

    grid = OccupancyGrid.from_msg_fields(found["/topomap/map"][2])
    assert np.array_equal(grid.cells, topo.grid.cells) and grid.origin == topo.grid.origin
    assert grid.resolution == pytest.approx(topo.grid.resolution, rel=1e-7)  # a float32 field
    image = found["/topomap/regions"][2]
    assert (image.encoding, image.width, image.height) == ("mono16", *topo.grid.shape[::-1])
    labels = np.frombuffer(image.data.tobytes(), "<u2").reshape(image.height, image.width)
    assert np.array_equal(labels[::-1], topo.regions.labels)  # row 0 at the origin

    markers = found["/topomap/markers"][2].markers
    texts = _by(markers, "region_name")
    assert {r: m.text for r, m in texts.items()} == names
    for region, marker in texts.items():
        node = topo.graph.nodes[region]
        assert (marker.pose.position.x, marker.pose.position.y) == (node["x"], node["y"])
        assert marker.type == marker.TEXT_VIEW_FACING
    for region, marker in _by(markers, "region_outline").items():
        polygon = topo.regions.polygons[region]
        ring = list(polygon.exterior.coords)
        edges = set(itertools.pairwise(ring))
        ends = _xy(marker.points)
        assert marker.type == marker.LINE_LIST
        assert set(zip(ends[::2], ends[1::2], strict=True)) >= edges  # every vertex, in order
    for region, marker in _by(markers, "region_fill").items():
        corners = np.array(_xy(marker.points)).reshape(-1, 3, 2)
        area = sum(shapely.Polygon(t).area for t in corners)
        assert area == pytest.approx(topo.regions.polygons[region].area, rel=1e-6)
        label = topo.graph.nodes[region]["label"]
        assert (marker.color.r, marker.color.g, marker.color.b) == pytest.approx(
            label_colour(label)
        )
    doors = _by(markers, "doors")
    for k, (_, _, transitions) in enumerate(sorted(topo.graph.edges(data="doors"))):
        expected = [tuple(end) for t in transitions for end in (t.start, t.end)]
        assert _xy(doors[k].points) == expected
    segments = _xy(_by(markers, "graph_edges")[0].points)
    assert segments == [end for _, s in edge_segments(topo.graph) for end in s]
    for _, _, transitions in topo.graph.edges(data="doors"):
        assert tuple(transitions[0].centre) in segments  # each edge runs through its door

    route = building_route_graph(topo.planner(0.2))
    nodes = _by(found["/topomap/route_graph"][2].markers, "route_nodes")
    for k, kind in enumerate(["door", "region", "corner"]):
        expected = [(d["x"], d["y"]) for _, d in sorted(route.nodes(data=True))]
        expected = [xy for (n, d), xy in zip(sorted(route.nodes(data=True)), expected, strict=True)
                    if d["metadata"]["kind"] == kind]  # fmt: skip
        assert _xy(nodes[k].points) == expected
    lines = _xy(_by(found["/topomap/route_graph"][2].markers, "route_edges")[0].points)
    assert len(lines) == route.number_of_edges()  # both directions drawn once

    poses = found["/topomap/path_0"][2].poses
    assert [(p.pose.position.x, p.pose.position.y) for p in poses] == [
        tuple(xy) for xy in path.waypoints.tolist()
    ]


def test_bag_is_never_overwritten_unasked_and_errors_leave_nothing(topo, tmp_path, monkeypatch):
    out = topo.to_rosbag(tmp_path / "bag", stamp=0.0)
    before = (out / "bag_0.mcap").read_bytes()
    with pytest.raises(OutputExistsError):
        topo.to_rosbag(out)
    assert (out / "bag_0.mcap").read_bytes() == before
    with pytest.raises(ExportError, match="storage 'zip'"):
        topo.to_rosbag(tmp_path / "other", storage="zip")
    monkeypatch.setattr("topomap.rosbag_export.MAX_MARKER_POINTS", 10)
    with pytest.raises(ExportError, match="more than 10 points"):
        topo.to_rosbag(tmp_path / "huge")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]  # no half-written folder


def test_a_full_disk_is_a_typed_error_and_leaves_nothing(topo, tmp_path, monkeypatch):
    from rosbags.rosbag2 import Writer

    def full(self, connection, timestamp, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Writer, "write", full)
    with pytest.raises(OutputWriteError, match="bag: No space left on device") as caught:
        topo.to_rosbag(tmp_path / "bag")
    assert caught.value.errno == errno.ENOSPC
    assert list(tmp_path.iterdir()) == []
