"""Laser scans (sensor_msgs/LaserScan, REP-117), keyframes and the keyframe selection rule."""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.errors import InvalidScanError
from maps.grid import Pose
from maps.limits import MAX_COORDINATE, MAX_HEADING, finite_in

#: The fields of sensor_msgs/LaserScan a :class:`LaserScan` is made of, in its order.
_SCAN_FIELDS = ("ranges", "angle_min", "angle_increment", "range_min", "range_max")


@dataclass(frozen=True, eq=False)
class LaserScan:
    """One planar laser scan with the fields of sensor_msgs/LaserScan.

    Readings follow REP-117: ``+inf`` means no return within range, ``-inf`` too close,
    ``NaN`` an invalid measurement; readings outside ``[range_min, range_max]`` are not valid.
    Beam ``i`` points at ``angle_min + i * angle_increment`` radians in the sensor frame
    (counter-clockwise, x forward).
    """

    ranges: NDArray[np.float64]
    angle_min: float
    angle_increment: float
    range_min: float = 0.0
    range_max: float = math.inf

    def __post_init__(self) -> None:
        try:
            ranges = np.array(self.ranges, dtype=np.float64, copy=True)
        except (TypeError, ValueError, OverflowError):  # strings, a ragged list, 10**400
            raise InvalidScanError(f"ranges must be numbers, got {self.ranges!r:.200}") from None
        if ranges.ndim != 1 or ranges.size == 0:
            raise InvalidScanError(
                f"ranges must be a non-empty 1-D array, got shape {ranges.shape}"
            )
        for name in ("angle_min", "angle_increment", "range_min"):
            problem = finite_in(getattr(self, name), name, -math.inf, math.inf)
            if problem is not None:
                raise InvalidScanError(problem)
        if not isinstance(self.range_max, numbers.Real) or isinstance(self.range_max, bool):
            raise InvalidScanError(f"range_max must be a number, got {self.range_max!r}")
        if self.angle_increment == 0:
            raise InvalidScanError("angle_increment must not be 0")
        if abs(self.angle_min) > MAX_HEADING:
            raise InvalidScanError(
                f"angle_min is {self.angle_min:g} rad: no angle (at most {MAX_HEADING:g} rad)"
            )
        span = abs(self.angle_increment) * (ranges.size - 1)
        if span > 2 * math.pi + abs(self.angle_increment):  # a 360 degree scan may close
            raise InvalidScanError(
                f"{ranges.size} beams {self.angle_increment:g} rad apart span {span:g} rad: a "
                "scan turns once at most"
            )
        if self.range_min < 0 or not self.range_max > self.range_min:
            raise InvalidScanError(
                f"need 0 <= range_min < range_max, got {self.range_min}, {self.range_max}"
            )
        ranges.setflags(write=False)
        object.__setattr__(self, "ranges", ranges)

    @classmethod
    def from_msg_fields(cls, message: Any) -> LaserScan:
        """The scan of a sensor_msgs/LaserScan message (a ROS or rosbags message, or any
        object with its fields).

        Examples
        --------
        >>> from types import SimpleNamespace
        >>> message = SimpleNamespace(
        ...     ranges=[1.0, 2.0], angle_min=0.0, angle_increment=0.5, range_min=0.1, range_max=9.0
        ... )
        >>> LaserScan.from_msg_fields(message).points().round(3).tolist()
        [[1.0, 0.0], [1.755, 0.959]]
        """
        try:
            fields = [getattr(message, name) for name in _SCAN_FIELDS]
        except AttributeError as err:
            raise InvalidScanError(f"not a LaserScan message ({err})") from None
        return cls(*fields)

    def __len__(self) -> int:
        return int(self.ranges.size)

    def __repr__(self) -> str:
        """One line, without the ranges.

        Examples
        --------
        >>> LaserScan(np.ones(181), -1.5708, 0.01745, 0.1, 30.0)
        LaserScan(181 beams, 181 valid, angle_min=-1.5708, angle_increment=0.01745, range 0.1-30 m)
        """
        return (
            f"LaserScan({len(self)} beams, {int(self.valid.sum())} valid, "
            f"angle_min={self.angle_min:g}, angle_increment={self.angle_increment:g}, "
            f"range {self.range_min:g}-{self.range_max:g} m)"
        )

    @property
    def angles(self) -> NDArray[np.float64]:
        """Beam angles in radians, sensor frame."""
        return self.angle_min + self.angle_increment * np.arange(self.ranges.size, dtype=np.float64)

    @property
    def valid(self) -> NDArray[np.bool_]:
        """Beams with a finite reading inside ``[range_min, range_max]``."""
        r = self.ranges
        with np.errstate(invalid="ignore"):
            return np.isfinite(r) & (r >= self.range_min) & (r <= self.range_max)

    @property
    def no_return(self) -> NDArray[np.bool_]:
        """Beams that saw nothing within range (``+inf``, or finite beyond ``range_max``)."""
        with np.errstate(invalid="ignore"):
            return np.isposinf(self.ranges) | (
                np.isfinite(self.ranges) & (self.ranges > self.range_max)
            )

    def points(self) -> NDArray[np.float64]:
        """``(n, 2)`` end points of the valid beams in the sensor frame, metres."""
        ok = self.valid
        r, a = self.ranges[ok], self.angles[ok]
        return np.column_stack((r * np.cos(a), r * np.sin(a)))


