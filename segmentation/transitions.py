"""Transitions between touching regions: where they meet, how wide the opening is."""

from __future__ import annotations

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
    """

    a: int
    b: int
    start: tuple[float, float]
    end: tuple[float, float]
    centre: tuple[float, float]
    width: float


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
    1.5 cells of each other.
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
            )
        )
    return found
