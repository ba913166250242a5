"""Spectral partition of keyframes: sparsification, the normalised Laplacian, adaptive k.

The paper's pipeline on a sparse affinity matrix ``S``:

1. sparsify: ``switch = S_min + p (S_max - S_min)`` over the pairs present; entries at or below
   it become 0 (eqs. 4-5);
2. the normalised Laplacian ``L_sym = I - D^-1/2 S D^-1/2`` (eq. 6) and its smallest
   eigenvectors, from a sparse shift-invert eigensolver;
3. for every ``k`` in a range around a guess ``k'`` (given, or the largest eigengap), k-means on
   the rows of the first ``k`` eigenvectors (normalised to unit length) several times; the
   clustering with the highest silhouette coefficient (eqs. 8-10) wins.

Connected components of the sparsified graph never share a cluster: a cluster that spans two
components is split, and components too small to embed are clusters of their own.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse import linalg as splinalg
from scipy.sparse.csgraph import connected_components, laplacian, minimum_spanning_tree
from threadpoolctl import threadpool_limits

from maps.limits import finite_in
from maps.scan import Keyframe
from maps.seeding import RandomState, as_generator
from segmentation.base import Estimator, check_flags, clone, is_count
from segmentation.errors import ParameterError, SegmentationError
from segmentation.similarity import Criterion, PointsSimilarity, as_criterion

log = logging.getLogger(__name__)

#: k-means runs per ``k`` at most: the best of a thousand is as good as it gets.
MAX_N_INIT = 1000
#: Above this many keyframes the silhouette is estimated on a random sample of this size.
SILHOUETTE_SAMPLE = 1500
#: Up to this many keyframes a dense eigensolver is faster than the sparse one.
DENSE_UP_TO = 600
#: The most keyframes one partition takes (ten times the 10,000 of ``topomap bench segment``,
#: 4 s there): the eigensolver's time grows faster than the keyframes, and a large map is
#: partitioned block by block (:mod:`segmentation.blocks`).
MAX_NODES = 100_000


def sparsify(affinity: sparse.spmatrix, p: float, *, connected: bool = False) -> sparse.csr_matrix:
    """Drop the similarities at or below ``S_min + p (S_max - S_min)`` (eqs. 4-5).

    ``S_min`` and ``S_max`` are taken over the entries present (the pairs that can be similar).
    With ``connected``, the links of a maximum spanning forest stay: sparsifying then removes
    weak links without cutting the graph into more pieces than it had (parts of the graph
    never share a cluster, so a given ``k`` could not be reached below their count).

    Examples
    --------
    >>> chain = sparse.csr_matrix(np.array([[0, 0.9, 0], [0.9, 0, 0.1], [0, 0.1, 0]]))
    >>> sparsify(chain, 0.5).nnz, sparsify(chain, 0.5, connected=True).toarray()[1, 2]
    (2, np.float64(0.1))
    """
    if not 0 <= p < 1:
        raise ParameterError(f"p must lie in [0, 1), got {p!r}")
    matrix = sparse.csr_matrix(affinity, dtype=float, copy=True)
    matrix.eliminate_zeros()  # stored zeros (keyframes a wall parts) are no links
    if matrix.nnz == 0:
        return matrix
    low, high = matrix.data.min(), matrix.data.max()
    if high > low:
        keep = matrix.data > low + p * (high - low)
        if connected:
            inverted = matrix.copy()
            inverted.data = 2 * high - inverted.data  # > 0: its minimum tree is our maximum
            forest = minimum_spanning_tree(inverted)
            forest = sparse.csr_matrix((forest + forest.T).astype(bool), dtype=float)
            keep |= np.asarray(forest[matrix.nonzero()]).ravel() > 0
        matrix.data[~keep] = 0.0
        matrix.eliminate_zeros()
    return matrix


def spectrum(affinity: sparse.csr_matrix, count: int) -> tuple[NDArray[np.float64], NDArray]:
    """The ``count`` smallest eigenvalues and eigenvectors of ``L_sym`` of a connected graph."""
    n = affinity.shape[0]
    lap = laplacian(affinity, normed=True).tocsc()
    if count >= n - 1 or n <= DENSE_UP_TO:
        values, vectors = np.linalg.eigh(lap.toarray())
        return values[:count], vectors[:, :count]
    values, vectors = splinalg.eigsh(
        lap, k=count, sigma=-1e-3, which="LM", v0=np.ones(n) / math.sqrt(n)
    )
    order = np.argsort(values)
    return values[order], vectors[:, order]


def eigengap(values: NDArray[np.float64], low: int = 2) -> int:
    """The ``k >= low`` after which the eigenvalues jump the most (``k`` = number kept)."""
    if len(values) <= low:
        return len(values)
    gaps = np.diff(values)
    return int(np.argmax(gaps[low - 1 :])) + low


def at_most(segmenter: SpectralSegmenter, places: int) -> SpectralSegmenter:
    """``segmenter`` (cloned) choosing its ``k`` from the spectrum among at most ``places``
    regions, or one region when there is one place; a given ``k`` is kept.

    Regions are unions of places, so the place count bounds the eigengap's search; the
    partition, not the count, decides how many there are.

    Examples
    --------
    >>> at_most(SpectralSegmenter(), 12).max_regions, at_most(SpectralSegmenter(), 1).k
    (12, 1)
    >>> at_most(SpectralSegmenter(k=5), 12).k
    5
    """
    if segmenter.k is not None:
        return clone(segmenter)
    if places <= 1:
        return clone(segmenter, k=1)
    return clone(segmenter, max_regions=min(segmenter.max_regions, places))


def silhouette(distances: NDArray[np.float64], labels: NDArray[np.integer]) -> float:
    """The mean silhouette coefficient (eqs. 8-10) of ``labels`` from a symmetric matrix of
    ``distances``; a point alone in its cluster scores 0 (as scikit-learn's
    ``silhouette_score`` computes it, without importing scikit-learn at start-up).

    Examples
    --------
    >>> points = np.array([0.0, 0.1, 5.0, 5.1])
    >>> round(silhouette(np.abs(points[:, None] - points[None, :]), np.array([0, 0, 1, 1])), 4)
    0.98
    """
    _, labels = np.unique(labels, return_inverse=True)
    count = int(labels.max()) + 1
    members = np.bincount(labels, minlength=count).astype(float)
    # (n, k): distance from each point to each cluster; the distances are symmetric, so the
    # sparse one-hot rows times them: n^2 additions, not BLAS's n^2 k of a dense one-hot
    member = sparse.csr_matrix((np.ones(len(labels)), (labels, np.arange(len(labels)))))
    sums = (member @ distances).T
    own = np.arange(len(labels)), labels
    inside = np.divide(
        sums[own], members[labels] - 1, out=np.zeros(len(labels)), where=members[labels] > 1
    )
    mean = sums / members
    mean[own] = np.inf
    nearest = mean.min(axis=1)
    width = np.maximum(inside, nearest)
    value = np.divide(nearest - inside, width, out=np.zeros_like(width), where=width > 0)
    return float(np.mean(np.where(members[labels] > 1, value, 0.0)))


def kmeans(
    points: NDArray[np.float64],
    k: int,
    rng: np.random.Generator,
    max_iter: int = 100,
    weights: NDArray[np.float64] | None = None,
) -> NDArray[np.int64]:
    """Labels of ``points`` by k-means: k-means++ seeds (Arthur and Vassilvitskii, 2007), then
    Lloyd's iterations until no label changes (or ``max_iter``); ``weights`` (one per point)
    weigh the seeding and the centres.

    Distances are one matrix product per iteration (BLAS), and the seeding keeps each point's
    distance to its nearest seed up to date in one pass per seed: the partition of a large map
    runs k-means hundreds of times on a thousand points in a hundred dimensions, where SciPy's
    ``kmeans2`` (no BLAS, a quadratic ``++`` seeding) is ten times slower, and importing
    scikit-learn's would add a second to every command's start-up.

    Examples
    --------
    >>> points = np.array([[0.0, 0.0], [0.0, 0.1], [9.0, 9.0], [9.0, 9.1]])
    >>> labels = kmeans(points, 2, np.random.default_rng(0))
    >>> bool(labels[0] == labels[1] != labels[2] == labels[3])
    True
    """
    n = len(points)
    weight = np.ones(n) if weights is None else np.asarray(weights, float)
    squared = (points**2).sum(axis=1)
    chosen = [_draw(weight / weight.sum(), rng)]
    nearest = np.maximum(squared - 2 * (points @ points[chosen[0]]) + squared[chosen[0]], 0.0)
    for _ in range(1, k):
        total = (weight * nearest).sum()
        chance = weight * nearest / total if total > 0 else weight / weight.sum()
        pick = _draw(chance, rng)
        chosen.append(pick)
        distance = np.maximum(squared - 2 * (points @ points[pick]) + squared[pick], 0.0)
        nearest = np.minimum(nearest, distance)
    centres = points[chosen].copy()
    labels = np.full(n, -1, np.int64)
    for _ in range(max_iter):
        distances = (centres**2).sum(axis=1)[None, :] - 2 * (points @ centres.T)
        new = np.argmin(distances, axis=1)
        if np.array_equal(new, labels):
            break
        labels = new
        member = sparse.csr_matrix((weight, (labels, np.arange(n))), shape=(k, n))
        counts, sums = np.bincount(labels, weight, k), member @ points
        filled = counts > 0  # an emptied cluster keeps its centre
        centres[filled] = sums[filled] / counts[filled, None]
    return labels


def _draw(chance: NDArray[np.float64], rng: np.random.Generator) -> int:
    """An index drawn with probabilities ``chance`` (summing to 1): ``rng.choice(len(chance),
    p=chance)``, the same draw from the same stream, without its checks of ``chance``, which
    cost k-means++ on 10,000 keyframes a fifth of its time.

    Examples
    --------
    >>> chance = np.array([0.1, 0.0, 0.6, 0.3])
    >>> all(_draw(chance, np.random.default_rng(seed))
    ...     == np.random.default_rng(seed).choice(4, p=chance) for seed in range(100))
    True
    """
    cdf = chance.cumsum()
    cdf /= cdf[-1]
    return int(cdf.searchsorted(rng.random(), side="right"))


def best_clustering(
    embedding: NDArray[np.float64], k: int, n_init: int, rng: np.random.Generator
) -> tuple[float, NDArray[np.int64]]:
    """:func:`kmeans` ``n_init`` times on the first ``k`` columns; the best silhouette and
    labels.

    The silhouette is measured on all rows, or on one random sample of
    :data:`SILHOUETTE_SAMPLE` rows shared by the runs, from one distance matrix.
    """
    rows = embedding[:, :k]
    rows = rows / np.maximum(np.linalg.norm(rows, axis=1, keepdims=True), 1e-12)
    best: tuple[float, NDArray[np.int64]] = (-math.inf, np.zeros(len(rows), np.int64))
    sample = np.arange(len(rows))
    if len(rows) > SILHOUETTE_SAMPLE:
        sample = np.sort(rng.choice(len(rows), SILHOUETTE_SAMPLE, replace=False))
    chosen = rows[sample]
    squared = (chosen**2).sum(axis=1)
    gram = squared[:, None] + squared[None, :] - 2 * chosen @ chosen.T  # BLAS, not pdist
    distances = np.sqrt(np.maximum(gram, 0.0))
    np.fill_diagonal(distances, 0.0)
    for _ in range(n_init):
        labels = kmeans(rows, k, rng)
        if len(np.unique(labels[sample])) < 2:
            continue
        score = silhouette(distances, labels[sample])
        if score > best[0]:
            best = (score, labels.astype(np.int64))
    return best


@dataclass
class SpectralSegmenter(Estimator):
    """Cluster keyframes into regions by the paper's spectral partition.

    Parameters
    ----------
    criterion
        ``"nn"`` (nearest neighbour, default), ``"hausdorff"``, ``"features"``, a
        :class:`~segmentation.similarity.Criterion`, or a callable ``f(points_i, points_j)``.
    p
        Sparsification parameter in ``[0, 1)`` (eqs. 4-5).
    k
        The guess ``k'`` for the number of regions; ``None`` estimates it from the largest
        eigengap among the first ``max_regions`` eigenvalues.
    spread
        ``k`` is searched in ``k' - spread .. k' + spread``.
    max_regions
        Cap on ``k`` (and on the eigenvalues computed to estimate it).
    n_init
        k-means runs per ``k``; the best silhouette wins.
    connected
        Sparsify without cutting the graph into more parts than it had (see
        :func:`sparsify`): parts never share a cluster, so a ``k`` below their count can only be
        reached with this.
    random_state
        Seed or Generator; the same seed gives the same labels.

    Attributes
    ----------
    labels_ : ndarray of int, shape (n_keyframes,)
        Region of each keyframe, ``0 .. n_regions_ - 1``.
    n_regions_ : int
    silhouette_by_k_ : dict of int to float
        Best silhouette per ``k`` tried.
    affinity_ : scipy.sparse.csr_matrix
        The sparsified similarity matrix (of the distinct keyframes, see :meth:`fit`).
    eigenvalues_ : ndarray
        The smallest eigenvalues of ``L_sym`` of the keyframes in components of 3 or more.
    """

    criterion: str | Criterion | PointsSimilarity = "nn"
    p: float = 0.3
    k: int | None = None
    spread: int = 2
    max_regions: int = 100
    n_init: int = 3
    connected: bool = False
    random_state: RandomState = None

    def _validate_params(self) -> None:
        if self.k is not None and not (is_count(self.k) and self.k >= 1):
            raise ParameterError(f"k must be an integer >= 1, got {self.k!r}")
        check_flags(self, "connected")
        if finite_in(self.p, "p", 0, 1) is not None or self.p == 1:
            raise ParameterError(f"p must lie in [0, 1), got {self.p!r}")
        for name in ("spread", "n_init", "max_regions"):
            value = getattr(self, name)
            if not is_count(value) or value < (0 if name == "spread" else 1):
                raise ParameterError(f"{name} must be a positive integer, got {value!r}")
        if self.n_init > MAX_N_INIT:
            raise ParameterError(f"n_init must be at most {MAX_N_INIT}, got {self.n_init!r}")
        as_criterion(self.criterion)

    def _check(self, n: int) -> None:
        self._validate_params()
        if self.k is not None and self.k > n:
            raise ParameterError(f"k must be an integer in 1..{n} (the keyframes), got {self.k!r}")

    def fit(self, keyframes: Sequence[Keyframe]) -> SpectralSegmenter:
        """Compute the affinity of ``keyframes`` and cluster them (see the module docstring).

        Keyframes with the same pose and the same scan (a robot standing still) are clustered
        once and share their cluster; ``k`` is capped at the number of distinct keyframes.
        """
        if not isinstance(keyframes, Sequence) or not all(
            isinstance(k, Keyframe) for k in keyframes
        ):
            raise ParameterError(f"fit takes a list of Keyframes, got {keyframes!r:.200}")
        if not keyframes:  # whatever the criterion
            raise SegmentationError("no keyframes to segment")
        if len(keyframes) > MAX_NODES:
            raise ParameterError(
                f"{len(keyframes)} keyframes, more than the {MAX_NODES} one partition takes "
                "(select fewer with a larger keyframe distance, or partition block by block)"
            )
        self._check(len(keyframes))
        criterion = as_criterion(self.criterion)
        keys = [(tuple(k.pose), k.scan.ranges.tobytes()) for k in keyframes]
        first: dict[tuple, int] = {}
        index = np.array([first.setdefault(key, len(first)) for key in keys], np.int64)
        if len(first) == len(keyframes):
            return self.fit_affinity(criterion.affinity(keyframes))
        distinct = [keyframes[i] for i in np.unique(index, return_index=True)[1]]
        k = self.k if self.k is None else min(self.k, len(distinct))
        if len(distinct) == 1:
            fitted = clone(self, k=1).fit_affinity(sparse.csr_matrix((1, 1)))
        else:
            fitted = clone(self, k=k).fit_affinity(criterion.affinity(distinct))
        self._set_fitted(
            fitted.affinity_, fitted.eigenvalues_, fitted.silhouette_by_k_, fitted.labels_[index]
        )
        return self

    def fit_predict(self, keyframes: Sequence[Keyframe]) -> NDArray[np.int64]:
        """:meth:`fit` ``keyframes`` and return their clusters, ``labels_`` (scikit-learn's
        clusterer contract).

        Examples
        --------
        >>> import maps
        >>> from segmentation.virtual import virtual_keyframes
        >>> plan = maps.generate_floor_plan("flat", random_state=0)
        >>> frames = virtual_keyframes(plan.grid, 2.0, random_state=0)
        >>> model = SpectralSegmenter(random_state=0)
        >>> labels = model.fit_predict(frames)
        >>> labels.shape == (len(frames),), labels is model.labels_
        (True, True)
        """
        return self.fit(keyframes).labels_

    def fit_affinity(self, affinity: sparse.spmatrix) -> SpectralSegmenter:
        """Cluster from a precomputed symmetric affinity matrix (real, finite values >= 0,
        at most :data:`MAX_NODES` rows).

        Examples
        --------
        >>> SpectralSegmenter().fit_affinity(sparse.csr_matrix([[0.0, 1.0], [0.0, 0.0]]))
        Traceback (most recent call last):
        ...
        segmentation.errors.ParameterError: the affinity must be symmetric (W_ij = W_ji), ...
        """
        shape = getattr(affinity, "shape", None)
        if shape == (0, 0):  # nothing to cluster: no clusters
            self._check(0)
            self._set_fitted(sparse.csr_matrix((0, 0)), np.zeros(0), {}, np.zeros(0, np.int64))
            return self
        if not (isinstance(shape, tuple) and len(shape) == 2 and shape[0] == shape[1]):
            raise ParameterError(f"the affinity must be a square matrix, got {affinity!r:.80}")
        if shape[0] > MAX_NODES:
            raise ParameterError(
                f"the affinity has {shape[0]} rows, more than the {MAX_NODES} this partition "
                "takes at once (partition a large map block by block)"
            )
        if np.iscomplexobj(getattr(affinity, "data", affinity)):
            raise ParameterError("the affinity's values must be real numbers")
        try:
            affinity = sparse.csr_matrix(affinity, dtype=float)
        except (TypeError, ValueError) as err:
            raise ParameterError(f"the affinity must be a matrix of numbers ({err})") from None
        n = affinity.shape[0]
        if not np.all(np.isfinite(affinity.data)) or (affinity.data < 0).any():
            raise ParameterError("the affinity's values must be finite and >= 0")
        asymmetry = abs(affinity - affinity.T).max() if affinity.nnz else 0.0
        if asymmetry > 1e-9 * max(float(affinity.data.max(initial=0.0)), 1.0):
            raise ParameterError(
                f"the affinity must be symmetric (W_ij = W_ji), got a difference of {asymmetry:g}"
            )
        self._check(n)
        rng = as_generator(self.random_state)
        sparse_affinity = sparsify(affinity, self.p, connected=self.connected)
        count, component = connected_components(sparse_affinity, directed=False)
        sizes = np.bincount(component)
        main = np.flatnonzero(sizes[component] >= 3)
        silhouettes: dict[int, float] = {}
        values = np.zeros(0)
        labels = np.zeros(n, np.int64)
        if len(main) >= 3:
            # small dense problems: BLAS threads cost more than they save (and oversubscribe)
            with threadpool_limits(1):
                values, labels[main] = self._cluster(
                    sparse_affinity[main][:, main], rng, silhouettes
                )
        labels = labels * count + component  # never one cluster across two components
        labels = np.unique(labels, return_inverse=True)[1].astype(np.int64)
        self._set_fitted(sparse_affinity, values, silhouettes, labels)
        return self

    def _set_fitted(
        self,
        affinity: sparse.csr_matrix,
        eigenvalues: NDArray[np.float64],
        silhouettes: dict[int, float],
        labels: NDArray[np.int64],
    ) -> None:
        self.affinity_ = affinity
        self.eigenvalues_ = eigenvalues
        self.silhouette_by_k_ = silhouettes
        self.labels_ = labels
        self.n_regions_ = int(labels.max(initial=-1)) + 1

    def _cluster(
        self, affinity: sparse.csr_matrix, rng: np.random.Generator, silhouettes: dict[int, float]
    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """The eigenvalues and the labels of the best clustering of a connected ``affinity``;
        fills ``silhouettes`` (best score per ``k`` tried)."""
        n = affinity.shape[0]
        if self.k == 1:
            return np.zeros(0), np.zeros(n, np.int64)
        components = connected_components(affinity, directed=False)[0]
        top = min(n - 1, self.max_regions) if self.k is None else min(n - 1, self.k + self.spread)
        top = max(top, 1)
        values, vectors = spectrum(affinity, min(n - 1, top + 1))
        guess = self.k if self.k is not None else eigengap(values, max(2, components))
        ks = list(range(max(2, guess - self.spread), min(n, guess + self.spread + 1)))
        ks = [k for k in ks if k <= vectors.shape[1]] or [min(max(2, guess), vectors.shape[1])]
        best: tuple[float, NDArray[np.int64]] = (-math.inf, np.zeros(n, np.int64))
        for k in ks:
            score, labels = best_clustering(vectors, k, self.n_init, rng)
            silhouettes[k] = score
            if score > best[0]:
                best = (score, labels)
        log.debug("k' = %d, silhouette by k: %s", guess, silhouettes)
        return values, best[1]
