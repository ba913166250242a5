"""A footprint's configuration space on a grid, one layer per heading bin: a state check is a
lookup.

For each of ``headings`` bins, the blocked cells (occupied, unknown, off the map) are dilated
(OpenCV) by a kernel that holds every obstacle cell some footprint pose of the bin could touch:
the footprint turned to the bin's middle, grown by how far any of its points moves when the
heading spans the bin and by ``margin``, then grown by one cell on each side (the reference
point may be anywhere in its cell). A state ``(x, y, yaw)`` is valid when its cell is free in its
bin's layer, so the check is conservative: a valid state's footprint touches no blocked cell,
and a motion checked at states whose footprint points are at most ``2 * margin`` apart is
collision-free between them. The layers are packed as bits, eight bins a byte.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import cv2
import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import Polygon

from maps.grid import OccupancyGrid
from maps.limits import MAX_LENGTH, finite_in
from planners.errors import PlannerParameterError
from planners.robots import Footprint
from planners.workspace import crop_grid
from segmentation.base import is_count

#: Heading bins of a configuration space by default.
HEADINGS = 64
#: Cells a side of a footprint's dilation kernel may have: each heading tests its cells one by
#: one (64 headings of 301 x 301 cells, a 10 x 10 m robot on 5 cm cells, take 5 s; 747 x 747
#: on 2 cm cells 31 s), so a large robot on a fine map would take minutes and gigabytes.
MAX_KERNEL_SIDE = 501


def bin_turn(robot: Footprint, headings: int) -> float:
    """How far a footprint point moves when the heading turns over half a bin, metres."""
    return 2 * robot.circumradius * math.sin(math.pi / headings / 2)


def footprint_kernels(
    robot: Footprint, resolution: float, headings: int, margin: float, yaw: float = 0.0
) -> list[NDArray[np.uint8]]:
    """The dilation kernel of every heading bin: ``kernel[r, c]`` is 1 when an obstacle cell
    ``r - R`` rows and ``c - R`` columns from the robot's cell may touch the footprint of a
    pose in that bin (``R`` the kernel's middle). ``yaw`` is the grid's rotation in the map
    frame.

    Raises
    ------
    PlannerParameterError
        The kernel would be wider than :data:`MAX_KERNEL_SIDE` cells.

    Examples
    --------
    >>> from planners.robots import rectangle
    >>> kernel = footprint_kernels(Footprint(rectangle(0.3, 0.1)), 0.1, 4, 0.0)[0]
    >>> kernel.shape, int(kernel.sum())
    ((9, 9), 35)
    """
    turn = bin_turn(robot, headings)
    reach = robot.circumradius + turn + margin + resolution
    size = math.ceil(reach / resolution)
    if 2 * size + 1 > MAX_KERNEL_SIDE:
        raise PlannerParameterError(
            f"the robot's footprint, grown to {reach:.3g} m from its reference point, spans "
            f"{2 * size + 1} cells of {resolution:g} m, more than {MAX_KERNEL_SIDE}: plan on a "
            "coarser map or with a smaller robot"
        )
    offsets = np.arange(-size, size + 1) * resolution
    i, j = np.meshgrid(offsets, offsets[::-1])  # rows go down, the lattice's v up
    # obstacle cells whose square, grown by a cell, meets the grown footprint
    boxes = shapely.box(i - resolution, j - resolution, i + resolution, j + resolution)
    kernels = []
    for k in range(headings):
        angle = 2 * math.pi * k / headings - yaw
        c, s = math.cos(angle), math.sin(angle)
        corners = robot.polygon @ np.array([[c, s], [-s, c]])
        shape = Polygon(corners).buffer(turn + margin) if turn + margin > 0 else Polygon(corners)
        kernels.append(shapely.intersects(shape, boxes).astype(np.uint8))
    return kernels


@dataclass(frozen=True, eq=False)
class HeadingCSpace:
    """Valid poses of a footprint robot on a grid, per heading bin.

    Parameters
    ----------
    grid
        The occupancy map: only free cells are free (unknown ones block).
    robot
        The footprint.
    headings
        Number of heading bins (a multiple of 8, at most 256).
    margin
        Metres the footprint is grown by, so motions can be checked at states whose
        footprint points are ``2 * margin`` apart; half a cell by default.
    blocked
        Packed layers (rows, columns, ``headings // 8``) when already known (a crop).

    Examples
    --------
    >>> from planners.robots import rectangle
    >>> grid = OccupancyGrid(np.zeros((20, 40), np.int8), resolution=0.1)
    >>> space = HeadingCSpace(grid, Footprint(rectangle(1.2, 0.4)), headings=16)
    >>> space.valid(2.0, 0.5, 0.0), space.valid(2.0, 0.5, math.pi / 2)  # 0.5 m from the edge
    (True, False)
    """

    grid: OccupancyGrid
    robot: Footprint
    headings: int = HEADINGS
    margin: float | None = None
    blocked: NDArray[np.uint8] = field(default=None, repr=False)  # type: ignore[arg-type]

    def __post_init__(self) -> None:
        headings = self.headings
        if not is_count(headings) or headings % 8 or not 8 <= headings <= 256:
            raise PlannerParameterError(
                f"headings must be a multiple of 8 in [8, 256], got {headings!r:.80}"
            )
        if self.margin is not None:
            problem = finite_in(self.margin, "margin", 0.0, MAX_LENGTH, unit="m")
            if problem is not None:
                raise PlannerParameterError(problem)
        margin = self.grid.resolution / 2 if self.margin is None else float(self.margin)
        object.__setattr__(self, "margin", margin)
        if self.blocked is None:
            object.__setattr__(self, "blocked", self._build())

    def _build(self) -> NDArray[np.uint8]:
        walls = (~self.grid.free).astype(np.uint8)
        kernels = footprint_kernels(
            self.robot, self.grid.resolution, self.headings, self.margin or 0.0, self.grid.origin[2]
        )
        packed = np.zeros((*walls.shape, self.headings // 8), np.uint8)
        for k, kernel in enumerate(kernels):
            layer = cv2.dilate(walls, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=1)
            packed[:, :, k // 8] |= np.asarray(layer, np.uint8) << np.uint8(k % 8)
        return packed

    @property
    def growth(self) -> float:
        """Metres this space grows the footprint by on every side: the turn over half a
        heading bin, the margin and a cell (the reference point anywhere in its cell). A
        door narrower than the footprint's width plus twice this has no valid pose."""
        return bin_turn(self.robot, self.headings) + (self.margin or 0.0) + self.grid.resolution

    # ------------------------------------------------------------------ lookups
    def bin_of(self, yaw: ArrayLike) -> NDArray[np.intp]:
        """Heading bin of each yaw (map frame, radians): bin ``k`` is centred on
        ``2 pi k / headings``."""
        return np.rint(np.asarray(yaw, float) * self.headings / (2 * math.pi)).astype(
            np.intp
        ) % int(self.headings)

    def valid_many(self, poses: ArrayLike) -> NDArray[np.bool_]:
        """Whether each pose ``(x, y, yaw)`` is valid (vectorised :meth:`valid`)."""
        p = np.asarray(poses, float).reshape(-1, 3)
        _, w, h, _, ox, oy, c, s, _ = self._scalar  # the arithmetic of :meth:`valid`
        dx, dy = p[:, 0] - ox, p[:, 1] - oy
        cols = np.floor(c * dx + s * dy).astype(np.intp)
        rows = h - 1 - np.floor(c * dy - s * dx).astype(np.intp)
        inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        k = self.bin_of(p[:, 2])
        out = np.zeros(len(p), bool)
        byte = self.blocked[rows[inside], cols[inside], k[inside] // 8]
        out[inside] = (byte >> (k[inside] % 8).astype(np.uint8)) & 1 == 0
        return out

    @cached_property
    def _scalar(self) -> tuple[bytes, int, int, int, float, float, float, float, float]:
        """The layers as bytes in lattice order and the frame constants, for :meth:`valid`."""
        h, w, depth = self.blocked.shape
        ox, oy, yaw = self.grid.origin
        r = self.grid.resolution
        c, s = math.cos(yaw) / r, math.sin(yaw) / r
        return self.blocked[::-1].tobytes(), w, h, depth, ox, oy, c, s, self.headings / math.tau

    def valid(self, x: float, y: float, yaw: float) -> bool:
        """Whether the robot may stand at ``(x, y)`` heading ``yaw`` (a lookup, no numpy:
        fast for OMPL callbacks)."""
        table, w, h, depth, ox, oy, c, s, per_radian = self._scalar
        dx, dy = x - ox, y - oy
        u, v = math.floor(c * dx + s * dy), math.floor(c * dy - s * dx)
        if not (0 <= u < w and 0 <= v < h):
            return False
        k = round(yaw * per_radian) % (depth * 8)
        return not (table[(v * w + u) * depth + (k >> 3)] >> (k & 7)) & 1

    def free_headings(self, x: float, y: float) -> NDArray[np.float64]:
        """The middles of the heading bins valid at ``(x, y)``, radians (none off the map)."""
        yaws = np.arange(self.headings, dtype=np.float64) * (2 * math.pi / self.headings)
        poses = np.column_stack([np.full_like(yaws, x), np.full_like(yaws, y), yaws])
        return yaws[self.valid_many(poses)]

    def crop(
        self, rows: slice, cols: slice, keep: NDArray[np.bool_] | None = None
    ) -> HeadingCSpace:
        """The part of this space in cells ``[rows, cols]``, blocked where ``keep`` (the
        part's shape) is false: states outside are invalid; map-frame coordinates unchanged."""
        grid = crop_grid(self.grid, rows, cols)
        blocked = self.blocked[rows, cols].copy()
        if keep is not None:
            blocked[~keep] = 255
        return HeadingCSpace(grid, self.robot, self.headings, self.margin, blocked)
