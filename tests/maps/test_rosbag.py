import math
import re
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from maps.errors import LogFormatError, MapFileNotFoundError
from maps.rosbag import read_bag_scans, read_rosbag
from tests.maps.bags import Robot, compose, drift, inverse, map_bag, tf_bag


def _messages(store, increment=0.5, far=False, blind=False):
    t = store.types
    time = t["builtin_interfaces/msg/Time"]
    fields = t["std_msgs/msg/Header"].__dataclass_fields__

    def header(**kwargs):  # ROS 1 headers also carry a sequence number
        return t["std_msgs/msg/Header"](**({"seq": 0} if "seq" in fields else {}), **kwargs)

    scans, poses = [], []
    for i in range(5):
        stamp = time(sec=10 + i, nanosec=500_000_000)
        ranges = np.array([np.nan, -1.0, np.inf] if blind else [1.0, 2.0, np.inf], np.float32)
        scans.append(
            t["sensor_msgs/msg/LaserScan"](
                header=header(stamp=stamp, frame_id="laser"),
                angle_min=-0.5,
                angle_max=0.5,
                angle_increment=increment,
                time_increment=0.0,
                scan_time=0.1,
                range_min=0.1,
                range_max=20.0,
                ranges=ranges,
                intensities=np.zeros(0, np.float32),
            )
        )
    geo = t
    for i in range(7):  # poses at 10, 11, ... 16 s: x = i, yaw = 0.1 i
        yaw, x = 0.1 * i, 5000.0 if far and i == 3 else float(i)
        pose = geo["geometry_msgs/msg/Pose"](
            position=geo["geometry_msgs/msg/Point"](x=x, y=2.0, z=0.0),
            orientation=geo["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
            ),
        )
        poses.append(
            geo["geometry_msgs/msg/PoseStamped"](
                header=header(stamp=time(sec=10 + i, nanosec=0), frame_id="map"), pose=pose
            )
        )
    return scans, poses


def _write(writer, store, ros1, increment=0.5, far=False, blind=False, edit=None):
    scans, poses = _messages(store, increment, far, blind)
    if edit is not None:  # a test's damage to the messages
        edit(scans, poses)
    kwargs = {"typestore": store}
    scan_c = writer.add_connection("/scan", "sensor_msgs/msg/LaserScan", **kwargs)
    pose_c = writer.add_connection("/pose", "geometry_msgs/msg/PoseStamped", **kwargs)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    for msg in poses:
        writer.write(
            pose_c, msg.header.stamp.sec * 10**9, serialize(msg, "geometry_msgs/msg/PoseStamped")
        )
    for msg in scans:
        stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
        writer.write(scan_c, stamp, serialize(msg, "sensor_msgs/msg/LaserScan"))


@pytest.mark.parametrize("ros1", [True, False])
def test_bag_round_trip(tmp_path, ros1):
    if ros1:
        store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "run.bag"
        with Writer1(path) as writer:
            _write(writer, store, True)
    else:
        store, path = get_typestore(Stores.ROS2_HUMBLE), tmp_path / "run"
        with Writer2(path, version=9) as writer:
            _write(writer, store, False)
    frames = read_rosbag(path)
    assert [f.scan_index for f in frames] == [0, 1, 2, 3, 4]
    for i, frame in enumerate(frames):
        assert frame.stamp == pytest.approx(10.5 + i)
        assert frame.pose == pytest.approx((i + 0.5, 2.0, 0.1 * (i + 0.5)))
        assert frame.scan.ranges.tolist() == [1.0, 2.0, math.inf]
        assert frame.scan.angle_increment == 0.5 and frame.scan.range_max == 20.0


def _lengthened(scans, poses):
    """Every orientation ten times as long: the same rotations (tf2 normalises them)."""
    for pose in poses:
        q = pose.pose.orientation
        q.x, q.y, q.z, q.w = (10 * v for v in (q.x, q.y, q.z, q.w))


def test_a_pose_topic_quaternion_of_any_length_is_its_rotation(tmp_path):
    store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "long.bag"
    with Writer1(path) as writer:
        _write(writer, store, True, edit=_lengthened)
    poses = np.array([frame.pose for frame in read_rosbag(path)])
    assert poses == pytest.approx(np.array([(i + 0.5, 2.0, 0.1 * (i + 0.5)) for i in range(5)]))


