"""Similarity between keyframes (the paper's three criteria), as sparse affinity matrices.

Every criterion maps a list of keyframes to a symmetric ``(n, n)`` CSR matrix of similarities
``>= 0`` with an empty diagonal; a pair missing from the matrix has similarity 0. Only pairs
that see common structure get an entry, so the matrix stays sparse as the map grows:

- :class:`NearestNeighbour` (eq. 12): the mean distance from each point of one scan to the
  nearest point of the other, truncated at ``tolerance`` and turned into ``1 - d / tolerance``,
  averaged over both directions. Computed for all pairs at once as one sparse product of the
  scans' points with their truncated distance fields.
- :class:`Hausdorff` (eq. 13): ``1 - H_ij / H_max`` over the pairs whose scans share a cell of
  ``reach`` metres.
- :class:`SharedFeatures` (eq. 14): corners of each scan, associated into one list when they lie
  within ``radius`` of each other; the similarity is the number of corners both scans saw.
- :class:`Pairwise`: any callable ``f(points_i, points_j) -> float`` of two ``(m, 2)`` point
  arrays, evaluated on the pairs that share a cell of ``reach`` metres.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from maps.scan import Keyframe
from segmentation.cloud import ScanCloud
from segmentation.errors import ParameterError
from segmentation.views import SharedView

PointsSimilarity = Callable[[NDArray[np.float64], NDArray[np.float64]], float]


@runtime_checkable
class Criterion(Protocol):
    """Anything that turns keyframes into a sparse symmetric affinity matrix."""

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """Similarities between all pairs of ``keyframes``."""
        ...


def _positive(name: str, value: float) -> float:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ParameterError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def nearest_first(keys: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The distinct values (>= 0) of the ``(steps, n)`` array ``keys``, sorted, and for each
    the first row it occurs in (rows in order of distance: the nearest).

    One sort of the keys with their row in the lowest bits: a third of the time of
    ``np.unique``'s stable sort with ``return_index`` on the 10^7 keys of 10,000 keyframes;
    ``np.unique`` where the keys are too large for that.

    Examples
    --------
    >>> nearest_first(np.array([[5, 3, 3], [5, 7, 3]]))
    (array([3, 5, 7]), array([0, 0, 1]))
    >>> nearest_first(np.array([[2**61, 3], [3, 5]]))  # too large for the low bits
    (array([                  3,                   5, 2305843009213693952]), array([0, 1, 0]))
    """
    steps = keys.shape[0]
    bits = max(1, (steps - 1).bit_length())
    if keys.size == 0 or int(keys.max()) >= 1 << (62 - bits):
        distinct, first = np.unique(keys, return_index=True)
        return distinct, first // keys.shape[1]
    combined = ((keys << bits) | np.arange(steps)[:, None]).ravel()
    combined.sort()
    distinct = combined >> bits
    fresh = np.r_[True, distinct[1:] != distinct[:-1]]
    return distinct[fresh], combined[fresh] & ((1 << bits) - 1)


def symmetric(values: NDArray[np.float64], i: NDArray[np.int64], j: NDArray[np.int64], n: int):
    """The symmetric CSR matrix with ``values`` at ``(i, j)`` and ``(j, i)``, zeros dropped."""
    keep = values > 0
    rows = np.concatenate([i[keep], j[keep]])
    cols = np.concatenate([j[keep], i[keep]])
    data = np.concatenate([values[keep], values[keep]]).astype(float)
    return sparse.csr_matrix((data, (rows, cols)), shape=(n, n))


def incidence(owner: NDArray[np.int64], item: NDArray[np.int64], n: int) -> sparse.csr_matrix:
    """Binary ``(n, n_items)`` matrix: keyframe ``owner[t]`` has item ``item[t]``."""
    _, columns = np.unique(item, return_inverse=True)
    data = np.ones(len(owner), np.float64)
    matrix = sparse.csr_matrix(
        (data, (owner, columns)), shape=(n, int(columns.max(initial=-1)) + 1)
    )
    matrix.data[:] = 1.0
    return matrix


