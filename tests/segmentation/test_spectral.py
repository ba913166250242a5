import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from sklearn.metrics import adjusted_rand_score

import maps
from maps.scan import Keyframe, poses_array
from segmentation.errors import ParameterError, SegmentationError
from segmentation.spectral import SpectralSegmenter, eigengap, sparsify
from segmentation.virtual import virtual_keyframes


@pytest.fixture(scope="module")
def flat():
    plan = maps.generate_floor_plan("flat", random_state=1)
    return plan, virtual_keyframes(plan.grid, 0.8, random_state=0)


def room_of(plan, keyframes):
    poses = poses_array(keyframes)
    rows, cols = plan.grid.world_to_cell(poses[:, 0], poses[:, 1])
    return plan.labels[rows, cols]


@given(
    st.lists(st.floats(0.01, 10.0), min_size=1, max_size=30),
    st.floats(0.0, 0.99),
)
def test_sparsify_keeps_exactly_the_similarities_above_the_switch(values, p):
    n = len(values) + 1
    matrix = sparse.csr_matrix((values, (np.arange(len(values)), np.arange(1, n))), shape=(n, n))
    kept = sparsify(matrix + matrix.T, p)
    low, high = min(values), max(values)
    switch = low + p * (high - low)
    expected = {v for v in values if v > switch} if high > low else set(values)
    assert set(kept.data) == expected
    assert (kept != kept.T).nnz == 0


def test_eigengap_finds_the_jump():
    assert eigengap(np.array([0, 0.01, 0.02, 0.5, 0.6, 0.7])) == 3
    assert eigengap(np.array([0.0, 0.1])) == 2


def test_rooms_are_recovered_and_the_seed_fixes_the_result(flat):
    plan, keyframes = flat
    truth = room_of(plan, keyframes)
    first = SpectralSegmenter(k=plan.n_rooms, random_state=4).fit(keyframes)
    again = SpectralSegmenter(k=plan.n_rooms, random_state=4).fit(keyframes)
    np.testing.assert_array_equal(first.labels_, again.labels_)
    assert adjusted_rand_score(truth, first.labels_) > 0.6
    assert set(first.silhouette_by_k_) == set(range(plan.n_rooms - 2, plan.n_rooms + 3))
    assert first.n_regions_ == len(np.unique(first.labels_))
    assert first.affinity_.shape == (len(keyframes),) * 2


def test_disconnected_parts_never_share_a_region(flat):
    _, keyframes = flat
    far = [
        Keyframe((x + 500.0, y, t), k.scan, k.scan_index)
        for k in keyframes[:40]
        for x, y, t in [k.pose]
    ]
    both = [*keyframes[:40], *far]
    labels = SpectralSegmenter(k=2, random_state=0).fit(both).labels_
    assert not set(labels[:40]) & set(labels[40:])


def test_one_keyframe_and_k_one_give_one_region(flat):
    _, keyframes = flat
    assert SpectralSegmenter().fit(keyframes[:1]).labels_.tolist() == [0]
    one = SpectralSegmenter(k=1).fit(keyframes[:30])
    # k = 1 is one region per connected piece of the similarity graph
    assert one.n_regions_ == connected_components(one.affinity_)[0]


def test_bad_input_is_named(flat):
    _, keyframes = flat
    with pytest.raises(SegmentationError, match="no keyframes"):
        SpectralSegmenter().fit([])
    with pytest.raises(ParameterError, match=r"k must be an integer in 1\.\.5"):
        SpectralSegmenter(k=6).fit(keyframes[:5])
    with pytest.raises(ParameterError, match="p must lie"):
        SpectralSegmenter(p=1.5).fit(keyframes[:5])
    with pytest.raises(ParameterError, match="n_init"):
        SpectralSegmenter(n_init=0).fit(keyframes[:5])
    with pytest.raises(ValueError, match="finite"):
        Keyframe((float("nan"), 0.0, 0.0), keyframes[0].scan)


@given(st.integers(0, 2**31 - 1), st.integers(2, 6), st.integers(8, 40))
@settings(max_examples=40, deadline=None)
def test_silhouette_equals_scikit_learns(seed, k, n):
    from scipy.spatial.distance import pdist, squareform
    from sklearn.metrics import silhouette_score

    from segmentation.spectral import silhouette

    rng = np.random.default_rng(seed)
    points = rng.normal(size=(n, 3))
    labels = rng.integers(0, k, n)
    if len(np.unique(labels)) < 2:
        labels[0], labels[1] = 0, 1
    distances = squareform(pdist(points))
    expected = silhouette_score(distances, labels, metric="precomputed")
    assert silhouette(distances, labels) == pytest.approx(expected, abs=1e-9)
