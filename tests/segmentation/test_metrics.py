import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from sklearn.metrics import adjusted_rand_score
from sklearn.metrics.cluster import contingency_matrix

from segmentation.errors import SegmentationError
from segmentation.metrics import adjusted_rand, score


def two_rooms_truth():
    truth = np.zeros((20, 41), np.int32)
    truth[:, :20] = 1
    truth[:, 21:] = 2
    return truth


def test_a_perfect_segmentation_scores_one():
    truth = two_rooms_truth()
    result = score(truth * 7, truth)
    assert result.recall == result.precision == result.mcc == result.ari == 1.0
    assert (result.segments, result.rooms) == (2, 2)


def test_splitting_keeps_precision_merging_keeps_recall():
    truth = two_rooms_truth()
    split = truth.copy()
    split[:10, :20] = 3
    result = score(split, truth)
    assert result.precision == 1.0 and result.recall == pytest.approx(0.75)
    merged = (truth > 0).astype(np.int32)
    result = score(merged, truth)
    assert result.recall == 1.0 and result.precision == pytest.approx(0.5)


def _columns(widths, rows=20):
    """A label image of vertical bands ``widths`` columns wide, labelled 1, 2, ..."""
    return np.repeat(np.arange(1, len(widths) + 1), widths)[None].repeat(rows, 0).astype(np.int32)


def test_scores_of_a_shifted_boundary_counted_by_hand():
    # rooms 1 | 2 of 300 pixels each (15 + 15 columns of 20 rows); segments A | B of 400 and
    # 200 pixels (20 + 10 columns). Overlaps: A-1 300, A-2 100, B-2 200; N = 600 labelled.
    truth, segments = _columns([15, 15]), _columns([20, 10])
    result = score(segments, truth)
    # recall: each room's best overlap over its size; precision: each segment's over its size
    assert result.recall == pytest.approx((300 / 300 + 200 / 300) / 2)
    assert result.precision == pytest.approx((300 / 400 + 200 / 200) / 2)
    assert result.recall_macro == pytest.approx(500 / 600)
    assert result.precision_macro == pytest.approx(500 / 600)
    # MAORIS pairs zones greedily by overlap: (A, 1), then (B, 2). Per pair, as its evaluation
    # code counts them: tp, fp = |s| - tp, fn = |g| - tp, tn = N - (fp - |g|)
    # (A, 1): tp 300, fp 100, fn 0, tn 800;  (B, 2): tp 200, fp 0, fn 100, tn 900
    mcc_a1 = (300 * 800 - 100 * 0) / math.sqrt(400 * 300 * 900 * 800)
    mcc_b2 = (200 * 900 - 0 * 100) / math.sqrt(200 * 300 * 900 * 1000)
    assert result.mcc == pytest.approx((mcc_a1 + mcc_b2) / 2)
    # adjusted Rand index (Hubert and Arabie) of the table [[300, 100], [0, 200]]
    pairs = math.comb(300, 2) + math.comb(100, 2) + math.comb(200, 2)
    rows = math.comb(400, 2) + math.comb(200, 2)
    cols = 2 * math.comb(300, 2)
    chance = rows * cols / math.comb(600, 2)
    assert result.ari == pytest.approx((pairs - chance) / ((rows + cols) / 2 - chance))
    assert (result.segments, result.rooms) == (2, 2)


def test_an_unpaired_segment_scores_zero_in_the_mcc_mean():
    # rooms 1 | 2 of 300 pixels; segments A | B | C of 300, 180 and 120 pixels (15, 9, 6
    # columns). Pairs (A, 1): tp 300, fp 0, fn 0, tn 900 -> MCC 1; (B, 2): tp 180, fp 0,
    # fn 120, tn 900; C finds room 2 taken: unpaired, 0. The mean runs over three zones.
    result = score(_columns([15, 9, 6]), _columns([15, 15]))
    mcc_b2 = 180 * 900 / math.sqrt(180 * 300 * 900 * 1020)
    assert result.mcc == pytest.approx((1.0 + mcc_b2 + 0.0) / 3)
    assert result.precision == 1.0
    assert result.recall == pytest.approx((1.0 + 180 / 300) / 2)


def test_small_zones_and_unlabelled_pixels_are_ignored():
    truth = two_rooms_truth()
    seg = truth.copy()
    seg[0, :5] = 9  # 5 pixels: not a segment
    seg[5, 25:30] = 0
    result = score(seg, truth)
    assert result.segments == 2 and result.precision == 1.0


def test_shapes_must_agree():
    with pytest.raises(SegmentationError, match="shape"):
        score(np.zeros((3, 3), int), np.zeros((3, 4), int))


@given(
    st.lists(st.tuples(st.integers(0, 4), st.integers(0, 4)), min_size=2, max_size=60),
)
def test_adjusted_rand_from_the_overlap_table_is_scikit_learns(pairs):
    a, b = np.array(pairs).T
    table = contingency_matrix(a, b).astype(float)
    assert adjusted_rand(table) == pytest.approx(adjusted_rand_score(a, b), abs=1e-9)
