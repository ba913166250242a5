"""Walls that continue past a gap: where a straight wall breaks off and goes on along the same
line, the gap between is where people draw the room's edge.

A SLAM map rarely shows a room's wall whole: an open door, a wide opening onto a corridor, a
glass wall the laser saw through leave a gap in a straight wall. The clearance alone cannot tell
a corridor beside a wide opening from the room behind it (the space only widens), so the places
found in it straddle the opening. A wall that goes on past the gap, on the same line, says where
the edge is. :func:`wall_gaps` finds such gaps (the walls' lines from the runs of their faces'
cells along the building's main directions, :func:`_straight_lines`: the same walls give the
same lines wherever they lie) and returns the free cells that close them but for a hole in the
middle; the places are then found with these cells as wall, so a gap is a passage narrower than
a door: the places end there, and the partition decides whether to cut there. Gaps where
corridors meet (a crossing, a T junction) stay open.

Every length is in metres: a gap at most as wide as double doors (``gap``), walls at least
``flank`` long on both sides of it, lines at least ``min_length`` long.
"""

from __future__ import annotations

import itertools
import math
import os
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from maps.grid import OccupancyGrid
from segmentation.coverage import DOOR_WIDTH
from segmentation.refine import OPEN

#: The widest gap closed: double doors, metres (the coverage's widest door).
GAP = DOOR_WIDTH
#: The wall on each side of a gap, metres: a room's wall, not a door frame or a cabinet.
FLANK = 1.0
#: The hole left in the middle of a closed gap, metres: narrower than a door, wide enough for
#: scans to see through, so the gap is a passage (the places end there, the partition decides)
#: and the affinity graph keeps its links (a given ``k`` stays reachable). On the ROSE² maps
#: 0.3 m scored MCC 0.73 but cut the affinity graph apart; 0.5 m 0.71, 0.8 m 0.68; the ipa
#: plans score the same with all three.
HOLE = 0.5
#: How far a SLAM wall's face wanders, metres: the wall cells this close to free space are its
#: face, and a line is on the wall where the face is this close. Measured on the map's own
#: cells (on a 0.1 m working grid, its 3 x 3 neighbourhoods and the blocks' offset on the map
#: came to about this, but the gaps found moved with where the blocks fell: a ROSE² map's MCC
#: by 0.09 between a map and the same map one cell over, 0.03 since).
JAGGED = 0.15
#: A channel's walls run on this far from a gap's ends, metres: a corridor, not an alcove.
CHANNEL = 2.0
#: The shortest wall line, metres.
MIN_LENGTH = 2.5
#: Walls lie along a building's few main directions; a line direction (within ``TOLERANCE``
#: degrees) carrying less than ``SHARE`` of all line length is a ray's end or clutter's edge.
TOLERANCE = 3
SHARE = 0.1
#: How finely wall lines' directions are found, degrees: a 30 m wall along a direction half a
#: step off runs at most 0.07 m (half :data:`JAGGED`) off its line.
STEP = 0.25
#: The widest mouth of a hall closed, metres: twice the widest door (:data:`GAP`). A mouth is
#: a gap between two walls' ends in any direction, the walls going on roughly straight across
#: it, between a hall and the corridor it opens onto (:func:`hall_mouths`).
MOUTH = 2 * GAP
#: The least wall that bounds a mouth, metres: a seen stretch of wall, not a cabinet's side.
PIECE = 1.5
#: How far the walls may bend across a mouth, degrees: a wall broken by a wide opening goes on
#: near its own line (two walls at 36 and 60 degrees across a 2.9 m mouth bend 12 degrees
#: each to meet the line between their ends).
BEND = 20.0
#: A hall is at least this many times as wide as the corridor its mouth opens onto: its
#: clearance straight in from the mouth rises to twice the corridor's (a crossing of two
#: corridors rises to sqrt(2) times, a corridor's wide spots less).
HALL = 2.0
#: The least corridor, metres: building codes' least width (the corridors' cuts' too).
CORRIDOR = 1.2
#: How many places (a point in a row) :func:`_runs` takes at a time: arrays of a few
#: megabytes, where those of every place of a large map (tens of millions) cost more to
#: allocate than to fill.
BLOCK = 1 << 18
#: How many points :func:`_energy` projects at a time: arrays that stay in the processor's
#: cache.
CHUNK = 1 << 15


def seen_walls(
    grid: OccupancyGrid, space: NDArray[np.bool_], clutter: NDArray[np.bool_]
) -> NDArray[np.bool_]:
    """The walls whose lines and gaps :func:`wall_gaps` looks for: the occupied cells, and the
    unknown strips at most 2 :data:`JAGGED` wide between parts of the robot's ``space`` and
    at least :data:`FLANK` long (a floor plan's walls drawn in grey, which a map_server
    threshold reads as unknown; a glass wall seen from both sides), furniture (``clutter``)
    left out. Unknown space beside the robot's space on one side only is unexplored, not a
    wall; the unknown streaks between a fan's rays lie between thin rays, not between robot
    space; the cells no beam crossed between two that did are specks, not a wall's length.

    Examples
    --------
    >>> free = np.zeros((30, 41), bool)
    >>> free[1:29, 1:20] = free[1:29, 21:40] = True  # two rooms, a grey wall between them
    >>> cells = np.where(free, 0, -1).astype(np.int8)
    >>> walls = seen_walls(OccupancyGrid(cells, 0.05), free, np.zeros_like(free))
    >>> bool(walls[10, 20]), bool(walls[10, 0])  # the wall between, not the unknown outside
    (True, False)
    """
    size = 2 * max(1, round(JAGGED / grid.resolution)) + 1
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    between = (
        cv2.morphologyEx(
            space.astype(np.uint8),
            cv2.MORPH_CLOSE,
            disc,
            borderType=cv2.BORDER_CONSTANT,
            borderValue=0,
        )
        > 0
    )  # beyond the map's edge is no robot space
    strips = (grid.unknown & between).astype(np.uint8)
    _, pieces, stats, _ = cv2.connectedComponentsWithStats(strips, connectivity=8)
    extent = np.maximum(stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT])
    long = extent * grid.resolution >= FLANK  # a wall, not the unseen cells between beams
    long[0] = False
    return (grid.occupied | long[pieces]) & ~clutter


