"""The working grid: labels grown a ring at a time (segmentation.working.grow) against a
breadth-first search, and blocks laid by the map (block_phase): a map one cell over alike."""

from collections import deque

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import maps
from maps.grid import OccupancyGrid, clearance_of
from segmentation.pipeline import MapSegmenter
from segmentation.working import ALL_AROUND, AROUND, block_phase, grow, pool, unpool


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


@st.composite
def _rooms(draw):
    """A space of a few overlapping rectangles (rooms and corridors), with a few cells off."""
    height, width = draw(st.integers(6, 30)), draw(st.integers(6, 30))
    space = np.zeros((height, width), bool)
    for _ in range(draw(st.integers(1, 4))):
        top, left = draw(st.integers(0, height - 2)), draw(st.integers(0, width - 2))
        rows, cols = draw(st.integers(2, height - top)), draw(st.integers(2, width - left))
        space[top : top + rows, left : left + cols] = True
    for _ in range(draw(st.integers(0, 5))):
        space[draw(st.integers(0, height - 1)), draw(st.integers(0, width - 1))] = False
    return space


@settings(max_examples=80, deadline=None)
@given(
    space=_rooms(),
    factor=st.integers(2, 3),
    down=st.integers(0, 2),
    right=st.integers(0, 2),
)
@example(space=np.pad(np.ones((2, 2), bool), ((0, 4), (0, 4))), factor=2, down=0, right=1)
def test_a_map_one_cell_over_pools_to_the_same_working_grid(space, factor, down, right):
    """The blocks fall where the space keeps the most of them whole (block_phase), so the
    same space padded above and left pools to the same working grid and labels come back to
    the same cells; only where two ways of laying the blocks tie may it differ."""
    counts = []
    for top in range(factor):
        for left in range(factor):
            padded = np.pad(space, ((top, factor), (left, factor)))
            counts.append(int(pool(padded, _grid(padded), factor).free.sum()))
    assume(counts.count(max(counts)) == 1)  # one best way: no tie to break
    moved = np.pad(space, ((down, 0), (right, 0)))
    pooled = [
        pool(cells, _grid(cells), factor, phase=block_phase(cells, factor))
        for cells in (space, moved)
    ]
    first, second = (_trimmed(p.free) for p in pooled)
    assert first.shape == second.shape and (first == second).all()
    # every working cell a label of its own, 1 up: a label 0 would be no region
    labels = [
        np.arange(1, p.free.size + 1, dtype=np.int32).reshape(p.free.shape) * p.free for p in pooled
    ]
    back = [
        unpool(found, factor, cells, block_phase(cells, factor))
        for found, cells in zip(labels, (space, moved), strict=True)
    ]
    assert ((back[0] > 0) == (back[1][down:, right:] > 0)).all()


def _grid(cells):
    return OccupancyGrid.from_masks(cells, 0.05)


def _trimmed(free):
    """``free`` without its all-False border rows and columns."""
    rows, cols = np.flatnonzero(free.any(axis=1)), np.flatnonzero(free.any(axis=0))
    if not len(rows):
        return free[:0, :0]
    return free[rows[0] : rows[-1] + 1, cols[0] : cols[-1] + 1]


@pytest.mark.parametrize(("left", "top"), [(1, 0), (0, 1), (1, 1)])
def test_a_plan_one_cell_over_is_segmented_alike(left, top):
    """MapSegmenter lays its working blocks by the map (block_phase), so the generated flat
    padded by a cell gives the same regions on the same cells (with the blocks at the array's
    corner they differ)."""
    grid = maps.generate_floor_plan("flat", random_state=0).grid
    found = MapSegmenter().segment(grid, random_state=0).regions.labels
    moved = MapSegmenter().segment(grid.padded(left, top), random_state=0).regions.labels
    assert (moved[top:, left:] == found).all()
