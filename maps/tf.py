"""A planar transform tree in the manner of ROS tf2 (REP-105): frames, static and timed links.

A robot's bag carries the tree on ``/tf`` and ``/tf_static``: ``map -> odom`` from a SLAM or
localisation node, ``odom -> base_link`` from odometry, ``base_link -> laser`` from the robot's
description (static). :class:`TransformTree` collects those links and answers "where was frame
``laser`` in frame ``map`` at these times", interpolating each timed link at the asked stamps and
composing the links along the tree.

Transforms are kept planar, as 3 x 3 homogeneous matrices of the x-y plane: a link's 3-D
rotation is projected onto the plane, so a laser mounted upside down (rolled by pi about its x
axis) becomes a reflection, and its scans are mirrored when placed (see
:meth:`TransformTree.lookup`).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.errors import TransformError
from maps.limits import MAX_COORDINATE

log = logging.getLogger(__name__)

#: Seconds a timed link's first or last value is held beyond its span (tf2 holds none; bags cut
#: a link's messages at both ends, and localisation nodes post-date ``map -> odom``).
TOLERANCE = 0.2
#: Degrees out of the plane from which a link used in a look-up is reported as tilted.
TILT = 10.0


def is_rotation(x: float, y: float, z: float, w: float) -> bool:
    """Whether a quaternion names a rotation: finite, and not (nearly) zero."""
    return 1e-9 < math.hypot(x, y, z, w) < math.inf


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """The rotation about z of a quaternion of any length (normalised first, as tf2 does; see
    :func:`is_rotation`), radians.

    Examples
    --------
    >>> round(yaw_from_quaternion(0.0, 0.0, math.sin(0.25), math.cos(0.25)), 6)
    0.5
    >>> round(yaw_from_quaternion(0.0, 0.0, 1.0, 1.0), 6)  # a quarter turn
    1.570796
    """
    norm = math.hypot(x, y, z, w)
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def quaternion_from_yaw(yaw: float) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` of a rotation by ``yaw`` radians about z.

    Examples
    --------
    >>> quaternion_from_yaw(0.0)
    (0.0, 0.0, 0.0, 1.0)
    """
    return 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)


def frame_problem(name: object) -> str | None:
    """What is wrong with ``name`` as a tf frame name (no string, empty, or only the ``/``
    that tf2 drops in front of a name: it names no frame, and no link can be chained to it),
    or None when it is fine. Callers raise their own located error with it.

    Examples
    --------
    >>> frame_problem("/odom") is None
    True
    >>> frame_problem("/")
    "frame name '/' is empty"
    >>> frame_problem(5)
    'frame name must be a string, got 5'
    """
    if not isinstance(name, str):
        return f"frame name must be a string, got {name!r:.80}"
    return None if name.lstrip("/") else f"frame name {name!r} is empty"


def planar_matrix(
    translation: tuple[float, float, float], rotation: tuple[float, float, float, float]
) -> NDArray[np.float64]:
    """The 3 x 3 planar matrix of a 3-D transform: its translation's x, y and its rotation
    projected onto the x-y plane (a reflection when the rotated z axis points down). The
    rotation matrix is SciPy's ``Rotation.from_quat(...).as_matrix()`` written out: 1.6 times
    faster per message, without importing ``scipy.spatial.transform`` (0.3 s).

    Examples
    --------
    >>> planar_matrix((1.0, 2.0, 0.5), (1.0, 0.0, 0.0, 0.0)).round(6).tolist()  # rolled by pi
    [[1.0, 0.0, 1.0], [0.0, -1.0, 2.0], [0.0, 0.0, 1.0]]
    """
    x, y, z, w = rotation
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not norm > 0 or not all(map(math.isfinite, (*translation, norm))):
        raise TransformError(f"not a transform: translation {translation}, rotation {rotation}")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    rotation_3d = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    matrix = np.eye(3)
    # the x axis is projected as it is; the y axis follows it, mirrored when z points down
    heading = math.atan2(rotation_3d[1, 0], rotation_3d[0, 0])
    side = 1.0 if rotation_3d[2, 2] >= 0 else -1.0
    c, s = math.cos(heading), math.sin(heading)
    matrix[:2, :2] = [[c, -s * side], [s, c * side]]
    matrix[:2, 2] = translation[:2]
    return matrix


def _matrices(x: NDArray, y: NDArray, yaw: NDArray) -> NDArray[np.float64]:
    """``(n, 3, 3)`` rotations by ``yaw`` then translations by ``(x, y)``."""
    out = np.zeros((len(x), 3, 3))
    c, s = np.cos(yaw), np.sin(yaw)
    out[:, 0, 0], out[:, 0, 1], out[:, 0, 2] = c, -s, x
    out[:, 1, 0], out[:, 1, 1], out[:, 1, 2] = s, c, y
    out[:, 2, 2] = 1.0
    return out