def test_bad_bags(tmp_path):
    with pytest.raises(MapFileNotFoundError):
        read_rosbag(tmp_path / "missing.bag")
    store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "run.bag"
    with Writer1(path) as writer:
        _write(writer, store, True)
    with pytest.raises(LogFormatError, match="/odom"):
        read_rosbag(path, pose_topic="/odom")
    (tmp_path / "junk.bag").write_bytes(b"not a bag at all")
    with pytest.raises(LogFormatError, match=r"junk\.bag"):
        read_rosbag(tmp_path / "junk.bag")


def _unturned(scans, poses):
    """The fourth pose's orientation all zeros: no rotation."""
    orientation = poses[3].pose.orientation
    orientation.x = orientation.y = orientation.z = orientation.w = 0.0


def _endless(scans, poses):
    """The fourth pose's orientation infinite."""
    poses[3].pose.orientation.w = math.inf


def _overflowing(scans, poses):
    """The last scan stamped 4e9 ns past its second: 4 s later, or a corrupt field."""
    scans[4].header.stamp.nanosec = 4_000_000_000


def _later(scans, poses):
    """The poses stamped 1,000 s after the scans."""
    for pose in poses:
        pose.header.stamp.sec += 1000


@pytest.mark.parametrize(
    ("name", "damage", "shown"),
    [
        ("zero.bag", {"increment": 0.0}, r"zero\.bag.*/scan message 0.*angle_increment"),
        # the pose at 13 s is 5 km off: scan 2 jumps
        ("far.bag", {"far": True}, r"far\.bag.*/scan message 2.*jumps.*message 1"),
        ("blind.bag", {"blind": True}, r"blind\.bag.*5 scans of 15 beams.*no beam"),
        ("still.bag", {"edit": _unturned}, r"still\.bag, field '/pose message 3'.*no rotation"),
        ("endless.bag", {"edit": _endless}, r"endless\.bag, field '/pose message 3'.*no rotation"),
        ("ns.bag", {"edit": _overflowing}, r"ns\.bag, field '/scan message 4'.*nanosec 4000000000"),
        (
            "late.bag",
            {"edit": _later},
            r"late\.bag.*none of the 5 scans \(stamped 10\.5\.\.14\.5 s\)",
        ),
    ],
)
def test_a_damaged_message_is_refused_naming_bag_and_message(tmp_path, name, damage, shown):
    store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / name
    with Writer1(path) as writer:
        _write(writer, store, True, **damage)
    with pytest.raises(LogFormatError, match=shown):
        read_rosbag(path)


# ---------------------------------------------------------------- bags as robots record them
def _wall_distance_in_cells(plan_grid, built):
    """Distance of each occupied cell of ``built`` to the nearest true wall cell, in cells."""
    from scipy import ndimage

    distance = ndimage.distance_transform_edt(~plan_grid.occupied)
    rows, cols = np.nonzero(built.occupied)
    x, y = built.cell_to_world(rows, cols)
    r, c = plan_grid.world_to_cell(x, y)
    inside = plan_grid.contains(r, c)
    assert inside.mean() > 0.99
    return distance[r[inside], c[inside]]


@pytest.fixture(scope="module")
def robot():
    return Robot()


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_tf_bag_walls_within_a_cell(tmp_path, robot, kind):
    from maps import grid_from_keyframes, select_keyframes

    path = tf_bag(tmp_path, kind, robot)
    found = read_bag_scans(path)
    assert found.fixed_frame == "map"
    assert found.chain == ["map", "odom", "base_link", "laser"]
    assert len(found.keyframes) == found.scans == len(robot.scans)
    poses = np.array([k.pose for k in found.keyframes])
    assert np.abs(poses[:, :2] - robot.laser[:, :2]).max() < 0.02
    turn = np.angle(np.exp(1j * (poses[:, 2] - robot.laser[:, 2])))
    assert np.abs(turn).max() < 0.01
    keyframes = select_keyframes(found.keyframes, distance=0.3)
    built = grid_from_keyframes(keyframes, 0.05, max_range=12.0)
    distance = _wall_distance_in_cells(robot.plan.grid, built)
    assert np.quantile(distance, 0.99) <= 1.0
    assert distance.max() <= 2.0

    # the same bag in the odometry frame: the drift bends the walls away from the truth
    in_odom = read_bag_scans(path, fixed_frame="odom")
    assert in_odom.chain == ["odom", "base_link", "laser"]
    drifted = np.array([k.pose for k in in_odom.keyframes])
    assert np.abs(drifted[:, :2] - robot.laser[:, :2]).max() > 0.3


