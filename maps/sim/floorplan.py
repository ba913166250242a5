"""A seeded generator of office-like floor plans with their ground-truth rooms.

The layout is the double-loaded corridor of real office buildings: from the bottom, a row of
rooms, a corridor, two rows of rooms back to back, a corridor, ... a row of rooms. Cross
corridors join the corridors into loops (or make an L in a one-corridor flat); large halls
take the place of rooms in two back-to-back rows, with doors to both corridors. Every room
opens onto a corridor through a door; some rooms also open onto their neighbour.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise
from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.errors import InvalidMapError
from maps.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from maps.limits import MAX_FURNITURE, check_map_size
from maps.seeding import RandomState, as_generator

RoomType = Literal["room", "corridor", "hall"]
Wall = Literal["top", "bottom", "left", "right"]
SIZES: dict[str, tuple[float, float]] = {
    "flat": (20.0, 15.0),
    "office": (100.0, 60.0),
    "campus": (300.0, 200.0),
}
WALL = 0.15  # interior wall thickness, metres
OUTER_WALL = 0.3
MARGIN = 0.5  # unknown border around the building


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in metres."""

    x0: float
    y0: float
    x1: float
    y1: float

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        return self.y1 - self.y0


@dataclass(frozen=True)
class Door:
    """A door between two spaces: its centre (map frame, metres), width and the two labels."""

    x: float
    y: float
    width: float
    rooms: tuple[int, int]
    vertical: bool  # True when the door is in a vertical wall (you walk through along x)


@dataclass(frozen=True)
class FloorPlan:
    """A generated building: its grid, ground-truth room labels, room types and doors.

    ``labels`` is aligned with ``grid.cells``: 0 on walls and outside, ``i`` (1..K) on the
    cells of space ``i``, whose type is ``types[i - 1]``. Door openings belong to the room
    whose wall they cross. Furniture cells keep their room's label (as in the empty plan),
    although the grid marks them occupied.
    """

    grid: OccupancyGrid
    labels: NDArray[np.int32]
    types: tuple[RoomType, ...]
    doors: tuple[Door, ...]
    rects: tuple[Rect, ...] = field(repr=False)

    @property
    def n_rooms(self) -> int:
        """Number of labelled spaces (rooms, corridors and halls)."""
        return len(self.types)

    def corridor_systems(self) -> NDArray[np.int32]:
        """``labels`` with the corridors that meet with no door between them (at a junction,
        a corner) as one space each, as people name a corridor system: one label per system
        (the lowest of its corridors' labels), the other spaces as they are.

        Examples
        --------
        >>> plan = generate_floor_plan("office", random_state=0)
        >>> corridors = [i for i, t in enumerate(plan.types, start=1) if t == "corridor"]
        >>> systems = plan.corridor_systems()
        >>> len(corridors) > 1, len(set(systems[np.isin(plan.labels, corridors)].tolist()))
        (True, 1)
        """
        corridor = np.zeros(self.n_rooms + 1, bool)
        corridor[1:] = np.array(self.types) == "corridor"
        parent = np.arange(self.n_rooms + 1)

        def root(i: int) -> int:
            while parent[i] != i:
                i = int(parent[i])
            return i

        for a, b in (
            (self.labels[:, :-1], self.labels[:, 1:]),
            (self.labels[:-1], self.labels[1:]),
        ):
            touching = (a != b) & corridor[a] & corridor[b]
            for x, y in set(zip(a[touching].tolist(), b[touching].tolist(), strict=True)):
                low, high = sorted((root(x), root(y)))
                parent[high] = low
        system = np.array([root(i) for i in range(self.n_rooms + 1)], np.int32)
        return system[self.labels]

    def rooms_on(
        self, grid: OccupancyGrid, labels: NDArray[np.int32] | None = None
    ) -> NDArray[np.int32]:
        """The plan's ``labels`` (its spaces', by default; :meth:`corridor_systems`) at the
        centres of ``grid``'s cells (a map of this building, as a robot built it): 0 outside
        the plan and on its walls.

        Examples
        --------
        >>> plan = generate_floor_plan("flat", random_state=0)
        >>> bool((plan.rooms_on(plan.grid) == plan.labels).all())
        True
        """
        labels = self.labels if labels is None else labels
        rows, cols = np.indices(grid.shape)
        x, y = grid.cell_to_world(rows.ravel(), cols.ravel())
        plan_rows, plan_cols = self.grid.world_to_cell(x, y)
        inside = self.grid.contains(plan_rows, plan_cols)
        rooms = np.zeros(rows.size, np.int32)
        rooms[inside] = labels[plan_rows[inside], plan_cols[inside]]
        return rooms.reshape(grid.shape)


