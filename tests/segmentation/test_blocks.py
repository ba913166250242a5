"""Block-wise spectral partition of maps with many places."""

import numpy as np
import pytest

from maps.sim.floorplan import generate_floor_plan
from segmentation.blocks import BlockSpectralSegmenter, keyframe_blocks
from segmentation.refine import basins, count_basins
from segmentation.spectral import SpectralSegmenter
from segmentation.virtual import virtual_keyframes


def test_blocks_partition_keyframes_and_never_share_a_region():
    plan = generate_floor_plan("flat", random_state=2)
    basin = basins(plan.grid)
    keyframes = virtual_keyframes(plan.grid, 0.8, random_state=0)
    blocks, places = keyframe_blocks(plan.grid, basin, keyframes, places=3)
    assert len(blocks) == len(keyframes)
    assert len(places) == len(np.unique(blocks)) >= 2
    assert places.sum() == count_basins(plan.grid, basin)
    model = BlockSpectralSegmenter(SpectralSegmenter(random_state=0), blocks, places)
    labels = model.fit(keyframes).labels_
    assert model.n_regions_ == labels.max() + 1 == sum(s.n_regions_ for s in model.segmenters_)
    for region in np.unique(labels):
        assert len(np.unique(blocks[labels == region])) == 1
    with pytest.raises(ValueError, match="block ids for"):
        model.fit(keyframes[:-1])


def _flat_blocks(random_state):
    plan = generate_floor_plan("flat", random_state=2)
    keyframes = virtual_keyframes(plan.grid, 0.8, random_state=0)
    blocks, places = keyframe_blocks(plan.grid, basins(plan.grid), keyframes, places=3)
    model = BlockSpectralSegmenter(SpectralSegmenter(random_state=random_state), blocks, places)
    return model, keyframes, places


def test_blocks_in_two_threads_equal_one_after_the_other():
    from segmentation.base import clone

    model, keyframes, places = _flat_blocks(0)
    one = clone(model, n_jobs=1).fit(keyframes)
    two = clone(model, n_jobs=2).fit(keyframes)
    assert len(places) >= 2 and len(np.unique(one.labels_)) > len(places)
    assert np.array_equal(two.labels_, one.labels_)
    assert [s.n_regions_ for s in two.segmenters_] == [s.n_regions_ for s in one.segmenters_]
    assert model.n_jobs is None and not hasattr(model, "labels_")  # clones were fitted


def test_blocks_seeded_by_one_generator_give_the_same_labels_at_once_or_in_turn():
    from segmentation.base import clone

    fits = []
    for jobs in (1, 2, 2, 2):
        model, keyframes, _ = _flat_blocks(np.random.default_rng(5))
        fits.append(clone(model, n_jobs=jobs).fit(keyframes).labels_)
    assert all(np.array_equal(labels, fits[0]) for labels in fits[1:])
    with pytest.raises(
        ValueError, match="n_jobs must be None or a nonzero integer within ±1024, got 0"
    ):
        clone(model, n_jobs=0).fit(keyframes)
