"""The robot's configuration space on a grid: free cells after inflation by the robot radius.

Every planner in :mod:`planners` uses the same validity rule: a point is valid when its cell is
free in the inflated grid; a straight motion is valid when it stays in the closed free space:
every cell its interior passes through is free, and a motion along a grid line has a free cell
on one side of each piece (exact grid traversal, not sampling).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from maps.grid import OCCUPIED_FROM, UNKNOWN, OccupancyGrid
from planners.errors import InvalidQueryError, PlannerParameterError

Point = tuple[float, float]
#: A point given as a tuple, a list or a numpy array of two numbers.
PointLike = Sequence[float] | NDArray[np.float64]
#: Lattice snapping tolerance (in cells) for crossings that pass through a grid vertex.
_SNAP = 1e-9
#: Motions crossing more grid lines than this are checked band by band with numpy.
_LONG = 48


@dataclass(frozen=True, eq=False)
class Workspace:
    """Free space of a disc robot of ``robot_radius`` metres on ``grid``.

    Parameters
    ----------
    grid
        The occupancy map; unknown cells block like occupied ones.
    robot_radius
        Inflation radius, metres.
    free
        The free cells, when already known (e.g. a submap); computed from ``grid`` otherwise.

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.1)
    >>> space = Workspace(grid, robot_radius=0.2)
    >>> space.segment_free((0.5, 0.5), (1.5, 1.5)), space.segment_free((0.5, 0.5), (0.1, 0.5))
    (True, False)
    """

    grid: OccupancyGrid
    robot_radius: float = 0.2
    free: NDArray[np.bool_] = field(default=None, repr=False)  # type: ignore[arg-type]

    def __post_init__(self) -> None:
        if self.free is None:
            free = self.grid.inflate(self.robot_radius).free
        else:
            free = np.asarray(self.free, bool)
            if free.shape != self.grid.shape:
                raise PlannerParameterError(
                    f"free has shape {free.shape}, the grid {self.grid.shape}"
                )
            free = free & self.grid.free
        free.setflags(write=False)
        object.__setattr__(self, "free", free)

    def crop(self, rows: slice, cols: slice, keep: NDArray[np.bool_] | None = None) -> Workspace:
        """The part of this workspace in cells ``[rows, cols]``, optionally only where
        ``keep`` (same shape as the part) is true; map-frame coordinates are unchanged."""
        free = self.free[rows, cols] if keep is None else self.free[rows, cols] & keep
        return Workspace(crop_grid(self.grid, rows, cols), self.robot_radius, free)

    @cached_property
    def components(self) -> NDArray[np.int32]:
        """Connected pieces of the free space (4-connected; 0 = not free)."""
        pieces, _ = ndimage.label(self.free)
        return pieces.astype(np.int32)

    # ------------------------------------------------------------------ frames
    def to_lattice(self, points: ArrayLike) -> NDArray[np.float64]:
        """Map-frame points to continuous grid coordinates ``(u, v)``: cell ``(row, col)``
        spans ``u`` in ``[col, col + 1)`` and ``v`` in ``[H - 1 - row, H - row)``."""
        p = np.asarray(points, float).reshape(-1, 2)
        ox, oy, yaw = self.grid.origin
        c, s = np.cos(yaw), np.sin(yaw)
        dx, dy = p[:, 0] - ox, p[:, 1] - oy
        return np.column_stack([c * dx + s * dy, -s * dx + c * dy]) / self.grid.resolution

    def from_lattice(self, uv: ArrayLike) -> NDArray[np.float64]:
        """Inverse of :meth:`to_lattice`."""
        q = np.asarray(uv, float).reshape(-1, 2) * self.grid.resolution
        ox, oy, yaw = self.grid.origin
        c, s = np.cos(yaw), np.sin(yaw)
        return np.column_stack([ox + c * q[:, 0] - s * q[:, 1], oy + s * q[:, 0] + c * q[:, 1]])

    def cells_free(self, u: NDArray, v: NDArray) -> NDArray[np.bool_]:
        """Whether lattice cells with integer-valued coordinates ``(u, v)`` are free
        (off-grid cells are not)."""
        h, w = self.free.shape
        col = u.astype(np.intp)
        row = h - 1 - v.astype(np.intp)
        inside = (u >= 0) & (v >= 0) & (col < w) & (row >= 0)
        out = np.zeros(len(u), bool)
        out[inside] = self.free[row[inside], col[inside]]
        return out

    # ------------------------------------------------------------------ validity
    def points_free(self, points: ArrayLike) -> NDArray[np.bool_]:
        """Whether each map-frame point is a valid robot position."""
        uv = self.to_lattice(points)
        return self.cells_free(np.floor(uv[:, 0]), np.floor(uv[:, 1]))

    def segments_free(self, starts: ArrayLike, ends: ArrayLike) -> NDArray[np.bool_]:
        """Whether each straight motion ``starts[i] -> ends[i]`` is valid (exact traversal)."""
        return self.lattice_segments_free(self.to_lattice(starts), self.to_lattice(ends))

    def lattice_segments_free(
        self, starts: NDArray[np.float64], ends: NDArray[np.float64]
    ) -> NDArray[np.bool_]:
        """:meth:`segments_free` for points already in lattice coordinates."""
        a, b = _snap(starts), _snap(ends)
        rows, cols = self._blocked_prefix
        steep = np.abs(b[:, 1] - a[:, 1]) > np.abs(b[:, 0] - a[:, 0])
        ok = np.empty(len(a), bool)
        ok[~steep] = _runs_free(rows, a[~steep], b[~steep])
        ok[steep] = _runs_free(cols, a[steep, ::-1], b[steep, ::-1])  # axes swapped
        for axis in (0, 1):  # motions along a grid line need a free cell on either side
            on_line = (a[:, axis] == b[:, axis]) & (a[:, axis] == np.round(a[:, axis]))
            on_line &= np.any(a != b, axis=1)
            if on_line.any():
                ok[on_line] = self._along_line(a[on_line], b[on_line], axis)
        return ok

    def _along_line(self, a: NDArray, b: NDArray, axis: int) -> NDArray[np.bool_]:
        """Validity of motions lying on grid lines ``coordinate[axis] = const``: each unit
        piece needs the cell on one side or the other free."""
        other = 1 - axis
        lo = np.floor(np.minimum(a[:, other], b[:, other]))
        count = (np.ceil(np.maximum(a[:, other], b[:, other])) - lo).astype(np.intp)
        owner = np.repeat(np.arange(len(a)), count)
        along = lo[owner] + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        line = a[owner, axis]
        sides = [(line, along), (line - 1, along)]
        free = [self.cells_free(*(s if axis == 0 else s[::-1])) for s in sides]
        return np.bincount(owner, weights=~(free[0] | free[1]), minlength=len(a)) == 0

    @cached_property
    def _scalar(self) -> tuple[bytes, int, int, float, float, float, float, float]:
        """Free cells as bytes in lattice order (``v * width + u``) and the frame constants,
        for the one-at-a-time tests OMPL calls."""
        h, w = self.free.shape
        ox, oy, yaw = self.grid.origin
        r = self.grid.resolution
        c, s = math.cos(yaw) / r, math.sin(yaw) / r
        return self.free[::-1].tobytes(), w, h, ox, oy, c, s, 1e-9

    def point_free(self, x: float, y: float) -> bool:
        """:meth:`points_free` for one point, without numpy (fast for OMPL callbacks)."""
        free, w, h, ox, oy, c, s, _ = self._scalar
        dx, dy = x - ox, y - oy
        u, v = math.floor(c * dx + s * dy), math.floor(c * dy - s * dx)
        return 0 <= u < w and 0 <= v < h and free[v * w + u] == 1

    def segment_free(self, start: PointLike, end: PointLike) -> bool:
        """Whether the straight motion ``start -> end`` is valid: :meth:`segments_free` for
        one motion, walking the cells one by one (Amanatides and Woo) without numpy."""
        _, _, _, ox, oy, c, s, _ = self._scalar
        x0, y0, x1, y1 = float(start[0]), float(start[1]), float(end[0]), float(end[1])
        u0, v0 = c * (x0 - ox) + s * (y0 - oy), c * (y0 - oy) - s * (x0 - ox)
        return self.lattice_segment_free(
            u0, v0, c * (x1 - ox) + s * (y1 - oy), c * (y1 - oy) - s * (x1 - ox)
        )

    def lattice_segment_free(self, u0: float, v0: float, u1: float, v1: float) -> bool:
        """:meth:`segment_free` for a motion in lattice coordinates (:meth:`to_lattice`)."""
        free, w, h, _, _, _, _, snap = self._scalar
        u0, v0, u1, v1 = _snap1(float(u0)), _snap1(float(v0)), _snap1(float(u1)), _snap1(float(v1))
        if (u0 == u1 and u0 == round(u0) and v0 != v1) or (
            v0 == v1 and v0 == round(v0) and u0 != u1
        ):
            return bool(self.lattice_segments_free(np.array([[u0, v0]]), np.array([[u1, v1]]))[0])
        du, dv = u1 - u0, v1 - v0
        if abs(du) + abs(dv) > _LONG:
            return self._bands_free(u0, v0, u1, v1)
        su, sv = (1 if du > 0 else -1), (1 if dv > 0 else -1)
        cu = math.ceil(u0) - 1 if du < 0 else math.floor(u0)
        cv = math.ceil(v0) - 1 if dv < 0 else math.floor(v0)
        nu = (
            max(0, math.ceil(u1) - 1 - math.floor(u0))
            if du > 0
            else max(0, math.ceil(u0) - 1 - math.floor(u1))
        )
        nv = (
            max(0, math.ceil(v1) - 1 - math.floor(v0))
            if dv > 0
            else max(0, math.ceil(v0) - 1 - math.floor(v1))
        )
        t_u = (cu + (su > 0) - u0) / du if du else math.inf
        t_v = (cv + (sv > 0) - v0) / dv if dv else math.inf
        step_u, step_v = (abs(1 / du) if du else math.inf), (abs(1 / dv) if dv else math.inf)
        tie = snap / max(abs(du), abs(dv), 1e-300)
        while True:
            if not (0 <= cu < w and 0 <= cv < h and free[cv * w + cu] == 1):
                return False
            if nu == 0 and nv == 0:
                return True
            cross_u = nu > 0 and (nv == 0 or t_u <= t_v + tie)
            cross_v = nv > 0 and (nu == 0 or t_v <= t_u + tie)
            if cross_u:
                cu, t_u, nu = cu + su, t_u + step_u, nu - 1
            if cross_v:
                cv, t_v, nv = cv + sv, t_v + step_v, nv - 1

    def precompute(self) -> None:
        """Build the lookup tables of the fast motion tests now, not at the first long
        motion (part of a planner's preprocessing)."""
        _ = self._blocked_prefix

    @cached_property
    def _blocked_prefix(self) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
        """Running counts of blocked cells along each lattice row ``[v, u]`` and each
        lattice column ``[u, v]`` (one leading zero), for :meth:`_bands_free`."""
        blocked = ~self.free[::-1]
        h, w = blocked.shape
        rows = np.zeros((h, w + 1), np.int32)
        np.cumsum(blocked, axis=1, out=rows[:, 1:])
        cols = np.zeros((w, h + 1), np.int32)
        np.cumsum(blocked.T, axis=1, out=cols[:, 1:])
        return rows, cols

    def _bands_free(self, u0: float, v0: float, u1: float, v1: float) -> bool:
        """Exact test of a long motion (not along a grid line) with numpy: across each
        unit band of the minor axis, the cells it crosses form one run, checked at once with
        running counts of blocked cells. Agrees with the cell walk of :meth:`segment_free`."""
        rows, cols = self._blocked_prefix
        if abs(u1 - u0) < abs(v1 - v0):  # mostly vertical: swap the axes
            u0, v0, u1, v1 = v0, u0, v1, u1
            prefix = cols
        else:
            prefix = rows
        bands, length = prefix.shape[0], prefix.shape[1] - 1
        du, dv = u1 - u0, v1 - v0
        if dv == 0:
            k0, k1 = math.floor(v0), math.floor(v0) + 1
            u = np.array([u0, u1])
        else:
            k0, k1 = math.floor(min(v0, v1)), math.ceil(max(v0, v1))
            lines = np.arange(k0, k1 + 1, dtype=float)  # band edges
            u = u0 + np.clip((lines - v0) / dv, 0.0, 1.0) * du
            nearest = np.rint(u)
            u = np.where(np.abs(u - nearest) < _SNAP, nearest, u)
        if k0 < 0 or k1 > bands:
            return False
        first = np.floor(np.minimum(u[:-1], u[1:])).astype(np.intp)
        last = np.ceil(np.maximum(u[:-1], u[1:])).astype(np.intp)
        if first.min() < 0 or last.max() > length:
            return False
        k = np.arange(k0, k1)
        return not (prefix[k, last] - prefix[k, first]).any()

    def path_free(self, waypoints: ArrayLike) -> bool:
        """Whether every segment of a polyline is valid."""
        p = np.asarray(waypoints, float).reshape(-1, 2)
        if len(p) == 1:
            return bool(self.points_free(p)[0])
        return bool(self.segments_free(p[:-1], p[1:]).all())

    def collisions(self, waypoints: ArrayLike, step: float | None = None) -> int:
        """Samples of a polyline, every ``step`` metres (a tenth of a cell by default), that
        lie outside the closed free space (touching a free cell's edge or corner is allowed):
        an independent check of a planner's output."""
        step = self.grid.resolution / 10 if step is None else step
        uv = self.to_lattice(sample_polyline(waypoints, step))
        touching = np.zeros(len(uv), bool)
        for du in (-_SNAP, _SNAP):
            for dv in (-_SNAP, _SNAP):
                touching |= self.cells_free(np.floor(uv[:, 0] + du), np.floor(uv[:, 1] + dv))
        return int((~touching).sum())

    def component_at(self, point: ArrayLike) -> int:
        """Free-space piece containing ``point`` (0 if it is not free)."""
        uv = self.to_lattice(point)[0]
        if not self.cells_free(np.floor(uv[:1]), np.floor(uv[1:]))[0]:
            return 0
        row = self.free.shape[0] - 1 - int(np.floor(uv[1]))
        return int(self.components[row, int(np.floor(uv[0]))])

    def check(self, point: ArrayLike, what: str = "point") -> Point:
        """``point`` as ``(x, y)`` if a robot can stand there, else :class:`InvalidQueryError`
        saying why (not two numbers, off the map, unknown, in or too close to a wall)."""
        try:
            p = np.asarray(point, float)
        except (TypeError, ValueError):  # strings, a dict, complex numbers
            p = np.zeros(0)
        if p.shape != (2,) or not np.all(np.isfinite(p)):
            raise InvalidQueryError(f"{what} must be two finite numbers (x, y), got {point!r}")
        x, y = float(p[0]), float(p[1])
        row, col = self.grid.world_to_cell(x, y)
        if not self.grid.contains(row, col):
            xmin, ymin, xmax, ymax = self.grid.bounds()
            raise InvalidQueryError(
                f"{what} ({x:g}, {y:g}) lies outside the map "
                f"[{xmin:g}, {xmax:g}] x [{ymin:g}, {ymax:g}]"
            )
        if self.free[row, col]:
            return x, y
        occupancy = int(self.grid.cells[row, col])
        if occupancy == UNKNOWN:
            raise InvalidQueryError(f"{what} ({x:g}, {y:g}) lies in an unknown cell")
        if occupancy >= OCCUPIED_FROM:
            raise InvalidQueryError(f"{what} ({x:g}, {y:g}) lies in a wall")
        raise InvalidQueryError(
            f"{what} ({x:g}, {y:g}) lies within the robot radius "
            f"({self.robot_radius:g} m) of a wall or unknown space"
        )


def crop_grid(grid: OccupancyGrid, rows: slice, cols: slice) -> OccupancyGrid:
    """The cells ``[rows, cols]`` of ``grid`` as a grid of their own, at the same place in
    the map frame."""
    h, _ = grid.shape
    u, v = (cols.start or 0) * grid.resolution, (h - (rows.stop or h)) * grid.resolution
    ox, oy, yaw = grid.origin
    c, s = math.cos(yaw), math.sin(yaw)
    origin = (ox + c * u - s * v, oy + s * u + c * v, yaw)
    return OccupancyGrid(grid.cells[rows, cols], grid.resolution, origin)


def sample_polyline(waypoints: ArrayLike, step: float) -> NDArray[np.float64]:
    """Points along a polyline at most ``step`` apart, both ends included."""
    p = np.asarray(waypoints, float).reshape(-1, 2)
    if len(p) < 2:
        return p[-1:].copy()
    d = np.diff(p, axis=0)
    counts = np.maximum(1, np.ceil(np.hypot(*d.T) / step).astype(np.intp))
    owner = np.repeat(np.arange(len(d)), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / counts[owner]
    return np.vstack([p[owner] + t[:, None] * d[owner], p[-1:]])


def _snap1(value: float) -> float:
    """:func:`_snap` for one number."""
    nearest = round(value)
    return float(nearest) if abs(value - nearest) < _SNAP else value


def _snap(uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lattice coordinates within rounding error of a grid line put exactly on it."""
    nearest = np.round(uv)
    return np.where(np.abs(uv - nearest) < _SNAP, nearest, uv)


def _runs_free(
    prefix: NDArray[np.int32], a: NDArray[np.float64], b: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """Whether the segments ``a[i] -> b[i]`` (lattice ``(u, v)``, ``|dv| <= |du|``) enter
    no blocked cell: across each unit band of ``v`` the cells a segment's interior enters
    form one run of ``u``, checked at once with ``prefix``, the running counts of blocked
    cells along each lattice row (:attr:`Workspace._blocked_prefix`, one leading zero).

    A segment starting or ending on a band's edge does not enter the band beyond it, and one
    through a grid vertex goes to the diagonal cell without touching the others, as the cell
    walk of :meth:`Workspace.segment_free` does; a point is the cell it lies in (up and right
    on a grid line). Cells off the grid are blocked. Motions along grid lines are left to
    :meth:`Workspace._along_line`.
    """
    bands, length = prefix.shape[0], prefix.shape[1] - 1
    d = b - a
    lo, hi = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
    k0 = np.floor(lo)
    count = np.maximum(np.ceil(hi) - k0, 1).astype(np.intp)  # bands; a flat motion has one
    owner = np.repeat(np.arange(len(a)), count)
    k = k0[owner] + np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    dv = d[owner, 1]
    edges = []  # u where the segment meets the band's two edges (a flat one: its ends)
    for line, flat in ((k, 0.0), (k + 1, 1.0)):
        t = np.full_like(dv, flat)
        np.divide(line - a[owner, 1], dv, out=t, where=dv != 0)
        edges.append(_snap(a[owner, 0] + np.clip(t, 0, 1) * d[owner, 0]))
    first = np.floor(np.minimum(*edges)).astype(np.intp)
    last = np.maximum(np.ceil(np.maximum(*edges)).astype(np.intp), first + 1)
    band = k.astype(np.intp)
    inside = (band >= 0) & (band < bands) & (first >= 0) & (last <= length)
    blocked = ~inside
    rows = np.clip(band, 0, bands - 1)
    blocked[inside] = (prefix[rows[inside], last[inside]] - prefix[rows[inside], first[inside]]) > 0
    return np.bincount(owner, weights=blocked, minlength=len(a)) == 0


def cell_beyond(coord: NDArray[np.float64], delta: NDArray[np.float64]) -> NDArray[np.float64]:
    """Lattice index, on one axis, of the cell a point at ``coord`` enters when moving by
    ``delta`` (the cell containing it when it is not on a grid line)."""
    return np.where(delta < 0, np.ceil(coord) - 1, np.floor(coord))
