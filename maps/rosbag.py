"""Reader for laser scans and poses in ROS 1 and ROS 2 bags, through the ``rosbags`` package."""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np

from maps.errors import InvalidScanError, LogFormatError, MapFileNotFoundError
from maps.scan import Keyframe, LaserScan

log = logging.getLogger(__name__)

SCAN_TYPE = "sensor_msgs/msg/LaserScan"
POSE_TYPES = (
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
)


def _pick_topic(
    topics: dict[str, str], wanted: tuple[str, ...], given: str | None, path: Path
) -> str:
    matching = sorted(name for name, kind in topics.items() if kind in wanted)
    if given is not None:
        if topics.get(given) not in wanted:
            found = topics.get(given, "absent")
            raise LogFormatError(
                f"topic {given!r} is {found}, expected one of {wanted}; candidates: {matching}",
                path=path,
                field="topic",
            )
        return given
    if len(matching) != 1:
        raise LogFormatError(
            f"{'no' if not matching else 'several'} topics of type {wanted}: {matching}; name one",
            path=path,
            field="topic",
        )
    return matching[0]


def _stamp(message: Any) -> float:
    stamp = message.header.stamp
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def _pose_of(message: Any) -> tuple[float, float, float]:
    pose = message.pose
    if hasattr(pose, "pose"):  # Odometry and PoseWithCovarianceStamped wrap a covariance
        pose = pose.pose
    q = pose.orientation
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
    return float(pose.position.x), float(pose.position.y), yaw


def read_rosbag(
    path: str | Path, *, scan_topic: str | None = None, pose_topic: str | None = None
) -> list[Keyframe]:
    """Read laser scans and the poses they were taken at from a ROS 1 or ROS 2 bag.

    Parameters
    ----------
    path
        A ROS 1 ``.bag`` file or a ROS 2 bag directory.
    scan_topic, pose_topic
        Topics to read; when omitted, the bag's only sensor_msgs/LaserScan topic and its only
        nav_msgs/Odometry, geometry_msgs/PoseStamped or PoseWithCovarianceStamped topic.

    Returns
    -------
    list of Keyframe
        Scans in bag order with poses interpolated at their header stamps (linear in x, y and
        unwrapped yaw); ``scan_index`` counts all scans on the topic from 0. Scans stamped
        outside the span of the poses are dropped (logged), since their pose is unknown.
        Poses are taken as the laser's pose in the map frame.

    Raises
    ------
    MapFileNotFoundError
        If the bag does not exist.
    LogFormatError
        If the bag cannot be read, or the topics are missing or ambiguous.
    """
    from rosbags.highlevel import AnyReader, AnyReaderError
    from rosbags.typesys import Stores, get_typestore

    path = Path(path)
    if not path.exists():
        raise MapFileNotFoundError(path, "ROS bag")
    store = Stores.ROS1_NOETIC if path.suffix == ".bag" else Stores.LATEST
    scans: list[tuple[float, LaserScan]] = []
    poses: list[tuple[float, tuple[float, float, float]]] = []
    try:
        with AnyReader([path], default_typestore=get_typestore(store)) as reader:
            topics = {c.topic: c.msgtype for c in reader.connections}
            scan_name = _pick_topic(topics, (SCAN_TYPE,), scan_topic, path)
            pose_name = _pick_topic(topics, POSE_TYPES, pose_topic, path)
            wanted = [c for c in reader.connections if c.topic in (scan_name, pose_name)]
            for connection, _, raw in reader.messages(connections=wanted):
                message = reader.deserialize(raw, connection.msgtype)
                if connection.topic == scan_name:
                    try:
                        scan = _scan_of(message)
                    except InvalidScanError as err:
                        field = f"{scan_name} message {len(scans)}"
                        raise LogFormatError(str(err), path=path, field=field) from err
                    scans.append((_stamp(message), scan))
                else:
                    poses.append((_stamp(message), _pose_of(message)))
    except AnyReaderError as err:
        raise LogFormatError(f"cannot read the bag ({err})", path=path) from err
    if not poses:
        raise LogFormatError("the pose topic has no messages", path=path, field="pose_topic")
    poses.sort(key=lambda item: item[0])
    times = np.array([t for t, _ in poses])
    xyz = np.array([p for _, p in poses])
    xyz[:, 2] = np.unwrap(xyz[:, 2])
    frames = []
    for index, (stamp, scan) in enumerate(scans):
        if not times[0] <= stamp <= times[-1]:
            continue
        pose = tuple(float(np.interp(stamp, times, xyz[:, k])) for k in range(3))
        frames.append(Keyframe(pose, scan, scan_index=index, stamp=stamp))  # type: ignore[arg-type]
    if len(frames) < len(scans):
        log.info("%s: dropped %d scans stamped outside the poses", path, len(scans) - len(frames))
    return frames


def _scan_of(message: Any) -> LaserScan:
    return LaserScan(
        np.asarray(message.ranges, dtype=float),
        float(message.angle_min),
        float(message.angle_increment),
        float(message.range_min),
        float(message.range_max),
    )