def test_tf_bag_without_map_falls_back_to_odom(tmp_path):
    robot = Robot(with_map_tf=False)
    found = read_bag_scans(tf_bag(tmp_path, "ros1", robot))
    assert found.fixed_frame == "odom"
    assert found.chain == ["odom", "base_link", "laser"]
    expected = compose(inverse(drift(robot.scan_times)), robot.laser)
    poses = np.array([k.pose for k in found.keyframes])
    assert np.abs(poses[:, :2] - expected[:, :2]).max() < 0.02


def test_missing_mount_names_the_transform(tmp_path):
    from maps.errors import TransformError

    path = tf_bag(tmp_path, "sqlite3", Robot(with_mount=False))
    with pytest.raises(TransformError, match=r"robot-sqlite3.*'laser'.*map -> odom") as info:
        read_bag_scans(path)
    assert info.value.source == "laser"
    with pytest.raises(TransformError, match="'nowhere'"):
        read_bag_scans(path, fixed_frame="nowhere")


def _renamed(topic, index, end, name):
    """Rename the parent (``end`` 0) or child (1) of the first transform of ``topic``'s
    message ``index``."""

    def edit(records):
        messages = [m for _, c, m, _ in sorted(records, key=lambda r: r[0]) if c.topic == topic]
        item = messages[index].transforms[0]
        if end == 0:
            item.header.frame_id = name
        else:
            item.child_frame_id = name

    return edit


def _unturned_tf(records):
    """The rotation of /tf message 7's first transform all zeros."""
    rotation = [m for _, c, m, _ in records if c.topic == "/tf"][7].transforms[0].transform.rotation
    rotation.x = rotation.y = rotation.z = rotation.w = 0.0


def _overflowing_tf(records):
    """/tf message 3's first transform stamped a whole second in nanoseconds."""
    item = [m for _, c, m, _ in records if c.topic == "/tf"][3].transforms[0]
    item.header.stamp.nanosec = 1_000_000_000


@pytest.mark.parametrize(
    ("kind", "edit", "shown"),
    [
        ("ros1", _renamed("/tf", 5, 1, ""), r"field '/tf message 5'.*'/odom' -> ''.*empty"),
        ("ros1", _renamed("/tf", 9, 0, ""), r"field '/tf message 9'.*'' -> 'base_link'.*empty"),
        ("mcap", _renamed("/tf", 0, 0, "/"), r"field '/tf message 0'.*'/' -> 'base_link'.*empty"),
        ("ros1", _renamed("/tf_static", 0, 1, ""), r"field '/tf_static message 0'.*empty"),
        ("ros1", _unturned_tf, r"field '/tf message 7'.*rotation \(0\.0, 0\.0, 0\.0, 0\.0\)"),
        ("ros1", _overflowing_tf, r"field '/tf message 3'.*nanosec 1000000000"),
    ],
)
def test_a_malformed_transform_is_refused_naming_bag_topic_and_message(
    tmp_path, robot, kind, edit, shown
):
    """A transform naming an empty frame cannot be chained, like one that is no rotation."""
    from maps.errors import TransformError

    path = tf_bag(tmp_path, kind, robot, edit)
    with pytest.raises(TransformError, match=re.escape(str(path)) + ".*" + shown):
        read_bag_scans(path)


@pytest.mark.parametrize("frame", ["", "/", "//"])
def test_an_empty_fixed_frame_is_refused_naming_the_option(tmp_path, robot, frame):
    path = tf_bag(tmp_path, "ros1", robot)
    with pytest.raises(LogFormatError, match=r"field 'fixed_frame'.*frame name .* is empty"):
        read_bag_scans(path, fixed_frame=frame)


@pytest.mark.parametrize("frame", [5, b"map", ["map"]])
def test_a_fixed_frame_that_is_no_string_is_refused_naming_the_option(tmp_path, frame):
    """Not a name: refused before the bag is opened (it was an AttributeError)."""
    with pytest.raises(LogFormatError, match=r"field 'fixed_frame'.*frame name must be a str"):
        read_bag_scans(tmp_path / "run.bag", fixed_frame=frame)


@pytest.mark.parametrize("ros1", [True, False])
def test_map_from_bag(tmp_path, ros1):
    from maps import OccupancyGrid
    from maps.rosbag import read_rosbag_map

    rng = np.random.default_rng(0)
    grids = [
        OccupancyGrid(rng.choice([-1, 0, 100], size=(30 + i, 40)).astype(np.int8), 0.05, origin)
        for i, origin in enumerate([(1.0, -2.0, 0.0), (-3.5, 4.0, 0.7), (0.25, 0.5, -2.0)])
    ]
    path = map_bag(tmp_path, ros1, grids)
    last = read_rosbag_map(path)
    assert np.array_equal(last.cells, grids[-1].cells)
    assert last.origin == pytest.approx(grids[-1].origin)
    at_two = read_rosbag_map(path, topic="/map", stamp=2.5)
    assert np.array_equal(at_two.cells, grids[1].cells)
    assert at_two.origin == pytest.approx(grids[1].origin)
    with pytest.raises(LogFormatError, match=r"/map.*no map at or before 0.5 s"):
        read_rosbag_map(path, stamp=0.5)
    with pytest.raises(LogFormatError, match="/costmap"):
        read_rosbag_map(path, topic="/costmap")


