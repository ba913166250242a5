"""Labels grown a ring at a time (segmentation.working.grow) against a breadth-first search."""

from collections import deque

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from maps.grid import OccupancyGrid, clearance_of
from segmentation.working import ALL_AROUND, AROUND, grow, pool


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


@settings(max_examples=60, deadline=None)
@given(
    free=arrays(bool, st.tuples(st.integers(1, 23), st.integers(1, 23))),
    factor=st.integers(1, 5),
)
def test_a_working_cell_is_free_where_all_its_map_cells_are(free, factor):
    grid = OccupancyGrid.from_masks(free, 0.02)
    pooled = pool(free, grid, factor, fine_clearance=True)
    rows, cols = -(-free.shape[0] // factor), -(-free.shape[1] // factor)
    blocks = np.zeros((rows * factor, cols * factor), bool)
    blocks[: free.shape[0], : free.shape[1]] = free
    blocks = blocks.reshape(rows, factor, cols, factor)
    assert np.array_equal(pooled.free, blocks.all(axis=(1, 3)))
    fine = np.zeros(blocks.shape, np.float32)
    fine.reshape(rows * factor, cols * factor)[:] = clearance_of(
        blocks.reshape(rows * factor, cols * factor), 0.02
    )
    expected = np.where(pooled.free, fine.min(axis=(1, 3)), 0)  # each block's least
    assert np.array_equal(pooled.free_clearance(), expected)


@given(width=st.integers(24, 40), top=st.integers(0, 1))
def test_the_working_clearance_is_a_map_cells_not_a_working_cells(width, top):
    free = np.zeros((60, 40), bool)
    free[5 + top : 5 + top + width] = True  # a corridor, its walls one way or the other of a block
    grid = OccupancyGrid.from_masks(free, 0.05)
    true = float(clearance_of(free, 0.05).max())
    fine = float(pool(free, grid, 2, fine_clearance=True).free_clearance().max())
    coarse = float(pool(free, grid, 2).free_clearance().max())
    assert true - 0.05 - 1e-6 <= fine <= true  # off by at most a map cell, whatever the phase
    assert abs(coarse - true) <= 0.1 + 1e-6  # a working cell: twice the error