class _Builder:
    """Collects spaces and doors in metres, then rasterises them."""

    def __init__(
        self, width: float, height: float, resolution: float, rng: np.random.Generator
    ) -> None:
        self.width, self.height, self.res, self.rng = width, height, resolution, rng
        self.rects: list[Rect] = []
        self.types: list[RoomType] = []
        self.doors: list[Door] = []
        self.open_ends: set[int] = set()  # indices of cross corridors, open where they join

    def add(self, rect: Rect, kind: RoomType, *, open_ends: bool = False) -> int:
        if open_ends:
            self.open_ends.add(len(self.rects))
        self.rects.append(rect)
        self.types.append(kind)
        return len(self.rects)

    def door(
        self,
        room: int,
        other: int,
        wall: Wall,
        span: tuple[float, float] | None = None,
    ) -> None:
        """A door in ``room``'s ``wall`` onto ``other``, somewhere along ``span`` (metres)."""
        r = self.rects[room - 1]
        width = float(self.rng.uniform(0.8, 1.2))
        lo, hi = (
            span
            if span is not None
            else ((r.x0, r.x1) if wall in ("top", "bottom") else (r.y0, r.y1))
        )
        lo, hi = lo + width / 2 + 0.35, hi - width / 2 - 0.35
        if hi < lo:
            return
        at = float(self.rng.uniform(lo, hi))
        if wall in ("top", "bottom"):
            y = r.y1 if wall == "top" else r.y0
            self.doors.append(Door(at, y, width, (room, other), vertical=False))
        else:
            x = r.x1 if wall == "right" else r.x0
            self.doors.append(Door(x, at, width, (room, other), vertical=True))

    def cells(self, rect: Rect, shape: tuple[int, int]) -> tuple[slice, slice]:
        rows = shape[0]
        c0 = int(round((rect.x0 + MARGIN) / self.res))
        c1 = int(round((rect.x1 + MARGIN) / self.res))
        r0 = rows - int(round((rect.y1 + MARGIN) / self.res))
        r1 = rows - int(round((rect.y0 + MARGIN) / self.res))
        return slice(max(r0, 0), max(r1, 0)), slice(max(c0, 0), max(c1, 0))

    def rasterise(self) -> tuple[NDArray[np.int8], NDArray[np.int32]]:
        shape = (
            int(round((self.height + 2 * MARGIN) / self.res)),
            int(round((self.width + 2 * MARGIN) / self.res)),
        )
        cells = np.full(shape, UNKNOWN, np.int8)
        cells[self.cells(Rect(0, 0, self.width, self.height), shape)] = OCCUPIED
        labels = np.zeros(shape, np.int32)
        inner = Rect(OUTER_WALL, OUTER_WALL, self.width - OUTER_WALL, self.height - OUTER_WALL)
        half = WALL / 2
        # corridors last, cross corridors before the corridors they join: a junction belongs to
        # the main corridor
        order = sorted(
            range(len(self.rects)),
            key=lambda i: (self.types[i] == "corridor", i not in self.open_ends),
        )
        for i in order:
            r = self.rects[i]
            y_in = -half if i in self.open_ends else half
            shrunk = Rect(
                max(r.x0 + half, inner.x0),
                max(r.y0 + y_in, inner.y0),
                min(r.x1 - half, inner.x1),
                min(r.y1 - y_in, inner.y1),
            )
            window = self.cells(shrunk, shape)
            cells[window] = FREE
            labels[window] = i + 1
        for d in self.doors:
            reach = WALL / 2 + self.res
            if d.vertical:
                rect = Rect(d.x - reach, d.y - d.width / 2, d.x + reach, d.y + d.width / 2)
            else:
                rect = Rect(d.x - d.width / 2, d.y - reach, d.x + d.width / 2, d.y + reach)
            window = self.cells(rect, shape)
            opening = labels[window] == 0
            cells[window] = FREE
            labels[window][opening] = d.rooms[0]
        return cells, labels