def wall_gaps(
    walls: NDArray[np.bool_],
    free: NDArray[np.bool_],
    resolution: float,
    *,
    gap: float = GAP,
    flank: float = FLANK,
    min_length: float = MIN_LENGTH,
) -> NDArray[np.bool_]:
    """Free cells that close the gaps of straight walls but for a :data:`HOLE` in the middle
    (see the module docstring).

    Parameters
    ----------
    walls
        Wall cells (occupied, furniture left out); only their cells beside free cells count.
    free
        Free cells; only these are returned.
    resolution
        Metres per cell.
    gap, flank, min_length
        The widest gap, the wall on each side of it, the shortest line, metres.

    Examples
    --------
    >>> walls = np.zeros((40, 60), bool)
    >>> walls[20, :25] = walls[20, 40:] = True  # a wall with a 1.5 m gap (0.1 m cells)
    >>> closed = wall_gaps(walls, ~walls, 0.1)
    >>> bool(closed[20, 27]), bool(closed[20, 32]), bool(closed[5, 27]), bool(closed[20, 10])
    (True, False, False, False)
    """
    out = np.zeros(free.shape, np.uint8)
    reach = _reach(resolution)
    surface = walls & _within(free, reach)  # what scans saw of them
    near = _within(surface, reach)  # jagged walls
    xs, ys, line_ends = _wall_lines(surface, resolution, gap, min_length)
    on = near[ys, xs]
    # the runs of cells on and off the walls along each line (a line's first cell starts one)
    change = np.zeros(len(xs), bool)
    change[line_ends[:-1]] = True
    change[:1] = True
    change[1:] |= on[1:] != on[:-1]
    starts = np.flatnonzero(change)
    ends = np.r_[starts[1:], len(xs)]
    line = np.searchsorted(line_ends, starts, side="right")
    inner = np.zeros(len(starts), bool)  # a run with another of its line on both sides
    inner[1:-1] = (line[:-2] == line[1:-1]) & (line[2:] == line[1:-1])
    run = np.flatnonzero(inner & ~on[starts])  # gaps with wall on both sides
    first, stop = starts[run], ends[run]  # a gap's cells: first .. stop - 1
    flanks = np.minimum(ends[run - 1] - starts[run - 1], ends[run + 1] - starts[run + 1])
    free_cells = np.r_[0, np.cumsum(free[ys, xs])]
    width = (stop - first) * resolution
    walled = (width <= gap) & (flanks * resolution >= flank)  # a door or a wider gap
    candidate = (
        walled
        & (HOLE + 2 * resolution < width)  # a narrower gap is a door
        & ((free_cells[stop] - free_cells[first]) / (stop - first) > 0.5)
    )
    # a wall runs on through its doors: a corridor with doors in its walls is still one
    doors = np.zeros(free.shape, np.uint8)
    for i, j in zip(first[walled].tolist(), stop[walled].tolist(), strict=True):
        cv2.line(doors, (int(xs[i - 1]), int(ys[i - 1])), (int(xs[j]), int(ys[j])), 1)
    walls_on = near | _within(doors > 0, reach)
    for i, j in zip(first[candidate].tolist(), stop[candidate].tolist(), strict=True):
        if not _through_channel(
            near,
            (xs[i - 1 - reach], ys[i - 1 - reach]),  # on the walls' faces
            (xs[j + reach], ys[j + reach]),
            CHANNEL / resolution,
            walls_on,
        ):
            _close(out, (xs[i - 1], ys[i - 1]), (xs[j], ys[j]), HOLE / resolution)
    return out.astype(bool) & free


def hall_mouths(
    walls: NDArray[np.bool_], free: NDArray[np.bool_], resolution: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Free cells that close the mouths of halls but for a :data:`HOLE` in the middle, and
    the free cells of the mouths' whole lines (run on twice :data:`JAGGED` into the walls).

    A hall opening onto a corridor through a gap in the corridor's side wall is one clearance
    basin with it: the space only widens into the hall, and the gap may be wider than double
    doors and its walls off the building's main directions, where :func:`wall_gaps` does not
    look. A mouth (:func:`mouth_lines`) is a gap of :data:`GAP` to :data:`MOUTH` metres
    between the ends of two straight walls (lines of the walls' faces along any direction
    they line up along, :func:`_straight_lines`, at least :data:`PIECE` long, each followed
    to where its wall ends) that go on across it
    within :data:`BEND` degrees, where the two sides differ in kind: straight in from the
    gap, the clearance on one side rises to :data:`HALL` times the other's (a hall beside a
    corridor), both sides are at least a corridor deep all along the gap (:data:`CORRIDOR`:
    furniture or a wall with doors just behind a gap is no corridor), and on neither side
    does the space keep the gap's width (within :data:`~segmentation.refine.OPEN`) as it
    leaves the gap: a corridor that goes on through the gap is not closed.

    Parameters
    ----------
    walls
        Wall cells (occupied, furniture left out); only their cells beside free cells count.
    free
        Free cells (the gaps :func:`wall_gaps` closed taken out); only these are returned.
    resolution
        Metres per cell.

    Examples
    --------
    >>> free = np.zeros((120, 160), bool)  # 0.1 m cells: a corridor above, a hall below
    >>> free[10:110, 10:150] = True
    >>> free[40:43, 10:70] = free[40:43, 100:150] = False  # a 3 m mouth in the wall between
    >>> closed, line = hall_mouths(~free, free, 0.1)
    >>> bool(closed[42, 75]), bool(closed[42, 85]), bool(line[42, 85]), bool(closed[80, 80])
    (True, False, True, False)
    """
    closed = np.zeros(free.shape, np.uint8)
    lines = np.zeros(free.shape, np.uint8)
    on = 2 * JAGGED / resolution  # the ends lie on the walls' faces, up to JAGGED off them
    for a, b in mouth_lines(walls, free, resolution):
        _close(closed, _cell(a), _cell(b), HOLE / resolution)
        way = (b - a) / float(np.hypot(*(b - a)))
        cv2.line(lines, _cell(a - on * way), _cell(b + on * way), 1, 2)
    return closed.astype(bool) & free, lines.astype(bool) & free


def mouth_lines(
    walls: NDArray[np.bool_], free: NDArray[np.bool_], resolution: float
) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The mouths :func:`hall_mouths` closes, each as its two ends (x, y cells, on the walls'
    faces).

    Examples
    --------
    >>> free = np.zeros((120, 160), bool)  # 0.1 m cells: a corridor above, a hall below
    >>> free[10:110, 10:150] = True
    >>> free[40:43, 10:70] = free[40:43, 100:150] = False  # a 3 m mouth in the wall between
    >>> [(a.round().tolist(), b.round().tolist()) for a, b in mouth_lines(~free, free, 0.1)]
    [([99.0, 41.0], [70.0, 41.0])]
    """
    reach = _reach(resolution)
    surface = walls & _within(free, reach)
    near = _within(surface, reach)
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    face = surface & (cv2.dilate(free.astype(np.uint8), cross) > 0)  # beside a free cell
    return [
        (a, b)
        for a, b in _mouths(
            near, _straight_lines(face, resolution, PIECE, HOLE, 1), free, resolution
        )
        if _hall_beside_corridor(free, a, b, resolution)
    ]


