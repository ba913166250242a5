"""Scores of a segmentation against a human one, as the room segmentation benchmarks define them.

Recall and precision (micro and macro) after Bormann et al. (ICRA 2016); the per-zone Matthews
correlation as MAORIS (Mielle et al., ICRA 2018) evaluates it; the adjusted Rand index.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import sparse

from segmentation.errors import SegmentationError

#: Segments and rooms with at most this many pixels are not scored.
MIN_PIXELS = 100


@dataclass(frozen=True)
class Scores:
    """Scores of one segmentation (see the module docstring)."""

    recall: float
    precision: float
    recall_macro: float
    precision_macro: float
    mcc: float
    ari: float
    segments: int
    rooms: int

    def as_dict(self) -> dict[str, float | int]:
        """The scores as a plain dict."""
        return asdict(self)


def _keep_large(labels: NDArray[np.integer]) -> NDArray[np.int64]:
    labels = labels.astype(np.int64)
    sizes = np.bincount(labels.ravel())
    small = sizes <= MIN_PIXELS
    small[0] = True
    return np.where(small[labels], 0, labels)


def _numbered(labels: NDArray[np.int64]) -> tuple[NDArray[np.intp], NDArray[np.int64]]:
    """``labels`` renumbered 1, 2, ... in ascending order (0 stays 0), and the pixel count of
    each (``np.unique(..., return_inverse=True)`` by counting, not sorting 2 million pixels).

    Examples
    --------
    >>> numbered, sizes = _numbered(np.array([[0, 7, 7], [3, 0, 7]]))
    >>> numbered.tolist(), sizes.tolist()
    ([[0, 2, 2], [1, 0, 2]], [1, 3])
    """
    counts = np.bincount(labels.ravel())
    ids = np.flatnonzero(counts[1:]) + 1
    number = np.zeros(len(counts), np.intp)
    number[ids] = np.arange(1, len(ids) + 1)
    return number[labels], counts[ids]


def _mcc(tp: float, fp: float, fn: float, tn: float) -> float:
    """Matthews' correlation of a confusion table; 0 where it is undefined (a factor of the
    denominator 0, or below 0 when a segment covers more than the labelled cells count).

    Examples
    --------
    >>> round(_mcc(10, 0, 0, 90), 3), _mcc(10, 95, 0, -5)
    (1.0, 0.0)
    """
    product = (tp + fp) * (tp + fn) * (tn + fp) * (tn + fn)
    return (tp * tn - fp * fn) / math.sqrt(product) if product > 0 else 0.0


def adjusted_rand(table: NDArray[np.floating]) -> float:
    """The adjusted Rand index (Hubert and Arabie) of two labellings from their contingency
    ``table`` (items in segment ``s`` and room ``g``), as scikit-learn computes it (a test
    checks they agree); :func:`score` has the table already, where
    ``sklearn.metrics.adjusted_rand_score`` would count 2 million pixels again (0.4 s) after
    importing scikit-learn (1 s).

    Examples
    --------
    >>> adjusted_rand(np.array([[2.0, 0.0], [0.0, 2.0]]))
    1.0
    >>> round(adjusted_rand(np.array([[1.0, 1.0], [1.0, 1.0]])), 9)
    -0.5
    """
    pairs = float((table * (table - 1)).sum() / 2)
    rows, cols = table.sum(axis=1), table.sum(axis=0)
    row_pairs = float((rows * (rows - 1)).sum() / 2)
    col_pairs = float((cols * (cols - 1)).sum() / 2)
    n = float(table.sum())
    total = n * (n - 1) / 2
    if total == 0 or row_pairs == col_pairs == total or row_pairs == col_pairs == 0:
        return 1.0
    expected = row_pairs * col_pairs / total
    top = (row_pairs + col_pairs) / 2
    return (pairs - expected) / (top - expected)


def score(segments: NDArray[np.integer], truth: NDArray[np.integer]) -> Scores:
    """Score label image ``segments`` against ``truth`` (both 0 = unlabelled).

    Sizes ``|s|``, ``|g|`` count every pixel of a segment / room; overlaps ``O[s, g]`` and ``N``
    count the pixels labelled on both sides.
    """
    if segments.shape != truth.shape:
        raise SegmentationError(
            f"segmentation shape {segments.shape} differs from ground truth {truth.shape}"
        )
    seg, seg_size = _numbered(_keep_large(segments))
    gt, gt_size = _numbered(_keep_large(truth))
    both = (seg > 0) & (gt > 0)
    n_gt = len(gt_size) + 1
    pairs = np.bincount(seg[both] * n_gt + gt[both], minlength=(len(seg_size) + 1) * n_gt)
    overlap = pairs.reshape(-1, n_gt)[1:, 1:].astype(float)
    n_seg, n_gt = overlap.shape
    if n_seg == 0 or n_gt == 0:
        return Scores(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, n_seg, n_gt)
    recall = overlap.max(axis=0)
    precision = overlap.max(axis=1)
    total = float(both.sum())
    pair_scores: list[float] = []
    order = np.argsort(-overlap, axis=None, kind="stable")
    used_s, used_g = np.zeros(n_seg, bool), np.zeros(n_gt, bool)
    for flat in order:
        s, g = divmod(int(flat), n_gt)
        if used_s[s] or used_g[g] or overlap[s, g] == 0:
            continue
        used_s[s] = used_g[g] = True
        tp = float(overlap[s, g])
        fp, fn = seg_size[s] - tp, gt_size[g] - tp
        pair_scores.append(_mcc(tp, fp, fn, total - (fp - gt_size[g])))
    unpaired = int((~used_s).sum() + (~used_g).sum())
    return Scores(
        recall=float(np.mean(recall / gt_size)),
        precision=float(np.mean(precision / seg_size)),
        recall_macro=float(recall.sum() / gt_size.sum()),
        precision_macro=float(precision.sum() / seg_size.sum()),
        mcc=float(np.sum(pair_scores) / (len(pair_scores) + unpaired)),
        ari=adjusted_rand(overlap),
        segments=n_seg,
        rooms=n_gt,
    )


#: ROSE²'s evaluation ignores rooms of the ground truth with at most this many pixels.
ROSE2_MIN_ROOM = 200


@dataclass(frozen=True)
class Rose2Scores:
    """ROSE²'s scores of one segmentation, in % (Luperto et al., RA-L 2022,
    ``code/util/evaluation.py``)."""

    precision: float
    recall: float
    iou: float

    def as_dict(self) -> dict[str, float]:
        """The scores as a plain dict, keys prefixed ``rose2_``."""
        return {f"rose2_{k}": v for k, v in asdict(self).items()}


def rose2_score(segments: NDArray[np.integer], truth: NDArray[np.integer]) -> Rose2Scores:
    """Score ``segments`` against ``truth`` (0 = no room / no segment) the way ROSE² does.

    Rooms of at most :data:`ROSE2_MIN_ROOM` pixels are ignored; ``|s|`` counts every pixel of a
    segment, ``|g|`` every pixel of a room. Precision is the mean over segments of
    ``max_g O[s, g] / |s|``, recall the mean over rooms of ``max_s O[s, g] / |g|``, IoU the mean
    over segments of ``O[s, g*] / (|s| + |g*| - O[s, g*])`` with ``g*`` the room of largest
    overlap (0 when the segment meets no room).

    Examples
    --------
    >>> truth = np.repeat([[1] * 20 + [2] * 20], 20, axis=0)
    >>> whole = rose2_score(truth, truth)
    >>> (whole.precision, whole.recall, whole.iou)
    (100.0, 100.0, 100.0)
    >>> one = rose2_score(np.ones_like(truth), truth)  # two rooms, one segment
    >>> (one.precision, one.recall, one.iou)
    (50.0, 100.0, 50.0)
    """
    if segments.shape != truth.shape:
        raise SegmentationError(
            f"segmentation shape {segments.shape} differs from ground truth {truth.shape}"
        )
    gt = truth.astype(np.int64)
    sizes = np.bincount(gt.ravel())
    gt = np.where(sizes[gt] > ROSE2_MIN_ROOM, gt, 0)
    gt[truth <= 0] = 0
    seg_ids, seg_index = np.unique(segments, return_inverse=True)
    gt_ids, gt_index = np.unique(gt, return_inverse=True)
    seg_index, gt_index = seg_index.reshape(gt.shape), gt_index.reshape(gt.shape)
    table = sparse.coo_matrix(
        (np.ones(gt.size), (seg_index.ravel(), gt_index.ravel())),
        shape=(len(seg_ids), len(gt_ids)),
    ).toarray()
    seg_size = table.sum(axis=1)[seg_ids > 0]
    gt_size = table.sum(axis=0)[gt_ids > 0]
    overlap = table[seg_ids > 0][:, gt_ids > 0]
    if overlap.shape[0] == 0 or overlap.shape[1] == 0:
        return Rose2Scores(0.0, 0.0, 0.0)
    best = overlap.max(axis=1)
    partner = gt_size[overlap.argmax(axis=1)]
    iou = np.where(best > 0, best / (seg_size + partner - best), 0.0)
    return Rose2Scores(
        precision=round(100 * float(np.mean(best / seg_size)), 3),
        recall=round(100 * float(np.mean(overlap.max(axis=0) / gt_size)), 3),
        iou=round(100 * float(np.mean(iou)), 3),
    )


def colour_labels(image: NDArray[np.uint8]) -> NDArray[np.int32]:
    """Rooms of a colour ground truth (black = no room, each other colour one room), 1..K.

    Examples
    --------
    >>> image = np.zeros((1, 4, 3), np.uint8)
    >>> image[0, 1] = image[0, 3] = (0, 0, 255)
    >>> image[0, 2] = (0, 255, 0)
    >>> colour_labels(image).tolist()
    [[0, 1, 2, 1]]
    """
    pixels = image[..., :3].reshape(-1, 3).astype(np.int64)
    key = (pixels[:, 0] << 16) | (pixels[:, 1] << 8) | pixels[:, 2]
    colours, index = np.unique(key, return_inverse=True)
    labels = index.astype(np.int32) + (0 if colours[0] == 0 else 1)
    return labels.reshape(image.shape[:2])
