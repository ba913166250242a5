"""Compiled grid baseline: scikit-image's minimum-cost-path search on the inflated map.

This is the grid search users run at compiled speed (like Nav2's NavFn / Smac): Dijkstra over
the 8-connected grid of free cells (``skimage.graph.MCP_Geometric``, Cython), stopping when
the goal cell is reached. Diagonal steps join cell centres through a shared grid vertex, a
valid motion under the workspace's rule (the interior crosses only the two cells).
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray
from skimage.graph import MCP_Geometric

from planners.errors import NoPathError
from planners.path import SearchPlanner
from planners.workspace import Point, Workspace


class GridMCP(SearchPlanner):
    """Shortest 8-connected grid path with scikit-image's ``MCP_Geometric``.

    Parameters
    ----------
    space
        The free space; building the search object is the preprocessing, timed in
        :attr:`build_seconds`.

    Examples
    --------
    >>> from maps.grid import OccupancyGrid
    >>> grid = OccupancyGrid(np.zeros((10, 30), np.int8), resolution=0.1)
    >>> path = GridMCP(Workspace(grid, 0.0)).plan((0.25, 0.55), (2.75, 0.55))
    >>> round(path.length, 2)
    2.5
    """

    name = "grid_mcp"

    def __init__(self, space: Workspace) -> None:
        clock = time.perf_counter()
        self.space = space
        self._mcp = MCP_Geometric(np.where(space.free, 1.0, np.inf), fully_connected=True)
        self.build_seconds = time.perf_counter() - clock

    def _search(self, start: Point, goal: Point) -> NDArray[np.float64]:
        grid = self.space.grid
        source = tuple(int(v) for v in grid.world_to_cell(*start))
        target = tuple(int(v) for v in grid.world_to_cell(*goal))
        costs, _ = self._mcp.find_costs([source], [target])
        if not np.isfinite(costs[target]):
            raise NoPathError(f"no 8-connected grid path joins start {start} and goal {goal}")
        rows, cols = np.array(self._mcp.traceback(target)).T
        xs, ys = grid.cell_to_world(rows, cols)
        return np.vstack([start, np.column_stack([xs, ys]), goal])
