"""A vectorised 2-D laser simulator: rays cast on an occupancy grid."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.errors import InvalidScanError
from maps.grid import OccupancyGrid
from maps.scan import Keyframe, LaserScan, check_pose, keyframe_indices
from maps.seeding import RandomState, as_generator

#: Rays traced together; bounds memory at about 100 bytes a ray.
_CHUNK = 262_144
#: Beams a simulated laser may have: a 3D lidar's ring of 0.01 degree steps is 36,000.
MAX_BEAMS = 100_000


@dataclass(frozen=True)
class LaserModel:
    """A planar laser: field of view, beams, range limits and noise.

    Parameters
    ----------
    fov
        Field of view in radians; beams are centred on the sensor's x axis. A full circle
        (``2 pi``) spaces ``beams`` evenly without repeating the first beam.
    beams
        Number of beams.
    max_range, min_range
        Range limits in metres; nothing within ``max_range`` gives ``+inf`` (REP-117).
    noise
        Standard deviation of Gaussian range noise, metres.
    dropout
        Probability that a beam returns nothing (``+inf``).
    """

    fov: float = math.pi
    beams: int = 181
    max_range: float = 30.0
    min_range: float = 0.05
    noise: float = 0.0
    dropout: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < self.fov <= 2 * math.pi:
            raise InvalidScanError(f"fov must lie in (0, 2 pi] radians, got {self.fov}")
        if not (isinstance(self.beams, int | np.integer) and 2 <= self.beams <= MAX_BEAMS):
            raise InvalidScanError(
                f"a laser has a whole number of beams in 2..{MAX_BEAMS}, got {self.beams!r}"
            )
        if not 0 <= self.min_range < self.max_range < math.inf:
            raise InvalidScanError(
                f"need 0 <= min_range < max_range < inf, got {self.min_range}, {self.max_range}"
            )
        if not (self.noise >= 0 and 0 <= self.dropout <= 1):  # NaN fails both
            raise InvalidScanError(
                f"need noise >= 0 and dropout in [0, 1], got {self.noise}, {self.dropout}"
            )

    @property
    def angle_increment(self) -> float:
        """Radians between beams."""
        full = math.isclose(self.fov, 2 * math.pi)
        return self.fov / (self.beams if full else self.beams - 1)

    @property
    def angle_min(self) -> float:
        """Angle of the first beam, radians."""
        return -self.fov / 2

    @property
    def angles(self) -> NDArray[np.float64]:
        """Beam angles in the sensor frame."""
        return self.angle_min + self.angle_increment * np.arange(self.beams, dtype=np.float64)


class RayCaster:
    """Casts rays on a grid's non-free cells (occupied and unknown block; off the grid blocks).

    Rays advance by the distance to the nearest blocked cell where it is large (sphere tracing
    on the Euclidean distance transform) and cell boundary by cell boundary near obstacles, so
    no blocked cell is skipped; a range is exact to the grid: where the ray enters the first
    blocked cell.
    """

    def __init__(self, grid: OccupancyGrid) -> None:
        self.grid = grid
        # a cell of blocked space round the grid: off the grid blocks
        self._blocked = np.pad(~grid.free, 1, constant_values=True)
        # in cells; off the grid blocks, so the edge counts (a sphere step never leaves the map)
        self._clearance = np.pad((grid.clearance() / grid.resolution).astype(np.float32), 1)

    def cast(self, origins: ArrayLike, angles: ArrayLike, max_range: float) -> NDArray[np.float64]:
        """Ranges in metres of rays from map-frame ``origins`` ``(n, 2)`` at map-frame ``angles``
        ``(n, b)``; ``+inf`` where nothing is hit within ``max_range``. A ray starting in a
        blocked cell has range 0."""
        xy = np.asarray(origins, float).reshape(-1, 2)
        theta = np.asarray(angles, float).reshape(xy.shape[0], -1)
        out = np.empty(theta.shape)
        flat_out = out.reshape(-1)
        starts = np.repeat(xy, theta.shape[1], axis=0)
        flat_theta = theta.reshape(-1)
        for lo in range(0, flat_theta.size, _CHUNK):
            hi = min(lo + _CHUNK, flat_theta.size)
            flat_out[lo:hi] = self._cast(starts[lo:hi], flat_theta[lo:hi], max_range)
        return out

    def _cast(
        self, xy: NDArray[np.float64], theta: NDArray[np.float64], max_range: float
    ) -> NDArray[np.float64]:
        grid = self.grid
        height, width = grid.shape
        ox, oy, oyaw = grid.origin
        c, s = math.cos(oyaw), math.sin(oyaw)
        dx, dy = xy[:, 0] - ox, xy[:, 1] - oy
        # continuous image coordinates: u along columns, v down the rows, one unit a cell
        u0 = (c * dx + s * dy) / grid.resolution
        v0 = height - (-s * dx + c * dy) / grid.resolution
        du, dv = np.cos(theta - oyaw), -np.sin(theta - oyaw)
        limit = max_range / grid.resolution
        result = np.full(theta.size, np.inf)
        # axis-parallel rays: a tiny component of the same sign, so the boundary test below and
        # the division agree (a flipped sign would step backwards)
        du_s = np.where(du >= 0, np.maximum(du, 1e-12), np.minimum(du, -1e-12))
        dv_s = np.where(dv >= 0, np.maximum(dv, 1e-12), np.minimum(dv, -1e-12))
        # the rays still on their way, each array of them compacted as rays stop (one copy of
        # each per step, not a gather of each from all the rays)
        ray, t = np.arange(theta.size), np.zeros(theta.size)
        while ray.size:
            u, v = u0 + t * du, v0 + t * dv
            # off the grid blocks: the cells round it, one deep, are blocked (a sphere step
            # never leaves the grid, a boundary step leaves it by one cell)
            col = np.clip(np.floor(u), -1, width).astype(np.intp)
            row = np.clip(np.floor(v), -1, height).astype(np.intp)
            hit = self._blocked[row + 1, col + 1]
            result[ray[hit]] = t[hit]
            # distance to the next cell boundary along the ray (strictly ahead: a ray on a
            # boundary going backwards must not see the boundary it stands on, or it creeps
            # by the 1e-6 nudge), and the safe sphere-tracing step
            next_u = np.where(du_s > 0, col + 1 - u, np.ceil(u) - 1 - u) / du_s
            next_v = np.where(dv_s > 0, row + 1 - v, np.ceil(v) - 1 - v) / dv_s
            boundary = np.minimum(next_u, next_v) + 1e-6
            safe = self._clearance[row + 1, col + 1] - math.sqrt(2)
            t = t + np.maximum(boundary, safe)
            on = ~hit & (t <= limit)
            ray, t, u0, v0, du, dv, du_s, dv_s = (
                part[on] for part in (ray, t, u0, v0, du, dv, du_s, dv_s)
            )
        result *= grid.resolution
        result[result > max_range] = np.inf
        return result


def simulate_scans(
    grid: OccupancyGrid,
    poses: ArrayLike,
    model: LaserModel | None = None,
    *,
    random_state: RandomState = None,
    caster: RayCaster | None = None,
) -> list[Keyframe]:
    """Scans a laser ``model`` would take at ``poses`` ``(n, 3)`` on ``grid``.

    Returns
    -------
    list of Keyframe
        One per pose, ``scan_index`` its position in ``poses``. Noise and dropouts are drawn
        from ``random_state``; readings below ``min_range`` become ``-inf`` (REP-117).
    """
    model = model or LaserModel()
    pose_array = np.asarray(poses, float)
    if pose_array.size == 0:
        return []
    pose_array = pose_array.reshape(-1, 3)
    for pose in pose_array:
        check_pose(pose)
    caster = caster or RayCaster(grid)
    rng = as_generator(random_state)
    angles = pose_array[:, 2:3] + model.angles[None, :]
    ranges = caster.cast(pose_array[:, :2], angles, model.max_range)
    hit = np.isfinite(ranges)
    if model.noise > 0:
        ranges[hit] += rng.normal(0.0, model.noise, int(hit.sum()))
        ranges[hit] = np.clip(ranges[hit], 0.0, model.max_range)
    if model.dropout > 0:
        ranges[rng.random(ranges.shape) < model.dropout] = np.inf
    ranges[ranges < model.min_range] = -np.inf
    return [
        Keyframe(
            tuple(pose),
            LaserScan(
                row, model.angle_min, model.angle_increment, model.min_range, model.max_range
            ),
            scan_index=i,
        )
        for i, (pose, row) in enumerate(zip(pose_array, ranges, strict=True))
    ]


def simulate_keyframes(
    grid: OccupancyGrid,
    poses: ArrayLike,
    model: LaserModel | None = None,
    *,
    distance: float = 0.5,
    angle: float = math.radians(30),
    random_state: RandomState = None,
) -> list[Keyframe]:
    """The keyframes a robot driving through ``poses`` would keep from a scan at every pose
    (:func:`~maps.scan.select_keyframes` with ``distance`` and ``angle``), with the scans cast
    at the kept poses only: the selection needs only the poses. ``scan_index`` is the
    position in ``poses``; noise and dropouts are drawn for the kept scans alone.

    Examples
    --------
    >>> free = np.zeros((40, 40), bool)
    >>> free[1:-1, 1:-1] = True
    >>> grid = OccupancyGrid.from_masks(free, 0.1)
    >>> poses = [(0.5 + 0.1 * i, 2.0, 0.0) for i in range(30)]
    >>> [k.scan_index for k in simulate_keyframes(grid, poses, distance=1.0)]
    [0, 11, 22]
    """
    pose_array = np.asarray(poses, float).reshape(-1, 3)
    kept = keyframe_indices(pose_array, distance=distance, angle=angle)
    frames = simulate_scans(grid, pose_array[kept], model, random_state=random_state)
    return [Keyframe(f.pose, f.scan, scan_index=i) for f, i in zip(frames, kept, strict=True)]
