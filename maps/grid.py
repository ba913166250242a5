"""The occupancy grid: cells, resolution and origin, as ROS nav_msgs/OccupancyGrid defines them."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.errors import InvalidMapError
from maps.limits import MAX_COORDINATE, MAX_LENGTH, RESOLUTION_RANGE, check_map_size, finite_in
from maps.tf import is_rotation, quaternion_from_yaw, yaw_from_quaternion

if TYPE_CHECKING:
    from typing import Self

UNKNOWN = -1
FREE = 0
OCCUPIED = 100
#: Cells at or above this occupancy (0..100) count as occupied, below it as free.
OCCUPIED_FROM = 50
#: The farthest cell index :meth:`OccupancyGrid.world_to_cell` returns, in cells from the
#: origin: far outside any grid (a grid's sides are bounded far below it), and safe from
#: overflow in the index arithmetic.
FAR = 2**40

Pose = tuple[float, float, float]


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """A 2-D occupancy grid in the map frame (REP-103, metres).

    Parameters
    ----------
    cells
        ``(height, width)`` int8 occupancy as in nav_msgs/OccupancyGrid: -1 unknown, 0 free to
        100 occupied. Rows are in image order: row 0 is the *top* of the map (largest y).
    resolution
        Cell size in metres.
    origin
        ``(x, y, yaw)`` of the lower-left corner of the lower-left cell in the map frame.

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((10, 20), np.int8), resolution=0.1)
    >>> [int(v) for v in grid.world_to_cell(0.05, 0.05)]
    [9, 0]
    """

    cells: NDArray[np.int8]
    resolution: float
    origin: Pose = (0.0, 0.0, 0.0)
    _derived: dict[str, NDArray[np.generic]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        try:
            cells = np.asarray(self.cells)
        except ValueError:  # rows of different lengths
            raise InvalidMapError(
                "cells must be a 2-D array, got rows of different lengths"
            ) from None
        if cells.ndim != 2 or cells.size == 0:
            raise InvalidMapError(f"cells must be a non-empty 2-D array, got shape {cells.shape}")
        check_map_size(*cells.shape, what="grid")  # before a pass over a view of a huge array
        if not np.issubdtype(cells.dtype, np.integer):
            raise InvalidMapError(f"cells must be integers (-1..100), got dtype {cells.dtype}")
        if cells.min() < UNKNOWN or cells.max() > OCCUPIED:
            raise InvalidMapError(
                f"cells must lie in -1..100, got {int(cells.min())}..{int(cells.max())}"
            )
        problem = finite_in(self.resolution, "resolution", *RESOLUTION_RANGE, unit="m per cell")
        if problem is not None:
            raise InvalidMapError(problem)
        resolution = float(self.resolution)
        try:
            origin = tuple(self.origin)
        except TypeError:  # None, a number
            origin = ()
        if len(origin) != 3 or any(
            finite_in(v, "origin", -MAX_COORDINATE, MAX_COORDINATE) for v in origin
        ):
            raise InvalidMapError(
                f"origin must be three finite numbers (x, y, yaw) within {MAX_COORDINATE:g} m, "
                f"got {self.origin!r}"
            )
        cells = np.array(cells, dtype=np.int8, copy=True)
        cells.setflags(write=False)
        object.__setattr__(self, "cells", cells)
        object.__setattr__(self, "resolution", resolution)
        object.__setattr__(self, "origin", tuple(float(v) for v in origin))

    # ------------------------------------------------------------------ construction and I/O
    @classmethod
    def from_masks(
        cls,
        free: ArrayLike,
        resolution: float,
        origin: Pose = (0.0, 0.0, 0.0),
        unknown: ArrayLike | None = None,
    ) -> Self:
        """A grid whose ``free`` cells are free and every other cell occupied (or ``unknown``);
        the masks are boolean (or 0 / 1) arrays of one 2-D shape.

        Examples
        --------
        >>> OccupancyGrid.from_masks([[True, False]], 0.1, unknown=[[False, True]]).cells.tolist()
        [[0, -1]]
        >>> OccupancyGrid.from_masks([[np.nan, 1.0]], 0.1)
        Traceback (most recent call last):
        ...
        maps.errors.InvalidMapError: free must be a boolean (or 0 / 1) 2-D mask, got dtype float64
        """
        masks = {"free": _mask(free, "free")}
        if unknown is not None:
            masks["unknown"] = _mask(unknown, "unknown")
            if masks["unknown"].shape != masks["free"].shape:
                raise InvalidMapError(
                    f"unknown of shape {masks['unknown'].shape} for free of shape "
                    f"{masks['free'].shape}"
                )
        cells = np.where(masks["free"], FREE, OCCUPIED).astype(np.int8)
        if unknown is not None:
            cells[masks["unknown"] & ~masks["free"]] = UNKNOWN
        return cls(cells, resolution, origin)

    @classmethod
    def load(cls, path: str | Path) -> OccupancyGrid:
        """Read a ROS map_server YAML and its image (see :func:`maps.map_server.load_map`)."""
        from maps.map_server import load_map

        return load_map(path)

    @classmethod
    def from_image(
        cls, image: str | Path | NDArray[np.uint8], resolution: float, **options: object
    ) -> OccupancyGrid:
        """A grid from a plain image file or array (see :func:`maps.map_server.grid_from_image`)."""
        from maps.map_server import grid_from_image

        return grid_from_image(image, resolution, **options)  # type: ignore[arg-type]

    def save(self, path: str | Path, *, overwrite: bool = False) -> Path:
        """Write ``path`` (YAML) and its PGM image (see :func:`maps.map_server.save_map`)."""
        from maps.map_server import save_map

        return save_map(self, path, overwrite=overwrite)

    @classmethod
    def from_msg_fields(cls, message: Any) -> OccupancyGrid:
        """A grid from the fields of a nav_msgs/OccupancyGrid message.

        ``message`` is a plain dict (as :meth:`to_msg_fields` writes it) or any object with the
        message's attributes (a ROS 2 message, a deserialised rosbags message). The message's
        row 0 is the *bottom* of the map; the grid's is the top. ``header`` is not read.

        Raises
        ------
        InvalidMapError
            If a field is missing or ``data`` does not hold ``width * height`` values in -1..100;
            the message names the field.

        Examples
        --------
        >>> grid = OccupancyGrid(np.array([[0, 100], [-1, 0]], np.int8), 0.5, (1.0, 2.0, 0.0))
        >>> fields = grid.to_msg_fields(frame_id="map")
        >>> fields["info"]["width"], fields["data"]  # bottom row first
        (2, [-1, 0, 0, 100])
        >>> OccupancyGrid.from_msg_fields(fields) == grid
        True
        """
        try:
            info = _field(message, "info")
            width, height = (
                _size(_field(info, "width"), "width"),
                _size(_field(info, "height"), "height"),
            )
            origin = _field(info, "origin")
            position, rotation = _field(origin, "position"), _field(origin, "orientation")
            quaternion = [float(_field(rotation, k)) for k in "xyzw"]
            if not is_rotation(*quaternion):
                raise InvalidMapError(
                    f"OccupancyGrid field 'info.origin.orientation' is no rotation: {quaternion}"
                )
            pose = (
                float(_field(position, "x")),
                float(_field(position, "y")),
                yaw_from_quaternion(*quaternion),
            )
            resolution = float(_field(info, "resolution"))
            data = np.asarray(_field(message, "data"))
        except KeyError as err:
            raise InvalidMapError(f"OccupancyGrid message has no field {err.args[0]!r}") from None
        except InvalidMapError:
            raise
        except (TypeError, ValueError, OverflowError) as err:
            raise InvalidMapError(
                f"OccupancyGrid message has a field that is not a number: {err}"
            ) from None
        if width == 0 or height == 0:
            raise InvalidMapError(
                f"OccupancyGrid message is empty: info.width {width}, info.height {height}"
            )
        check_map_size(height, width, what="OccupancyGrid message")
        if data.ndim != 1 or data.size != width * height:
            raise InvalidMapError(
                f"OccupancyGrid field 'data' holds {data.size} values, expected "
                f"info.width * info.height = {width} * {height}"
            )
        if data.dtype.kind not in "iuf" or (
            data.dtype.kind == "f" and not np.all(np.isfinite(data) & (data == np.round(data)))
        ):
            raise InvalidMapError(
                f"OccupancyGrid field 'data' must hold whole numbers, got {data.dtype} values"
            )
        if data.size and (data.min() < UNKNOWN or data.max() > OCCUPIED):
            raise InvalidMapError(
                f"OccupancyGrid field 'data' must lie in -1..100, got "
                f"{int(data.min())}..{int(data.max())}"
            )
        cells = data.astype(np.int8).reshape(height, width)[::-1]
        return cls(cells, resolution, pose)

    def to_msg_fields(self, *, frame_id: str = "map", stamp: float = 0.0) -> dict[str, Any]:
        """The fields of a nav_msgs/OccupancyGrid message, as plain dicts, lists and numbers.

        ``data`` runs row by row from the bottom of the map, as the message wants; stamps are
        ``{"sec", "nanosec"}`` (ROS 2). A ROS 2 node fills its message from it, e.g.
        ``msg.info.width = fields["info"]["width"]``; :meth:`from_msg_fields` reads it back.

        Parameters
        ----------
        frame_id
            The header's frame.
        stamp
            The header's and ``info.map_load_time``'s time, seconds.
        """
        sec = math.floor(stamp)
        time = {"sec": int(sec), "nanosec": round((stamp - sec) * 1e9)}
        x, y, yaw = self.origin
        qx, qy, qz, qw = quaternion_from_yaw(yaw)
        return {
            "header": {"stamp": dict(time), "frame_id": frame_id},
            "info": {
                "map_load_time": dict(time),
                "resolution": self.resolution,
                "width": self.shape[1],
                "height": self.shape[0],
                "origin": {
                    "position": {"x": x, "y": y, "z": 0.0},
                    "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
                },
            },
            "data": self.cells[::-1].ravel().tolist(),
        }

    # ------------------------------------------------------------------ cell classes
    @property
    def shape(self) -> tuple[int, int]:
        """``(height, width)`` in cells."""
        return (int(self.cells.shape[0]), int(self.cells.shape[1]))

    @property
    def free(self) -> NDArray[np.bool_]:
        """Boolean mask of free cells (occupancy 0..49), rows as in the image; cached,
        read-only."""
        return self._derive("free", lambda: (self.cells >= FREE) & (self.cells < OCCUPIED_FROM))

    @property
    def occupied(self) -> NDArray[np.bool_]:
        """Boolean mask of occupied cells (occupancy 50..100); cached, read-only."""
        return self._derive("occupied", lambda: self.cells >= OCCUPIED_FROM)

    @property
    def unknown(self) -> NDArray[np.bool_]:
        """Boolean mask of unknown cells (-1)."""
        return self.cells < FREE

    def __repr__(self) -> str:
        """One line: the size, resolution and origin (not the cells).

        Examples
        --------
        >>> OccupancyGrid(np.zeros((2, 3), np.int8), resolution=0.05)
        OccupancyGrid(3 x 2 cells of 0.05 m, origin (0.0, 0.0, 0.0))
        """
        rows, cols = self.shape
        return (
            f"OccupancyGrid({cols} x {rows} cells of {self.resolution:g} m, origin {self.origin})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, OccupancyGrid):
            return NotImplemented
        return (
            self.resolution == other.resolution
            and self.origin == other.origin
            and np.array_equal(self.cells, other.cells)
        )

    __hash__ = None  # type: ignore[assignment]

    # ------------------------------------------------------------------ frames
    def world_to_cell(
        self, x: ArrayLike, y: ArrayLike
    ) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Map-frame metres to ``(row, col)`` cell indices (may lie outside the grid; points
        farther than :data:`FAR` cells away are put that far, so any finite point is a cell
        index, outside the grid, with no overflow).

        Examples
        --------
        >>> grid = OccupancyGrid(np.zeros((2, 3), np.int8), 0.5)
        >>> grid.world_to_cell([0.2, 1.2], [0.2, 0.7])
        (array([1, 0]), array([0, 2]))
        >>> row, col = grid.world_to_cell(1e308, -1e308)
        >>> bool(grid.contains(row, col)), int(col) == FAR, int(row) == FAR + 1
        (False, True, True)
        """
        ox, oy, yaw = self.origin
        x, y = _numbers(x, y, "x", "y")
        dx, dy = x - ox, y - oy
        c, s = np.cos(yaw), np.sin(yaw)
        with np.errstate(over="ignore", invalid="ignore"):  # inf - inf: NaN, clipped below
            u = np.clip((c * dx + s * dy) / self.resolution, -FAR, FAR)
            v = np.clip((-s * dx + c * dy) / self.resolution, -FAR, FAR)
        col = np.floor(u).astype(np.intp)
        row = self.shape[0] - 1 - np.floor(v).astype(np.intp)
        return row, col

    def cell_to_world(
        self, row: ArrayLike, col: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centres of cells ``(row, col)`` in map-frame metres."""
        ox, oy, yaw = self.origin
        row, col = _numbers(row, col, "row", "col")
        u = (col + 0.5) * self.resolution
        v = (self.shape[0] - 1 - row + 0.5) * self.resolution
        c, s = np.cos(yaw), np.sin(yaw)
        return ox + c * u - s * v, oy + s * u + c * v

    def contains(self, row: ArrayLike, col: ArrayLike) -> NDArray[np.bool_]:
        """Whether cell indices lie inside the grid."""
        r, c = np.asarray(row), np.asarray(col)
        if not (_real(r) and _real(c)):  # the common case, index arrays, not copied
            r, c = _numbers(row, col, "row", "col")
        return (r >= 0) & (r < self.shape[0]) & (c >= 0) & (c < self.shape[1])

    def is_free(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.bool_]:
        """Whether map-frame points fall in free cells (points off the grid are not free)."""
        row, col = self.world_to_cell(x, y)
        inside = self.contains(row, col)
        out = np.zeros(np.shape(row), bool)
        out[inside] = self.free[row[inside], col[inside]]
        return out

    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of the grid's extent in the map frame."""
        h, w = self.shape
        corners = np.array([[0, 0], [w, 0], [0, h], [w, h]], float) * self.resolution
        ox, oy, yaw = self.origin
        c, s = np.cos(yaw), np.sin(yaw)
        xs = ox + c * corners[:, 0] - s * corners[:, 1]
        ys = oy + s * corners[:, 0] + c * corners[:, 1]
        return float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max())

    # ------------------------------------------------------------------ geometry
    def clearance(self) -> NDArray[np.float64]:
        """Distance in metres from each cell centre to the nearest non-free cell centre.

        The map's edge is an obstacle: the cells just outside the grid count as non-free, so
        no cell is clearer than its distance to the edge. Non-free cells have 0. Cached: the
        grid is immutable.

        Examples
        --------
        >>> grid = OccupancyGrid(np.zeros((3, 5), np.int8), resolution=0.1)  # all free
        >>> grid.clearance()[1]
        array([0.1, 0.2, 0.2, 0.2, 0.1])
        """
        return self._derive(
            "clearance", lambda: self.free_distance().astype(np.float64) * self.resolution
        )

    def free_clearance(self) -> NDArray[np.float32]:
        """``clearance_of(self.free, self.resolution)``, cached (read-only): the
        :func:`clearance_of` of the free cells in single precision, which the segmentation's
        stages share.

        Examples
        --------
        >>> grid = OccupancyGrid(np.zeros((3, 5), np.int8), resolution=0.5)
        >>> bool(np.array_equal(grid.free_clearance(), clearance_of(grid.free, 0.5)))
        True
        """
        return self._derive(
            "free_clearance", lambda: self.free_distance() * np.float32(self.resolution)
        )

    def with_free_clearance(self, clearance: ArrayLike) -> OccupancyGrid:
        """This grid with the clearance of its free cells given (metres, 0 on the other
        cells), e.g. measured on the finer map it was pooled from: :meth:`free_clearance`
        returns it.

        Examples
        --------
        >>> grid = OccupancyGrid(np.array([[0, 100]], np.int8), 0.1)
        >>> grid.with_free_clearance([[0.07, 0.0]]).free_clearance().tolist()
        [[0.07000000029802322, 0.0]]
        """
        try:
            values = np.array(clearance, np.float32)
        except (TypeError, ValueError, OverflowError):  # text, ragged rows
            raise InvalidMapError(f"clearance must be a {self.shape} array of metres") from None
        if values.shape != self.shape or not np.isfinite(values).all():
            raise InvalidMapError(
                f"clearance must be finite and of the grid's shape {self.shape}, got {values.shape}"
            )
        if (values < 0).any() or (values[~self.free] != 0).any():
            raise InvalidMapError("clearance must be >= 0 on free cells and 0 on the others")
        grid = OccupancyGrid(self.cells, self.resolution, self.origin)
        values.setflags(write=False)
        grid._derived["free_clearance"] = values
        return grid

    def free_distance(self) -> NDArray[np.float32]:
        """``clearance_of(self.free, 1.0)``, cached (read-only): the clearance in cells, what
        :meth:`clearance` and :meth:`free_clearance` are made of."""
        return self._derive("free_distance", lambda: clearance_of(self.free, 1.0))

    def _derive(self, name: str, make: Callable[[], NDArray[Any]]) -> NDArray[Any]:
        """``make()``, computed once per grid (the grid is immutable) and kept read-only."""
        if name not in self._derived:
            value = make()
            value.setflags(write=False)
            self._derived[name] = value
        return self._derived[name]

    def padded(self, left: int, top: int, right: int = 0, bottom: int = 0) -> OccupancyGrid:
        """The same map with ``left``, ``top``, ``right`` and ``bottom`` columns and rows of
        unknown cells added on those sides: every cell keeps its place in the map frame, only
        the cell grid moves against the building (what a map saved one cell over would be,
        or on a SLAM package's larger canvas).

        Examples
        --------
        >>> grid = OccupancyGrid(np.zeros((2, 3), np.int8), 0.1, (1.0, 2.0, 0.0))
        >>> moved = grid.padded(1, 2)
        >>> moved.shape, moved.origin, bool(moved.unknown[:2].all() and moved.unknown[:, 0].all())
        ((4, 4), (0.9, 2.0, 0.0), True)
        >>> [int(v) for v in moved.world_to_cell(1.05, 2.05)]
        [3, 1]
        >>> grid.padded(1, 2, 3, 4).shape, grid.padded(0, 0, 0, 1).origin
        ((8, 7), (1.0, 1.9, 0.0))
        """
        sides = (left, top, right, bottom)
        if not all(isinstance(side, int) and side >= 0 for side in sides):
            raise InvalidMapError(f"padding must be whole cells >= 0, got {sides!r}")
        height, width = self.shape[0] + top + bottom, self.shape[1] + left + right
        check_map_size(height, width, what="padded grid")
        cells = np.full((height, width), UNKNOWN, np.int8)
        cells[top : top + self.shape[0], left : left + self.shape[1]] = self.cells
        ox, oy, yaw = self.origin
        # the lower-left corner moves left along the grid's x and down along its y
        back, down = left * self.resolution, bottom * self.resolution
        c, s = math.cos(yaw), math.sin(yaw)
        return OccupancyGrid(
            cells, self.resolution, (ox - c * back + s * down, oy - s * back - c * down, yaw)
        )

    def known_box(self, margin: float) -> tuple[slice, slice]:
        """The rows and columns of the known cells and ``margin`` metres round them, within
        the grid (the whole grid if it knows nothing).

        Examples
        --------
        >>> cells = np.full((100, 200), -1, np.int8)
        >>> cells[40:50, 120:130] = 0  # a 1 x 1 m room at 0.1 m, in a 20 x 10 m canvas
        >>> OccupancyGrid(cells, 0.1).known_box(2.0)
        (slice(20, 70, None), slice(100, 150, None))
        """
        known = self.cells >= FREE
        rows, cols = np.flatnonzero(known.any(axis=1)), np.flatnonzero(known.any(axis=0))
        if len(rows) == 0:
            return slice(0, self.shape[0]), slice(0, self.shape[1])
        reach = math.ceil(margin / self.resolution - 1e-9)
        return (
            slice(max(int(rows[0]) - reach, 0), min(int(rows[-1]) + 1 + reach, self.shape[0])),
            slice(max(int(cols[0]) - reach, 0), min(int(cols[-1]) + 1 + reach, self.shape[1])),
        )

    def cropped(self, rows: slice, cols: slice) -> OccupancyGrid:
        """The cells ``rows`` x ``cols`` (slices with their bounds given, inside the grid) as
        a grid of their own: every cell keeps its place in the map frame.

        Examples
        --------
        >>> grid = OccupancyGrid(np.zeros((4, 5), np.int8), 0.1, (1.0, 2.0, 0.0))
        >>> part = grid.cropped(slice(1, 3), slice(2, 5))
        >>> part.shape, part.origin
        ((2, 3), (1.2, 2.1, 0.0))
        >>> grid.cell_to_world(2, 3) == part.cell_to_world(1, 1)
        True
        """
        height, width = self.shape
        if not (
            isinstance(rows.start, int)
            and isinstance(rows.stop, int)
            and isinstance(cols.start, int)
            and isinstance(cols.stop, int)
            and 0 <= rows.start < rows.stop <= height
            and 0 <= cols.start < cols.stop <= width
            and rows.step is None
            and cols.step is None
        ):
            raise InvalidMapError(
                f"a crop must be rows and columns inside the {height} x {width} cells, got "
                f"{rows!r}, {cols!r}"
            )
        ox, oy, yaw = self.origin
        right, up = cols.start * self.resolution, (height - rows.stop) * self.resolution
        c, s = math.cos(yaw), math.sin(yaw)  # the lower-left corner moves along the grid's axes
        origin = (ox + c * right - s * up, oy + s * right + c * up, yaw)
        return OccupancyGrid(self.cells[rows, cols], self.resolution, origin)

    def inflate(self, radius: float) -> OccupancyGrid:
        """A grid where free cells closer than ``radius`` metres to a non-free cell are occupied.

        A cell stays free when the nearest non-free cell's centre is more than
        ``radius + resolution / 2`` away, i.e. a disc of ``radius`` centred on the cell clears
        that cell's edge. Unknown cells block like occupied ones.
        """
        problem = finite_in(radius, "inflation radius", 0.0, MAX_LENGTH, unit="m")
        if problem is not None:
            raise InvalidMapError(problem)
        blocked = self.free & (self.clearance() <= radius + self.resolution / 2)
        cells = self.cells.copy()
        cells[blocked] = OCCUPIED
        return OccupancyGrid(cells, self.resolution, self.origin)


