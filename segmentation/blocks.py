"""Spectral segmentation of large maps, one block of places at a time.

One spectral problem with ``k`` clusters costs ``k`` eigenvectors of the whole keyframe graph
and k-means in ``k`` dimensions: fine for a floor of tens of rooms, hopeless for a campus of a
thousand. A large map is first divided along its clearance basins (the places found by
:func:`segmentation.refine.basins`): the basins' centres are grouped into blocks of about
``places`` basins by k-means, each keyframe goes to the block of the basin it stands in, and
the spectral partition runs in each block with ``k`` = the block's basin count. Block
boundaries follow basin boundaries, which lie at doors and narrow passages.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree
from threadpoolctl import threadpool_limits

from maps.grid import OccupancyGrid
from maps.scan import Keyframe, poses_array
from maps.seeding import RandomState
from segmentation.base import Estimator, clone, is_count
from segmentation.distinct import label_counts, nonzero_cells
from segmentation.errors import ParameterError
from segmentation.spectral import SpectralSegmenter, at_most, kmeans


def keyframe_blocks(
    grid: OccupancyGrid,
    basin: NDArray[np.int32],
    keyframes: Sequence[Keyframe],
    places: int,
    *,
    min_area: float = 1.0,
    random_state: int = 0,
) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Block of each keyframe, and the number of places (basins of ``min_area`` m^2 or more)
    in each block.

    Keyframes on no basin take the block of the nearest keyframe that has one.
    """
    sizes = label_counts(basin)
    ids = np.flatnonzero(sizes * grid.resolution**2 >= min_area)
    ids = ids[ids > 0]
    rows, cols = nonzero_cells(basin > 0)
    centre = _cell_sums(basin[rows, cols], rows, cols, len(sizes))
    centre[ids] /= sizes[ids, None]
    count = max(1, math.ceil(len(ids) / places))
    block_of_basin = np.zeros(len(sizes), np.int64)
    if count > 1:
        rng = np.random.default_rng(random_state)
        block_of_basin[ids] = kmeans(centre[ids], count, rng, weights=sizes[ids].astype(float))
        small = np.setdiff1d(np.arange(1, len(sizes)), ids)
        if len(small):
            nearest = cKDTree(centre[ids]).query(_centres(basin, small))[1]
            block_of_basin[small] = block_of_basin[ids[nearest]]
    poses = poses_array(keyframes)
    kr, kc = grid.world_to_cell(poses[:, 0], poses[:, 1])
    inside = grid.contains(kr, kc)
    on = np.zeros(len(poses), np.int64)
    on[inside] = basin[kr[inside], kc[inside]]
    blocks = block_of_basin[on]
    missing = on == 0
    if missing.any() and (~missing).any():
        nearest = cKDTree(poses[~missing, :2]).query(poses[missing, :2])[1]
        blocks[missing] = blocks[~missing][nearest]
    per_block = np.bincount(block_of_basin[ids], minlength=count)
    return blocks, per_block


def _centres(basin: NDArray[np.int32], which: NDArray[np.int64]) -> NDArray[np.float64]:
    rows, cols = nonzero_cells(np.isin(basin, which))
    order = np.searchsorted(which, basin[rows, cols])
    total = _cell_sums(order, rows, cols, len(which))
    return total / np.maximum(np.bincount(order, minlength=len(which)), 1)[:, None]


def _cell_sums(
    owner: NDArray[np.integer], rows: NDArray[np.intp], cols: NDArray[np.intp], count: int
) -> NDArray[np.float64]:
    """The sums of the ``rows`` and ``cols`` of the cells of each ``owner`` ``0 .. count - 1``,
    shape ``(count, 2)``: sums of integers, exact in floats in any order."""
    return np.column_stack([np.bincount(owner, rows, count), np.bincount(owner, cols, count)])


