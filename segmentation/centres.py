"""The centres of the paper's online rules (:mod:`segmentation.online`): hit counts per cell,
the cell index that finds the centres near a scan, and a centre seen as a keyframe."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from maps.scan import Keyframe, LaserScan
from segmentation.closeness import Closeness
from segmentation.distinct import distinct
from segmentation.similarity import cell_keys


@dataclass
class Centre:
    """A cluster centre: hit counts per cell (eq. 15 as integer sums) and its keyframes.

    ``Z(c) = counts[c] / members`` where ``members`` counts the keyframes that moved the centre
    (undecided keyframes join ``keyframes`` without moving it); ``mass = sum(counts)``.
    """

    counts: dict[int, int]
    members: int
    mass: int
    tiles: set[int]
    keyframes: list[int]
    born: int

    def arrays(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Cell keys and hit counts."""
        size = len(self.counts)
        keys = np.fromiter(self.counts.keys(), np.int64, size)
        return keys, np.fromiter(self.counts.values(), np.int64, size)

    def keyframe(self, resolution: float) -> CentreKeyframe:
        """The centre's most hit cells (of ``resolution`` metres; as many as a member hits on
        average) as a keyframe, for criteria that compare keyframes."""
        keys, counts = self.arrays()
        size = max(1, round(self.mass / self.members))
        top = np.lexsort((keys, -counts))[:size]
        points = ((decode(keys[top]) + 0.5) * resolution).astype(np.float64)
        mean = points.mean(axis=0)
        angle = np.arctan2(points[:, 1] - mean[1], points[:, 0] - mean[0])
        cloud = points[np.argsort(angle, kind="stable")]
        return CentreKeyframe((*mean, 0.0), NO_SCAN, 0, None, cloud)


def decode(keys: NDArray[np.int64]) -> NDArray[np.int64]:
    """Cells ``(m, 2)`` of :func:`segmentation.similarity.cell_keys`."""
    low = (keys & 0xFFFFFFFF).astype(np.int64)
    low = np.where(low >= 2**31, low - 2**32, low)
    return np.column_stack([(keys - low) >> 32, low])


def cells_of(points: NDArray[np.float64], resolution: float) -> NDArray[np.int64]:
    """Keys of the unique cells hit by ``points``."""
    return distinct(cell_keys(np.floor(points / resolution).astype(np.int64)))


@dataclass(frozen=True, eq=False)
class CentreKeyframe(Keyframe):
    """A centre seen as a keyframe by criteria that take keyframes: its ``points()`` are the
    centres of its most frequently hit cells, in angular order around their mean."""

    cloud: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 2)))

    def points(self) -> NDArray[np.float64]:
        """The centre's cells in metres, map frame."""
        return self.cloud


#: The scan of a :class:`CentreKeyframe` (criteria read its points, not its ranges).
NO_SCAN = LaserScan(np.ones(1), 0.0, 1.0)


class CellIndex:
    """Cell key -> the centres that hit the cell and how often: per cell a row of up to
    ``width`` (region, hits) entries (region 0 = a free entry), so lookups are vectorised.

    Examples
    --------
    >>> index = CellIndex()
    >>> keys = np.array([5, 9])
    >>> index.add(3, keys, np.array([1, 2]))
    >>> index.add(4, keys[:1], np.array([7]))
    >>> rows = index.rows(np.array([9, 5, 11]))
    >>> rows.tolist(), index.region[rows[:2]].tolist(), index.hits[rows[:2]].tolist()
    ([1, 0, -1], [[3, 0, 0, 0], [3, 4, 0, 0]], [[2, 0, 0, 0], [1, 7, 0, 0]])
    """

    def __init__(self) -> None:
        self._rows: dict[int, int] = {}
        self.region = np.zeros((1024, 4), np.int32)
        self.hits = np.zeros((1024, 4), np.int32)

    def rows(self, keys: NDArray[np.int64], create: bool = False) -> NDArray[np.int64]:
        """Rows for ``keys`` (-1 for a cell no centre hit, unless ``create``)."""
        if not create:
            get = self._rows.get
            return np.fromiter((get(k, -1) for k in keys.tolist()), np.int64, len(keys))
        rows = self._rows
        found = np.fromiter((rows.setdefault(k, len(rows)) for k in keys.tolist()), np.int64)
        if len(rows) > len(self.region):
            extra = ((0, max(len(rows), 2 * len(self.region)) - len(self.region)), (0, 0))
            self.region = np.pad(self.region, extra)
            self.hits = np.pad(self.hits, extra)
        return found

    def add(self, region: int, keys: NDArray[np.int64], hits: NDArray[np.int64]) -> None:
        """``region``'s centre hit the cells ``keys`` (unique) ``hits`` more times."""
        rows = self.rows(keys, create=True)
        while True:
            table = self.region[rows]
            match = table == region
            has = match.any(axis=1)
            free = table == 0
            if np.all(has | free.any(axis=1)):
                break
            # a cell hit by more centres than a row holds: widen the rows
            self.region = np.hstack([self.region, np.zeros_like(self.region)])
            self.hits = np.hstack([self.hits, np.zeros_like(self.hits)])
        column = np.where(has, match.argmax(axis=1), free.argmax(axis=1))
        self.region[rows, column] = region
        self.hits[rows, column] += hits

    def remove(self, region: int, keys: NDArray[np.int64]) -> None:
        """Forget ``region``'s hits of the cells ``keys`` (all of those it hit)."""
        rows = self.rows(keys)
        column = (self.region[rows] == region).argmax(axis=1)
        self.region[rows, column] = 0
        self.hits[rows, column] = 0


def centre_similarities(
    field: Closeness,
    index: CellIndex,
    centres: Mapping[int, Centre],
    keys: NDArray[np.int64],
    weights: NDArray[np.int64],
    own: int | None,
) -> tuple[list[int], NDArray[np.float64]]:
    """The centres with a hit within the tolerance of ``A``'s hits (other than ``own``) and
    ``S(A, B)`` of :mod:`segmentation.online` for each; ``A`` is given by the cell keys of its
    hits and their counts ``weights``."""
    around, closeness = field.around(decode(keys))
    unique, inverse = np.unique(around, return_inverse=True)
    rows = index.rows(unique)
    near = np.flatnonzero(rows >= 0)
    table, hits = index.region[rows[near]], index.hits[rows[near]]
    entry = (table > 0) & (table != (own or 0))
    at, slot = np.nonzero(entry)
    if len(at) == 0:
        return [], np.zeros(0)
    regions, column = np.unique(table[at, slot], return_inverse=True)
    found = np.zeros((len(unique), len(regions)))
    found[near[at], column] = hits[at, slot]
    # F_A around A's cells: the best closeness of A's hits
    field_a = np.zeros(len(unique))
    np.maximum.at(field_a, inverse, closeness)
    # F_B at A's cells: the best closeness of B's hits around each of them
    close = np.where(found[inverse] > 0, closeness[:, None], 0.0)
    near_b = close.reshape(len(keys), len(field.offsets), -1).max(axis=1)
    mass = np.array([centres[r].mass for r in regions.tolist()], np.float64)
    first = weights @ near_b / float(weights.sum())
    second = field_a @ found / mass
    return regions.tolist(), (first + second) / (2 * field.tolerance)