def _cell(point: NDArray) -> tuple[int, int]:
    """The nearest cell (x, y) of a point, halves rounded up (so one cell over, the same)."""
    x, y = np.floor(np.asarray(point) + 0.5).astype(int).tolist()
    return x, y


def _straight_lines(
    surface: NDArray[np.bool_], resolution: float, min_length: float, gap: float, window: int
) -> NDArray[np.int32]:
    """Straight lines (x0, y0, x1, y1) of ``surface`` (walls' faces), at least ``min_length``
    long across breaks of up to ``gap`` metres between the faces' jagged bands, along the
    directions the faces line up along best within ``window`` degrees either way
    (:func:`_line_directions`).

    Along each direction, the face cells within :data:`JAGGED` of a row (rows one cell apart,
    counted from the faces' own first) make runs across breaks of up to ``gap`` plus twice
    :data:`JAGGED` (the gap :func:`wall_gaps` measures between the bands the faces wander in); a
    run is a line where it is at least ``min_length`` long and the wall seen along it within a
    cell of its row (a face wanders a cell) covers at least half ``min_length``. The runs of all
    directions are taken in turn, the most cells first (the narrowest of equal ones): each is a
    line unless its cells on no line yet cover less than that (a wall's face jagged over several
    rows gives one line; the cells a crossing wall's line took still join a line's pieces), and
    the cells of walls that cross its row (:func:`_crossing`) do not count: a row through the
    faces of walls it crosses (through a building's rooms along the direction of one slanted
    wall) is no wall's line, a row of walls' ends (a room's cubicles) is. A
    line is its cells' least-squares line, from the first of them along to the last: the
    direction (the whole map's) only picks its cells, so the same walls give the same line
    wherever they lie in an image, whatever lies beyond its reach.

    Examples
    --------
    >>> faces = np.zeros((30, 80), bool)  # 0.1 m cells: a wall with a 1.5 m door
    >>> faces[10, 5:30] = faces[10, 45:75] = True
    >>> faces[11, 12:20] = faces[9, 50:55] = True  # where its face wanders a cell
    >>> _straight_lines(faces, 0.1, 2.5, 1.8, 3).tolist()
    [[5, 10, 74, 10]]
    """
    rows, columns = np.nonzero(surface)
    # measured from the faces' first column and row: the same sums wherever the walls lie
    corner = np.array([columns.min(), rows.min()] * 2) if len(rows) else np.zeros(4, int)
    xs, ys = (columns - corner[0]).astype(float), (rows - corner[1]).astype(float)
    reach = _reach(resolution)
    bridge, shortest = gap / resolution, min_length / resolution
    frames: list[tuple[float, NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]] = []
    places: list[tuple[NDArray[np.intp], NDArray[np.bool_]]] = []  # each direction's, in order
    keys: list[NDArray[np.float64]] = []  # every run's: -cells, spread, direction, row, point
    spans: list[NDArray[np.intp]] = []  # every run's direction and places (first, stop)

    def along_direction(angle: float) -> tuple[NDArray, ...]:
        along, across = _frame(xs, ys, angle)
        row_runs = _runs(along - along.min(), across, reach, bridge, shortest)
        # the faces of walls crossing their own row along the direction
        return along, across, _crossing(surface, columns, rows, angle, reach), *row_runs

    angles = _line_directions(xs, ys, window) if len(xs) else []
    # the directions side by side: most of their NumPy work runs without the interpreter's lock
    with ThreadPoolExecutor(min(len(angles), os.cpu_count() or 1) or 1) as pool:
        for angle, measured in zip(angles, pool.map(along_direction, angles), strict=True):
            along, across, crossing, point, near, row, starts, stops, spread = measured
            direction = np.full(len(starts), len(frames))
            keys.append(np.array([starts - stops, spread, direction, row, point[starts]]))
            spans.append(np.array([direction, starts, stops]))
            places.append((point, near))
            frames.append((angle, along, across, crossing))
    claimed = np.zeros(len(xs), bool)
    found = []
    every = np.concatenate(keys, axis=1) if keys else np.zeros((5, 0))
    runs = np.concatenate(spans, axis=1) if spans else np.zeros((3, 0), np.intp)
    for j, first, stop in runs[:, np.lexsort(every[::-1])].T.tolist():  # by keys, in turn
        point, near = places[j]
        members = point[first:stop]
        fresh = members[near[first:stop] & ~claimed[members]]
        if len(fresh) < shortest / 2:
            continue
        angle, along, across, crossing = frames[j]
        fresh = fresh[~crossing[fresh]]  # a wall crossing the row is not on it
        if len(fresh) < shortest / 2:
            continue
        if len(np.unique(np.floor(along[fresh]))) >= shortest / 2:
            claimed[members] = True
            found.append(_fitted(along[members], across[members], angle))
    ends = np.rint(np.reshape(found, (-1, 4))).astype(np.int32) + corner
    height, width = surface.shape
    return np.clip(ends, 0, [width - 1, height - 1] * 2).astype(np.int32)  # a fit may lean out


