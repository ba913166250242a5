"""The straightforward spectral partition, as a reference: every pair, dense matrices.

Used by ``topomap bench segment`` to measure what pruning, sparse products and a sparse
eigensolver buy, and by the tests to check that the fast criterion computes the same numbers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from scipy.sparse.csgraph import laplacian
from scipy.spatial import cKDTree
from threadpoolctl import threadpool_limits

from maps.scan import Keyframe
from maps.seeding import RandomState, as_generator
from segmentation.cloud import ScanCloud
from segmentation.similarity import NearestNeighbour
from segmentation.spectral import best_clustering, eigengap


def naive_nearest_neighbour(
    keyframes: Sequence[Keyframe], criterion: NearestNeighbour | None = None
) -> NDArray[np.float64]:
    """Dense ``(n, n)`` eq. 12 similarities, one KD-tree query per ordered pair."""
    criterion = criterion or NearestNeighbour()
    points = ScanCloud.from_keyframes(keyframes, criterion.resolution).split()
    trees = [cKDTree(p) for p in points]
    n = len(points)
    mean = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            if i != j:
                distance, _ = trees[j].query(points[i])
                mean[i, j] = np.minimum(distance, criterion.tolerance).mean()
    similarity = 1.0 - (mean + mean.T) / (2 * criterion.tolerance)
    np.fill_diagonal(similarity, 0.0)
    return similarity


def naive_segment(
    keyframes: Sequence[Keyframe],
    *,
    p: float = 0.3,
    k: int | None = None,
    spread: int = 2,
    max_regions: int = 100,
    n_init: int = 3,
    random_state: RandomState = None,
) -> NDArray[np.int64]:
    """The paper's pipeline with all pairs, a dense Laplacian and a dense eigensolver."""
    similarity = naive_nearest_neighbour(keyframes)
    present = similarity[similarity > 0]
    if len(present):
        low, high = present.min(), present.max()
        similarity[similarity <= low + p * (high - low)] = 0.0
    values, vectors = np.linalg.eigh(laplacian(similarity, normed=True))
    n = len(keyframes)
    guess = k if k is not None else eigengap(values[: min(n - 1, max_regions + 1)])
    rng = as_generator(random_state)
    best: tuple[float, NDArray[np.int64]] = (-math.inf, np.zeros(n, np.int64))
    with threadpool_limits(1):
        for count in range(max(2, guess - spread), min(n - 1, guess + spread) + 1):
            best = max(best, best_clustering(vectors, count, n_init, rng), key=lambda b: b[0])
    return best[1]
