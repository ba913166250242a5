"""Corridors the places cut across: where two clearance basins meet in a corridor, nothing
narrows the space, so they are one place.

A corridor's clearance is a plateau between its junctions and wide spots, each of which
raises a peak and seeds a basin (:func:`~segmentation.refine.basins`); the basins meet
somewhere on the plateau, at a cut that is no door. Compared with the basins' peaks (a
crossing of two corridors rises to sqrt(2) times their half width) such a cut looks like one,
so the places, and the partition that votes with them, would cut the corridor system at every
junction. :func:`join_corridor_cuts` joins two places where their boundary (any of its
pieces, where they touch at several passages) is a cut across a
channel: straight across the free space from wall to wall, at least a corridor wide
(:data:`CORRIDOR_WIDTH` less two cells, which a mapper's coarse cells take off the walls; the
way across read from the walls, not from the boundary, which
on a plateau follows the cells), the space keeping that width (its clearance within
:data:`~segmentation.refine.OPEN` of the cut's, and the inverse, with a cell of slack for
jagged walls) between walls on both hands for :data:`~segmentation.walls.CHANNEL` metres on
both sides; or where a corridor enters a wider space: on one side the space keeps the cut's
width so for :data:`CORRIDOR_LENGTH` times that width (longer than a room is for its width;
its walls broken only by doors, up to double doors wide; followed along its own walls, a
width in, as the walls round a junction lean the way across its cut), and on the other it never
narrows; or where a corridor (so long for its width) turns into or branches off a corridor
at least as wide that runs across it (an L or a T: the other keeps its own width along the
cut for the channel's length, :func:`_corridor_into_corridor`). A door, a room opening onto
a corridor, a narrow room entered through its full width, a corridor ending at a row of
open bays: the space widens or narrows within those metres, and the places stay apart for
the partition to decide.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from maps.grid import OccupancyGrid
from segmentation.coverage import DOOR_WIDTH
from segmentation.refine import OPEN
from segmentation.regions import boundary_pairs, relabelled
from segmentation.walls import CHANNEL, FLANK

#: The narrowest corridor, metres: building codes' least (1.1-1.2 m); a narrower passage is a
#: door or a gap between furniture.
CORRIDOR_WIDTH = 1.2
#: Where the width is checked on each side of a cut, as shares of :data:`CHANNEL`.
STEPS = (0.25, 0.5, 0.75, 1.0)
#: A corridor is at least this many times as long as it is wide; a room is rarely over 2.5
#: times (the names' ``corridor_length``, :class:`topomap.classifiers.RuleClassifier`).
CORRIDOR_LENGTH = 4.0
#: How far a corridor's own walls may turn it off a cut's normal, degrees.
LEAN = 15


def corridor_cuts(
    places: NDArray[np.integer], grid: OccupancyGrid
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Pairs ``a < b`` of touching places of ``grid`` whose boundary is a cut across a
    corridor (see the module docstring).

    Examples
    --------
    >>> free = np.zeros((22, 102), bool)
    >>> free[1:21, 1:101] = True  # a 2 m wide, 10 m long corridor (0.1 m cells)
    >>> places = np.where(free, 1 + (np.arange(102) >= 50), 0)
    >>> corridor_cuts(places, OccupancyGrid.from_masks(free, 0.1))
    (array([1]), array([2]))
    >>> free[1:21, 48:52] = False; free[10:12, 48:52] = True  # a 0.2 m slot between two rooms
    >>> corridor_cuts(places * free, OccupancyGrid.from_masks(free, 0.1))
    (array([], dtype=int64), array([], dtype=int64))
    """
    clearance, resolution = grid.free_clearance(), grid.resolution
    ra, ca, rb, cb = boundary_pairs(places)
    first = places[ra, ca].astype(np.int64)
    second = places[rb, cb].astype(np.int64)
    count = int(places.max(initial=0)) + 1
    pair, index, cells = np.unique(first * count + second, return_inverse=True, return_counts=True)
    order = np.argsort(index, kind="stable")
    ends = np.cumsum(cells)
    middle = np.column_stack([(ca + cb) / 2.0, (ra + rb) / 2.0])[order]  # x, y
    open_at = np.minimum(clearance[ra, ca], clearance[rb, cb])[order]
    piece = _boundary_pieces(middle, index[order])
    found = []
    for p, end, n in zip(pair.tolist(), ends.tolist(), cells.tolist(), strict=True):
        if n < 3:
            continue
        here, opens = middle[end - n : end], open_at[end - n : end]
        if any(
            len(cut) >= 3 and _across_corridor(here[cut], opens[cut], clearance, resolution)
            for cut in _cut_pieces(here, opens, piece[end - n : end], resolution)
        ):
            found.append(p)
    a, b = np.divmod(np.array(found, np.int64), count)
    return a, b