def _split(length: float, lo: float, hi: float, rng: np.random.Generator) -> list[float]:
    """Cut ``length`` into pieces between ``lo`` and ``hi`` (a short last piece is merged)."""
    cuts = [0.0]
    while length - cuts[-1] > hi:
        cuts.append(cuts[-1] + float(rng.uniform(lo, hi)))
    if len(cuts) > 1 and length - cuts[-1] < lo:
        cuts.pop()  # the short remainder joins the last piece, halved if that is long enough
        if length - cuts[-1] >= 2 * lo:
            cuts.append((cuts[-1] + length) / 2)
    return [*cuts, length]


def generate_floor_plan(
    size: str | tuple[float, float] = "office",
    *,
    resolution: float = 0.05,
    furniture: float = 0.0,
    random_state: RandomState = None,
) -> FloorPlan:
    """Generate an office-like building and its ground truth.

    Parameters
    ----------
    size
        ``"flat"`` (about 20 x 15 m), ``"office"`` (100 x 60 m), ``"campus"`` (300 x 200 m),
        or ``(width, height)`` in metres (at least 12 x 10).
    resolution
        Cell size of the grid, metres.
    furniture
        Furniture blocks per 10 m^2 of room and hall floor (0 for an empty plan). Blocks never
        cut a room's free space in two.
    random_state
        Seed or Generator; the same seed gives the same building.
    """
    if isinstance(size, str):
        if size not in SIZES:
            raise InvalidMapError(f"unknown building size {size!r}; known: {sorted(SIZES)}")
        width, height = SIZES[size]
    else:
        width, height = (float(v) for v in size)
    if not (width >= 12 and height >= 10):
        raise InvalidMapError(f"a building must be at least 12 x 10 m, got {width} x {height}")
    if not 0 < resolution <= 0.5:
        raise InvalidMapError(f"resolution must lie in (0, 0.5] metres, got {resolution}")
    if not 0 <= furniture <= MAX_FURNITURE:
        raise InvalidMapError(
            f"furniture density must lie in [0, {MAX_FURNITURE:g}] blocks per 10 m^2, "
            f"got {furniture}"
        )
    check_map_size(
        (height + 2 * MARGIN) / resolution, (width + 2 * MARGIN) / resolution, what="building"
    )
    rng = as_generator(random_state)
    b = _Builder(width, height, resolution, rng)

    # vertical structure: row (corridor row row)* corridor row
    corridor_w = float(rng.uniform(1.8, 2.6))
    n_corridors = max(1, int(round(height / (2 * 8.0 + corridor_w))))
    depths = rng.uniform(6.0, 10.0, 2 * n_corridors)
    depths *= (height - n_corridors * corridor_w) / depths.sum()
    rows: list[tuple[float, float, int]] = []  # (y0, y1, index of the corridor it faces)
    corridor_ys: list[tuple[float, float]] = []
    y = 0.0
    for k in range(n_corridors):
        rows.append((y, y + depths[2 * k], k))
        y += depths[2 * k]
        corridor_ys.append((y, y + corridor_w))
        y += corridor_w
        rows.append((y, y + depths[2 * k + 1], k))
        y += depths[2 * k + 1]

    corridors = [b.add(Rect(0, y0, width, y1), "corridor") for y0, y1 in corridor_ys]

    # cross corridors: join all corridors into loops; a flat gets an L (a stub to the top wall)
    cross_x: list[tuple[float, float]] = []
    crossed_rows = set(range(1, len(rows) - 1))  # rows the cross corridors pass through
    if n_corridors > 1:
        n_cross = max(2, int(round(width / 40.0)) + 1)
        for x in np.linspace(0, width - corridor_w, n_cross):
            cross_x.append((float(x), float(x) + corridor_w))
        for k in range(n_corridors - 1):
            for x0, x1 in cross_x:
                b.add(
                    Rect(x0, corridor_ys[k][1], x1, corridor_ys[k + 1][0]),
                    "corridor",
                    open_ends=True,
                )
    elif rng.random() < 0.5:
        x0 = 0.0 if rng.random() < 0.5 else width - corridor_w
        cross_x.append((x0, x0 + corridor_w))
        crossed_rows = {len(rows) - 1}
        b.add(Rect(x0, corridor_ys[0][1], x0 + corridor_w, height), "corridor", open_ends=True)

    # halls: two back-to-back rows between corridors, or a wide stretch of one row in a flat
    hall_spans: dict[int, list[tuple[float, float]]] = {}
    n_halls = int(round(width * height / 2000.0)) or int(rng.random() < 0.5)
    pairs = list(range(1, len(rows) - 1, 2)) or [int(rng.integers(0, len(rows)))]
    for _ in range(n_halls * 4):
        if sum(len(v) for v in hall_spans.values()) // (2 if len(rows) > 2 else 1) >= n_halls:
            break
        first = int(rng.choice(pairs))
        members = [first, first + 1] if len(rows) > 2 else [first]
        span = float(rng.uniform(12.0, 20.0)) if len(rows) > 2 else float(rng.uniform(6.0, 9.0))
        x0 = float(rng.uniform(0, max(width - span, 0)))
        x1 = min(x0 + span, width)
        crossing = cross_x if crossed_rows & set(members) else []
        blocked = [(a - 1.0, c + 1.0) for a, c in crossing + hall_spans.get(first, [])]
        if any(x0 < c and a < x1 for a, c in blocked) or x1 - x0 < 5:
            continue
        y0, y1 = rows[members[0]][0], rows[members[-1]][1]
        hall = b.add(Rect(x0, y0, x1, y1), "hall")
        for m in members:
            hall_spans.setdefault(m, []).append((x0, x1))
            r_y0, _, k = rows[m]
            wall: Wall = "top" if r_y0 < corridor_ys[k][0] else "bottom"
            for part in ((x0, (x0 + x1) / 2), ((x0 + x1) / 2, x1)):
                b.door(hall, corridors[k], wall, span=part)

    # rooms: each row's free stretches (between cross corridors and halls) cut into rooms
    for m, (y0, y1, k) in enumerate(rows):
        taken = sorted((cross_x if m in crossed_rows else []) + hall_spans.get(m, []))
        stretches, x = [], 0.0
        for a, c in taken:
            if a - x > 2.5:
                stretches.append((x, a))
            x = max(x, c)
        if width - x > 2.5:
            stretches.append((x, width))
        facing: Wall = "top" if y0 < corridor_ys[k][0] else "bottom"
        for s0, s1 in stretches:
            cuts = _split(s1 - s0, 4.0, 9.0, rng)
            previous = None
            for a, c in pairwise(cuts):
                room = b.add(Rect(s0 + a, y0, s0 + c, y1), "room")
                b.door(room, corridors[k], facing)
                if previous is not None and rng.random() < 0.15:
                    b.door(room, previous, "left")
                previous = room

    cells, labels = b.rasterise()
    if furniture > 0:
        _furnish(cells, labels, b, furniture)
    grid = OccupancyGrid(cells, resolution, (-MARGIN, -MARGIN, 0.0))
    return FloorPlan(grid, labels, tuple(b.types), tuple(b.doors), tuple(b.rects))


