"""Readers for ROS 1 and ROS 2 bags, through the ``rosbags`` package: laser scans placed by the
tf tree (REP-105) or by a pose topic, and nav_msgs/OccupancyGrid maps."""

from __future__ import annotations

import itertools
import logging
import sqlite3
import struct
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from maps.errors import (
    InvalidMapError,
    InvalidScanError,
    LogFormatError,
    MapFileNotFoundError,
    MapTooLargeError,
    TopomapError,
    TransformError,
)
from maps.grid import OccupancyGrid
from maps.limits import no_valid_beam, pose_jump
from maps.scan import Keyframe, LaserScan
from maps.tf import TOLERANCE, TransformTree, frame_problem, is_rotation, yaw_from_quaternion

log = logging.getLogger(__name__)

SCAN_TYPE = "sensor_msgs/msg/LaserScan"
POSE_TYPES = (
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
)
TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
MAP_TYPE = "nav_msgs/msg/OccupancyGrid"
#: Fixed frames tried in turn when none is given (REP-105: map is drift-free, odom continuous).
FIXED_FRAMES = ("map", "odom")


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


#: Nanoseconds in a second: a header stamp's ``nanosec`` lies below it.
NANOSECONDS = 1_000_000_000


def _stamp(message: Any) -> float:
    """The header stamp in seconds; a ``nanosec`` of a second or more (a corrupt field, or a
    converter's whole stamp in nanoseconds) is refused, not read as seconds later."""
    stamp = message.header.stamp
    if not 0 <= stamp.nanosec < NANOSECONDS:
        raise InvalidScanError(f"header stamp nanosec {stamp.nanosec} is not below {NANOSECONDS}")
    return float(stamp.sec) + 1e-9 * float(stamp.nanosec)


def _pose_of(message: Any) -> tuple[float, float, float]:
    pose = message.pose
    if hasattr(pose, "pose"):  # Odometry and PoseWithCovarianceStamped wrap a covariance
        pose = pose.pose
    q = pose.orientation
    quaternion = (float(q.x), float(q.y), float(q.z), float(q.w))
    if not is_rotation(*quaternion):
        raise InvalidScanError(f"orientation {quaternion} is no rotation")
    return float(pose.position.x), float(pose.position.y), yaw_from_quaternion(*quaternion)


@dataclass(frozen=True)
class BagScans:
    """Scans read from a bag and how they were placed.

    Attributes
    ----------
    keyframes
        The placed scans, poses of the laser in :attr:`fixed_frame`.
    fixed_frame
        The frame the poses are in (``"map"``, ``"odom"``...; the pose topic's frame when
        placed by a pose topic).
    chain
        How: the frames from the fixed frame to the laser (``["map", "odom", "base_link",
        "laser"]``), or ``[pose_topic]``.
    scans
        Scans on the topic; those not placed (no transform or pose at their stamp) were dropped.
    """

    keyframes: list[Keyframe]
    fixed_frame: str
    chain: list[str]
    scans: int

    def describe(self) -> str:
        """One line: how many scans were placed, and by what.

        Examples
        --------
        >>> BagScans([], "odom", ["odom", "base_link", "laser"], 0).describe()
        '0 of 0 scans placed in odom by odom -> base_link -> laser'
        """
        return (
            f"{len(self.keyframes)} of {self.scans} scans placed in {self.fixed_frame} by "
            + " -> ".join(self.chain)
        )


#: What rosbags and its deserialisers raise on a corrupt or truncated bag (besides their own
#: ReaderError, AnyReaderError and SerdeError), found by cutting and flipping bytes of bags and
#: their metadata.yaml: a ROS 2 bag's SQLite database raises sqlite3's (or apsw's) errors, a
#: metadata field of the wrong type a TypeError, and a ROS 1 record whose length field is
#: corrupt makes rosbags read (allocate) up to 4 GiB at once, a MemoryError when that is more
#: than this process may have.
_CORRUPT = (
    AssertionError,
    EOFError,
    IndexError,
    KeyError,
    MemoryError,
    OSError,
    OverflowError,
    TypeError,
    UnicodeDecodeError,
    ValueError,
    sqlite3.Error,
    struct.error,
)