def join_corridor_cuts(places: NDArray[np.int32], grid: OccupancyGrid) -> NDArray[np.int32]:
    """``places`` of ``grid`` with the places of every :func:`corridor_cuts` pair made one
    (consecutive ids; 0 stays 0)."""
    a, b = corridor_cuts(places, grid)
    if len(a) == 0:
        return places
    count = int(places.max()) + 1
    links = sparse.coo_matrix((np.ones(len(a)), (a, b)), shape=(count, count))
    _, component = connected_components(links, directed=False)
    return relabelled(places, np.r_[0, component[1:] + 1])


def _boundary_pieces(
    middle: NDArray[np.float64], boundary: NDArray[np.integer]
) -> NDArray[np.intp]:
    """The piece of its boundary each midpoint of a cell pair lies on (x and y, cells; the
    ``boundary`` of each, those of one boundary one after the other): the midpoints within
    1.5 cells of each other are one piece, numbered from 0 in each boundary in the order of
    their first midpoints. All boundaries at once: one search of near midpoints, one graph.

    Examples
    --------
    >>> middle = np.array([[0.5, 0.0], [0.5, 1.0], [0.5, 9.0], [0.5, 2.0], [0.5, 3.0]])
    >>> _boundary_pieces(middle, np.array([0, 0, 0, 1, 1])).tolist()
    [0, 0, 1, 0, 0]
    """
    near = cKDTree(middle).query_pairs(1.5, output_type="ndarray")
    near = near[boundary[near[:, 0]] == boundary[near[:, 1]]]
    links = sparse.coo_matrix(
        (np.ones(len(near)), (near[:, 0], near[:, 1])), shape=(len(middle), len(middle))
    )
    _, piece = connected_components(links, directed=False)  # numbered by first midpoint
    first = np.r_[True, boundary[1:] != boundary[:-1]]
    return piece - np.maximum.accumulate(np.where(first, piece, 0))


