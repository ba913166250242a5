"""Build an occupancy grid from keyframes: ray-traced free space, beam end points occupied."""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np
from numpy.typing import NDArray

from maps.errors import InvalidScanError, MapTooLargeError
from maps.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from maps.limits import RESOLUTION_RANGE, check_map_size, finite_in
from maps.scan import Keyframe, transform_points

#: Sub-pixel bits used when filling scan polygons with OpenCV.
_SHIFT = 4


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
    if not keyframes:
        raise InvalidScanError("cannot build a map from no keyframes")
    for problem in (
        finite_in(resolution, "resolution", *RESOLUTION_RANGE, unit="m per cell"),
        finite_in(max_range, "max_range", 0.0, 1e4, unit="m", low_open=True),
        finite_in(margin, "margin", 0.0, 1e3, unit="m"),
    ):
        if problem is not None:
            raise InvalidScanError(problem)
    ends, origins = [], []
    for frame in keyframes:
        scan = frame.scan
        keep = scan.valid & (scan.ranges <= max_range)
        ranges = np.where(keep, scan.ranges, 0.0)
        local = np.column_stack((np.cos(scan.angles), np.sin(scan.angles)))
        ends.append((transform_points(local * ranges[:, None], frame.pose), keep))
        origins.append(frame.pose[:2])
    every = np.vstack([p[k] for p, k in ends] + [np.array(origins)])
    lo = every.min(axis=0) - margin
    hi = every.max(axis=0) + margin
    width = math.ceil((hi[0] - lo[0]) / resolution)
    height = math.ceil((hi[1] - lo[1]) / resolution)
    try:
        check_map_size(height, width, what=f"map at {resolution:g} m per cell")
    except MapTooLargeError as err:
        poses = np.array(origins)
        far = int(np.argmax(np.hypot(*(poses - np.median(poses, axis=0)).T)))
        x, y = poses[far]
        raise MapTooLargeError(
            f"{err}: the keyframes span {hi[0] - lo[0]:.4g} x {hi[1] - lo[1]:.4g} m; the farthest "
            f"from the others is scan {keyframes[far].scan_index} at ({x:.4g}, {y:.4g}) m"
        ) from None
    visits = np.zeros((height, width), np.uint32)
    hits = np.zeros((height, width), np.uint32)

    def to_pixels(xy: NDArray[np.float64]) -> NDArray[np.float64]:
        """Map metres to continuous (col, row) image coordinates, row 0 at the top."""
        return np.column_stack(
            ((xy[:, 0] - lo[0]) / resolution, height - (xy[:, 1] - lo[1]) / resolution)
        )

    for (points, keep), origin in zip(ends, origins, strict=True):
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
        window = (slice(corner[1], far[1]), slice(corner[0], far[0]))
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
        visits[window] += seen | hit
        hits[window] += hit
    cells = np.full((height, width), UNKNOWN, np.int8)
    seen_any = visits > 0
    ratio = np.divide(hits, visits, out=np.zeros(hits.shape), where=seen_any)
    cells[seen_any & (ratio < occupied_ratio)] = FREE
    cells[seen_any & (ratio >= occupied_ratio)] = OCCUPIED
    return OccupancyGrid(cells, resolution, (float(lo[0]), float(lo[1]), 0.0))