def _bag_errors() -> tuple[type[Exception], ...]:
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Ros1ReaderError
    from rosbags.rosbag2 import ReaderError as Ros2ReaderError
    from rosbags.serde import SerdeError

    errors = (AnyReaderError, Ros1ReaderError, Ros2ReaderError, SerdeError, *_CORRUPT)
    try:
        import apsw  # rosbags 0.11 reads SQLite bags through it
    except ImportError:
        return errors
    return (*errors, apsw.Error)


def _corrupt(path: Path, err: Exception) -> LogFormatError:
    reason = " ".join(str(err).split())[:200] or type(err).__name__
    return LogFormatError(f"cannot read the bag, it is corrupt or cut short ({reason})", path=path)


@contextmanager
def _open(path: Path) -> Iterator[Any]:
    """An ``AnyReader`` on a ROS 1 ``.bag`` or a ROS 2 bag folder; read errors name the bag."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    try:
        if not path.exists():
            raise MapFileNotFoundError(path, "ROS bag")
        if path.is_dir() and not (path / "metadata.yaml").is_file():
            raise LogFormatError("not a ROS 2 bag: a bag folder holds a metadata.yaml", path=path)
    except PermissionError as err:  # a folder that may not be looked into
        raise LogFormatError(f"cannot be read ({err.strerror})", path=path) from None
    store = Stores.ROS1_NOETIC if path.suffix == ".bag" else Stores.LATEST
    try:
        with AnyReader([path], default_typestore=get_typestore(store)) as reader:
            yield reader
    except TopomapError:
        raise
    except _bag_errors() as err:
        raise _corrupt(path, err) from err


def _messages(
    reader: Any, connections: Sequence[Any], path: Path
) -> Iterator[tuple[Any, int, bytes]]:
    """``(connection, time_ns, raw message)`` of ``connections``; the errors of a corrupt or
    truncated bag, raised while iterating, name the bag."""
    errors = _bag_errors()
    messages = reader.messages(connections=connections)
    while True:
        try:
            connection, time_ns, raw = next(messages)
        except StopIteration:
            return
        except errors as err:
            raise _corrupt(path, err) from err
        yield connection, time_ns, raw


def _deserialize(reader: Any, raw: bytes, connection: Any, path: Path) -> Any:
    """A message of ``connection``; a corrupt one names the bag."""
    try:
        return reader.deserialize(raw, connection.msgtype)
    except _bag_errors() as err:
        raise _corrupt(path, err) from err


def read_rosbag(
    path: str | Path,
    *,
    scan_topic: str | None = None,
    pose_topic: str | None = None,
    fixed_frame: str | None = None,
    tolerance: float = TOLERANCE,
) -> list[Keyframe]:
    """Laser scans and the poses they were taken at, from a ROS 1 or ROS 2 bag.

    The keyframes of :func:`read_bag_scans` (which also says how the scans were placed).
    """
    return read_bag_scans(
        path,
        scan_topic=scan_topic,
        pose_topic=pose_topic,
        fixed_frame=fixed_frame,
        tolerance=tolerance,
    ).keyframes


def read_bag_scans(
    path: str | Path,
    *,
    scan_topic: str | None = None,
    pose_topic: str | None = None,
    fixed_frame: str | None = None,
    tolerance: float = TOLERANCE,
) -> BagScans:
    """Read laser scans from a ROS 1 or ROS 2 bag and place them in a fixed frame.

    Scans are placed by the bag's tf tree (``/tf`` and ``/tf_static``, REP-105): the laser's
    pose in the fixed frame at each scan's header stamp, through ``map -> odom -> base_link ->
    <the scan's frame_id>`` or whatever links the bag has, each timed link interpolated at the
    stamp (held :data:`~maps.tf.TOLERANCE` seconds past its ends), static links (the laser's
    mount) applied as they are. A laser mounted upside down has its scans mirrored.

    A bag without tf, or a ``pose_topic`` named, places scans by a pose topic instead (an
    Odometry, PoseStamped or PoseWithCovarianceStamped topic, taken as the laser's pose).

    Parameters
    ----------
    path
        A ROS 1 ``.bag`` file or a ROS 2 bag folder (sqlite3 or MCAP).
    scan_topic
        The sensor_msgs/LaserScan topic; by default the bag's only one.
    pose_topic
        Place scans by this pose topic rather than by tf.
    fixed_frame
        The frame to place scans in. By default ``map`` when its chain places at least half
        as many scans as ``odom``'s (the drift-free frame, once a SLAM node publishes it),
        else ``odom``. An empty name is refused.
    tolerance
        Seconds a timed transform is held beyond its first and last message.

    Returns
    -------
    BagScans
        The keyframes (bag order; ``scan_index`` counts every scan on the topic from 0;
        unplaced scans dropped and logged), the fixed frame and the chain used.

    Raises
    ------
    MapFileNotFoundError
        If the bag does not exist.
    TransformError
        If no scan can be placed by tf: the message names the missing link and its span; or
        a tf message is malformed (a frame name empty, a rotation zero): the message names
        its topic and index.
    LogFormatError
        If ``fixed_frame`` is empty, the bag cannot be read, the topics are missing or
        ambiguous, the laser jumps
        farther than :data:`~maps.limits.MAX_POSE_JUMP` between two scans, or no beam of
        the placed scans is valid.

    Examples
    --------
    >>> found = read_bag_scans("run.bag")  # doctest: +SKIP
    >>> found.describe()  # doctest: +SKIP
    '812 of 815 scans placed in map by map -> odom -> base_link -> laser'
    """
    path = Path(path)
    problem = None if fixed_frame is None else frame_problem(fixed_frame)
    if problem is not None:
        raise LogFormatError(problem, path=path, field="fixed_frame")
    scans: list[tuple[float, str, LaserScan]] = []
    poses: list[tuple[float, tuple[float, float, float]]] = []
    tree = TransformTree(tolerance)
    with _open(path) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        scan_name = _pick_topic(topics, (SCAN_TYPE,), scan_topic, path)
        tf_names = {name for name, kind in topics.items() if kind in TF_TYPES}
        by_tf = pose_topic is None and bool(tf_names)
        pose_name = None if by_tf else _pick_topic(topics, POSE_TYPES, pose_topic, path)
        wanted = [c for c in reader.connections if c.topic in {scan_name, pose_name} | tf_names]
        tf_counts = dict.fromkeys(tf_names, 0)
        for connection, _, raw in _messages(reader, wanted, path):
            message = _deserialize(reader, raw, connection, path)
            if connection.topic == scan_name:
                try:
                    scan, stamp = LaserScan.from_msg_fields(message), _stamp(message)
                except InvalidScanError as err:
                    field = f"{scan_name} message {len(scans)}"
                    raise LogFormatError(str(err), path=path, field=field) from err
                scans.append((stamp, message.header.frame_id, scan))
            elif connection.topic == pose_name:
                try:
                    poses.append((_stamp(message), _pose_of(message)))
                except InvalidScanError as err:
                    field = f"{pose_name} message {len(poses)}"
                    raise LogFormatError(str(err), path=path, field=field) from err
            else:
                topic = connection.topic
                try:
                    _add_transforms(tree, message, static=topic.endswith("tf_static"))
                except TransformError as err:
                    field = f"{topic} message {tf_counts[topic]}"
                    raise TransformError(err.detail, path=path, field=field) from err
                tf_counts[topic] += 1
    if not scans:
        raise LogFormatError("the scan topic has no messages", path=path, field=scan_name)
    if pose_name is not None:
        if fixed_frame is not None:
            raise LogFormatError(
                f"--fixed-frame {fixed_frame!r} needs /tf, but scans are placed by {pose_name}",
                path=path,
                field="fixed_frame",
            )
        try:
            placed = _place_by_poses(path, scans, poses, pose_name)
        except InvalidScanError as err:
            raise LogFormatError(str(err), path=path, field=pose_name) from err
    else:
        try:
            placed = _place_by_tf(tree, scans, fixed_frame)
        except TransformError as err:
            raise TransformError(
                err.detail, path=path, source=err.source, target=err.target, stamp=err.stamp
            ) from err
        except InvalidScanError as err:
            raise LogFormatError(str(err), path=path, field="/tf") from err
    _check_jumps(placed.keyframes, path, scan_name)
    problem = no_valid_beam(placed.keyframes)
    if problem is not None:
        raise LogFormatError(problem, path=path, field=scan_name)
    return placed


def _check_jumps(frames: list[Keyframe], path: Path, scan_name: str) -> None:
    """Refuse a laser that jumps farther than :data:`~maps.limits.MAX_POSE_JUMP` between two
    placed scans, naming both scans' messages."""
    for before, after in itertools.pairwise(frames):
        jump = pose_jump(before.pose, after.pose)
        if jump is not None:
            raise LogFormatError(
                f"{jump}; the previous scan is message {before.scan_index}",
                path=path,
                field=f"{scan_name} message {after.scan_index}",
            )


def _add_transforms(tree: TransformTree, message: Any, *, static: bool) -> None:
    for item in message.transforms:
        t, r = item.transform.translation, item.transform.rotation
        try:
            stamp = None if static else _stamp(item)
        except InvalidScanError as err:
            link = f"{item.header.frame_id!r} -> {item.child_frame_id!r}"
            raise TransformError(f"link {link}: {err}") from None
        tree.add(
            item.header.frame_id,
            item.child_frame_id,
            (float(t.x), float(t.y), float(t.z)),
            (float(r.x), float(r.y), float(r.z), float(r.w)),
            stamp=stamp,
        )


def _place_by_tf(
    tree: TransformTree, scans: list[tuple[float, str, LaserScan]], fixed_frame: str | None
) -> BagScans:
    """Scans placed through the tf tree in ``fixed_frame``, or the best of map and odom."""
    stamps = np.array([stamp for stamp, _, _ in scans])
    lasers = sorted({frame.lstrip("/") for _, frame, _ in scans})
    if len(lasers) != 1 or not lasers[0]:
        raise TransformError(f"scans must come from one named frame, got {lasers}")
    laser = lasers[0]
    if fixed_frame is not None:
        candidates = [fixed_frame]
    else:
        candidates = [f for f in FIXED_FRAMES if f in tree.frames] or [FIXED_FRAMES[-1]]
    found: dict[str, tuple[np.ndarray, bool] | None] = {}
    for frame in candidates:
        try:
            found[frame] = tree.lookup(frame, laser, stamps, partial=True)
        except TransformError:
            found[frame] = None
    count = {f: 0 if r is None else int(np.isfinite(r[0][:, 0]).sum()) for f, r in found.items()}
    chosen = candidates[0]
    if len(candidates) > 1 and 2 * count[candidates[0]] < count[candidates[1]]:
        chosen = candidates[1]
    result = found[chosen]
    if result is None or count[chosen] == 0:  # the strict look-up's error names the missing link
        tree.lookup(chosen, laser, stamps)
    assert result is not None
    poses, mirrored = result
    frames = []
    for index, ((stamp, _, scan), pose) in enumerate(zip(scans, poses, strict=True)):
        if np.isfinite(pose[0]):
            placed_scan = _mirrored(scan) if mirrored else scan
            at = (float(pose[0]), float(pose[1]), float(pose[2]))
            frames.append(Keyframe(at, placed_scan, scan_index=index, stamp=stamp))
    placed = BagScans(frames, chosen, tree.chain(chosen, laser), len(scans))
    log.info("%s", placed.describe())
    return placed


def _mirrored(scan: LaserScan) -> LaserScan:
    """The scan of a laser mounted upside down, seen from above: angles turn clockwise."""
    return LaserScan(
        scan.ranges, -scan.angle_min, -scan.angle_increment, scan.range_min, scan.range_max
    )


def _place_by_poses(
    path: Path,
    scans: list[tuple[float, str, LaserScan]],
    poses: list[tuple[float, tuple[float, float, float]]],
    pose_name: str,
) -> BagScans:
    """Scans at their pose topic's pose, interpolated at their stamps."""
    if not poses:
        raise LogFormatError("the pose topic has no messages", path=path, field="pose_topic")
    poses.sort(key=lambda item: item[0])
    times = np.array([t for t, _ in poses])
    xyz = np.array([p for _, p in poses])
    xyz[:, 2] = np.unwrap(xyz[:, 2])
    frames = []
    for index, (stamp, _, scan) in enumerate(scans):
        if not times[0] <= stamp <= times[-1]:
            continue
        pose = tuple(float(np.interp(stamp, times, xyz[:, k])) for k in range(3))
        frames.append(Keyframe(pose, scan, scan_index=index, stamp=stamp))  # type: ignore[arg-type]
    if scans and not frames:
        raise LogFormatError(
            f"none of the {len(scans)} scans (stamped {min(s[0] for s in scans):.6g}.."
            f"{max(s[0] for s in scans):.6g} s) falls within the poses' {times[0]:.6g}.."
            f"{times[-1]:.6g} s: no scan can be placed",
            path=path,
            field=pose_name,
        )
    if len(frames) < len(scans):
        log.info("%s: dropped %d scans stamped outside the poses", path, len(scans) - len(frames))
    return BagScans(frames, "pose topic", [pose_name], len(scans))


def read_rosbag_map(
    path: str | Path, *, topic: str | None = None, stamp: float | None = None
) -> OccupancyGrid:
    """A nav_msgs/OccupancyGrid map recorded in a ROS 1 or ROS 2 bag.

    Parameters
    ----------
    path
        A ROS 1 ``.bag`` file or a ROS 2 bag (a folder, or its ``.mcap`` or ``.db3`` file).
    topic
        The map topic; by default the bag's only OccupancyGrid topic (``/map`` usually).
    stamp
        Take the last map recorded at or before this time (seconds, the bag's clock); by
        default the last map in the bag (a SLAM node's most complete one).

    Raises
    ------
    MapFileNotFoundError
        If the bag does not exist.
    LogFormatError
        If the topic is missing or ambiguous, has no map (before ``stamp``), or its map is
        malformed; the message names the bag, topic and message.

    Examples
    --------
    >>> grid = read_rosbag_map("run.bag", topic="/map")  # doctest: +SKIP
    """
    path = Path(path)
    with _open(path) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        name = _pick_topic(topics, (MAP_TYPE,), topic, path)
        wanted = [c for c in reader.connections if c.topic == name]
        chosen = None
        count = first = 0
        for connection, time_ns, raw in _messages(reader, wanted, path):
            first = first or time_ns
            if stamp is None or time_ns <= stamp * 1e9:
                chosen, count = (connection, raw), count + 1
        if chosen is None:
            when = "" if stamp is None else f" at or before {stamp} s (first at {first / 1e9} s)"
            raise LogFormatError(f"no map{when}", path=path, field=name)
        message = _deserialize(reader, chosen[1], chosen[0], path)
    try:
        return OccupancyGrid.from_msg_fields(message)
    except (InvalidMapError, MapTooLargeError) as err:
        kind = MapTooLargeError if isinstance(err, MapTooLargeError) else LogFormatError
        raise kind(str(err), path=path, field=f"{name} message {count - 1}") from err