def _crossing(
    surface: NDArray[np.bool_], x: NDArray[np.intp], y: NDArray[np.intp], angle: float, reach: int
) -> NDArray[np.bool_]:
    """Whether the walls' faces at cells (``x``, ``y``) belong to a wall that crosses the row
    along ``angle`` (radians) through them: ``surface`` within ``reach`` cells along the row,
    beyond the band the faces wander in (``reach`` cells across) by up to ``reach`` more, on
    both sides. A wall that ends at the row (a stub, a room's wall meeting a corridor's) or
    runs along it has faces on one side at most.

    Examples
    --------
    >>> faces = np.zeros((40, 40), bool)
    >>> faces[5:35, 10] = True  # a wall crossing the row y = 20 ...
    >>> faces[5:20, 30] = True  # ... and one ending at it
    >>> _crossing(faces, np.array([10, 30]), np.array([20, 19]), 0.0, 3).tolist()
    [True, False]
    """
    image = surface.astype(np.uint8)
    sides = [_any_at(image, dx, dy)[y, x] > 0 for dx, dy in _beside(angle, reach)]
    return sides[0] & sides[1]


def _any_at(
    image: NDArray[np.uint8], dx: NDArray[np.intp], dy: NDArray[np.intp]
) -> NDArray[np.uint8]:
    """Whether ``image`` is set at any of the offsets (``dx``, ``dy`` cells) from each cell (a
    dilation; nothing is set beyond the grid).

    Examples
    --------
    >>> image = np.zeros((3, 5), np.uint8)
    >>> image[1, 2] = 1
    >>> _any_at(image, np.array([1, 2]), np.array([0, 0])).tolist()
    [[0, 0, 0, 0, 0], [1, 1, 0, 0, 0], [0, 0, 0, 0, 0]]
    """
    size = 2 * int(max(np.abs(dx).max(), np.abs(dy).max())) + 1
    kernel = np.zeros((size, size), np.uint8)
    kernel[dy + size // 2, dx + size // 2] = 1
    return np.asarray(cv2.dilate(image, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0))


def _beside(angle: float, reach: int) -> tuple[tuple[NDArray[np.intp], NDArray[np.intp]], ...]:
    """The offsets (x, y whole cells, halves rounded up, each once) :func:`_crossing` looks
    at on each side of a row along ``angle`` (radians)."""
    way = np.array([math.cos(angle), math.sin(angle)])
    normal = np.array([-way[1], way[0]])
    k, t = np.meshgrid(np.arange(reach + 1, 2 * reach + 1), np.arange(-2 * reach, 2 * reach + 1))
    offsets = []
    for side in (1.0, -1.0):
        shifts = k.reshape(-1, 1) * normal * side + t.reshape(-1, 1) * way
        dx, dy = np.unique(np.floor(shifts + 0.5).astype(np.intp), axis=0).T
        offsets.append((dx, dy))
    return tuple(offsets)


def _fitted(along: NDArray[np.float64], across: NDArray[np.float64], angle: float) -> list[float]:
    """The line (x0, y0, x1, y1) of points at ``along`` and ``across`` the direction ``angle``
    (radians): their least-squares line (``across`` on ``along``), from the first of them
    along to the last."""
    slope, offset = np.polyfit(along, across, 1)
    way = np.array([math.cos(angle), math.sin(angle)])
    normal = np.array([-way[1], way[0]])
    ends = [t * way + (slope * t + offset) * normal for t in (along.min(), along.max())]
    return np.concatenate(ends).tolist()


def _frame(
    xs: NDArray[np.float64], ys: NDArray[np.float64], angle: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The points' (x, y) coordinates along the direction ``angle`` (radians) and across it."""
    return xs * math.cos(angle) + ys * math.sin(angle), _across(xs, ys, angle)


def _line_directions(xs: NDArray[np.float64], ys: NDArray[np.float64], window: int) -> list[float]:
    """The directions (radians) along which the points (x, y) line up best: whole degrees where
    the sum of squares of their counts in rows one unit apart (the projection's energy, as a
    standard Hough accumulator's peaks; its rows counted from the points' own first) peaks
    within ``window`` degrees either way, each refined to its best direction less than a
    degree off, in steps of :data:`STEP` degrees."""
    whole = np.arange(180.0)
    energy = _energy(xs, ys, whole)
    peak = np.ones(len(whole), bool)
    for shift in range(1, window + 1):  # the first of equal ones
        peak &= (energy >= np.roll(energy, shift)) & (energy > np.roll(energy, -shift))
    # a direction along which the points line up: its energy rises above that of the
    # directions along which nothing does (the median) by at least SHARE of the strongest's
    excess = energy - np.median(energy)
    peak &= excess >= SHARE * excess.max()
    steps = np.arange(STEP - 1, 1, STEP)
    return [
        math.radians(float(near[np.argmax(_energy(xs, ys, near))]))
        for near in whole[peak & (energy > 0)][:, None] + steps
    ]


def _energy(
    xs: NDArray[np.float64], ys: NDArray[np.float64], degrees: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The sum of squares of the points' (x, y) counts in rows one unit apart across each
    direction (``degrees``), the rows counted from the points' own first. The points are
    counted :data:`CHUNK` at a time, from their first and last rows (those of
    :func:`_extremes`).

    Examples
    --------
    >>> xs, ys = np.array([0.0, 1, 2, 0]), np.array([0.0, 0, 0, 3])
    >>> _energy(xs, ys, np.array([0.0, 90.0])).tolist()  # rows of 3 and 1; of 2, 1 and 1
    [10.0, 6.0]
    """
    edge_xs, edge_ys = _extremes(xs, ys)
    energy = np.zeros(len(degrees))
    for i, angle in enumerate(np.radians(degrees)):
        edges = _across(edge_xs, edge_ys, angle)
        lowest = edges.min()
        counts = np.zeros(int(edges.max() - lowest) + 1, np.int64)
        for start in range(0, len(xs), CHUNK):
            part = slice(start, start + CHUNK)
            across = _across(xs[part], ys[part], angle) - lowest
            rows = np.bincount(across.astype(np.int64))  # floor, as >= 0
            counts[: len(rows)] += rows
        energy[i] = np.dot(counts, counts)
    return energy


def _extremes(
    xs: NDArray[np.float64], ys: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The points (x, y) with the least and the most x of each y: their least and greatest
    coordinate across any direction (:func:`_across`) are all the points', to the last bit (a
    product's and a difference's rounding keep their order).

    Examples
    --------
    >>> [e.tolist() for e in _extremes(np.array([3.0, 1, 2, 5]), np.array([1.0, 0, 1, 1]))]
    [[1.0, 2.0, 1.0, 5.0], [0.0, 1.0, 0.0, 1.0]]
    """
    order = np.argsort(ys, kind="stable")  # the points of np.nonzero are by y already
    xs, ys = xs[order], ys[order]
    first = np.flatnonzero(np.r_[True, ys[1:] != ys[:-1]])
    least, most = np.minimum.reduceat(xs, first), np.maximum.reduceat(xs, first)
    return np.r_[least, most], np.r_[ys[first], ys[first]]


def _across(xs: NDArray[np.float64], ys: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    """The points' (x, y) coordinates across the direction ``angle`` (radians)."""
    return ys * math.cos(angle) - xs * math.sin(angle)


def _runs(
    ahead: NDArray[np.float64],
    across: NDArray[np.float64],
    reach: int,
    bridge: float,
    shortest: float,
) -> tuple[
    NDArray[np.intp],
    NDArray[np.bool_],
    NDArray[np.int64],
    NDArray[np.intp],
    NDArray[np.intp],
    NDArray[np.float64],
]:
    """The runs of points along rows across breaks of up to ``bridge``, each point (at
    ``ahead`` along the rows, from 0, and ``across`` them) in every row within ``reach`` of its
    own (rows one unit apart, counted from the points' first), that are at least ``shortest``
    long with their places (a point in a row) within a row of their own on at least half
    ``shortest`` cells along: their places by row and ``ahead``, as each place's point and
    whether it is within a row of the point's own, and each run's row, first place, the place
    after its last and the variance of its places' ``across``, from the sums over the places
    of all runs in order (kept or not, so to the last bit the same wherever the runs lie).

    The rows are taken in blocks of about :data:`BLOCK` places: on a large map, arrays of
    every place cost more to allocate than to fill.

    Examples
    --------
    >>> point, near, row, starts, stops, spread = _runs(
    ...     np.array([0.0, 1, 2, 3, 4, 9]), np.full(6, 0.5), 1, 1.0, 3.0
    ... )
    >>> row.tolist(), starts.tolist(), stops.tolist(), point[:6].tolist(), spread.tolist()
    ([-1, 0, 1], [0, 5, 10], [5, 10, 15], [0, 1, 2, 3, 4, 0], [0.0, 0.0, 0.0])
    """
    own = np.floor(across - across.min()).astype(np.int64)
    # places by row, then along, then point: whole-number keys, so the order (and the runs'
    # sums and fits, to the last bit) does not hang on how a sort leaves ties
    by_ahead = np.argsort(ahead, kind="stable")
    first_row = own[by_ahead]  # each point's first row, the points by ahead
    per_row = np.bincount(first_row)
    ends = np.cumsum(np.convolve(per_row, np.ones(2 * reach + 1, np.int64)))  # rows' places
    by_row = _stable_order(first_row)  # the points in a block's rows are a slice of these
    from_row = np.r_[0, np.cumsum(per_row)]
    cuts = np.searchsorted(ends, np.arange(BLOCK, ends[-1], BLOCK), side="right")
    blocks: list[tuple[NDArray, ...]] = []
    sums = np.zeros(2)  # of the places' across and its square, before the block's
    for low, high in itertools.pairwise(np.unique(np.r_[0, cuts, len(ends)]).tolist()):
        points = by_row[from_row[max(low - 2 * reach, 0)] : from_row[min(high, len(per_row))]]
        ranks = np.sort(points)  # by ahead
        place, near, row = _places(first_row[ranks], low, high, reach)
        point = by_ahead[ranks[place]]
        starts, stops, keep = _split(ahead[point], row, near, bridge, shortest)
        spread, sums = _spreads(across[point], starts[keep], stops[keep], sums)
        taken = np.repeat(keep, stops - starts)
        counts = (stops - starts)[keep]
        blocks.append((point[taken], near[taken], row[starts[keep]] - reach, counts, spread))
    point, near, row, counts, spread = (np.concatenate(part) for part in zip(*blocks, strict=True))
    stops = np.cumsum(counts)
    return point, near, row, stops - counts, stops, spread


def _stable_order(keys: NDArray[np.integer]) -> NDArray[np.intp]:
    """``np.argsort(keys, kind="stable")`` of whole numbers from 0: a radix sort where they fit
    in 16 bits."""
    fits = not len(keys) or keys.max() < 1 << 16
    return np.argsort(keys.astype(np.uint16) if fits else keys, kind="stable")


def _places(
    first_rows: NDArray[np.int64], low: int, high: int, reach: int
) -> tuple[NDArray[np.intp], NDArray[np.bool_], NDArray[np.int64]]:
    """The places in rows ``low`` to ``high`` - 1 of the points with these ``first_rows`` (each
    point in its first row and the next 2 ``reach``), by row, then point: each place's point,
    whether it is within a row of the point's own (its first row + ``reach``) and its row."""
    width = 2 * reach + 1
    rows = (first_rows[:, None] + np.arange(width)).ravel()
    at = np.flatnonzero((rows >= low) & (rows < high))  # a point's rows in turn
    at = at[_stable_order(rows[at] - low)]
    return at // width, np.abs(at % width - reach) <= 1, rows[at]


def _split(
    ahead: NDArray[np.float64],
    row: NDArray[np.int64],
    near: NDArray[np.bool_],
    bridge: float,
    shortest: float,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
    """The runs of places (by ``row``, then ``ahead`` along the rows) across breaks of up to
    ``bridge``: each run's first place and the one after its last, and whether it is at least
    ``shortest`` long with its places ``near`` (within a row of their own) on at least half
    ``shortest`` cells along."""
    new = np.ones(len(row), bool)
    new[1:] = (row[1:] != row[:-1]) | (ahead[1:] - ahead[:-1] > bridge + 1)
    run = np.cumsum(new) - 1
    starts = np.flatnonzero(new)
    stops = np.r_[starts[1:], len(row)]
    # the cells along that hold a place within a row of its own, each once
    counted, column = run[near], np.floor(ahead[near])
    first = np.ones(len(counted), bool)
    first[1:] = (counted[1:] != counted[:-1]) | (column[1:] != column[:-1])
    cells = np.bincount(counted[first], minlength=len(starts))
    keep = (ahead[stops - 1] - ahead[starts] >= shortest) & (cells >= shortest / 2)
    return starts, stops, keep


def _spreads(
    offsets: NDArray[np.float64],
    starts: NDArray[np.intp],
    stops: NDArray[np.intp],
    before: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The variance of the ``offsets`` of each run (``starts`` to ``stops`` - 1), from the
    running sums of the offsets and their squares on from ``before`` (those before them), and
    the sums after them."""
    total = [np.cumsum(np.r_[before[0], offsets]), np.cumsum(np.r_[before[1], np.square(offsets)])]
    count = stops - starts
    mean, square = ((sums[stops] - sums[starts]) / count for sums in total)
    return square - mean**2, np.array([sums[-1] for sums in total])


def _mouths(
    near: NDArray[np.bool_], lines: NDArray[np.int32], free: NDArray[np.bool_], resolution: float
) -> list[tuple[NDArray, NDArray]]:
    """The gaps (x, y cells of both ends) of :data:`GAP` to :data:`MOUTH` metres between the
    ends of two ``lines``, each followed along its own line while on a wall (``near``), that
    go on across the gap within :data:`BEND` degrees, the gap's cells mostly free and off the
    walls; one per place (the narrowest of those within :data:`HOLE` of each other)."""
    if len(lines) < 2:
        return []
    starts, stops = lines[:, :2].astype(float), lines[:, 2:].astype(float)
    along = (stops - starts) / np.maximum(np.hypot(*(stops - starts).T), 1e-9)[:, None]
    out = np.concatenate([-along, along])  # each end's way out of its wall
    tips = _wall_ends(near, np.concatenate([starts, stops]), out, MOUTH / resolution)
    line = np.tile(np.arange(len(lines)), 2)
    near_pairs = cKDTree(tips).query_pairs(MOUTH / resolution, output_type="ndarray")
    first, second = near_pairs[line[near_pairs[:, 0]] != line[near_pairs[:, 1]]].T
    apart = tips[second] - tips[first]
    span = np.hypot(apart[:, 0], apart[:, 1])
    way = apart / np.maximum(span, 1e-9)[:, None]
    bend = math.cos(math.radians(BEND))
    keep = (
        (span > GAP / resolution)
        & ((way * out[first]).sum(axis=1) >= bend)
        & ((-way * out[second]).sum(axis=1) >= bend)
    )
    skip = 2 * _reach(resolution) + 1  # the ends' own walls
    found = []
    for i, j, length, unit in zip(first[keep], second[keep], span[keep], way[keep], strict=True):
        steps = np.arange(skip, int(length) - skip)
        cells = np.rint(tips[i] + steps[:, None] * unit).astype(int)
        if (
            len(cells)
            and free[cells[:, 1], cells[:, 0]].mean() >= 0.8
            and near[cells[:, 1], cells[:, 0]].mean() <= 0.3
        ):
            found.append((float(length), tips[i], tips[j]))
    kept: list[tuple[NDArray, NDArray]] = []
    for _, a, b in sorted(found, key=lambda f: f[0]):
        middle = (a + b) / 2
        if all(np.hypot(*(middle - (p + q) / 2)) * resolution > HOLE for p, q in kept):
            kept.append((a, b))
    return kept


def _wall_ends(
    near: NDArray[np.bool_], tips: NDArray, ways: NDArray, longest: float
) -> NDArray[np.float64]:
    """Where the walls at ``tips`` (x, y cells) end, each followed along its unit ``ways``
    while on a wall (``near``), at most ``longest`` cells."""
    height, width = near.shape
    tips = tips.astype(float).copy()
    going = np.ones(len(tips), bool)
    for _ in range(int(longest)):
        ahead = np.rint(tips + ways).astype(int)
        inside = (
            (ahead[:, 0] >= 0) & (ahead[:, 0] < width) & (ahead[:, 1] >= 0) & (ahead[:, 1] < height)
        )
        on = np.zeros(len(tips), bool)
        on[inside] = near[ahead[inside, 1], ahead[inside, 0]]
        going &= on
        if not going.any():
            break
        tips[going] += ways[going]
    return tips


def _hall_beside_corridor(
    free: NDArray[np.bool_], a: NDArray[np.float64], b: NDArray[np.float64], resolution: float
) -> bool:
    """Whether the gap from ``a`` to ``b`` (x, y cells) in the ``free`` cells is a hall's
    mouth onto a corridor (:func:`hall_mouths`): from three points along it (a quarter, half
    and three quarters of the way) straight in on each side, the shortest run of free cells
    (the side's depth) and the median of the most clearance along them (measured with the gap
    shut); at 0.5 to 2 m from its middle on each side, the median width across."""
    span = float(np.hypot(*(b - a)))
    way = (b - a) / span
    normal = np.array([-way[1], way[0]])
    longest = MOUTH / resolution
    runs = []
    for side in (1.0, -1.0):
        widths = [
            sum(
                len(_run(free, (a + b) / 2 + side * t / resolution * normal, w, longest))
                for w in (way, -way)
            )
            for t in (0.5, 1.0, 1.5, 2.0)
        ]
        if float(np.median(widths)) * OPEN <= span:
            return False  # a corridor going on through the gap
        runs.append(
            [_run(free, a + t * (b - a), side * normal, longest) for t in (0.25, 0.5, 0.75)]
        )
        if min(len(r) for r in runs[-1]) * resolution < CORRIDOR:
            return False  # furniture or a wall just behind the gap: no corridor, no hall
    # the clearance round the gap (obstacles up to MOUTH beyond the runs' ends count), shut
    margin = int(2 * longest) + 2
    (left, top), (right, bottom) = (
        np.minimum(a, b).astype(int) - margin,
        np.maximum(a, b).astype(int) + margin + 1,
    )
    left, top = max(left, 0), max(top, 0)
    window = free[top:bottom, left:right].astype(np.uint8)
    cv2.line(window, _cell(a - (left, top)), _cell(b - (left, top)), 0, 2)
    clearance = cv2.distanceTransform(window, cv2.DIST_L2, 5)
    rise = [
        float(np.median([clearance[r[:, 1] - top, r[:, 0] - left].max(initial=0) for r in side]))
        for side in runs
    ]
    return max(rise) >= HALL * max(min(rise), 1.0)


def _run(free: NDArray[np.bool_], start: NDArray, way: NDArray, length: float) -> NDArray[np.intp]:
    """The cells (x, y) from ``start`` along ``way`` while free, at most ``length`` cells."""
    height, width = free.shape
    steps = np.rint(start + np.arange(1, max(2, int(length)))[:, None] * way).astype(int)
    inside = (
        (steps[:, 0] >= 0) & (steps[:, 0] < width) & (steps[:, 1] >= 0) & (steps[:, 1] < height)
    )
    stop = np.flatnonzero(~inside)
    steps = steps[: stop[0] if len(stop) else len(steps)]
    stop = np.flatnonzero(~free[steps[:, 1], steps[:, 0]])
    return steps[: stop[0] if len(stop) else len(steps)]


def wall_stubs(
    grid: OccupancyGrid, clutter: NDArray[np.bool_], *, gap: float = GAP, flank: float = FLANK
) -> NDArray[np.bool_]:
    """The ``clutter`` cells of the free-standing obstacles that are stretches of wall between
    two doors: at least ``flank`` long, on a wall line (a line of the walls' faces along the
    building's main directions, :func:`_straight_lines`, across gaps of up to ``gap``) that
    runs on over at least
    ``flank`` metres of other wall on both sides of them. They stand as free as a table;
    furniture does not stand in the line of the walls with walls on both hands.

    Examples
    --------
    >>> cells = np.zeros((40, 100), np.int8)
    >>> cells[[0, -1], :] = cells[:, [0, -1]] = 100  # the outer walls (0.1 m cells)
    >>> cells[20, 1:30] = cells[20, 70:99] = 100  # a wall with two doors ...
    >>> cells[20, 40:58] = 100  # ... and the 1.8 m stretch of wall between them
    >>> cells[8:12, 40:60] = 100  # a table
    >>> clutter = np.zeros(cells.shape, bool)
    >>> clutter[20, 40:58] = clutter[8:12, 40:60] = True
    >>> stubs = wall_stubs(OccupancyGrid(cells, 0.1), clutter)
    >>> bool(stubs[20, 45]), bool(stubs[10, 50])
    (True, False)
    """
    resolution = grid.resolution
    count, pieces, stats, _ = cv2.connectedComponentsWithStats(
        clutter.astype(np.uint8), connectivity=8
    )
    sides = np.maximum(stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT])
    stub = sides * resolution >= flank  # as long as a wall's flank
    stub[0] = False
    if not stub.any():
        return np.zeros(clutter.shape, bool)
    reach = _reach(resolution)
    surface = grid.occupied & _within(grid.free, reach)
    square = np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)
    # the stubs numbered in order from 1 (the greatest near a cell is the same stub)
    stubs = np.r_[0, np.flatnonzero(stub)]
    kind = np.uint16 if len(stubs) <= 1 << 16 else np.float32
    numbers = np.zeros(count, kind)
    numbers[stubs] = np.arange(len(stubs))
    near = cv2.dilate(numbers[pieces], square)
    walls = _within(grid.occupied & ~clutter, reach)
    on_line = np.zeros(count, bool)
    every_x, every_y, ends = _wall_lines(surface, resolution, gap, MIN_LENGTH)
    every_crossed = stubs[near[every_y, every_x].astype(np.int64)]
    starts = ends - np.diff(ends, prepend=0)
    crossing = np.add.reduceat(every_crossed > 0, starts) > 0 if len(starts) else np.zeros(0, bool)
    for start, end in zip(starts[crossing].tolist(), ends[crossing].tolist(), strict=True):
        xs, ys, crossed = every_x[start:end], every_y[start:end], every_crossed[start:end]
        support = np.cumsum(walls[ys, xs] & (crossed == 0)) * resolution  # metres of wall
        for piece in np.unique(crossed[crossed > 0]).tolist():
            at = np.flatnonzero(crossed == piece)
            on_line[piece] |= min(support[at[0]], support[-1] - support[at[-1]]) >= flank
    return (stub & on_line)[pieces] & clutter


def _reach(resolution: float) -> int:
    """:data:`JAGGED` in cells, the nearest count (at least one)."""
    return max(1, math.floor(JAGGED / resolution + 0.5 - 1e-9))


def _wall_lines(
    surface: NDArray[np.bool_], resolution: float, gap: float, min_length: float
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """The cells (x, y) along the wall lines of ``surface`` (walls' faces), one line after
    the other, and where each line's cells end (:func:`_line_cells`): the lines
    (:func:`_straight_lines`) at least ``min_length`` long across gaps of up to ``gap`` metres
    along the directions the faces line up along best within :data:`TOLERANCE` degrees, kept
    along the building's main directions (:func:`_main_directions`)."""
    return _line_cells(
        _main_directions(_straight_lines(surface, resolution, min_length, gap, TOLERANCE))
    )


def _line_cells(
    lines: NDArray[np.int32],
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """The cells (x, y) along every line (x0, y0, x1, y1), one after the other, and where
    each line's cells end: those of ``np.rint(np.linspace(x0, x1, n))`` (and of y) with ``n``
    the line's longer side in cells, plus one, computed for all lines at once as
    ``np.linspace`` computes them (start + i * step, the end exact).

    Examples
    --------
    >>> xs, ys, ends = _line_cells(np.array([[0, 0, 4, 2], [3, 3, 3, 1]]))
    >>> xs.tolist(), ys.tolist(), ends.tolist()
    ([0, 1, 2, 3, 4, 3, 3, 3], [0, 0, 1, 2, 2, 3, 2, 1], [5, 8])
    """
    x0, y0, x1, y1 = lines.astype(np.int64).T
    n = np.maximum(np.abs(x1 - x0), np.abs(y1 - y0)) + 1
    ends = np.cumsum(n)
    line = np.repeat(np.arange(len(lines)), n)
    first = (ends - n)[line]
    along = np.arange(int(ends[-1]) if len(ends) else 0, dtype=np.float64) - first
    cells = []
    for start, stop in ((x0, x1), (y0, y1)):
        values = along * ((stop - start) / np.maximum(n - 1, 1))[line] + start[line]
        values[ends - 1] = stop
        cells.append(np.rint(values).astype(np.intp))
    return cells[0], cells[1], ends


def _within(cells: NDArray[np.bool_], reach: int) -> NDArray[np.bool_]:
    """The cells at most ``reach`` cells from one of ``cells`` along each axis (a square
    neighbourhood, as a wall's face wanders along the grid's rows and columns)."""
    square = np.ones((2 * reach + 1, 2 * reach + 1), np.uint8)
    return cv2.dilate(cells.astype(np.uint8), square) > 0


def _through_channel(
    near: NDArray[np.bool_],
    start: tuple[int, int],
    end: tuple[int, int],
    depth: float,
    walls_on: NDArray[np.bool_],
) -> bool:
    """Whether the gap from ``start`` to ``end`` (x, y cells) is where corridors meet: walls
    run on from both its ends, across the line, for ``depth`` cells on one side (a channel)
    and the other side is a channel too (a corridor crossing the line of the rooms' walls) or
    no deeper than twice the gap (a corridor branching off another: a T junction), or one of
    the channel's walls runs on into the other side (a corridor going on past an open area
    beside it, which people draw as part of the corridor). A channel opening into a deep
    space with neither wall going on (a passage leaving a hall) is closed like any gap. The
    ends given are on the walls' faces, not at the edge of the band they wander in. Walls run
    on where ``walls_on`` is set (``near`` and the lines of the doors and gaps in the walls,
    :func:`wall_gaps`: a corridor's wall with doors in it still runs on); the far wall of a T
    junction is looked for in ``near`` alone."""
    a, b = np.array(start, float), np.array(end, float)
    span = max(float(np.hypot(*(b - a))), 1e-9)
    along = (b - a) / span
    normal = np.array([-along[1], along[0]])
    channel = [_walls_run_on(walls_on, a, b, side * normal, depth) for side in (1.0, -1.0)]
    if all(channel):
        return True
    if not any(channel):
        return False
    across = -normal if channel[0] else normal  # from the gap, away from the channel
    if any(_wall_runs_on(walls_on, tip, across, depth) for tip in (a, b)):
        return True  # a corridor going on past an open space beside it, along one wall
    steps = (a + b) / 2 + np.arange(1, round(2 * span) + 1)[:, None] * across
    return bool(_hits(near, steps).any())


def _walls_run_on(
    near: NDArray[np.bool_], a: NDArray, b: NDArray, direction: NDArray, depth: float
) -> bool:
    """Whether walls run on from both ``a`` and ``b`` along ``direction`` for ``depth`` cells
    (all but one of their :func:`_run_on` points on a wall)."""
    return _run_on(near, a, direction, depth) + _run_on(near, b, direction, depth) >= 7


def _wall_runs_on(near: NDArray[np.bool_], tip: NDArray, direction: NDArray, depth: float) -> bool:
    """Whether a wall runs on from ``tip`` along ``direction`` for ``depth`` cells (all but one
    of its :func:`_run_on` points on a wall)."""
    return _run_on(near, tip, direction, depth) >= 3


def _run_on(near: NDArray[np.bool_], tip: NDArray, direction: NDArray, depth: float) -> int:
    """How many of four points a quarter of ``depth`` cells apart from ``tip`` along
    ``direction`` are on a wall."""
    points = [tip + t * depth * direction for t in (0.25, 0.5, 0.75, 1.0)]
    return int(_hits(near, np.array(points)).sum())


def _hits(near: NDArray[np.bool_], points: NDArray) -> NDArray[np.bool_]:
    """``near`` at the (x, y) ``points``, False outside the grid."""
    cells = np.rint(points).astype(int)
    height, width = near.shape
    inside = (
        (cells[:, 0] >= 0) & (cells[:, 0] < width) & (cells[:, 1] >= 0) & (cells[:, 1] < height)
    )
    found = np.zeros(len(cells), bool)
    found[inside] = near[cells[inside, 1], cells[inside, 0]]
    return found


def _close(
    out: NDArray[np.uint8], start: tuple[int, int], end: tuple[int, int], hole: float
) -> None:
    """Draw a wall from ``start`` to ``end`` (x, y cells) with a ``hole`` cells wide in its
    middle."""
    a, b = np.array(start, float), np.array(end, float)
    middle, along = (a + b) / 2, (b - a) / max(float(np.hypot(*(b - a))), 1e-9)
    for tip, near_middle in ((a, middle - along * hole / 2), (b, middle + along * hole / 2)):
        cv2.line(out, _cell(tip), _cell(near_middle), 1, 2)


def _main_directions(lines: NDArray[np.int32]) -> NDArray[np.int32]:
    """The lines along directions (degrees, modulo 180) that carry at least :data:`SHARE` of
    the lines' length within :data:`TOLERANCE` degrees."""
    dx, dy = lines[:, 2] - lines[:, 0], lines[:, 3] - lines[:, 1]
    angle = np.rint(np.degrees(np.arctan2(dy, dx))).astype(int) % 180
    length = np.hypot(dx, dy)
    per_degree = np.bincount(angle, length, 180)
    around = np.sum([np.roll(per_degree, s) for s in range(-TOLERANCE, TOLERANCE + 1)], axis=0)
    return lines[around[angle] >= SHARE * length.sum()]