@dataclass
class _Link:
    """The transform of ``child`` in ``parent``: one static matrix, or samples in time."""

    parent: str
    child: str
    static: NDArray[np.float64] | None = None
    samples: list[tuple[float, float, float, float]] = field(default_factory=list)
    #: The largest angle, degrees, between the child's z axis and the parent's (up or down).
    tilt: float = 0.0
    _table: NDArray[np.float64] | None = field(default=None, repr=False)

    def table(self) -> NDArray[np.float64]:
        """``(n, 4)`` samples ``t, x, y, unwrapped yaw`` sorted by time, one per stamp."""
        if self._table is None or len(self._table) != len(self.samples):
            table = np.array(sorted(self.samples), float).reshape(-1, 4)
            # the last sample of a repeated stamp wins
            _, last = np.unique(table[::-1, 0], return_index=True)
            table = table[len(table) - 1 - last]
            table[:, 3] = np.unwrap(table[:, 3])
            self._table = table
        return self._table

    def span(self) -> str:
        if self.static is not None:
            return "static"
        table = self.table()
        return f"{len(table)} stamps, {table[0, 0]:.3f} .. {table[-1, 0]:.3f} s"

    def at(
        self, stamps: NDArray[np.float64], tolerance: float
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Matrices at ``stamps`` and whether each stamp is covered (within ``tolerance``)."""
        if self.static is not None:
            return np.broadcast_to(self.static, (len(stamps), 3, 3)), np.ones(len(stamps), bool)
        table = self.table()
        times = table[:, 0]
        covered = (stamps >= times[0] - tolerance) & (stamps <= times[-1] + tolerance)
        x, y, yaw = (np.interp(stamps, times, table[:, k]) for k in (1, 2, 3))
        return _matrices(x, y, yaw), covered


class TransformTree:
    """Frames linked by static and timed planar transforms, as tf2's buffer holds them.

    Frame names are taken without a leading ``/`` (ROS 1 bags may write ``/odom``). Each frame
    has at most one parent; a link that would give a frame a second parent is refused.

    Parameters
    ----------
    tolerance
        Seconds a timed link's first or last value is held beyond its span.

    Examples
    --------
    >>> tree = TransformTree()
    >>> tree.add("odom", "base_link", (1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), stamp=0.0)
    >>> tree.add("odom", "base_link", (3.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), stamp=2.0)
    >>> tree.add("base_link", "laser", (0.3, 0.0, 0.0), quaternion_from_yaw(math.pi / 2))
    >>> poses, mirrored = tree.lookup("odom", "laser", [1.0])
    >>> poses.round(4).tolist(), mirrored
    ([[2.3, 0.0, 1.5708]], False)
    >>> tree.chain("odom", "laser")
    ['odom', 'base_link', 'laser']
    """

    def __init__(self, tolerance: float = TOLERANCE) -> None:
        self.tolerance = float(tolerance)
        self._links: dict[str, _Link] = {}

    @staticmethod
    def _name(frame: str) -> str:
        return frame.lstrip("/")

    @property
    def frames(self) -> set[str]:
        """Every frame named by a link."""
        return {n for link in self._links.values() for n in (link.parent, link.child)}

    def add(
        self,
        parent: str,
        child: str,
        translation: tuple[float, float, float],
        rotation: tuple[float, float, float, float],
        *,
        stamp: float | None = None,
    ) -> None:
        """Add the transform of ``child`` in ``parent`` at ``stamp`` (seconds), or a static one
        when ``stamp`` is None. A static link replaces an earlier static one."""
        problem = frame_problem(parent) or frame_problem(child)
        if problem is not None:
            raise TransformError(f"link {parent!r} -> {child!r}: {problem}")
        parent, child = self._name(parent), self._name(child)
        values = (*translation, *rotation)
        if not all(math.isfinite(v) for v in values) or max(map(abs, translation)) > MAX_COORDINATE:
            raise TransformError(
                f"link {parent} -> {child}: translation {tuple(translation)} and rotation "
                f"{tuple(rotation)} must be finite, the translation within {MAX_COORDINATE:g} m"
            )
        if sum(v * v for v in rotation) < 1e-12:
            raise TransformError(f"link {parent} -> {child}: rotation {tuple(rotation)} is zero")
        if parent == child:
            raise TransformError(f"frame {child!r} cannot be its own parent")
        link = self._links.get(child)
        if link is not None and link.parent != parent:
            raise TransformError(f"frame {child!r} has two parents: {link.parent!r} and {parent!r}")
        if link is None:
            link = self._links[child] = _Link(parent, child)
        matrix = planar_matrix(translation, rotation)
        qx, qy, qz, qw = rotation
        up = 1 - 2 * (qx * qx + qy * qy) / (qx * qx + qy * qy + qz * qz + qw * qw)
        link.tilt = max(link.tilt, math.degrees(math.acos(min(1.0, abs(up)))))
        if (link.static is not None and stamp is not None) or (link.samples and stamp is None):
            raise TransformError(f"link {parent} -> {child} is both static and timed")
        if stamp is None:
            link.static = matrix
            return
        yaw = math.atan2(matrix[1, 0], matrix[0, 0])
        link.samples.append((float(stamp), float(matrix[0, 2]), float(matrix[1, 2]), yaw))

    def _ancestors(self, frame: str) -> list[str]:
        """``frame``, its parent, its parent's parent... up to its root."""
        path = [frame]
        while path[-1] in self._links:
            path.append(self._links[path[-1]].parent)
            if len(path) > len(self._links) + 1:
                raise TransformError(f"the tf tree has a loop through {frame!r}")
        return path

    def chain(self, target: str, source: str) -> list[str]:
        """Frames from ``target`` to ``source`` through the tree (both included).

        Raises
        ------
        TransformError
            If the two frames are not in one tree; the message names the links that exist.
        """
        up_target, up_source, common = self._meet(target, source)
        down = up_source[: up_source.index(common)]
        return up_target[: up_target.index(common) + 1] + down[::-1]

    def _meet(self, target: str, source: str) -> tuple[list[str], list[str], str]:
        """Ancestors of ``target`` and ``source``, and the first frame both lead up to."""
        target, source = self._name(target), self._name(source)
        up_target, up_source = self._ancestors(target), self._ancestors(source)
        common = next((f for f in up_target if f in up_source), None)
        if common is None:
            links = "; ".join(f"{p} -> {c} ({span})" for p, c, span in self.links())
            raise TransformError(
                f"no transform from {target!r} to {source!r}: {source!r} leads up to "
                f"{up_source[-1]!r}, {target!r} to {up_target[-1]!r}; links: {links or 'none'}",
                source=source,
                target=target,
            )
        return up_target, up_source, common

    def _from_root(
        self, frame: str, root: str, stamps: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_], list[str]]:
        """``frame`` in its ancestor ``root`` at ``stamps``, which stamps every link covers,
        and the links that miss some stamp."""
        matrices = np.broadcast_to(np.eye(3), (len(stamps), 3, 3))
        covered = np.ones(len(stamps), bool)
        missing = []
        while frame != root:
            link = self._links[frame]
            if link.tilt > TILT:
                log.warning(
                    "link %s -> %s, tilted %.0f degrees out of the plane, is projected onto it",
                    link.parent,
                    link.child,
                    link.tilt,
                )
            step, ok = link.at(stamps, self.tolerance)
            matrices = step @ matrices
            if not ok.all():
                missing.append(f"{link.parent} -> {link.child} ({link.span()})")
            covered &= ok
            frame = link.parent
        return matrices, covered, missing

    def lookup(
        self, target: str, source: str, stamps: ArrayLike, *, partial: bool = False
    ) -> tuple[NDArray[np.float64], bool]:
        """Poses ``(x, y, yaw)`` of frame ``source`` in frame ``target`` at ``stamps``.

        Each timed link is interpolated at each stamp (linearly in x, y and yaw), and held
        ``tolerance`` seconds beyond its span.

        Parameters
        ----------
        target, source
            Frame names, e.g. ``"map"`` and ``"laser"``.
        stamps
            Times in seconds.
        partial
            Give NaN rows for stamps some link does not cover, instead of raising.

        Returns
        -------
        poses : ndarray
            ``(n, 3)`` poses.
        mirrored : bool
            Whether ``source`` is mirrored in ``target`` (a laser mounted upside down):
            its angles then turn clockwise in ``target``.

        Raises
        ------
        TransformError
            If the frames are not linked, or (unless ``partial``) a link does not cover a
            stamp; the message names the link, its span and the first stamp it misses.
        """
        times = np.atleast_1d(np.asarray(stamps, float))
        up_target, up_source, common = self._meet(target, source)
        source_in, ok_source, miss_source = self._from_root(up_source[0], common, times)
        target_in, ok_target, miss_target = self._from_root(up_target[0], common, times)
        covered = ok_source & ok_target
        if not partial and not covered.all():
            first = float(times[np.flatnonzero(~covered)[0]])
            raise TransformError(
                f"no transform from {up_target[0]!r} to {up_source[0]!r} at {first:.3f} s "
                f"({int((~covered).sum())} of {len(times)} stamps): missing "
                + "; ".join(miss_source + miss_target),
                source=up_source[0],
                target=up_target[0],
                stamp=first,
            )
        matrices = np.linalg.inv(target_in) @ source_in
        poses = np.column_stack(
            (
                matrices[:, 0, 2],
                matrices[:, 1, 2],
                np.arctan2(matrices[:, 1, 0], matrices[:, 0, 0]),
            )
        )
        poses[~covered] = np.nan
        mirrored = bool(np.linalg.det(matrices[0, :2, :2]) < 0) if len(matrices) else False
        return poses, mirrored

    def links(self) -> Iterable[tuple[str, str, str]]:
        """``(parent, child, span)`` of every link, span being ``"static"`` or its stamps."""
        return [(k.parent, k.child, k.span()) for k in self._links.values()]
