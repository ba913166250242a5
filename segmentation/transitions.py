"""Transitions between touching regions: where they meet, how wide the opening is."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import connected_components

from maps.grid import OccupancyGrid
from segmentation.regions import boundary_pairs


@dataclass(frozen=True)
class Transition:
    """One opening between regions ``a < b`` (a door, or where a corridor meets a hall).

    Attributes
    ----------
    a, b
        The two region ids.
    start, end
        Ends of the portal segment, map-frame metres.
    centre
        Centre of the opening.
    width
        Length of the opening in metres.
    clear_width
        Diameter in metres of the widest disc centred on a free cell that crosses the opening
        (to a cell: an even number of free cells across counts one less), from the clearance
        of the map's free cells on both sides of it (0 where no free cell pair crosses;
        ``inf`` when not measured). A disc robot of radius ``r`` crosses when it exceeds ``2 r``:
        the rule of :meth:`~maps.grid.OccupancyGrid.inflate`.
    """

    a: int
    b: int
    start: tuple[float, float]
    end: tuple[float, float]
    centre: tuple[float, float]
    width: float
    clear_width: float = math.inf

    @property
    def passable(self) -> float:
        """How wide a robot may be to cross, metres: the clear width (a robot may cross
        where two regions barely touch, in open space), the width where it was not measured.

        Examples
        --------
        >>> Transition(1, 2, (0.0, 0.0), (0.0, 0.1), (0.0, 0.05), 0.1, 0.05).passable
        0.05
        >>> Transition(1, 2, (0.0, 0.0), (0.0, 1.0), (0.0, 0.5), 1.0).passable  # not measured
        1.0
        """
        return self.clear_width if math.isfinite(self.clear_width) else self.width


def _portal(points: NDArray[np.float64], resolution: float) -> tuple[NDArray, NDArray, float]:
    """Ends and width of the segment that best fits boundary ``points``."""
    centre = points.mean(axis=0)
    if len(points) == 1:
        axis = np.array([1.0, 0.0])
    else:
        axis = np.linalg.svd(points - centre, full_matrices=False)[2][0]
    along = (points - centre) @ axis
    low, high = along.min() - resolution / 2, along.max() + resolution / 2
    return centre + low * axis, centre + high * axis, float(high - low)


def find_transitions(grid: OccupancyGrid, labels: NDArray[np.integer]) -> list[Transition]:
    """Every opening between two regions of ``labels``, ordered by ``(a, b)`` and position.

    Boundary cell pairs of the same two regions belong to one opening when they lie within
    1.5 cells of each other. An opening's clear width is ``2 c - resolution``, ``c`` the
    largest clearance (distance to the nearest cell that is not free,
    :func:`~maps.grid.clearance_of`) that both cells of one of its pairs have.
    """
    from scipy.spatial import cKDTree  # imported here: a planner read back needs none

    ra, ca, rb, cb = boundary_pairs(labels)
    if len(ra) == 0:
        return []
    a = labels[ra, ca].astype(np.int64)
    b = labels[rb, cb].astype(np.int64)
    rows, cols = (ra + rb) / 2.0, (ca + cb) / 2.0
    links = cKDTree(np.column_stack([rows, cols])).query_pairs(1.5, output_type="ndarray")
    same = (a[links[:, 0]] == a[links[:, 1]]) & (b[links[:, 0]] == b[links[:, 1]])
    links = links[same]
    graph = sparse.coo_matrix((np.ones(len(links)), (links[:, 0], links[:, 1])), (len(a), len(a)))
    _, piece = connected_components(graph, directed=False)
    clearance = grid.free_clearance()
    crossing = np.minimum(clearance[ra, ca], clearance[rb, cb])
    x, y = grid.cell_to_world(rows, cols)
    found: list[Transition] = []
    order = np.lexsort((piece, b, a))
    splits = np.flatnonzero(np.diff(piece[order])) + 1
    for group in np.split(order, splits):
        start, end, width = _portal(np.column_stack([x[group], y[group]]), grid.resolution)
        found.append(
            Transition(
                int(a[group[0]]),
                int(b[group[0]]),
                (float(start[0]), float(start[1])),
                (float(end[0]), float(end[1])),
                (float(x[group].mean()), float(y[group].mean())),
                width,
                max(0.0, 2 * float(crossing[group].max()) - grid.resolution),
            )
        )
    return found
