"""The similarities of a keyframe as it arrives, kept for the re-partitions of the online engine
(:mod:`segmentation.incremental`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from maps.scan import Keyframe
from segmentation.closeness import Closeness
from segmentation.distinct import distinct
from segmentation.similarity import (
    ByFieldOfView,
    Criterion,
    NearestNeighbour,
    cell_keys,
    symmetric,
)


class KeptSimilarities:
    """A :class:`~segmentation.similarity.Criterion` that looks up the similarities computed
    as the keyframes arrived (pairs never computed are 0)."""

    def __init__(self, rows: list[dict[int, float]], index: dict[int, int]) -> None:
        self.rows = rows
        self.index = index  # id(keyframe) -> arrival number

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """The kept similarities among ``keyframes``."""
        local = {self.index[id(k)]: n for n, k in enumerate(keyframes)}
        i, j, values = [], [], []
        for number, n in local.items():
            for other, value in self.rows[number].items():
                m = local.get(other)
                if m is not None:
                    i.append(n)
                    j.append(m)
                    values.append(value)
        return symmetric(np.asarray(values), np.asarray(i, np.int64), np.asarray(j), len(local))


class OneToMany:
    """Eq. 12 (:class:`~segmentation.similarity.NearestNeighbour`) of one scan against a few
    earlier ones, each scan kept as the cells it hit: the same values as the criterion's
    matrix, without its pairs among the earlier scans.

    Examples
    --------
    >>> from maps.scan import LaserScan
    >>> from segmentation.similarity import NearestNeighbour
    >>> scans = [Keyframe((x, 0.0, 0.0), LaserScan(np.full(90, 2.0), -np.pi, np.pi / 45))
    ...          for x in (0.0, 0.3, 1.0)]
    >>> one = OneToMany(NearestNeighbour())
    >>> for k in scans:
    ...     one.keep(k)
    >>> full = NearestNeighbour().affinity(scans).toarray()[2, :2]
    >>> bool(np.allclose(one.similarities(scans[2], [0, 1]), full))
    True
    """

    def __init__(self, criterion: NearestNeighbour) -> None:
        self.criterion = criterion
        self.field = Closeness.of(criterion)
        self._cells: list[NDArray[np.int64]] = []

    def cells(self, keyframe: Keyframe) -> NDArray[np.int64]:
        """Keys of the cells the keyframe's beams ended in."""
        cells = np.floor(keyframe.points() / self.field.resolution).astype(np.int64)
        return distinct(cell_keys(cells))

    def keep(self, keyframe: Keyframe) -> None:
        """Remember a keyframe's cells (the next index)."""
        self._cells.append(self.cells(keyframe))

    def similarities(self, keyframe: Keyframe, others: Sequence[int]) -> NDArray[np.float64]:
        """Eq. 12 of ``keyframe`` against the kept keyframes ``others``."""
        mine = self.cells(keyframe)
        theirs = [self._cells[i] for i in others]
        sizes = np.array([len(c) for c in theirs])
        owner = np.repeat(np.arange(len(theirs)), sizes)
        decoded = np.column_stack([mine >> 32, (mine & 0xFFFFFFFF).astype(np.int32)])
        around, closeness = self.field.around(decoded)
        every, index = np.unique(np.concatenate([around, *theirs]), return_inverse=True)
        spread, placed = index[: len(around)], index[len(around) :]
        hit = np.zeros((len(every), len(theirs)), bool)
        hit[placed, owner] = True
        # over my cells: the closeness of each earlier scan's nearest hit
        near_them = (hit[spread] * closeness[:, None]).reshape(len(mine), -1, len(theirs))
        first = near_them.max(axis=1).mean(axis=0)
        # over their cells: the closeness of my nearest hit
        field = np.zeros(len(every))
        np.maximum.at(field, spread, closeness)
        second = np.bincount(owner, weights=field[placed], minlength=len(theirs)) / sizes
        return (first + second) / (2 * self.field.tolerance)


def one_to_many(criterion: Criterion) -> OneToMany | None:
    """The :class:`OneToMany` of eq. 12 for a criterion that is, or may choose (``auto``,
    :class:`~segmentation.similarity.ByFieldOfView`, for scans narrower than a full circle),
    :class:`~segmentation.similarity.NearestNeighbour`; ``None`` for the others.

    Examples
    --------
    >>> from segmentation.similarity import Hausdorff
    >>> one_to_many(ByFieldOfView()).criterion
    NearestNeighbour(tolerance=0.2, resolution=0.1)
    >>> one_to_many(NearestNeighbour(0.3)).field.tolerance, one_to_many(Hausdorff())
    (0.3, None)
    """
    if isinstance(criterion, ByFieldOfView):
        return OneToMany(NearestNeighbour())
    return OneToMany(criterion) if isinstance(criterion, NearestNeighbour) else None
