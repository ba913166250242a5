"""Build an occupancy grid from keyframes: ray-traced free space, beam end points occupied."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np
from numpy.typing import NDArray

from maps.errors import InvalidScanError, MapTooLargeError
from maps.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from maps.limits import MAX_LENGTH, RESOLUTION_RANGE, check_map_size, finite_in
from maps.scan import Keyframe, transform_points

#: Sub-pixel bits used when filling scan polygons with OpenCV.
_SHIFT = 4
#: Side of the tiles the counts of a :class:`MapBuilder` are kept in, cells.
TILE = 256


def grid_from_keyframes(
    keyframes: Sequence[Keyframe],
    resolution: float = 0.05,
    *,
    max_range: float = 30.0,
    occupied_ratio: float = 0.25,
    margin: float = 1.0,
) -> OccupancyGrid:
    """An occupancy grid from keyframes with the counting (reflection) model.

    Each scan clears the cells it saw through: the polygon from the sensor through its beam end
    points, pulled one cell towards the sensor (beams with no valid reading, or longer than
    ``max_range``, clear nothing). Each end point hits its cell. A cell is occupied when hits
    make at least ``occupied_ratio`` of the scans that saw it, free when fewer, unknown when no
    scan saw it. Moving people, seen once or twice in cells seen free many times, wash out.

    Parameters
    ----------
    keyframes
        Scans with their poses in the map frame.
    resolution
        Cell size of the grid, metres.
    max_range
        Readings beyond this many metres are ignored (long readings are noisy).
    occupied_ratio
        Hit ratio from which a cell is occupied.
    margin
        Metres of unknown border around the observed area.
    """
    builder = MapBuilder(resolution, max_range=max_range, occupied_ratio=occupied_ratio)
    ends = _reserve(builder, keyframes, margin)
    for frame, (points, keep) in zip(keyframes, ends, strict=True):
        builder.count(np.asarray(frame.pose[:2]), points, keep)
    return builder.grid()


def check_map_extent(
    keyframes: Sequence[Keyframe],
    resolution: float = 0.05,
    *,
    max_range: float = 30.0,
    margin: float = 1.0,
) -> None:
    """Refuse keyframes whose map (:func:`grid_from_keyframes` with the same options) would be
    larger than memory allows, as it does, before a cell of it is allocated.

    Raises
    ------
    MapTooLargeError
        Naming the map's size, the keyframes' span and the keyframe farthest from the others.

    Examples
    --------
    >>> from maps.scan import LaserScan
    >>> scan = LaserScan(np.full(9, 2.0), -1.0, 0.25)
    >>> check_map_extent([Keyframe((0.0, 0.0, 0.0), scan), Keyframe((50.0, 0.0, 0.0), scan)])
    >>> far = [Keyframe((x, x, 0.0), scan, i) for i, x in enumerate((0.0, 1.0, 3e4))]
    >>> check_map_extent(far)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    maps.errors.MapTooLargeError: map at 0.05 m per cell of ... is scan 2 at (3e+04, 3e+04) m
    """
    _reserve(MapBuilder(resolution, max_range=max_range), keyframes, margin)


def _reserve(
    builder: MapBuilder, keyframes: Sequence[Keyframe], margin: float
) -> list[tuple[NDArray[np.float64], NDArray[np.bool_]]]:
    """Reserve in ``builder`` the map of ``keyframes`` with ``margin`` metres around (no cell
    allocated yet); the end points of each keyframe's beams and which of them count."""
    if not keyframes:
        raise InvalidScanError("cannot build a map from no keyframes")
    problem = finite_in(margin, "margin", 0.0, MAX_LENGTH, unit="m")
    if problem is not None:
        raise InvalidScanError(problem)
    ends = [builder.end_points(frame) for frame in keyframes]
    every = np.vstack([p[k] for p, k in ends] + [[frame.pose[:2] for frame in keyframes]])
    # the corner on the lattice of the cells, as MapBuilder.add puts it: a map built keyframe
    # by keyframe has the same cells
    res = builder.resolution
    lo = np.floor((every.min(axis=0) - margin) / res) * res
    hi = every.max(axis=0) + margin
    try:
        builder.reserve(lo, hi)
    except MapTooLargeError as err:
        poses = np.array([frame.pose[:2] for frame in keyframes])
        far = int(np.argmax(np.hypot(*(poses - np.median(poses, axis=0)).T)))
        x, y = poses[far]
        raise MapTooLargeError(
            f"{err}: the keyframes span {hi[0] - lo[0]:.4g} x {hi[1] - lo[1]:.4g} m; the farthest "
            f"from the others is scan {keyframes[far].scan_index} at ({x:.4g}, {y:.4g}) m"
        ) from None
    return ends