def check_pose(pose: ArrayLike) -> Pose:
    """``(x, y, yaw)`` as floats; raises InvalidScanError unless three finite numbers, the
    point within :data:`~maps.limits.MAX_COORDINATE` metres and the yaw within
    :data:`~maps.limits.MAX_HEADING` radians.

    Examples
    --------
    >>> check_pose([1, 2, 0.5])
    (1.0, 2.0, 0.5)
    >>> check_pose((0.0, 0.0, 1e300))
    Traceback (most recent call last):
    ...
    maps.errors.InvalidScanError: a pose's yaw must lie within 10000 rad, got 1e+300
    """
    try:
        values = np.asarray(pose, dtype=float).ravel()
    except (TypeError, ValueError, OverflowError):  # "abc", None in it, 10**400
        values = np.zeros(0)
    if values.shape != (3,) or not np.all(np.isfinite(values)):
        raise InvalidScanError(
            f"a pose must be three finite numbers (x, y, yaw), got {pose!r:.200}"
        )
    if np.abs(values[:2]).max() > MAX_COORDINATE:
        raise InvalidScanError(
            f"a pose must lie within {MAX_COORDINATE:g} m of the origin, got "
            f"({values[0]:g}, {values[1]:g}, {values[2]:g})"
        )
    if abs(values[2]) > MAX_HEADING:
        raise InvalidScanError(
            f"a pose's yaw must lie within {MAX_HEADING:g} rad, got {values[2]:g}"
        )
    return float(values[0]), float(values[1]), float(values[2])


