"""Reference planner: the exact shortest path, from the visibility graph of obstacle corners.

In the inflated grid the free space is a union of cells; its shortest paths bend only at
grid vertices where three of the four cells are free (convex obstacle corners). The graph
joins corner pairs in straight sight whose line is tangent to the obstacle at both ends;
a query joins start and goal to the corners they see and runs Dijkstra. Motions use the
workspace's exact validity rule, so the length is the optimum every planner is judged by.
"""

from __future__ import annotations

import time
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from planners.errors import NoPathError
from planners.path import SearchPlanner
from planners.workspace import Point, Workspace, cell_beyond

#: Most nodes a point's sight tests one by one (the cell walk) rather than in one batch: on
#: a room's few nodes the batch spent 5x as long in numpy's per-call overhead.
FEW_SIGHTS = 32

#: Candidate pairs tested at once (bounds memory, not results).
_CHUNK = 2_000_000
#: Sample points of the straight-sight pre-test taken at once (bounds memory, not results).
_SAMPLES = 1_000_000


class VisibilityGraph(SearchPlanner):
    """Exact Euclidean shortest paths in a :class:`~planners.workspace.Workspace`.

    Parameters
    ----------
    space
        The free space; building the graph is the preprocessing, timed in
        :attr:`build_seconds`.
    sites
        Extra map-frame points made graph nodes (e.g. the doors of a submap); the shortest
        paths from every site to every node are found once, at build time
        (:meth:`site_distances`).

    Examples
    --------
    >>> from maps.grid import OccupancyGrid
    >>> cells = np.zeros((20, 20), np.int8)
    >>> cells[5:15, 9:11] = 100
    >>> grid = OccupancyGrid(cells, resolution=0.1)
    >>> graph = VisibilityGraph(Workspace(grid, 0.0), sites=[(0.5, 1.8)])
    >>> round(graph.plan((0.5, 1.0), (1.5, 1.0)).length, 3)
    1.481
    >>> graph.site_distances().shape
    (1, 5)
    """

    name = "exact"

    def __init__(self, space: Workspace, sites: ArrayLike | None = None) -> None:
        clock = time.perf_counter()
        self.space = space
        self.corners, self._blocked = _convex_corners(space.free)
        n = len(self.corners)
        self.sites = space.to_lattice(np.zeros((0, 2)) if sites is None else sites)
        rows, cols = [], []
        per_chunk = max(1, _CHUNK // max(n, 1))  # corners whose pairs are tested together
        for first in range(0, n, per_chunk):
            i, j = _pairs(first, min(n, first + per_chunk), n)
            keep = _tangent(self.corners[j] - self.corners[i], self._blocked[i])
            keep &= _tangent(self.corners[j] - self.corners[i], self._blocked[j])
            i, j = i[keep], j[keep]
            seen = self._visible(self.corners[i], self.corners[j])
            rows.append(i[seen])
            cols.append(j[seen])
        self.n_corner_edges = sum(len(r) for r in rows)
        nodes = self.nodes
        m = len(self.sites)
        if m:  # site -> corner pairs the corner is tangent to, and site -> site pairs
            k, j = np.repeat(np.arange(m), n), np.tile(np.arange(n), m)
            keep = _tangent(self.corners[j] - self.sites[k], self._blocked[j])
            si, sj = _pairs(0, m, m)
            i = np.concatenate([n + k[keep], n + si])
            j = np.concatenate([j[keep], n + sj])
            seen = self._visible(nodes[i], nodes[j])
            rows.append(i[seen])
            cols.append(j[seen])
        i, j = np.concatenate([*rows, []]).astype(int), np.concatenate([*cols, []]).astype(int)
        length = np.hypot(*(nodes[j] - nodes[i]).T) * space.grid.resolution
        size = len(nodes)
        self.graph = sparse.coo_matrix(
            (np.concatenate([length, length]), (np.concatenate([i, j]), np.concatenate([j, i]))),
            shape=(size, size),
        ).tocsr()
        self._site_paths: tuple[NDArray[np.float64], NDArray[np.int32]] | None = None
        if len(self.sites):
            self._site_paths = dijkstra(
                self.graph, indices=np.arange(n, size), return_predecessors=True
            )
        self.build_seconds = time.perf_counter() - clock

    def arrays(self) -> dict[str, NDArray]:
        """What the graph is made of, to save: ``corners`` and ``sites`` (lattice), the
        corners' ``blocked`` quadrants, the CSR ``data``, ``indices``, ``indptr`` of the
        graph, the shortest ``dist`` and predecessors ``pred`` from each site, and
        ``n_corner_edges``; :meth:`from_arrays` reads them back."""
        size = len(self.nodes)
        dist, pred = self._site_paths or (np.zeros((0, size)), np.zeros((0, size), np.int32))
        csr = self.graph
        return {
            "corners": self.corners,
            "blocked": self._blocked,
            "sites": self.sites,
            "data": csr.data,
            "indices": csr.indices,
            "indptr": csr.indptr,
            "dist": dist,
            "pred": pred.astype(np.int32),
            "n_corner_edges": np.array(self.n_corner_edges),
        }

    @classmethod
    def from_arrays(cls, space: Workspace, arrays: dict[str, NDArray]) -> VisibilityGraph:
        """The graph :meth:`arrays` described, on ``space`` (the free space it was built in)."""
        graph = cls.__new__(cls)
        graph.space = space
        graph.corners = np.asarray(arrays["corners"], np.float64)
        graph._blocked = np.asarray(arrays["blocked"], np.int8)
        graph.sites = np.asarray(arrays["sites"], np.float64)
        graph.n_corner_edges = int(arrays["n_corner_edges"])
        size = len(graph.corners) + len(graph.sites)
        graph.graph = sparse.csr_matrix(
            (arrays["data"], arrays["indices"], arrays["indptr"]), shape=(size, size)
        )
        graph._site_paths = (arrays["dist"], arrays["pred"]) if len(graph.sites) else None
        graph.build_seconds = 0.0
        return graph

    @cached_property
    def nodes(self) -> NDArray[np.float64]:
        """Lattice coordinates of the graph's nodes: the corners, then the sites."""
        return np.vstack([self.corners, self.sites])

    @property
    def n_edges(self) -> int:
        """Corner-to-corner edges in the graph."""
        return self.n_corner_edges

    def site_distances(self) -> NDArray[np.float64]:
        """Shortest distances (metres) from each site (rows) to every node (columns: the
        corners, then the sites); ``inf`` where none."""
        if self._site_paths is None:
            return np.zeros((0, len(self.nodes)))
        return self._site_paths[0]

    @cached_property
    def points(self) -> NDArray[np.float64]:
        """Map-frame coordinates of the graph's nodes (:attr:`nodes`)."""
        return self.space.from_lattice(self.nodes)

    def site_path(self, site: int, node: int) -> NDArray[np.float64]:
        """Map-frame polyline of the shortest path from site ``site`` to node ``node``."""
        assert self._site_paths is not None
        pred = self._site_paths[1][site]
        order = [node]
        root = len(self.corners) + site
        while order[-1] != root:
            order.append(int(pred[order[-1]]))
        return self.points[order[::-1]]

    def sight(self, point: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Nodes a free map-frame point sees on a shortest path (corners it is tangent to,
        every site) and their distances, metres."""
        return self._sight(self.space.to_lattice(point)[0], self.nodes)

    def _sight(
        self, end: NDArray[np.float64], nodes: NDArray[np.float64]
    ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        n = len(self.corners)
        d = nodes - end
        candidates = np.flatnonzero(_tangent(d[:n], self._blocked))
        candidates = np.concatenate([candidates, np.arange(n, len(nodes))])
        if len(candidates) <= FEW_SIGHTS:  # the cell walk: numpy's overhead is the most
            u, v = float(end[0]), float(end[1])
            walk = self.space.lattice_segment_free
            seen = np.array([c for c in candidates if walk(u, v, *nodes[c])], np.intp)
        else:
            ends = np.repeat(end[None], len(candidates), axis=0)
            seen = candidates[self.space.lattice_segments_free(ends, nodes[candidates])]
        return seen, np.hypot(*d[seen].T) * self.space.grid.resolution

    def _visible(self, a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Exact straight-sight test of lattice segments, cheap samples first."""
        alive = np.ones(len(a), bool)
        d = b - a
        length = np.abs(d).max(axis=1, initial=0.0)
        # motions along grid lines go to the exact test; the others are sampled, level by
        # level, while their own samples are more than 2 cells apart
        idx = np.flatnonzero(np.all(d != 0, axis=1))
        level = 1
        while len(idx := idx[alive[idx] & (length[idx] > 2 ** (level + 1))]):
            fracs = np.arange(1, 2**level, 2) / 2**level
            for some in np.array_split(idx, max(1, len(idx) * len(fracs) // _SAMPLES)):
                p = a[some, None] + fracs[:, None] * d[some, None]
                step = np.broadcast_to(d[some, None], p.shape)
                ok = self.space.cells_free(
                    cell_beyond(p[..., 0].ravel(), step[..., 0].ravel()),
                    cell_beyond(p[..., 1].ravel(), step[..., 1].ravel()),
                )
                alive[some] = ok.reshape(len(some), len(fracs)).all(axis=1)
            level += 1
        idx = np.flatnonzero(alive)
        for chunk in np.array_split(idx, max(1, len(idx) // 20_000)):
            alive[chunk] = self.space.lattice_segments_free(a[chunk], b[chunk])
        return alive

    def _search(self, start: Point, goal: Point) -> NDArray[np.float64]:
        space, s, g = self.space, start, goal
        if space.component_at(s) != space.component_at(g):
            raise NoPathError(f"start {s} and goal {g} lie in different parts of the free space")
        size = self.graph.shape[0]
        rows, cols, weights = [], [], []
        for point, node in ((s, size), (g, size + 1)):
            seen, length = self.sight(point)
            rows += [np.full(len(seen), node), seen]
            cols += [seen, np.full(len(seen), node)]
            weights += [length, length]
        if space.segment_free(s, g):
            rows.append(np.array([size]))
            cols.append(np.array([size + 1]))
            weights.append(np.array([np.hypot(s[0] - g[0], s[1] - g[1])]))
        extra = sparse.coo_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
            shape=(size + 2, size + 2),
        )
        graph = sparse.bmat([[self.graph, None], [None, sparse.csr_matrix((2, 2))]]) + extra
        dist, parent = dijkstra(graph.tocsr(), indices=size, return_predecessors=True)
        if not np.isfinite(dist[size + 1]):
            raise NoPathError(f"no path found from {s} to {g}")
        order = [size + 1]
        while order[-1] != size:
            order.append(int(parent[order[-1]]))
        nodes = np.vstack([self.nodes, space.to_lattice([s, g])])
        waypoints = space.from_lattice(nodes[order[::-1]])
        waypoints[0], waypoints[-1] = s, g
        return waypoints


def _convex_corners(free: NDArray[np.bool_]) -> tuple[NDArray[np.float64], NDArray[np.int8]]:
    """Lattice vertices with exactly one blocked cell around them, and that cell's quadrant
    ``(sign u, sign v)`` seen from the vertex."""
    lattice = np.pad(free[::-1], 1)  # lattice[v + 1, u + 1] is cell (u, v); off-grid blocked
    quads = {
        (-1, -1): lattice[:-1, :-1],
        (1, -1): lattice[:-1, 1:],
        (-1, 1): lattice[1:, :-1],
        (1, 1): lattice[1:, 1:],
    }
    count = sum(q.astype(np.int8) for q in quads.values())
    points, signs = [], []
    for sign, quad in quads.items():
        v, u = np.nonzero((count == 3) & ~quad)
        points.append(np.column_stack([u, v]).astype(float))
        signs.append(np.tile(np.array(sign, np.int8), (len(u), 1)))
    return np.concatenate(points), np.concatenate(signs)


def _pairs(first: int, last: int, n: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """All ``(i, j)`` with ``first <= i < last`` and ``i < j < n``."""
    counts = n - 1 - np.arange(first, last)
    i = np.repeat(np.arange(first, last), counts)
    j = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts) + i + 1
    return i, j


def _tangent(d: NDArray[np.float64], blocked: NDArray[np.int8]) -> NDArray[np.bool_]:
    """Whether the line through a corner along ``d`` leaves its blocked cell on one side."""
    return d[:, 0] * d[:, 1] * blocked[:, 0] * blocked[:, 1] <= 0