def cell_keys(cells: NDArray[np.int64]) -> NDArray[np.int64]:
    """One int64 per 2-D cell (cells within +-2**31)."""
    return (cells[:, 0] << 32) + (cells[:, 1] & 0xFFFFFFFF)


def candidate_pairs(cloud: ScanCloud, reach: float) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Pairs ``i < j`` of keyframes with points in a common cell of ``reach`` metres."""
    coarse = np.floor(cloud.points / reach).astype(np.int64)
    shared = incidence(cloud.owner, cell_keys(coarse), cloud.n_keyframes)
    shared = sparse.triu(shared @ shared.T, k=1).tocoo()
    return shared.row.astype(np.int64), shared.col.astype(np.int64)


@dataclass(frozen=True)
class NearestNeighbour:
    """Eq. 12: truncated mean nearest-neighbour distance between the scans' points.

    ``S_ij = 1 - (d(i, j) + d(j, i)) / (2 tolerance)`` where ``d(i, j)`` is the mean over the
    points of scan ``i`` of ``min(distance to the nearest point of scan j, tolerance)``.
    Points are first quantised to ``resolution`` cells.
    """

    tolerance: float = 0.2
    resolution: float = 0.1

    def __post_init__(self) -> None:
        _positive("tolerance", self.tolerance)
        _positive("resolution", self.resolution)

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """Similarities of all pairs, as one sparse product (see the module docstring)."""
        cloud = ScanCloud.from_keyframes(keyframes, self.resolution)
        n = cloud.n_keyframes
        reach = math.ceil(self.tolerance / cloud.resolution)
        di, dj = np.mgrid[-reach : reach + 1, -reach : reach + 1].reshape(2, -1)
        distance = cloud.resolution * np.hypot(di, dj)
        order = np.argsort(distance, kind="stable")
        near = order[distance[order] < self.tolerance]
        # The truncated distance field of every scan: (cell, keyframe, tolerance - distance),
        # the nearest of the scan's points winning when several reach the same cell.
        low = cloud.cells.min(axis=0) - reach
        rows = int(cloud.cells[:, 1].max()) + reach - int(low[1]) + 1
        base = (cloud.cells[:, 0] - low[0]) * rows + (cloud.cells[:, 1] - low[1])
        shift = di[near] * rows + dj[near]
        key, step = nearest_first((base[None, :] + shift[:, None]) * n + cloud.owner)
        value = self.tolerance - distance[near][step]
        cell, owner = np.divmod(key, n)
        fresh = np.r_[True, cell[1:] != cell[:-1]]  # the keys are sorted, so are their cells
        columns, cell = cell[fresh], np.cumsum(fresh) - 1
        width = len(columns)
        points = sparse.csr_matrix(
            (np.ones(len(base)), (cloud.owner, np.searchsorted(columns, base))), shape=(n, width)
        )
        field = sparse.csr_matrix((value, (cell, owner)), shape=(width, n))
        sums = (points @ field).tocoo()  # sums[i, j]: over i's points, tolerance - distance to j
        mean = sparse.csr_matrix((sums.data / cloud.counts[sums.row], (sums.row, sums.col)), (n, n))
        both = sparse.triu(mean + mean.T, k=1).tocoo()
        return symmetric(both.data / (2 * self.tolerance), both.row, both.col, n)


@dataclass(frozen=True)
class Hausdorff:
    """Eq. 13: ``1 - H_ij / H_max`` with ``H`` the Hausdorff distance between the scans.

    Pairs whose scans share no cell of ``reach`` metres have similarity 0; ``H_max`` is the
    largest ``H`` among the other pairs.
    """

    reach: float = 1.0
    resolution: float = 0.2

    def __post_init__(self) -> None:
        _positive("reach", self.reach)
        _positive("resolution", self.resolution)

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """Hausdorff similarities of the candidate pairs."""
        cloud = ScanCloud.from_keyframes(keyframes, self.resolution)
        i, j = candidate_pairs(cloud, self.reach)
        distance = np.maximum(*_directed_hausdorff(cloud, i, j))
        largest = distance.max(initial=0.0)
        similarity = 1.0 - distance / largest if largest > 0 else np.ones_like(distance)
        return symmetric(similarity, i, j, cloud.n_keyframes)


def _directed_hausdorff(
    cloud: ScanCloud, i: NDArray[np.int64], j: NDArray[np.int64]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``h(i -> j)`` and ``h(j -> i)`` for the pairs: one KD-tree query per keyframe."""
    n = cloud.n_keyframes
    points = cloud.split()
    source = np.concatenate([i, j])
    target = np.concatenate([j, i])
    order = np.argsort(target, kind="stable")
    result = np.zeros(len(order))
    starts = np.searchsorted(target[order], np.arange(n + 1))
    for t in range(n):
        pairs = order[starts[t] : starts[t + 1]]
        if len(pairs) == 0:
            continue
        queries = [points[s] for s in source[pairs]]
        nearest, _ = cKDTree(points[t]).query(np.concatenate(queries))
        offsets = np.cumsum([0] + [len(q) for q in queries[:-1]])
        result[pairs] = np.maximum.reduceat(nearest, offsets)
    return result[: len(i)], result[len(i) :]


