"""An independent check of footprint paths: the footprint swept densely along the poses.

It shares nothing with :mod:`planners.cspace`: the poses are resampled a quarter cell apart
(positions interpolated, headings along the shorter turn), the footprint is filled with points
(its outline an eighth of a cell apart, its inside on a lattice of half a cell, so no cell
can hide inside it) and every point is looked up in the map's free cells.
"""

from __future__ import annotations

import itertools

import numpy as np
from numpy.typing import ArrayLike, NDArray
from shapely import contains_xy
from shapely.geometry import Polygon

from maps.grid import OccupancyGrid


def footprint_samples(polygon: ArrayLike, spacing: float) -> NDArray[np.float64]:
    """Points of a footprint in its own frame: the outline ``spacing / 4`` apart and the
    inside on a lattice of ``spacing``.

    Examples
    --------
    >>> len(footprint_samples([[0, 0], [1, 0], [1, 1], [0, 1]], 0.5)) > 16
    True
    """
    p = np.asarray(polygon, float)
    ring = np.vstack([p, p[:1]])
    outline = []
    for a, b in itertools.pairwise(ring):
        t = np.linspace(0, 1, max(2, int(np.ceil(4 * np.hypot(*(b - a)) / spacing))), False)
        outline.append(a + t[:, None] * (b - a))
    (xmin, ymin), (xmax, ymax) = p.min(axis=0), p.max(axis=0)
    x, y = np.meshgrid(np.arange(xmin, xmax, spacing), np.arange(ymin, ymax, spacing))
    inside = contains_xy(Polygon(p), x.ravel(), y.ravel())
    return np.vstack([*outline, np.column_stack([x.ravel(), y.ravel()])[inside]])


def resample_poses(poses: ArrayLike, step: float) -> NDArray[np.float64]:
    """Poses ``(x, y, yaw)`` with extra ones between, positions at most ``step`` apart and
    headings at most ``step`` radians apart (turning the shorter way)."""
    p = np.asarray(poses, float).reshape(-1, 3)
    if len(p) == 1:
        return p
    turn = np.angle(np.exp(1j * np.diff(p[:, 2])))
    moves = np.maximum(np.hypot(*np.diff(p[:, :2], axis=0).T), np.abs(turn))
    counts = np.maximum(1, np.ceil(moves / step).astype(int))
    owner = np.repeat(np.arange(len(p) - 1), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / counts[owner]
    xy = p[owner, :2] + t[:, None] * (p[owner + 1, :2] - p[owner, :2])
    yaw = p[owner, 2] + t * turn[owner]
    return np.vstack([np.column_stack([xy, yaw]), p[-1:]])


def footprint_collisions(
    grid: OccupancyGrid, polygon: ArrayLike, poses: ArrayLike, *, chunk: int = 512
) -> int:
    """How many poses, resampled a quarter cell apart along ``poses``, put a point of the
    footprint ``polygon`` (robot frame, metres) on a cell that is not free or off the map.

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((10, 30), np.int8), resolution=0.1)
    >>> square = [[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]]
    >>> footprint_collisions(grid, square, [[0.5, 0.5, 0.0], [2.5, 0.5, 1.0]])
    0
    >>> footprint_collisions(grid, square, [[0.5, 0.5, 0.0], [0.5, 0.9, 0.0]]) > 0
    True
    """
    samples = footprint_samples(polygon, grid.resolution / 2)
    dense = resample_poses(poses, grid.resolution / 4)
    free = grid.free
    h, w = free.shape
    hits = 0
    for begin in range(0, len(dense), chunk):
        p = dense[begin : begin + chunk]
        c, s = np.cos(p[:, 2])[:, None], np.sin(p[:, 2])[:, None]
        x = p[:, :1] + c * samples[:, 0] - s * samples[:, 1]
        y = p[:, 1:2] + s * samples[:, 0] + c * samples[:, 1]
        rows, cols = grid.world_to_cell(x, y)
        inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
        ok = np.zeros(inside.shape, bool)
        ok[inside] = free[rows[inside], cols[inside]]
        hits += int((~ok.all(axis=1)).sum())
    return hits
