import math

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from maps.errors import LogFormatError, MapFileNotFoundError
from maps.rosbag import read_bag_scans, read_rosbag


def _messages(store, increment=0.5):
    t = store.types
    time = t["builtin_interfaces/msg/Time"]
    fields = t["std_msgs/msg/Header"].__dataclass_fields__

    def header(**kwargs):  # ROS 1 headers also carry a sequence number
        return t["std_msgs/msg/Header"](**({"seq": 0} if "seq" in fields else {}), **kwargs)

    scans, poses = [], []
    for i in range(5):
        stamp = time(sec=10 + i, nanosec=500_000_000)
        ranges = np.array([1.0, 2.0, np.inf], np.float32)
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
        yaw = 0.1 * i
        pose = geo["geometry_msgs/msg/Pose"](
            position=geo["geometry_msgs/msg/Point"](x=float(i), y=2.0, z=0.0),
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


def _write(writer, store, ros1, increment=0.5):
    scans, poses = _messages(store, increment)
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


def test_bad_scan_message_names_bag_and_message(tmp_path):
    store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "zero.bag"
    with Writer1(path) as writer:
        _write(writer, store, True, increment=0.0)
    with pytest.raises(LogFormatError, match=r"zero\.bag.*/scan message 0.*angle_increment"):
        read_rosbag(path)


# ---------------------------------------------------------------- bags as robots record them
MOUNT = (0.3, 0.0, 0.4)  # the laser: 0.3 m ahead of base_link, turned 0.4 rad


def _compose(a, b):
    """Pose ``b`` given in a frame at pose ``a``, in ``a``'s parent frame (arrays (n, 3))."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack(
        (
            a[:, 0] + c * b[:, 0] - s * b[:, 1],
            a[:, 1] + s * b[:, 0] + c * b[:, 1],
            a[:, 2] + b[:, 2],
        )
    )


def _inverse(a):
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack((-c * a[:, 0] - s * a[:, 1], s * a[:, 0] - c * a[:, 1], -a[:, 2]))


def _drift(t):
    """map -> odom: the odometry has drifted 0.6 m and 0.25 rad by the end of the run."""
    u = (np.asarray(t) - 10.0) / 40.0
    return np.column_stack((0.5 * u, -0.35 * u, 0.25 * u))


class _Robot:
    """A robot wandering through the generated flat: odometry at 20 Hz drifting against the
    map, map -> odom at 10 Hz, the laser's static mount, scans between odometry messages."""

    def __init__(self, with_map_tf=True, with_mount=True):
        from maps import LaserModel, generate_floor_plan, simulate_scans, wander

        self.plan = generate_floor_plan("flat", random_state=0)
        route = wander(self.plan.grid, self.plan.labels, random_state=0)
        base = np.array(route.poses[::3], float)[:800]
        base[:, 2] = np.unwrap(base[:, 2])
        self.times = 10.0 + 0.05 * np.arange(len(base))
        self.odom = _compose(_inverse(_drift(self.times)), base)  # base_link in odom
        self.scan_times = self.times[:-1:2] + 0.025
        true_base = np.column_stack(
            [np.interp(self.scan_times, self.times, base[:, k]) for k in range(3)]
        )
        self.laser = _compose(true_base, np.tile(MOUNT, (len(true_base), 1)))
        model = LaserModel(fov=2 * math.pi * 359 / 360, beams=360, max_range=12.0)
        frames = simulate_scans(self.plan.grid, self.laser, model, random_state=0)
        self.scans = [frame.scan for frame in frames]
        self.with_map_tf, self.with_mount = with_map_tf, with_mount

    def write(self, writer, store, ros1):
        t = store.types
        header_fields = t["std_msgs/msg/Header"].__dataclass_fields__
        serialize = store.serialize_ros1 if ros1 else store.serialize_cdr

        def time(seconds):
            sec = math.floor(seconds)
            return t["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((seconds - sec) * 1e9))

        def header(seconds, frame):
            seq = {"seq": 0} if "seq" in header_fields else {}
            return t["std_msgs/msg/Header"](**seq, stamp=time(seconds), frame_id=frame)

        def transform(seconds, parent, child, pose):
            x, y, yaw = (float(v) for v in pose)
            return t["geometry_msgs/msg/TransformStamped"](
                header=header(seconds, parent),
                child_frame_id=child,
                transform=t["geometry_msgs/msg/Transform"](
                    translation=t["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.2),
                    rotation=t["geometry_msgs/msg/Quaternion"](
                        x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
                    ),
                ),
            )

        tf_type, scan_type = "tf2_msgs/msg/TFMessage", "sensor_msgs/msg/LaserScan"
        tf = writer.add_connection("/tf", tf_type, typestore=store)
        scan_c = writer.add_connection("/scan", scan_type, typestore=store)
        records = []
        if self.with_mount:
            static = writer.add_connection("/tf_static", tf_type, typestore=store)
            mount = t[tf_type](transforms=[transform(10.0, "base_link", "laser", MOUNT)])
            records.append((10.0, static, mount, tf_type))
        for i, stamp in enumerate(self.times):
            parts = [transform(stamp, "/odom", "base_link", self.odom[i])]
            if self.with_map_tf and i % 2 == 0:
                parts.append(transform(stamp, "map", "odom", _drift(stamp)[0]))
            records.append((stamp, tf, t[tf_type](transforms=parts), tf_type))
        for stamp, scan in zip(self.scan_times, self.scans, strict=True):
            message = t[scan_type](
                header=header(stamp, "laser"),
                angle_min=scan.angle_min,
                angle_max=scan.angle_min + scan.angle_increment * (len(scan) - 1),
                angle_increment=scan.angle_increment,
                time_increment=0.0,
                scan_time=0.1,
                range_min=scan.range_min,
                range_max=scan.range_max,
                ranges=scan.ranges.astype(np.float32),
                intensities=np.zeros(0, np.float32),
            )
            records.append((stamp + 0.001, scan_c, message, scan_type))
        for stamp, connection, message, kind in sorted(records, key=lambda r: r[0]):
            writer.write(connection, round(stamp * 1e9), serialize(message, kind))


def _tf_bag(tmp_path, kind, robot):
    """Write ``robot``'s run as a ROS 1 bag, a ROS 2 sqlite3 bag or a ROS 2 MCAP bag."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.typesys import get_types_from_msg

    if kind == "ros1":
        store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "robot.bag"
        # the Noetic store lacks tf2_msgs; a recorder embeds each type's definition anyway
        text = "geometry_msgs/TransformStamped[] transforms"
        store.register(get_types_from_msg(text, "tf2_msgs/msg/TFMessage"))
        with Writer1(path) as writer:
            robot.write(writer, store, True)
        return path
    store, path = get_typestore(Stores.ROS2_HUMBLE), tmp_path / f"robot-{kind}"
    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as writer:
        robot.write(writer, store, False)
    return path


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
    return _Robot()


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_tf_bag_walls_within_a_cell(tmp_path, robot, kind):
    from maps import grid_from_keyframes, select_keyframes

    path = _tf_bag(tmp_path, kind, robot)
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
    robot = _Robot(with_map_tf=False)
    found = read_bag_scans(_tf_bag(tmp_path, "ros1", robot))
    assert found.fixed_frame == "odom"
    assert found.chain == ["odom", "base_link", "laser"]
    expected = _compose(_inverse(_drift(robot.scan_times)), robot.laser)
    poses = np.array([k.pose for k in found.keyframes])
    assert np.abs(poses[:, :2] - expected[:, :2]).max() < 0.02


def test_missing_mount_names_the_transform(tmp_path):
    from maps.errors import TransformError

    path = _tf_bag(tmp_path, "sqlite3", _Robot(with_mount=False))
    with pytest.raises(TransformError, match=r"robot-sqlite3.*'laser'.*map -> odom") as info:
        read_bag_scans(path)
    assert info.value.source == "laser"
    with pytest.raises(TransformError, match="'nowhere'"):
        read_bag_scans(path, fixed_frame="nowhere")


def _map_bag(tmp_path, ros1, grids):
    """A bag with ``grids`` published on /map at 1, 2, 3... s."""
    from rosbags.rosbag2 import StoragePlugin

    kind = "nav_msgs/msg/OccupancyGrid"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    t = store.types
    header_fields = t["std_msgs/msg/Header"].__dataclass_fields__

    def build(fields, name):  # the message type ``name`` filled from a plain dict of fields
        cls = t[name]
        values = {}
        for key in cls.__dataclass_fields__:
            if key == "__msgtype__":
                continue
            value = fields[key]
            if key == "data":
                value = np.asarray(value, np.int8)
            elif isinstance(value, dict):
                value = build(value, _field_type(name, key))
            values[key] = value
        return cls(**values)

    def _field_type(name, key):
        return {
            ("nav_msgs/msg/OccupancyGrid", "header"): "std_msgs/msg/Header",
            ("nav_msgs/msg/OccupancyGrid", "info"): "nav_msgs/msg/MapMetaData",
            ("std_msgs/msg/Header", "stamp"): "builtin_interfaces/msg/Time",
            ("nav_msgs/msg/MapMetaData", "map_load_time"): "builtin_interfaces/msg/Time",
            ("nav_msgs/msg/MapMetaData", "origin"): "geometry_msgs/msg/Pose",
            ("geometry_msgs/msg/Pose", "position"): "geometry_msgs/msg/Point",
            ("geometry_msgs/msg/Pose", "orientation"): "geometry_msgs/msg/Quaternion",
        }[name, key]

    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    path = tmp_path / ("maps.bag" if ros1 else "maps")
    writer = Writer1(path) if ros1 else Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer:
        connection = writer.add_connection("/map", kind, typestore=store)
        for second, grid in enumerate(grids, start=1):
            fields = grid.to_msg_fields(stamp=float(second))
            if "seq" in header_fields:
                fields["header"]["seq"] = second
            writer.write(connection, second * 10**9, serialize(build(fields, kind), kind))
    return path


@pytest.mark.parametrize("ros1", [True, False])
def test_map_from_bag(tmp_path, ros1):
    from maps import OccupancyGrid
    from maps.rosbag import read_rosbag_map

    rng = np.random.default_rng(0)
    grids = [
        OccupancyGrid(rng.choice([-1, 0, 100], size=(30 + i, 40)).astype(np.int8), 0.05, origin)
        for i, origin in enumerate([(1.0, -2.0, 0.0), (-3.5, 4.0, 0.7), (0.25, 0.5, -2.0)])
    ]
    path = _map_bag(tmp_path, ros1, grids)
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