def transform_points(points: NDArray[np.float64], pose: Pose) -> NDArray[np.float64]:
    """Points ``(n, 2)`` from a frame at ``pose`` into the map frame."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    rotation = np.array([[c, -s], [s, c]])
    return points @ rotation.T + np.array([x, y])


@dataclass(frozen=True, eq=False)
class Keyframe:
    """A laser scan taken at a pose of the sensor in the map frame.

    Parameters
    ----------
    pose
        ``(x, y, yaw)`` of the laser in the map frame (metres, radians).
    scan
        The scan.
    scan_index
        0-based position of this scan among the scans of its source (log line order, bag order,
        simulation step), so results can be traced back to the raw data.
    stamp
        Time in seconds, if the source has a trustworthy one.
    """

    pose: Pose
    scan: LaserScan
    scan_index: int = 0
    stamp: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "pose", check_pose(self.pose))
        if not isinstance(self.scan, LaserScan):
            raise InvalidScanError(f"a keyframe's scan is a LaserScan, got {self.scan!r:.200}")
        index = self.scan_index
        if finite_in(index, "scan_index", 0, math.inf) is not None or int(index) != index:
            raise InvalidScanError(f"scan_index must be an integer >= 0, got {index!r}")
        if self.stamp is not None and finite_in(self.stamp, "stamp", -math.inf, math.inf):
            raise InvalidScanError(f"stamp must be a finite number of seconds, got {self.stamp!r}")

    def __repr__(self) -> str:
        pose = ", ".join(f"{v:.3f}" for v in self.pose)
        return f"Keyframe(pose=({pose}), scan_index={self.scan_index}, {len(self.scan)} beams)"

    def points(self) -> NDArray[np.float64]:
        """``(n, 2)`` end points of the valid beams in the map frame, metres."""
        return transform_points(self.scan.points(), self.pose)


def angle_difference(a: float, b: float) -> float:
    """``a - b`` wrapped into ``[-pi, pi)``."""
    return (a - b + math.pi) % (2 * math.pi) - math.pi


def select_keyframes(
    frames: Iterable[Keyframe], *, distance: float = 0.5, angle: float = math.radians(30)
) -> list[Keyframe]:
    """Keep a frame when the pose moved more than ``distance`` metres or turned more than
    ``angle`` radians since the last kept one (the first frame is always kept).

    Examples
    --------
    >>> scan = LaserScan(np.ones(3), -0.1, 0.1)
    >>> frames = [Keyframe((0.1 * i, 0.0, 0.0), scan, i) for i in range(11)]
    >>> [k.scan_index for k in select_keyframes(frames, distance=0.25)]
    [0, 3, 6, 9]
    """
    frames = keyframe_list(frames)
    kept = keyframe_indices(poses_array(frames), distance=distance, angle=angle)
    return [frames[i] for i in kept]


def keyframe_indices(
    poses: ArrayLike, *, distance: float = 0.5, angle: float = math.radians(30)
) -> list[int]:
    """Positions of the poses ``(n, 3)`` that :func:`select_keyframes` keeps: the rule needs
    only the poses, so a simulation can cast the keyframes' scans alone.

    Examples
    --------
    >>> keyframe_indices([(0.0, 0, 0), (0.3, 0, 0), (0.6, 0, 0), (0.6, 0, 1.0)], distance=0.5)
    [0, 2, 3]
    """
    if not distance >= 0 or not angle >= 0:
        raise InvalidScanError(f"distance and angle must be >= 0, got {distance}, {angle}")
    kept: list[int] = []
    last_x = last_y = last_yaw = math.nan
    for i, (x, y, yaw) in enumerate(np.asarray(poses, float).reshape(-1, 3).tolist()):
        if kept:
            moved = math.hypot(x - last_x, y - last_y) > distance
            turned = abs(angle_difference(yaw, last_yaw)) > angle
            if not (moved or turned):
                continue
        kept.append(i)
        last_x, last_y, last_yaw = x, y, yaw
    return kept


def keyframe_list(frames: Iterable[Keyframe]) -> list[Keyframe]:
    """``frames`` as a list; :class:`InvalidScanError` naming the first item that is no
    :class:`Keyframe` (a string, None), before anything reads their scans.

    Examples
    --------
    >>> scan = LaserScan(np.ones(3), -0.1, 0.1)
    >>> len(keyframe_list(iter([Keyframe((1.0, 2.0, 0.5), scan)])))
    1
    >>> keyframe_list([Keyframe((1.0, 2.0, 0.5), scan), "x"])
    Traceback (most recent call last):
    ...
    maps.errors.InvalidScanError: keyframes must be Keyframes; item 1 is 'x'
    """
    try:
        frames = list(frames)
    except TypeError:
        raise InvalidScanError(
            f"keyframes must be a list of Keyframes, got {frames!r:.80}"
        ) from None
    for index, item in enumerate(frames):
        if not isinstance(item, Keyframe):
            raise InvalidScanError(f"keyframes must be Keyframes; item {index} is {item!r:.80}")
    return frames


def seeing(frames: Sequence[Keyframe]) -> list[Keyframe]:
    """The frames whose scan has a valid beam: a scan with none (every reading NaN, infinite,
    under the sensor's least range or beyond its greatest) saw nothing, and is clustered
    neither offline nor online.

    Examples
    --------
    >>> blind = Keyframe((0.0, 0.0, 0.0), LaserScan([float("nan"), 0.0], -0.1, 0.1, 0.05))
    >>> seen = Keyframe((1.0, 0.0, 0.0), LaserScan([1.0, 0.0], -0.1, 0.1, 0.05))
    >>> [frame.pose[0] for frame in seeing([blind, seen])]
    [1.0]
    """
    return [frame for frame in frames if frame.scan.valid.any()]


def poses_array(frames: Sequence[Keyframe]) -> NDArray[np.float64]:
    """``(n, 3)`` array of the frames' poses (:func:`keyframe_list`'s error for an item that
    is no keyframe)."""
    try:
        return np.array([f.pose for f in frames], dtype=float).reshape(-1, 3)
    except AttributeError:
        keyframe_list(frames)
        raise