def corners(
    points: NDArray[np.float64], *, arm: int = 3, angle: float = math.radians(50), gap: float = 0.3
) -> NDArray[np.float64]:
    """Corner points of one scan's end points, given in beam order.

    A point is a corner when the points ``arm`` beams before and after it are each within
    ``arm * gap`` metres (no depth jump between) and the two arms turn by more than ``angle``;
    of neighbouring corner candidates the sharpest is kept.
    """
    m = len(points)
    if m < 2 * arm + 1:
        return np.empty((0, 2))
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    jump = np.concatenate([[0], np.cumsum(steps > gap)])
    centre = np.arange(arm, m - arm)
    smooth = (jump[centre + arm] - jump[centre - arm]) == 0
    before = points[centre - arm] - points[centre]
    after = points[centre + arm] - points[centre]
    cosine = np.einsum("ij,ij->i", before, after) / np.maximum(
        np.linalg.norm(before, axis=1) * np.linalg.norm(after, axis=1), 1e-12
    )
    turn = math.pi - np.arccos(np.clip(cosine, -1.0, 1.0))
    sharp = smooth & (turn > angle)
    padded = np.concatenate([[-1.0], np.where(sharp, turn, -1.0), [-1.0]])
    peak = sharp & (padded[1:-1] >= padded[:-2]) & (padded[1:-1] > padded[2:])
    return points[centre[peak]]


@dataclass(frozen=True)
class SharedFeatures:
    """Eq. 14: the number of corner features two scans both saw.

    Corners of all scans within ``radius`` metres of each other (transitively) are one feature.
    """

    radius: float = 0.2
    angle: float = math.radians(50)

    def __post_init__(self) -> None:
        _positive("radius", self.radius)
        _positive("angle", self.angle)

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """Counts of shared corner features."""
        found = [corners(k.points(), angle=self.angle) for k in keyframes]
        n = len(keyframes)
        owner = np.repeat(np.arange(n), [len(c) for c in found])
        if len(owner) == 0:
            return sparse.csr_matrix((n, n))
        stacked = np.concatenate(found)
        pairs = cKDTree(stacked).query_pairs(self.radius, output_type="ndarray")
        links = sparse.csr_matrix(
            (np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(owner), len(owner))
        )
        _, feature = connected_components(links, directed=False)
        seen = incidence(owner, feature, n)
        shared = sparse.triu(seen @ seen.T, k=1).tocoo()
        return symmetric(shared.data, shared.row, shared.col, n)