class MapBuilder:
    """The occupancy grid of :func:`grid_from_keyframes`, built keyframe by keyframe: the
    counts grow with the area seen, each keyframe touches only the cells it saw.

    The counts are kept in tiles of :data:`TILE` cells made as scans reach them, so a map that
    grows never copies what it holds (a copy of a large map's counts took 80 ms).

    Examples
    --------
    >>> from maps.scan import LaserScan
    >>> scan = LaserScan(np.full(180, 2.0), -np.pi, 2 * np.pi / 180)
    >>> builder = MapBuilder(0.1)
    >>> builder.add(Keyframe((0.0, 0.0, 0.0), scan))
    >>> grid = builder.grid()
    >>> bool(grid.is_free(0.5, 0.5)), bool(grid.is_free(3.0, 0.0))
    (True, False)
    """

    def __init__(
        self, resolution: float = 0.05, *, max_range: float = 30.0, occupied_ratio: float = 0.25
    ) -> None:
        for problem in (
            finite_in(resolution, "resolution", *RESOLUTION_RANGE, unit="m per cell"),
            finite_in(max_range, "max_range", 0.0, 1e4, unit="m", low_open=True),
            finite_in(occupied_ratio, "occupied_ratio", 0.0, 1.0, low_open=True),
        ):
            if problem is not None:
                raise InvalidScanError(problem)
        self.resolution = float(resolution)
        self.max_range = float(max_range)
        self.occupied_ratio = occupied_ratio
        self._low = np.zeros(2)  # map point of the lower-left corner of the extent
        self._shape = (0, 0)  # rows (from the top, as the grid's) and columns of the extent
        self._corner = np.zeros(2, np.int64)  # (row, column) of its top-left cell in the tiles
        # (tile row, tile column) -> visits and hits of its cells
        self._tiles: dict[tuple[int, int], NDArray[np.uint32]] = {}
        self._shared: set[tuple[int, int]] = set()  # tiles a snapshot holds: copied on write
        self._seen: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None  # of add

    def snapshot(self) -> MapBuilder:
        """A copy of the counts so far that later keyframes do not change, made in the time
        of copying the index of the tiles: a tile is copied when a later keyframe first
        writes to it. It may be read on another thread while keyframes are added here.

        Examples
        --------
        >>> from maps.scan import LaserScan
        >>> builder = MapBuilder(0.1)
        >>> builder.add(Keyframe((0.0, 0.0, 0.0), LaserScan(np.full(180, 2.0), -np.pi, 0.035)))
        >>> before = builder.snapshot()
        >>> builder.add(Keyframe((1.0, 0.0, 0.0), LaserScan(np.full(180, 2.0), -np.pi, 0.035)))
        >>> bool(before.grid().is_free(2.5, 0.0)), bool(builder.grid().is_free(2.5, 0.0))
        (False, True)
        """
        copy = MapBuilder(
            self.resolution, max_range=self.max_range, occupied_ratio=self.occupied_ratio
        )
        copy._low, copy._shape, copy._corner = self._low.copy(), self._shape, self._corner.copy()
        copy._tiles, copy._seen = dict(self._tiles), self._seen
        copy._shared = set(self._tiles)
        self._shared = set(self._tiles)
        return copy

    def end_points(self, frame: Keyframe) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """The beams' end points in the map frame and which of them count."""
        scan = frame.scan
        keep = scan.valid & (scan.ranges <= self.max_range)
        ranges = np.where(keep, scan.ranges, 0.0)
        local = np.column_stack((np.cos(scan.angles), np.sin(scan.angles)))
        return transform_points(local * ranges[:, None], frame.pose), keep

    def add(self, frame: Keyframe) -> None:
        """Count what the keyframe saw, growing the map to hold it (1 m of margin; the corner
        on the lattice of the cells, so every grid of this map has its cells there)."""
        points, keep = self.end_points(frame)
        lattice, high = self._extent(frame, points, keep)
        self.reserve(lattice, high)
        self.count(np.asarray(frame.pose[:2]), points, keep)
        self._seen = self._union(lattice, high, self._seen)

    def check(self, frames: Sequence[Keyframe]) -> None:
        """Refuse ``frames`` if :meth:`add` would refuse one of them, before anything changes.

        Raises
        ------
        MapTooLargeError
            :meth:`reserve`'s, at the first frame the map cannot hold, naming its scan.
        """
        seen = self._seen
        for frame in frames:
            low, high = self._extent(frame, *self.end_points(frame))
            try:
                self._check_size(low, high, seen)
            except MapTooLargeError as err:
                x, y = frame.pose[:2]
                raise MapTooLargeError(
                    f"{err} with scan {frame.scan_index} at ({x:.4g}, {y:.4g}) m"
                ) from None
            seen = self._union(low, high, seen)

    def _extent(
        self, frame: Keyframe, points: NDArray[np.float64], keep: NDArray[np.bool_]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The map :meth:`add` grows to hold the frame (its beams' end ``points``, ``keep``
        those that count): its corner on the lattice of the cells and its far corner."""
        every = np.vstack([points[keep], [frame.pose[:2]]])
        lattice = np.floor((every.min(axis=0) - 1.0) / self.resolution) * self.resolution
        return lattice, every.max(axis=0) + 1.0

    @staticmethod
    def _union(
        low: NDArray[np.float64],
        high: NDArray[np.float64],
        seen: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``low`` to ``high`` and what was ``seen`` (None: nothing)."""
        if seen is None:
            return low, high
        return np.minimum(low, seen[0]), np.maximum(high, seen[1])

    def _check_size(
        self,
        low: NDArray[np.float64],
        high: NDArray[np.float64],
        seen: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
    ) -> None:
        """:func:`~maps.limits.check_map_size` of the map of ``seen`` and ``low`` to ``high``."""
        res = self.resolution
        seen_low, seen_high = self._union(low, high, seen)
        cols, rows = np.ceil((seen_high - seen_low) / res)
        check_map_size(int(rows), int(cols), what=f"map at {res:g} m per cell")

    def reserve(self, low: NDArray[np.float64], high: NDArray[np.float64]) -> None:
        """Grow the counts to cover map points ``low`` to ``high`` (by half again at least, so
        growing costs little over a run).

        Raises
        ------
        MapTooLargeError
            If the map of what was counted and ``low`` to ``high`` (the grid :meth:`grid` would
            give, and :func:`check_map_extent` checks) is larger than memory allows. The room
            to grow is no memory (the tiles are made as scans reach them), so it is not
            counted: a run is taken keyframe by keyframe exactly when it is taken at once.
        """
        self._check_size(low, high, self._seen)
        res = self.resolution
        height, width = self._shape
        if height:
            top = self._low + np.array([width, height]) * res
            if np.all(low >= self._low) and np.all(high <= top):
                return
            span = top - self._low
            low = np.where(low < self._low, np.minimum(low, self._low - span / 2), self._low)
            high = np.where(high > top, np.maximum(high, top + span / 2), top)
        cols, rows = np.ceil((np.asarray(high) - low) / res).astype(int)
        low = np.asarray(low, float)
        if height:  # the old extent's top-left cell is (row, col) of the new one
            col = round((self._low[0] - low[0]) / res)
            row = rows - height - round((self._low[1] - low[1]) / res)
            low = np.array([self._low[0] - col * res, self._low[1] - (rows - height - row) * res])
            self._corner = self._corner - (row, col)
        self._low, self._shape = low, (int(rows), int(cols))

    def _pieces(
        self, row: int, col: int, height: int, width: int
    ) -> list[tuple[tuple[int, int], tuple[slice, slice], tuple[slice, slice]]]:
        """The tiles under the extent's cells ``row .. row + height``, ``col .. col + width``:
        each tile's key, its part of them (in the tile) and where that part lies in them."""
        top, left = int(self._corner[0]) + row, int(self._corner[1]) + col
        found = []
        for tile_row in range(top // TILE, (top + height - 1) // TILE + 1):
            for tile_col in range(left // TILE, (left + width - 1) // TILE + 1):
                r0, c0 = max(top, tile_row * TILE), max(left, tile_col * TILE)
                r1 = min(top + height, (tile_row + 1) * TILE)
                c1 = min(left + width, (tile_col + 1) * TILE)
                in_tile = (
                    slice(r0 - tile_row * TILE, r1 - tile_row * TILE),
                    slice(c0 - tile_col * TILE, c1 - tile_col * TILE),
                )
                found.append(
                    (
                        (tile_row, tile_col),
                        in_tile,
                        (slice(r0 - top, r1 - top), slice(c0 - left, c1 - left)),
                    )
                )
        return found

    def _read(self, row: int, col: int, height: int, width: int) -> NDArray[np.uint32]:
        """Visits and hits ``(2, height, width)`` of the extent's cells from ``(row, col)``."""
        counts = np.zeros((2, max(height, 0), max(width, 0)), np.uint32)
        if height > 0 and width > 0:
            for key, in_tile, part in self._pieces(row, col, height, width):
                tile = self._tiles.get(key)
                if tile is not None:
                    counts[:, part[0], part[1]] = tile[:, in_tile[0], in_tile[1]]
        return counts

    def count(
        self, origin: NDArray[np.float64], points: NDArray[np.float64], keep: NDArray[np.bool_]
    ) -> None:
        """Count one scan from sensor ``origin`` with end ``points`` (``keep`` those that
        count); the counts must already cover them (:meth:`reserve`)."""
        height, width = self._shape
        res, lo = self.resolution, self._low

        def to_pixels(xy: NDArray[np.float64]) -> NDArray[np.float64]:
            """Map metres to continuous (col, row) image coordinates, row 0 at the top."""
            return np.column_stack(((xy[:, 0] - lo[0]) / res, height - (xy[:, 1] - lo[1]) / res))

        sensor = to_pixels(np.asarray([origin]))[0]
        ends_px = to_pixels(points)
        offset = ends_px - sensor
        length = np.maximum(np.hypot(offset[:, 0], offset[:, 1]), 1e-9)
        # the free polygon stops a cell short of the end points; a hit is counted a quarter
        # cell beyond its end point, inside the surface it lies on (not in the free cell next
        # to a cell edge)
        pulled = sensor + offset * (np.maximum(length - 1.0, 0.0) / length)[:, None]
        pixels = sensor + offset * ((length + 0.25) / length)[:, None]
        outline = np.where(keep[:, None], pulled, sensor)
        extent = np.vstack([outline, pixels[keep], sensor[None]])
        corner = np.maximum(np.floor(extent.min(axis=0)).astype(int), 0)
        far = np.minimum(np.ceil(extent.max(axis=0)).astype(int) + 1, (width, height))
        seen = np.zeros((far[1] - corner[1], far[0] - corner[0]), np.uint8)
        polygon = np.round(
            (np.vstack([sensor, outline]) - corner) * (1 << _SHIFT) - (1 << (_SHIFT - 1))
        )
        cv2.fillPoly(seen, [polygon.astype(np.int32)], 1, lineType=cv2.LINE_8, shift=_SHIFT)
        hit = np.zeros_like(seen)
        cells = np.floor(pixels[keep]).astype(int) - corner
        inside = (
            (cells[:, 0] >= 0)
            & (cells[:, 1] >= 0)
            & (cells[:, 0] < seen.shape[1])
            & (cells[:, 1] < seen.shape[0])
        )
        hit[cells[inside, 1], cells[inside, 0]] = 1
        seen |= hit
        for key, in_tile, part in self._pieces(int(corner[1]), int(corner[0]), *seen.shape):
            tile = self._tiles.get(key)
            if tile is None:
                tile = self._tiles[key] = np.zeros((2, TILE, TILE), np.uint32)
            elif key in self._shared:
                tile = self._tiles[key] = tile.copy()
                self._shared.discard(key)
            tile[0][in_tile] += seen[part]
            tile[1][in_tile] += hit[part]

    def grid(
        self, low: NDArray[np.float64] | None = None, high: NDArray[np.float64] | None = None
    ) -> OccupancyGrid:
        """The occupancy grid of everything counted (what :meth:`add` saw, 1 m around: the
        grid :func:`grid_from_keyframes` makes of the same keyframes), or of the part between
        map points ``low`` and ``high``."""
        res = self.resolution
        height, width = self._shape
        first_col, last_row = 0, height
        last_col, first_row = width, 0
        if (low is None or high is None) and self._seen is not None:
            low, high = self._seen
        if low is not None and high is not None:
            # a point on the lattice is on it, whatever the rounding of its metres; the cells
            # counted from it as grid_from_keyframes counts them
            start = np.floor((np.asarray(low) - self._low) / res + 1e-6).astype(int)
            end = start + np.ceil((np.asarray(high) - low) / res).astype(int)
            first_col, last_col = max(0, int(start[0])), min(width, int(end[0]))
            last_row, first_row = min(height, height - int(start[1])), max(0, height - int(end[1]))
        visits, hits = self._read(first_row, first_col, last_row - first_row, last_col - first_col)
        cells = np.full(visits.shape, UNKNOWN, np.int8)
        seen_any = visits > 0
        ratio = np.divide(hits, visits, out=np.zeros(hits.shape), where=seen_any)
        cells[seen_any & (ratio < self.occupied_ratio)] = FREE
        cells[seen_any & (ratio >= self.occupied_ratio)] = OCCUPIED
        x0 = self._low[0] + first_col * res
        y0 = self._low[1] + (height - last_row) * res
        return OccupancyGrid(cells, res, (float(x0), float(y0), 0.0))