@pytest.mark.parametrize(("until", "frame"), [(0.3, "odom"), (0.7, "map")])
def test_partial_map_chain(tmp_path, until, frame):
    """map -> odom over part of the run: map while it places at least half as many scans as
    odom (the rest dropped), else odom."""
    robot = Robot(map_tf_until=until)
    found = read_bag_scans(tf_bag(tmp_path, "ros1", robot))
    assert found.fixed_frame == frame
    last = max(t for t in robot.times[::2] if t <= robot.map_tf_until)  # its last message
    placed = sum(t <= last + 0.2 for t in robot.scan_times)  # held 0.2 s past it
    assert len(found.keyframes) == (placed if frame == "map" else len(robot.scans))


def _ros2_bag(tmp_path):
    store, path = get_typestore(Stores.ROS2_HUMBLE), tmp_path / "run"
    with Writer2(path, version=9) as writer:
        _write(writer, store, False)
    return path


def test_a_damaged_sqlite_bag_is_refused_naming_it(tmp_path):
    path = _ros2_bag(tmp_path)
    database = next(path.glob("*.db3"))
    data = database.read_bytes()
    page = len(data) - 4096  # the messages' page: SQLite's own errors came out of rosbags
    refused = 0
    for offset in range(page, len(data), 64):
        database.write_bytes(data[:offset] + b"\xff" * 8 + data[offset + 8 :])
        try:
            read_rosbag(path)
        except LogFormatError as err:
            assert "run: cannot read the bag" in str(err)
            refused += 1
    assert refused > 0


@pytest.mark.parametrize("field", ["nanoseconds", "nanoseconds_since_epoch"])
def test_a_bag_whose_metadata_has_a_field_of_the_wrong_type_is_refused(tmp_path, field):
    path = _ros2_bag(tmp_path)
    metadata = path / "metadata.yaml"
    text = metadata.read_text()
    metadata.write_text(re.sub(rf"\b{field}: \d+", f"{field}: 'x'", text))
    with pytest.raises(LogFormatError, match=r"run: cannot read the bag.*concatenate"):
        read_rosbag(path)


def test_a_ros1_record_claiming_4_gib_is_refused_where_memory_is_short(tmp_path):
    """A corrupt length field makes rosbags allocate it whole: a MemoryError under a limit."""
    store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "run.bag"
    with Writer1(path) as writer:
        _write(writer, store, True)
    data = bytearray(path.read_bytes())
    header = bytes(data[17 : 17 + struct.unpack_from("<I", data, 13)[0]])
    index = struct.unpack("<Q", header[header.index(b"index_pos=") + 10 :][:8])[0]
    struct.pack_into("<I", data, index, 0xFFFFFFF0)  # the first connection record's header
    path.write_bytes(bytes(data))
    code = (
        "import resource, sys\n"
        "from maps.errors import LogFormatError\n"
        "from maps.rosbag import read_rosbag\n"
        "size = int(open('/proc/self/statm').read().split()[0]) * resource.getpagesize()\n"
        "resource.setrlimit(resource.RLIMIT_AS, (size + 2**31, size + 2**31))\n"
        "try:\n"
        "    read_rosbag(sys.argv[1])\n"
        "except LogFormatError as err:\n"
        "    print(err)\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(path)],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=Path(__file__).parents[2],
    )
    assert done.returncode == 0, done.stderr[-300:]
    assert "run.bag: cannot read the bag" in done.stdout


def test_a_bag_map_larger_than_memory_names_the_bag_and_message(tmp_path, monkeypatch):
    from maps import OccupancyGrid, limits
    from maps.errors import MapTooLargeError
    from maps.rosbag import read_rosbag_map

    path = map_bag(tmp_path, False, [OccupancyGrid(np.zeros((30, 40), np.int8), 0.05)])
    monkeypatch.setattr(limits, "max_cells", lambda: 1000)
    with pytest.raises(MapTooLargeError, match=r"maps, field '/map message 0'.*40 x 30 cells"):
        read_rosbag_map(path)