@dataclass(eq=False)
class BlockSpectralSegmenter(Estimator):
    """:class:`SpectralSegmenter` run block by block (see the module docstring).

    Parameters
    ----------
    segmenter
        The settings of each block's partition, cloned per block to choose among at most
        the block's places (:func:`~segmentation.spectral.at_most`; never fitted itself).
    blocks
        Block of each keyframe (from :func:`keyframe_blocks`).
    places
        Places per block (the most regions it can have).
    n_jobs
        How many blocks are partitioned at once, with joblib as in scikit-learn: ``None``
        one at a time (unless a ``joblib.parallel_config`` says otherwise), ``-1`` one per
        core; inside ``joblib.parallel_config(backend="dask")`` the blocks run on the Dask
        cluster of the current ``distributed.Client``. The labels are the same either way.

    Attributes
    ----------
    labels_, n_regions_
        As :class:`SpectralSegmenter`'s; blocks never share a label.
    segmenters_
        The fitted partition of each block, in block order.
    silhouette_by_k_
        Empty: each block has its own curve in ``segmenters_``.
    """

    segmenter: SpectralSegmenter
    blocks: NDArray[np.int64]
    places: NDArray[np.int64]
    n_jobs: int | None = None

    def _validate_params(self) -> None:
        check_n_jobs(self.n_jobs)
        blocks = np.asarray(self.blocks)
        if blocks.ndim != 1 or not np.issubdtype(blocks.dtype, np.integer) or (blocks < 0).any():
            raise ParameterError("blocks must be one integer >= 0 per keyframe")
        if len(blocks) and len(self.places) <= blocks.max():
            raise ParameterError(
                f"places has {len(self.places)} entries for block ids up to {blocks.max()}"
            )
        self.segmenter._validate_params()

    def fit(self, keyframes: Sequence[Keyframe]) -> BlockSpectralSegmenter:
        """Partition each block's keyframes (:attr:`n_jobs` at once)."""
        self._validate_params()
        if len(self.blocks) != len(keyframes):
            raise ParameterError(f"{len(self.blocks)} block ids for {len(keyframes)} keyframes")
        members = [np.flatnonzero(self.blocks == block) for block in np.unique(self.blocks)]
        states = _block_states(self.segmenter.random_state, len(members))
        work = [
            (
                clone(
                    at_most(self.segmenter, int(min(self.places[block], len(m)))),
                    random_state=state,
                ),
                [keyframes[int(i)] for i in m],
            )
            for block, m, state in zip(np.unique(self.blocks), members, states, strict=True)
        ]
        parts = fit_blocks(work, self.n_jobs)
        labels = np.zeros(len(keyframes), np.int64)
        offset = 0
        for m, part in zip(members, parts, strict=True):
            labels[m] = part.labels_ + offset
            offset += part.n_regions_
        self.labels_ = labels
        self.segmenters_: list[SpectralSegmenter] = list(parts)
        self.silhouette_by_k_: dict[int, float] = {}
        self.n_regions_ = offset
        return self


def _block_states(random_state: RandomState, count: int) -> list[RandomState]:
    """The random state of each of ``count`` blocks: a seed or None as it is (each block's
    partition draws from it alone), a Generator's own independent children (one shared
    generator drawn from by blocks at once would give other labels each run).

    Examples
    --------
    >>> _block_states(7, 2)
    [7, 7]
    >>> children = _block_states(np.random.default_rng(0), 2)
    >>> [int(child.integers(100)) for child in children] == [
    ...     int(child.integers(100)) for child in _block_states(np.random.default_rng(0), 2)
    ... ]
    True
    """
    if isinstance(random_state, np.random.Generator):
        return list(random_state.spawn(count))
    return [random_state] * count


#: The most blocks partitioned at once (joblib's own bound is a million).
MAX_JOBS = 1024


def check_n_jobs(n_jobs: object) -> None:
    """Raise :class:`~segmentation.errors.ParameterError` unless ``n_jobs`` is None or a
    nonzero integer (joblib's values).

    Examples
    --------
    >>> check_n_jobs(0)
    Traceback (most recent call last):
    ...
    segmentation.errors.ParameterError: n_jobs must be None or a nonzero integer within ±1024, got 0
    """
    if n_jobs is not None and not (
        is_count(n_jobs) and n_jobs != 0 and -MAX_JOBS <= int(n_jobs) <= MAX_JOBS
    ):
        raise ParameterError(
            f"n_jobs must be None or a nonzero integer within ±{MAX_JOBS}, got {n_jobs!r}"
        )


def fit_blocks(
    work: Sequence[tuple[SpectralSegmenter, list[Keyframe]]], n_jobs: int | None = None
) -> list[SpectralSegmenter]:
    """``segmenter.fit(keyframes)`` for each ``(segmenter, keyframes)`` of ``work``, in
    order, ``n_jobs`` at once with :class:`joblib.Parallel` (imported only for two blocks or
    more), in threads unless a ``joblib.parallel_config`` says otherwise: the blocks share
    the keyframes without copying them, and the eigensolver's and k-means' work runs outside
    the interpreter's lock (on the campus the spectral stage takes 0.78 times as long on two
    cores, where worker processes gained nothing).

    Examples
    --------
    >>> import maps
    >>> from segmentation.virtual import virtual_keyframes
    >>> keyframes = virtual_keyframes(maps.generate_floor_plan("flat", random_state=0).grid)
    >>> work = [(SpectralSegmenter(random_state=0), keyframes[:n]) for n in (20, 30)]
    >>> [len(part.labels_) for part in fit_blocks(work, n_jobs=1)]
    [20, 30]
    """
    if len(work) < 2:
        return [segmenter.fit(keyframes) for segmenter, keyframes in work]
    from joblib import Parallel, delayed

    # each fit limits BLAS to one thread while it runs; limited here first, the threads'
    # limits save and restore one, and the caller's setting comes back whole at the end
    with threadpool_limits(1):
        fits = Parallel(n_jobs=n_jobs, prefer="threads")(
            delayed(segmenter.fit)(keyframes) for segmenter, keyframes in work
        )
    return list(fits)
