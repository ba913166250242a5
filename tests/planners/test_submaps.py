"""Near-convex submaps: a partition of each region, cut only where the region is concave."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from skimage.measure import regionprops

from planners.submaps import convex_parts


def test_convex_region_stays_whole_and_an_l_is_cut():
    labels = np.zeros((60, 60), np.int32)
    labels[5:25, 5:55] = 1  # a rectangle
    labels[30:58, 5:15] = 2  # an L: a bar and a foot
    labels[48:58, 15:55] = 2
    parts, region_of = convex_parts(labels, min_cells=50)
    assert sorted(region_of.values()).count(1) == 1
    pieces = [p for p, r in region_of.items() if r == 2]
    assert len(pieces) >= 2
    for part in pieces:
        assert regionprops((parts == part).astype(np.uint8))[0].solidity >= 0.85


@given(seed=st.integers(0, 1000))
def test_parts_partition_every_region(seed):
    rng = np.random.default_rng(seed)
    labels = np.zeros((50, 50), np.int32)
    for region in range(1, 5):  # random unions of rectangles
        for _ in range(3):
            r, c = rng.integers(0, 40, 2)
            h, w = rng.integers(3, 15, 2)
            labels[r : r + h, c : c + w] = region
    parts, region_of = convex_parts(labels, min_cells=20)
    assert np.array_equal(parts > 0, labels > 0)
    for part, region in region_of.items():
        assert np.all(labels[parts == part] == region)
