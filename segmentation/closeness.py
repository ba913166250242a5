"""Eq. 12's truncated closeness around a cell: the cells within the tolerance and how close
each is, shared by the online engines' one-scan-against-a-few similarities."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from segmentation.similarity import NearestNeighbour, cell_keys


@dataclass(frozen=True)
class Closeness:
    """The cells around a cell that are nearer than ``tolerance`` (``offsets``, in cells of
    ``resolution``) and their closeness ``tolerance - distance``.

    Examples
    --------
    >>> near = Closeness.of(NearestNeighbour(tolerance=0.2, resolution=0.1))
    >>> len(near.offsets), float(near.closeness.max())
    (9, 0.2)
    """

    tolerance: float
    resolution: float
    offsets: NDArray[np.int64] = field(repr=False)
    closeness: NDArray[np.float64] = field(repr=False)

    @classmethod
    def of(cls, criterion: NearestNeighbour) -> Closeness:
        """The field of the ``nn`` criterion (its tolerance and cells)."""
        tolerance, resolution = criterion.tolerance, criterion.resolution
        reach = math.ceil(tolerance / resolution)
        di, dj = np.mgrid[-reach : reach + 1, -reach : reach + 1].reshape(2, -1)
        distance = resolution * np.hypot(di, dj)
        near = distance < tolerance
        offsets = np.column_stack([di[near], dj[near]]).astype(np.int64)
        return cls(tolerance, resolution, offsets, tolerance - distance[near])

    def around(self, cells: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """The keys of the cells around each of ``cells`` (``(m, 2)``), ``len(offsets)`` per
        cell in order, and the closeness of each."""
        keys = cell_keys((cells[:, None, :] + self.offsets[None]).reshape(-1, 2))
        return keys, np.tile(self.closeness, len(cells))