def _cut_pieces(
    middle: NDArray[np.float64],
    open_at: NDArray[np.float32],
    piece: NDArray[np.intp],
    resolution: float,
) -> list[NDArray[np.intp]]:
    """The cuts a boundary (midpoints of its cell pairs, x and y in cells of ``resolution``
    metres, and the :func:`_boundary_pieces` they lie on) may be, most open first: each of its
    pieces (two places may touch at several passages: through a gap between clutter, at
    another corridor's junction farther along), with the pieces that lie on its line, within
    two cells across and :data:`~segmentation.walls.FLANK` along (a dotted wall's gaps, which
    together are no cut from wall to wall); a piece off that line stays a cut of its own (two
    places meeting on both arms of a ring).

    Examples
    --------
    >>> def cuts(middle, open_at):
    ...     piece = _boundary_pieces(middle, np.zeros(len(middle), int))
    ...     return [c.tolist() for c in _cut_pieces(middle, open_at, piece, 0.1)]
    >>> cut = [[5.5, 0.0], [5.5, 1.0], [5.5, 2.0]]
    >>> open_at = np.array([0.1, 0.3, 0.1, 0.1])
    >>> cuts(np.array([*cut, [30.0, 9.5]]), open_at)
    [[0, 1, 2], [3]]
    >>> cuts(np.array([*cut, [5.5, 9.0]]), open_at)
    [[0, 1, 2, 3]]
    >>> cuts(np.array([*cut, [5.5, 40.0]]), open_at)
    [[0, 1, 2], [3]]
    >>> far = np.array([*cut, [5.5, 9.0], [60.0, 0.5]])  # on the line, and a ring's other arm
    >>> cuts(far, np.r_[open_at, 0.1])
    [[0, 1, 2, 3], [4]]
    """
    count = int(piece.max()) + 1
    most = np.full(count, -np.inf)
    np.maximum.at(most, piece, open_at.astype(np.float64))
    cuts: list[NDArray[np.intp]] = []
    taken = np.zeros(len(middle), bool)
    for seed in np.argsort(-most, kind="stable").tolist():
        cut = piece == seed
        if taken[cut].all():
            continue  # part of a dotted wall's cut already
        if cut.sum() >= 2 and not cut.all():
            centre = middle[cut].mean(axis=0)
            axis = np.linalg.svd(middle[cut] - centre, full_matrices=False)[2][0]
            along, others = (middle[cut] - centre) @ axis, middle[~cut] - centre
            off_line = np.abs(others @ np.array([-axis[1], axis[0]]))
            beyond = np.maximum(along.min() - others @ axis, others @ axis - along.max())
            on_line = (off_line <= 2) & (beyond * resolution <= FLANK)
            cut |= np.isin(piece, piece[~cut][on_line])
        taken |= cut
        cuts.append(np.flatnonzero(cut))
    return cuts


def _across_corridor(
    middle: NDArray[np.float64],
    open_at: NDArray[np.float32],
    clearance: NDArray[np.float32],
    resolution: float,
) -> bool:
    """Whether a boundary (the midpoints of its cell pairs, x and y in cells, and the clearance
    there, metres) is a cut across a corridor of the map whose ``clearance`` is given."""
    centre = middle.mean(axis=0)
    _, axes = np.linalg.eigh(np.cov((middle - centre).T))
    most = int(np.argmax(open_at))
    width = 2 * float(open_at[most])  # the space's width at the cut's most open cell
    # the way across, wall to wall, is the walls' where there are walls to go by: on a
    # plateau, the boundary runs along a row or a column of cells whatever the walls' slant
    walls = _across_walls(clearance, middle[most], axes[:, 1], (width + 0.5) / resolution)
    way = axes[:, 1] if walls is None else walls
    length = _extent(middle, way) * resolution
    # not wall to wall, or narrower than a corridor even where a jagged wall took a cell off
    # each side (SLAM maps' corridors measure 1.1 m on the working cells)
    if length * OPEN > width or length < CORRIDOR_WIDTH - 2 * resolution:
        return False
    normal = np.array([-way[1], way[0]])
    steps = np.array(STEPS) * CHANNEL / resolution
    points = middle[most] + np.concatenate([steps, -steps])[:, None] * normal
    across = np.array([normal[1], -normal[0]]) * width / 2 / resolution
    holds = _keeps_width(clearance, points, across, width, resolution)
    half = len(STEPS)
    both_sides = holds.sum() >= 2 * half - 1 and holds[:half].any() and holds[half:].any()
    if both_sides:
        return True
    return _corridor_into_wider(
        middle[most], normal, width, clearance, resolution
    ) or _corridor_into_corridor(middle[most], normal, width, clearance, resolution)


def _extent(cells: NDArray[np.float64], way: NDArray[np.float64]) -> float:
    """How far the cells centred at ``cells`` (x, y) reach along the unit ``way``, in cells:
    from the first one's near edge to the last one's far edge (a cell spans ``|x| + |y|`` of
    the way), so that a cut along a column of cells is as long across walls a few degrees off
    the column as across walls square with it.

    Examples
    --------
    >>> column = np.column_stack([np.full(10, 5.0), np.arange(10.0)])
    >>> _extent(column, np.array([0.0, 1.0]))
    10.0
    >>> turned = np.radians(4.0)  # walls 4 degrees off the column: 9.98 from the centres
    >>> round(_extent(column, np.array([np.sin(turned), np.cos(turned)])), 3)
    10.045
    """
    along = cells @ way
    return float(along.max() - along.min()) + abs(float(way[0])) + abs(float(way[1]))


