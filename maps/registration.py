"""Where one occupancy map lies on another: the shift and small turn that lay its walls on the
other's.

Two maps of one building saved at different times rarely share their frame exactly: a SLAM
re-run, a loop closure or a map saved with another origin moves it by decimetres or metres and
turns it by a degree or two. :func:`register` finds the move at metric scale (each map's origin
and resolution, which may differ), from the walls alone:

1. every turn within :data:`MAX_TURN` degrees in steps of 2 degrees, each with every shift,
   on 0.4 m cells: the shift is the peak of the cross-correlation of the two maps' walls
   (scipy's FFT), which finds a map moved by metres and one that covers only part of the other;
   twice: anywhere, and within :data:`NEAR` metres (of shifts that fit alike, the nearest);
2. for each, the turns within a degree of it (and of :data:`MAX_TURN`) in quarter-degree
   steps, on 0.2 m cells, near it;
3. iterative closest points (scipy's ``cKDTree``) from the walls thinned to 0.1 m to the other
   map's, pairs farther apart than 0.3 m left out (walls that are in one map only): to a
   fraction of a cell (not kept if it turns the map beyond :data:`MAX_TURN`).

Of the two, the one that lays more walls on walls (within a cell), the near one when they lay
as many: where rooms repeat, a small map's walls fit as well at every room, and the move a
loop closure makes is the near one. A move that shifts no cell by half a cell, or that lays no
more walls on walls than none, is no move (:class:`Placement` ``()``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy import fft
from scipy.spatial import cKDTree

from maps.grid import OccupancyGrid

#: Degrees either way the search turns a map: a SLAM re-run or a loop closure turns a map by a
#: degree or two; a map turned further is another frame the user knows of.
MAX_TURN = 10.0
#: Cell sides of the three steps, metres (at least four, two and one of the maps' cells).
STEPS = (0.4, 0.2, 0.1)
#: Metres apart two wall points may be to pair in the last step.
PAIRED = 0.3
#: Cells on a side the first step's correlation may have (coarser cells on larger maps).
MAX_CANVAS = 512
#: Wall points the last step pairs at most (evenly spread over the walls).
MAX_PAIRS = 4000
#: Metres a frame moves at most when a loop closure or a SLAM re-run corrects it: a move this
#: near that lays as many walls on walls as the best one anywhere is taken over it.
NEAR = 3.0


@dataclass(frozen=True)
class Placement:
    """A rigid move of a map frame: turned ``degrees`` counter-clockwise about the frame's
    origin, then shifted ``(x, y)`` metres.

    Examples
    --------
    >>> move = Placement(1.0, 0.0, 90.0)
    >>> move.apply(np.array([[1.0, 0.0]])).round(6).tolist()
    [[1.0, 1.0]]
    >>> str(move)
    'shifted (1.00, 0.00) m and turned 90.0 degrees'
    """

    x: float = 0.0
    y: float = 0.0
    degrees: float = 0.0

    def __str__(self) -> str:
        x, y, turn = (round(v, n) + 0.0 for v, n in zip(self.as_tuple(), (2, 2, 1), strict=True))
        return f"shifted ({x:.2f}, {y:.2f}) m and turned {turn:.1f} degrees"  # + 0.0: no -0

    def apply(self, points: NDArray[np.floating]) -> NDArray[np.float64]:
        """``points`` (``n x 2``, metres) moved."""
        return _turned(np.asarray(points, float), self.degrees) + np.array([self.x, self.y])

    def moved(self, grid: OccupancyGrid) -> OccupancyGrid:
        """``grid`` with its origin moved: its cells where the move lays them."""
        ox, oy, yaw = grid.origin
        ((x, y),) = self.apply(np.array([[ox, oy]]))
        return OccupancyGrid(grid.cells, grid.resolution, (x, y, yaw + math.radians(self.degrees)))

    def largest_shift(self, grid: OccupancyGrid) -> float:
        """Metres the farthest moved corner of ``grid`` moves."""
        xmin, ymin, xmax, ymax = grid.bounds()
        corners = np.array([[xmin, ymin], [xmin, ymax], [xmax, ymin], [xmax, ymax]])
        return float(np.hypot(*(self.apply(corners) - corners).T).max())

    def as_dict(self) -> dict[str, float]:
        """The move for a JSON summary: millimetres and hundredths of a degree."""
        rounded = (round(v, n) + 0.0 for v, n in zip(self.as_tuple(), (3, 3, 2), strict=True))
        return dict(zip(("x", "y", "degrees"), rounded, strict=True))

    def as_tuple(self) -> tuple[float, float, float]:
        """``(x, y, degrees)``."""
        return self.x, self.y, self.degrees


def register(previous: OccupancyGrid, grid: OccupancyGrid) -> Placement:
    """The move that lays the walls of ``previous`` on those of ``grid`` (the module's steps).

    Examples
    --------
    >>> cells = np.zeros((60, 80), np.int8)
    >>> cells[[0, -1], :] = cells[:, [0, 30, -1]] = 100  # two rooms
    >>> cells[20:40, 30] = 0  # a door
    >>> old = OccupancyGrid(cells, 0.1)
    >>> register(old, OccupancyGrid(cells, 0.1, (1.3, -0.4, 0.0))).as_dict()
    {'x': 1.3, 'y': -0.4, 'degrees': 0.0}
    >>> register(old, old)
    Placement(x=0.0, y=0.0, degrees=0.0)
    """
    cell = max(previous.resolution, grid.resolution)
    walls, target = _walls(previous), _walls(grid)
    if len(walls) == 0 or len(target) == 0:
        return Placement()
    steps = [max(step, factor * cell) for step, factor in zip(STEPS, (4, 2, 1), strict=True)]
    about = walls.mean(axis=0)
    reach = float(np.hypot(*(walls - about).T).max())
    span = float(np.ptp(target, axis=0).max()) + 2 * reach
    steps[0] = max(steps[0], span / MAX_CANVAS)
    coarse = np.arange(-MAX_TURN, MAX_TURN + 1e-9, 2.0)
    sample = _thinned(walls, steps[2])
    tree, sample = cKDTree(target), sample[:: -(-len(sample) // MAX_PAIRS)]

    def refined(degrees: float, shift: NDArray[np.float64]) -> Placement:
        fine = degrees + np.arange(-1.0, 1.0 + 1e-9, 0.25)
        fine = fine[np.abs(fine) <= MAX_TURN + 1e-9]
        ((degrees, shift),) = _best_shift(walls, target, about, fine, steps[1], shift)
        closest = _closest_points(sample, tree, about, degrees, shift)
        if abs(closest[0]) <= MAX_TURN:  # beyond: pulled off by walls of another place
            degrees, shift = closest
        offset = about + shift - _turned(about[None], degrees)[0]
        return Placement(float(offset[0]), float(offset[1]), degrees)

    def on_walls(move: Placement) -> int:
        distance = tree.query(move.apply(sample), distance_upper_bound=cell)[0]
        return int(np.count_nonzero(np.isfinite(distance)))

    # the best move anywhere, and the best within NEAR: where rooms repeat, a far move can lay
    # a small map's walls as well as the true one; of two that do, the nearer is the one
    anywhere, near = (
        refined(*move) for move in _best_shift(walls, target, about, coarse, steps[0], near=NEAR)
    )
    fits = {move: on_walls(move) for move in (near, anywhere, Placement())}
    found = near if fits[near] >= fits[anywhere] else anywhere
    if found.largest_shift(previous) < cell / 2 or fits[found] <= fits[Placement()]:
        return Placement()
    return found


def _walls(grid: OccupancyGrid) -> NDArray[np.float64]:
    """Centres (metres) of the occupied cells with a cell of another kind beside them."""
    occupied = grid.occupied.view(np.uint8)
    inner = cv2.erode(occupied, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE)
    rows, cols = np.nonzero(occupied > inner)
    return np.column_stack(grid.cell_to_world(rows, cols))


def _thinned(points: NDArray[np.float64], step: float) -> NDArray[np.float64]:
    """One of ``points`` in each ``step``-sided cell they fall in."""
    keys = np.floor(points / step).astype(np.int64)
    keys -= keys.min(axis=0)
    _, first = np.unique(keys[:, 0] * (int(keys[:, 1].max()) + 1) + keys[:, 1], return_index=True)
    return points[first]


def _turned(points: NDArray[np.float64], degrees: float) -> NDArray[np.float64]:
    """``points`` turned ``degrees`` counter-clockwise about the frame's origin."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    return points @ np.array([[c, s], [-s, c]])


def _raster(
    points: NDArray[np.float64], low: NDArray[np.float64], shape: tuple[int, ...], step: float
) -> NDArray[np.float32]:
    """An image of ``shape`` with 1 in the ``step``-sided cells from ``low`` that hold points."""
    image = np.zeros(shape, np.float32)
    cols, rows = np.floor((points - low) / step).astype(np.intp).T
    inside = (rows >= 0) & (rows < shape[0]) & (cols >= 0) & (cols < shape[1])
    image[rows[inside], cols[inside]] = 1.0
    return image


def _best_shift(
    walls: NDArray[np.float64],
    target: NDArray[np.float64],
    about: NDArray[np.float64],
    turns: NDArray[np.float64],
    step: float,
    start: NDArray[np.float64] | None = None,
    near: float | None = None,
) -> list[tuple[float, NDArray[np.float64]]]:
    """Of ``turns`` (about ``about``) and the shifts, the one that lays the most of ``walls``
    on ``target`` (blurred by a cell), on ``step``-sided cells: ``[(degrees, shift)]``. Every
    shift, or with ``start`` those within two cells twice as large of it (the previous step's
    shift: a canvas the size of the walls, not of both maps); with ``near``, the same
    correlations give a second: the best of the shifts that move the frame's origin at most
    ``near`` metres (of those that fit alike, the nearest)."""
    walls, target = _thinned(walls, step), _thinned(target, step)
    if start is None:
        reach = np.full(2, float(np.hypot(*(walls - about).T).max()) + step)
        low, high = target.min(axis=0) - reach, target.max(axis=0) + reach
    else:  # the walls where the turns lay them, and the shifts' and turns' slack around
        turned = [_turned(walls - about, float(d)) + about + start for d in turns[[0, -1]]]
        low = np.min([t.min(axis=0) for t in turned], axis=0) - 5 * step
        high = np.max([t.max(axis=0) for t in turned], axis=0) + 5 * step
    shape = tuple(fft.next_fast_len(int(v), real=True) for v in ((high - low) / step + 1)[::-1])
    spectrum = fft.rfft2(cv2.GaussianBlur(_raster(target, low, shape, step), (0, 0), 1.0))
    anchor = low + np.array(shape[::-1]) * step / 2 if start is None else about + start
    size = np.array(shape[::-1])
    if near is not None:  # each cell's shift in cells (x, y), as the peak's is read below
        grid = np.indices(shape)[::-1].astype(float)
        wrapped = np.where(grid > size[:, None, None] // 2, grid - size[:, None, None], grid)
    searches = 1 if near is None else 2
    best = [-np.inf] * searches
    found = [(0.0, np.zeros(2))] * searches
    for degrees in turns:
        image = _raster(_turned(walls - about, degrees) + anchor, low, shape, step)
        scores = fft.irfft2(spectrum * np.conj(fft.rfft2(image)), s=shape)
        if start is not None:  # wrapped around beyond 4 cells: not searched
            scores[5:-4] = scores[:, 5:-4] = 0
        searched = [scores]
        if near is not None:  # the frame's origin moves by anchor + cells * step - turned about
            origin = anchor - _turned(about[None], float(degrees))[0]
            moves = np.hypot(*(origin[:, None, None] + wrapped * step))
            searched.append(np.where(moves <= near, scores - moves * 1e-6 * scores.max(), -np.inf))
        for i, values in enumerate(searched):
            peak = np.unravel_index(int(np.argmax(values)), shape)
            if values[peak] > best[i]:
                cells = np.array(peak[::-1]) + _vertex(scores, peak)
                cells = np.where(cells > size // 2, cells - size, cells)
                best[i] = float(values[peak])
                found[i] = (float(degrees), anchor - about + cells * step)
    return found


def _vertex(scores: NDArray[np.floating], peak: tuple[np.intp, ...]) -> NDArray[np.float64]:
    """Where, within half a cell of ``peak`` (x, y), the parabola through it and its two
    neighbours peaks (``scores`` wrap around)."""
    offsets = []
    for axis in (1, 0):
        before, after = list(peak), list(peak)
        before[axis], after[axis] = peak[axis] - 1, (peak[axis] + 1) % scores.shape[axis]
        low, mid, high = scores[tuple(before)], scores[peak], scores[tuple(after)]
        bend = low - 2 * mid + high
        offsets.append(0.0 if bend >= 0 else float(np.clip((low - high) / (2 * bend), -0.5, 0.5)))
    return np.array(offsets)


def _closest_points(
    walls: NDArray[np.float64],
    tree: cKDTree,
    about: NDArray[np.float64],
    degrees: float,
    shift: NDArray[np.float64],
    rounds: int = 30,
) -> tuple[float, NDArray[np.float64]]:
    """Iterative closest points from ``(degrees, shift)`` (about ``about``): each round pairs
    every wall point with the nearest of ``tree`` within :data:`PAIRED` and takes the turn and
    shift that lay the pairs closest (least squares), until they settle."""
    walls = walls - about
    for _ in range(rounds):
        distance, nearest = tree.query(
            _turned(walls, degrees) + about + shift, distance_upper_bound=PAIRED
        )
        paired = np.isfinite(distance)
        if np.count_nonzero(paired) < 2:
            break
        mine, theirs = walls[paired], tree.data[nearest[paired]] - about
        mine_mean, theirs_mean = mine.mean(axis=0), theirs.mean(axis=0)
        p, q = mine - mine_mean, theirs - theirs_mean
        turn = math.degrees(
            math.atan2(np.sum(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]), np.sum(p * q))
        )
        moved = theirs_mean - _turned(mine_mean[None], turn)[0]
        settled = abs(turn - degrees) < 1e-3 and np.hypot(*(moved - shift)) < 1e-4
        degrees, shift = turn, moved
        if settled:
            break
    return degrees, shift
