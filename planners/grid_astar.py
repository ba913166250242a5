"""Reference planner: A* on the 8-connected grid of the inflated map, octile costs."""

from __future__ import annotations

import heapq
import math

import numpy as np
from numpy.typing import NDArray

from planners.errors import NoPathError
from planners.path import SearchPlanner
from planners.workspace import Point, Workspace

_SQRT2 = math.sqrt(2.0)


class GridAStar(SearchPlanner):
    """A* over free cells, 8-connected, with octile step costs and the octile heuristic.

    A diagonal step is allowed only when both cells it squeezes between are free, so every
    step is a valid straight motion. The path runs start -> cell centres -> goal.

    Parameters
    ----------
    space
        The free space to plan in.
    """

    name = "grid_astar"

    def __init__(self, space: Workspace) -> None:
        self.space = space
        h, w = space.free.shape
        self._width = w
        # a one-cell blocked border: neighbours never wrap around rows
        padded = np.zeros((h + 2, w + 2), bool)
        padded[1:-1, 1:-1] = space.free
        self._free = padded.tobytes()  # bytes: fast to index, not tracked by the GC
        self._padded_width = w + 2

    def _search(self, start: Point, goal: Point) -> NDArray[np.float64]:
        space, pw = self.space, self._padded_width
        (sr,), (sc,) = (np.atleast_1d(v) for v in space.grid.world_to_cell(start[0], start[1]))
        (gr,), (gc,) = (np.atleast_1d(v) for v in space.grid.world_to_cell(goal[0], goal[1]))
        source, target = (int(sr) + 1) * pw + int(sc) + 1, (int(gr) + 1) * pw + int(gc) + 1
        cells = self._cells(source, target, int(gr) + 1, int(gc) + 1)
        if len(cells) == 1:
            return np.array([start, goal])
        rows, cols = np.divmod(np.asarray(cells), pw)
        xs, ys = space.grid.cell_to_world(rows - 1, cols - 1)
        return np.vstack([start, np.column_stack([xs, ys])[1:-1], goal])

    def _cells(self, source: int, target: int, goal_row: int, goal_col: int) -> list[int]:
        free, pw = self._free, self._padded_width
        steps = (  # (offset, cost, the two cells a diagonal step squeezes between)
            (1, 1.0, ()),
            (-1, 1.0, ()),
            (pw, 1.0, ()),
            (-pw, 1.0, ()),
            (pw + 1, _SQRT2, (pw, 1)),
            (pw - 1, _SQRT2, (pw, -1)),
            (-pw + 1, _SQRT2, (-pw, 1)),
            (-pw - 1, _SQRT2, (-pw, -1)),
        )
        best = {source: 0.0}
        parent = {source: source}
        frontier = [(0.0, 0.0, source)]
        closed = set()
        diagonal = _SQRT2 - 2.0
        while frontier:
            _, cost, cell = heapq.heappop(frontier)
            if cell == target:
                path = [cell]
                while cell != source:
                    cell = parent[cell]
                    path.append(cell)
                return path[::-1]
            if cell in closed:
                continue
            closed.add(cell)
            for off, step, orth in steps:
                nxt = cell + off
                if not free[nxt] or nxt in closed:
                    continue
                if orth and not (free[cell + orth[0]] and free[cell + orth[1]]):
                    continue
                new = cost + step
                if new < best.get(nxt, math.inf):
                    best[nxt] = new
                    parent[nxt] = cell
                    r, c = divmod(nxt, pw)
                    dr, dc = abs(r - goal_row), abs(c - goal_col)
                    h = dr + dc + diagonal * min(dr, dc)
                    heapq.heappush(frontier, (new + h, new, nxt))
        raise NoPathError("no 8-connected grid path joins start and goal")