@dataclass(frozen=True)
class Pairwise:
    """A user's ``similarity(points_i, points_j) -> float`` on pairs sharing a ``reach`` cell."""

    similarity: PointsSimilarity
    reach: float = 1.0
    resolution: float = 0.05

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """The callable evaluated on the candidate pairs."""
        cloud = ScanCloud.from_keyframes(keyframes, self.resolution)
        i, j = candidate_pairs(cloud, _positive("reach", self.reach))
        points = cloud.split()
        try:
            values = np.array(
                [float(self.similarity(points[a], points[b])) for a, b in zip(i, j, strict=True)]
            )
        except Exception as err:  # the user's function, whatever it raised
            raise ParameterError(
                f"similarity {self.similarity!r} failed on two keyframes' points "
                f"({type(err).__name__}: {err}); it takes two (n, 2) arrays and returns a float"
            ) from err
        if not np.all(np.isfinite(values)) or np.any(values < 0):
            raise ParameterError(f"similarity {self.similarity!r} must return finite values >= 0")
        return symmetric(values, i, j, cloud.n_keyframes)


@dataclass(frozen=True)
class ByFieldOfView:
    """The shared view (:class:`~segmentation.views.SharedView`) for scans that see all
    around, the paper's nearest-neighbour similarity (:class:`NearestNeighbour`) otherwise.

    What a scan saw is the area its beams swept: from anywhere in a room a 360 degree scan
    sees the room whole, so the overlap of two such views says whether they stand in one
    space. A scan of a narrower field sees what it faces: two keyframes in one room facing
    away from each other share little of it, and the walls they hit (the paper's criterion)
    say more. Keyframes whose scans are all full circles use the view (virtual keyframes on
    a map, a 360 degree lidar), others the nearest neighbours (a 180 degree laser).

    Examples
    --------
    >>> from maps.scan import LaserScan
    >>> ring = LaserScan(np.full(360, 2.0), -math.pi, 2 * math.pi / 360, 0.0, 10.0)
    >>> half = LaserScan(np.full(181, 2.0), -math.pi / 2, math.pi / 180, 0.0, 10.0)
    >>> ByFieldOfView().chosen([Keyframe((0.0, 0.0, 0.0), ring)]).__class__.__name__
    'SharedView'
    >>> ByFieldOfView().chosen([Keyframe((0.0, 0.0, 0.0), half)]).__class__.__name__
    'NearestNeighbour'
    """

    def chosen(self, keyframes: Sequence[Keyframe]) -> Criterion:
        """The criterion for these keyframes."""
        whole = all(
            abs(k.scan.angle_increment) * len(k.scan.ranges) >= 2 * math.pi - 1e-6
            for k in keyframes
        )
        return SharedView() if whole else NearestNeighbour()

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """The affinity of :meth:`chosen`'s criterion."""
        return self.chosen(keyframes).affinity(keyframes)


CRITERIA: dict[str, Callable[[], Criterion]] = {
    "auto": ByFieldOfView,
    "nn": NearestNeighbour,
    "hausdorff": Hausdorff,
    "features": SharedFeatures,
    "view": SharedView,
}


def as_criterion(criterion: str | Criterion | PointsSimilarity) -> Criterion:
    """A criterion from its name (``auto``, ``nn``, ``hausdorff``, ``features``, ``view``),
    object or callable."""
    if isinstance(criterion, str):
        if criterion not in CRITERIA:
            raise ParameterError(
                f"unknown criterion {criterion!r}; known: {', '.join(sorted(CRITERIA))}"
            )
        return CRITERIA[criterion]()
    if isinstance(criterion, Criterion):
        return criterion
    if callable(criterion):
        return Pairwise(criterion)
    raise ParameterError(f"criterion must be a name, a Criterion or a callable, got {criterion!r}")
