"""Labels grown a ring at a time (segmentation.working.grow) against a breadth-first search."""

from collections import deque

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from segmentation.working import ALL_AROUND, AROUND, grow


def _nearest_labels(labels, keep, around):
    """Per cell, the labels at the least number of steps through ``keep`` (a plain BFS from
    every labelled cell at once); empty where none reaches."""
    height, width = keep.shape
    steps = np.full(keep.shape, -1)
    found = [[set() for _ in range(width)] for _ in range(height)]
    queue = deque()
    for r, c in zip(*np.nonzero(labels > 0), strict=True):
        steps[r, c] = 0
        found[r][c] = {int(labels[r, c])}
        queue.append((r, c))
    while queue:
        r, c = queue.popleft()
        for dr, dc in around:
            rr, cc = r + dr, c + dc
            if not (0 <= rr < height and 0 <= cc < width) or not keep[rr, cc]:
                continue
            if steps[rr, cc] == -1:
                steps[rr, cc] = steps[r, c] + 1
                queue.append((rr, cc))
            if steps[rr, cc] == steps[r, c] + 1:
                found[rr][cc] |= found[r][c]
    return found


@settings(max_examples=60, deadline=None)
@given(
    keep=arrays(bool, st.tuples(st.integers(2, 12), st.integers(2, 12))),
    data=st.data(),
    corners=st.booleans(),
)
def test_every_cell_takes_a_nearest_label(keep, data, corners):
    seeds = data.draw(arrays(np.int32, keep.shape, elements=st.integers(0, 3)))
    seeds = np.where(keep, seeds, 0).astype(np.int32)
    around = ALL_AROUND if corners else AROUND
    grown = grow(seeds.copy(), keep, around)
    nearest = _nearest_labels(seeds, keep, around)
    for r, c in np.ndindex(keep.shape):
        if seeds[r, c]:
            assert grown[r, c] == seeds[r, c]  # a seed keeps its label
        elif keep[r, c] and nearest[r][c]:
            assert grown[r, c] in nearest[r][c]
        else:  # a wall, or a kept cell no label reaches
            assert grown[r, c] == 0