def _size(value: Any, name: str) -> int:
    """A message's ``info.width`` or ``info.height``: a whole number >= 0."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 0:
        raise InvalidMapError(
            f"OccupancyGrid field 'info.{name}' must be a whole number >= 0, got {value!r}"
        )
    return int(value)


def _field(message: Any, name: str) -> Any:
    """Field ``name`` of a message given as a mapping or as an object; KeyError if absent."""
    if isinstance(message, Mapping):
        return message[name]
    if not hasattr(message, name):
        raise KeyError(name)
    return getattr(message, name)


def clearance_of(space: NDArray[np.bool_], resolution: float) -> NDArray[np.float32]:
    """Distance in metres from each cell of ``space`` to the nearest cell outside it, the map
    edge counting as outside: the exact Euclidean distance transform, OpenCV's (ten times
    faster than SciPy's ``distance_transform_edt`` on a 768 x 864 map, 4 ms against 40; the
    same values to 4e-6 cells). :meth:`OccupancyGrid.clearance` is this of the free cells.

    Examples
    --------
    >>> space = np.ones((3, 5), bool)
    >>> clearance_of(space, 0.5)[1].tolist()
    [0.5, 1.0, 1.0, 1.0, 0.5]

    Only the box round ``space`` is transformed (a building takes a fraction of its map): the
    cells just outside the box are outside ``space`` and nearer than any farther one, so the
    distances are the same.

    >>> space = np.zeros((4, 6), bool); space[1:3, 2:5] = True
    >>> clearance_of(space, 1.0)[1:3].tolist()
    [[0.0, 0.0, 1.0, 1.0, 1.0, 0.0], [0.0, 0.0, 1.0, 1.0, 1.0, 0.0]]
    """
    import cv2

    found = np.zeros(space.shape, np.float32)
    rows, cols = np.flatnonzero(space.any(axis=1)), np.flatnonzero(space.any(axis=0))
    if len(rows) == 0:
        return found
    box = np.s_[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]
    padded = np.pad(space[box], 1).astype(np.uint8)
    distance = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    # the distance to the nearest outside cell's centre is the root of a whole number of
    # cells squared; OpenCV's last bits are not (on small images they differ from one call
    # to the next), so the squares are rounded to it: the same map gives the same places
    np.multiply(distance, distance, out=distance)
    np.sqrt(np.rint(distance, out=distance), out=distance)
    np.multiply(distance[1:-1, 1:-1], np.float32(resolution), out=found[box])
    return found


def _mask(values: ArrayLike, name: str) -> NDArray[np.bool_]:
    """``values`` as a boolean 2-D mask, its size bounded before it is copied: booleans or
    integers 0 / 1 (a NaN or a string is no answer to "is this cell free")."""
    found = np.asarray(values)
    if found.ndim != 2 or found.size == 0:
        raise InvalidMapError(f"{name} must be a non-empty 2-D mask, got shape {found.shape}")
    check_map_size(*found.shape, what=f"{name} mask")
    if found.dtype != bool and not (
        np.issubdtype(found.dtype, np.integer) and found.min() >= 0 and found.max() <= 1
    ):
        raise InvalidMapError(
            f"{name} must be a boolean (or 0 / 1) 2-D mask, got dtype {found.dtype}"
        )
    return found.astype(bool)


def _real(values: NDArray) -> bool:
    """Whether ``values`` hold real numbers (integers, floats or booleans)."""
    return values.dtype.kind in "biuf"


def _numbers(a: ArrayLike, b: ArrayLike, first: str, second: str) -> tuple[NDArray, NDArray]:
    """``a`` and ``b`` as float arrays of one shape, or :class:`InvalidMapError` naming them
    (text, a dict, complex numbers, a 400-digit integer, shapes that do not broadcast).

    Examples
    --------
    >>> [v.tolist() for v in _numbers([1, 2], 3, "x", "y")]
    [[1.0, 2.0], [3.0, 3.0]]
    >>> _numbers("a", 1, "x", "y")
    Traceback (most recent call last):
    ...
    maps.errors.InvalidMapError: x and y must be real numbers of one shape, got 'a' and 1
    """
    try:
        if np.iscomplexobj(a) or np.iscomplexobj(b):
            raise TypeError("complex")
        found = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    except (TypeError, ValueError, OverflowError):
        raise InvalidMapError(
            f"{first} and {second} must be real numbers of one shape, got {a!r:.40} and {b!r:.40}"
        ) from None
    return found[0], found[1]
