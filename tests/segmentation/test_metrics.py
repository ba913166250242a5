import numpy as np
import pytest

from segmentation.errors import SegmentationError
from segmentation.metrics import score


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


def test_mcc_by_hand_for_a_merge():
    # one segment of 800 pixels over two rooms of 400: the pair (tp 400, fp 400, fn 0,
    # tn = N - (fp - |g|) = 800) scores 400*800 / sqrt(800*400*1200*800); the other room 0.
    truth = two_rooms_truth()
    merged = (truth > 0).astype(np.int32)
    expected = 400 * 800 / np.sqrt(800 * 400 * 1200 * 800) / 2
    assert score(merged, truth).mcc == pytest.approx(expected)


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
