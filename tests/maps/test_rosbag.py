import math

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from maps.errors import LogFormatError, MapFileNotFoundError
from maps.rosbag import read_rosbag


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