def _across_walls(
    clearance: NDArray[np.float32],
    point: NDArray[np.float64],
    axis: NDArray[np.float64],
    reach: float,
) -> NDArray[np.float64] | None:
    """The unit way (x, y) across the walls within ``reach`` cells of ``point`` (x, y cells),
    within 60 degrees of ``axis``: the way along which the wall cells stack into the fewest,
    fullest rows (a Radon transform at one cell's resolution, every degree); None where
    there are no walls to go by.

    Examples
    --------
    >>> clearance = np.ones((20, 40), np.float32)
    >>> rows, columns = np.indices(clearance.shape)
    >>> clearance[np.abs(rows - 10 - (columns - 20) * np.tan(np.radians(20))) > 5] = 0
    >>> way = _across_walls(clearance, np.array([20.0, 10.0]), np.array([0.0, 1.0]), 12.0)
    >>> bool(abs(np.degrees(np.arctan2(way[1], way[0])) - 110) <= 2)  # a corridor at 20 degrees
    True
    """
    span = int(np.ceil(reach))
    x, y = np.rint(point).astype(int)
    top, left = max(y - span, 0), max(x - span, 0)
    solid = np.pad(clearance[top : y + span + 1, left : x + span + 1] <= 0, 1, "edge")
    inner = solid[1:-1, 1:-1]
    edge = inner & ~(solid[:-2, 1:-1] & solid[2:, 1:-1] & solid[1:-1, :-2] & solid[1:-1, 2:])
    rows, columns = np.nonzero(edge)
    cells = np.column_stack([columns + left - point[0], rows + top - point[1]])
    cells = cells[np.hypot(cells[:, 0], cells[:, 1]) <= reach]
    if len(cells) < 4:
        return None
    angles = np.arctan2(axis[1], axis[0]) + np.radians(np.arange(-60, 61))
    ways = np.column_stack([np.cos(angles), np.sin(angles)])
    rows_of = np.floor(cells @ ways.T + reach + 1).astype(np.int64)  # >= 0
    width = int(rows_of.max()) + 1
    columns_of = rows_of + width * np.arange(len(angles))
    counts = np.bincount(columns_of.ravel(), minlength=width * len(angles))
    fullness = (counts.reshape(len(angles), width).astype(np.float64) ** 2).sum(axis=1)
    return ways[int(np.argmax(fullness))]


def _corridor_into_wider(
    start: NDArray[np.float64],
    normal: NDArray[np.float64],
    width: float,
    clearance: NDArray[np.float32],
    resolution: float,
) -> bool:
    """Whether a cut ``width`` metres wide at ``start`` (x, y cells) is where a corridor
    enters a wider space: on one side along ``normal`` a corridor (:func:`_corridor_on`), on
    the other the space never narrows over :data:`~segmentation.walls.CHANNEL` metres."""
    behind = np.arange(1, int(CHANNEL / 0.25) + 1) * 0.25 / resolution  # every 0.25 m
    for sign in (1.0, -1.0):
        wider = _clearance_at(clearance, start - sign * behind[:, None] * normal)
        if (
            _corridor_on(start, sign * normal, width, clearance, resolution)
            and (wider >= OPEN * width / 2 - resolution).all()
        ):
            return True
    return False