def _furnish(
    cells: NDArray[np.int8], labels: NDArray[np.int32], b: _Builder, density: float
) -> None:
    """Drop furniture blocks into rooms and halls without disconnecting their floor."""
    res, rng = b.res, b.rng
    near_door = np.zeros(cells.shape, bool)
    for d in b.doors:
        reach = d.width / 2 + 0.8
        near_door[
            b.cells(Rect(d.x - reach, d.y - reach, d.x + reach, d.y + reach), cells.shape)
        ] = True
    for label, (rect, kind) in enumerate(zip(b.rects, b.types, strict=True), start=1):
        if kind == "corridor":
            continue
        window = b.cells(rect, cells.shape)
        for _ in range(rng.poisson(rect.width * rect.height * density / 10.0)):
            w, h = rng.uniform(0.4, 1.6, 2)
            x0 = rng.uniform(rect.x0, rect.x1 - w)
            y0 = rng.uniform(rect.y0, rect.y1 - h)
            block = b.cells(Rect(x0, y0, x0 + w, y0 + h), cells.shape)
            mine = labels[block] == label
            if near_door[block].any() or not mine.any():
                continue
            before = cells[block].copy()
            cells[block][mine] = OCCUPIED
            floor = (cells[window] == FREE) & (labels[window] == label)
            # the floor must stay one piece, with room for a robot (0.3 m) to pass
            passable = ndimage.binary_opening(floor, iterations=max(1, int(0.15 / res)))
            if ndimage.label(passable)[1] != 1 or ndimage.label(floor)[1] != 1:
                cells[block] = before