def _corridor_on(
    start: NDArray[np.float64],
    way: NDArray[np.float64],
    width: float,
    clearance: NDArray[np.float32],
    resolution: float,
) -> bool:
    """Whether the space from ``start`` (x, y cells) along about the unit ``way`` (along its
    own walls, :func:`_own_way`) keeps ``width`` metres between walls (:func:`_keeps_width`,
    doors along it up to double doors) for
    :data:`CORRIDOR_LENGTH` times that width, a sample every 0.25 m: as across a cut (7 of 8
    samples), one in eight may miss, as a curved corridor leaves the straight line. A room is
    rarely over 2.5 times as long as wide: this is a corridor, not a narrow room entered
    through its full width."""
    way = _own_way(start, way, width, clearance, resolution)
    offsets = np.arange(1, int(CORRIDOR_LENGTH * width / 0.25) + 1) * 0.25 / resolution
    sides = np.array([way[1], -way[0]]) * width / 2 / resolution
    door = round(DOOR_WIDTH / 0.25)
    holds = _keeps_width(clearance, start + offsets[:, None] * way, sides, width, resolution, door)
    return bool(holds.sum() >= len(holds) - len(holds) // 8)


def _own_way(
    start: NDArray[np.float64],
    way: NDArray[np.float64],
    width: float,
    clearance: NDArray[np.float32],
    resolution: float,
) -> NDArray[np.float64]:
    """The unit way along a corridor that leaves a cut at ``start`` (x, y cells) along about
    ``way``: across the walls one ``width`` in (:func:`_across_walls`), turned to ``way``,
    where that is within :data:`LEAN` degrees of it; else ``way``. At a junction the walls
    round the cut lean the way across it; the corridor's own walls, a width in, do not."""
    inside = start + way * width / resolution
    normal = np.array([way[1], -way[0]])
    across = _across_walls(clearance, inside, normal, (width + 0.5) / resolution)
    if across is None:
        return way
    along = np.array([-across[1], across[0]])
    along = along if along @ way >= 0 else -along
    return along if along @ way >= np.cos(np.radians(LEAN)) else way


def _corridor_into_corridor(
    start: NDArray[np.float64],
    normal: NDArray[np.float64],
    width: float,
    clearance: NDArray[np.float32],
    resolution: float,
) -> bool:
    """Whether a cut ``width`` metres wide at ``start`` (x, y cells) is where a corridor turns
    into or branches off a corridor at least as wide that runs across it (an L or a T): on
    one side along ``normal`` a corridor (:func:`_corridor_on`); on the other, the channel
    from the cut to its far wall (within three widths: farther is a hall) is at least as wide
    as the cut, and from its centreline, past the cut's mouth, it keeps its own width for
    :data:`~segmentation.walls.CHANNEL` metres along the cut one way or the other. A corridor
    ending at a narrower channel across it (a row of open bays, a room entered through its
    full width) is no such junction: the places stay apart.

    Examples
    --------
    >>> from scipy.ndimage import distance_transform_edt
    >>> free = np.zeros((120, 120), bool)
    >>> free[2:20, 2:118] = True  # a 1.8 m corridor (0.1 m cells) ...
    >>> free[20:118, 2:16] = True  # ... and a 1.4 m one turning into it at a corner
    >>> clearance = (distance_transform_edt(free) * 0.1).astype(np.float32)
    >>> start, up = np.array([9.0, 19.5]), np.array([0.0, 1.0])
    >>> bool(_corridor_into_corridor(start, up, 1.4, clearance, 0.1))
    True
    >>> free[2:20, 30:118] = False  # the wide one now ends 1.4 m past the narrow one's side
    >>> clearance = (distance_transform_edt(free) * 0.1).astype(np.float32)
    >>> bool(_corridor_into_corridor(start, up, 1.4, clearance, 0.1))
    False
    >>> free[2:20, :] = False; free[8:20, 2:118] = True  # the one across only 1.2 m wide
    >>> clearance = (distance_transform_edt(free) * 0.1).astype(np.float32)
    >>> bool(_corridor_into_corridor(start, up, 1.4, clearance, 0.1))
    False
    """
    tangent = np.array([normal[1], -normal[0]])
    door = round(DOOR_WIDTH / 0.25)
    for sign in (1.0, -1.0):
        if not _corridor_on(start, sign * normal, width, clearance, resolution):
            continue
        # cell by cell from the cut (between two cells) to the far wall
        depth = np.arange(int(3 * width / resolution) + 1) + 0.5
        beyond = _clearance_at(clearance, start - sign * depth[:, None] * normal)
        walls = np.flatnonzero(beyond <= 0)
        if len(walls) == 0:
            continue  # no far wall within three widths: a hall (:func:`_corridor_into_wider`)
        channel = walls[0] * resolution  # the width of the channel across
        if channel < width - resolution:
            continue  # narrower than the corridor entering it
        centre = start - sign * walls[0] / 2 * normal
        reach = (width / 2 + 0.25 + np.arange(int(CHANNEL / 0.25)) * 0.25) / resolution
        sides = normal * channel / 2 / resolution
        for way in (1.0, -1.0):
            run = centre + (way * reach)[:, None] * tangent
            keeps = _keeps_width(clearance, run, sides, channel, resolution, door)
            if keeps.sum() >= len(keeps) - len(keeps) // 8:
                return True
    return False


def _keeps_width(
    clearance: NDArray[np.float32],
    points: NDArray[np.float64],
    across: NDArray[np.float64],
    width: float,
    resolution: float,
    door: int = 0,
) -> NDArray[np.bool_]:
    """Whether the space at each of ``points`` (x, y cells) is ``width`` metres wide between
    walls on both hands (``across``, cells, reaches from the middle to a wall): the clearance
    in the middle is half the width, with a cell of slack (SLAM maps' walls are jagged), and
    at ``points ± across`` it is no more than that (no room opens along a wall). With
    ``door`` (the widest door, in points), a wall's break over at most that many consecutive
    points is a door along the corridor, not a room opening onto it.

    Examples
    --------
    >>> from scipy.ndimage import distance_transform_edt
    >>> free = np.zeros((60, 100), bool)
    >>> free[30:42, :] = True  # a 1.2 m corridor (0.1 m cells) along a room's wall (row 29)
    >>> free[5:29, :] = True; free[29, 40:60] = True  # the room, double doors (2 m) in the wall
    >>> clearance = (distance_transform_edt(free) * 0.1).astype(np.float32)
    >>> points = np.column_stack([np.arange(20, 80, 2.5), np.full(24, 35.5)])  # every 0.25 m
    >>> across = np.array([0.0, 6.0])
    >>> int(_keeps_width(clearance, points, across, 1.2, 0.1).sum())
    21
    >>> int(_keeps_width(clearance, points, across, 1.2, 0.1, door=8).sum())  # 2 m
    24
    """
    half = width / 2
    there = _clearance_at(clearance, points)
    walls = np.maximum(
        _clearance_at(clearance, points + across), _clearance_at(clearance, points - across)
    )
    keeps = (there >= OPEN * half - resolution) & (there * OPEN <= half + resolution)
    on_walls = walls * OPEN <= half
    if door > 0:
        on_walls |= _short_breaks(on_walls, door)
    return keeps & on_walls


def _short_breaks(holds: NDArray[np.bool_], longest: int) -> NDArray[np.bool_]:
    """The runs of False in ``holds`` at most ``longest`` long with True on both sides.

    Examples
    --------
    >>> _short_breaks(np.array([1, 0, 0, 1, 0, 0, 0, 1, 0], bool), 2).astype(int).tolist()
    [0, 1, 1, 0, 0, 0, 0, 0, 0]
    """
    edges = np.flatnonzero(np.diff(np.r_[1, holds.astype(np.int8), 1]))
    out = np.zeros(len(holds), bool)
    for start, end in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        if start > 0 and end < len(holds) and end - start <= longest:
            out[start:end] = True
    return out


def _clearance_at(
    clearance: NDArray[np.float32], points: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``clearance`` at the cells nearest ``points`` (x, y in cells); 0 off the map."""
    cells = np.rint(points).astype(int)
    height, wide = clearance.shape
    inside = (cells[:, 0] >= 0) & (cells[:, 0] < wide) & (cells[:, 1] >= 0) & (cells[:, 1] < height)
    there = np.zeros(len(cells))
    there[inside] = clearance[cells[inside, 1], cells[inside, 0]]
    return there
