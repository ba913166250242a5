"""Regions of a growing map keep their ids: matching, merges, splits, new and removed ids."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from maps.grid import OccupancyGrid
from segmentation.growing import align, carry_ids

shapes = st.tuples(st.integers(1, 12), st.integers(1, 12))
labels = arrays(np.int32, shapes, elements=st.integers(0, 6))


@given(labels, st.permutations(list(range(1, 7))))
def test_the_same_regions_under_other_ids_get_their_ids_back(previous, permutation):
    lookup = np.array([0, *permutation])
    found = carry_ids(previous, lookup[previous])
    assert np.array_equal(found.labels, previous)
    assert {e["event"] for e in found.events} <= {"kept"}


@given(labels, labels)
def test_ids_are_unique_and_new_ids_were_never_used(previous, new):
    new = new[: previous.shape[0], : previous.shape[1]]
    previous = previous[: new.shape[0], : new.shape[1]]
    found = carry_ids(previous, new, next_id=20)
    carried = list(found.ids.values())
    assert len(carried) == len(set(carried))  # two regions never share an id
    old = set(np.unique(previous[previous > 0]).tolist())
    assert all(v in old or v >= 20 for v in carried)
    assert found.next_id == max([20, *[v + 1 for v in carried if v >= 20]])
    # the label image is the new partition under other names: same cells together
    pairs = set(zip(new.ravel().tolist(), found.labels.ravel().tolist(), strict=True))
    assert len(pairs) == len({a for a, _ in pairs}) and all((a == 0) == (b == 0) for a, b in pairs)


def test_a_merge_keeps_the_older_id_and_names_the_absorbed_one():
    previous = np.array([[3, 3, 9, 9, 0, 0]])
    found = carry_ids(previous, np.array([[1, 1, 1, 1, 2, 2]]))
    assert found.labels.tolist() == [[3, 3, 3, 3, 10, 10]]
    assert {"event": "merged", "region": 3, "absorbed": [9]} in found.events
    assert {"event": "created", "region": 10} in found.events


def test_a_split_keeps_the_id_on_the_larger_piece_and_a_region_gone_is_removed():
    previous = np.array([[4, 4, 4, 4, 4, 6]])
    found = carry_ids(previous, np.array([[1, 1, 2, 2, 2, 0]]))
    assert found.labels.tolist() == [[7, 7, 4, 4, 4, 0]]
    assert {"event": "split", "region": 7, "source": 4} in found.events
    assert {"event": "removed", "region": 6} in found.events


def test_align_follows_the_map_frame_at_any_resolution_and_yaw():
    old = OccupancyGrid(np.zeros((3, 3), np.int8), 0.5, origin=(1.0, 2.0, 0.0))
    previous = np.arange(9).reshape(3, 3)
    new = OccupancyGrid(np.zeros((4, 5), np.int8), 0.5, origin=(0.0, 2.0, 0.0))
    moved = align(old, previous, new)
    # old cell (row 2, col 0) has its lower-left corner at (1, 2): new cell (row 3, col 2)
    assert moved[3, 2] == previous[2, 0] and moved[1, 4] == previous[0, 2]
    assert moved[:, :2].sum() == 0 and moved[0].sum() == 0
    finer = align(old, previous, OccupancyGrid(np.zeros((6, 6), np.int8), 0.25, (1.0, 2.0, 0.0)))
    assert np.array_equal(finer, np.repeat(np.repeat(previous, 2, axis=0), 2, axis=1))
    # the old map turned a quarter turn about its corner: its bottom row stands on the left of
    # it, its first cell lowest (rows count down)
    turned = OccupancyGrid(old.cells, 0.5, (1.0, 2.0, np.pi / 2))
    assert align(turned, previous, new)[1:, 1].tolist() == previous[2, ::-1].tolist()


def _align_everywhere(previous, labels, grid):
    """align's reference: every cell of ``grid`` looked up in ``previous``."""
    rows, cols = np.indices(grid.shape)
    r, c = previous.world_to_cell(*grid.cell_to_world(rows, cols))
    inside = previous.contains(r, c)
    out = np.zeros(grid.shape, np.int32)
    out[inside] = labels[r[inside], c[inside]]
    return out


@given(
    arrays(np.int32, (6, 7), elements=st.integers(0, 4)),
    st.sampled_from([0.05, 0.1, 0.2]),
    st.floats(-1.0, 1.0),
    st.floats(-3.0, 3.0),
    st.floats(-np.pi, np.pi),
)
def test_align_looks_at_the_previous_regions_box_only_and_finds_what_every_cell_would(
    labels, resolution, x, y, yaw
):
    previous = OccupancyGrid(np.zeros((6, 7), np.int8), 0.1, (0.3, -0.2, 0.4))
    grid = OccupancyGrid(np.zeros((40, 50), np.int8), resolution, (x - 1.0, y - 1.0, yaw))
    np.testing.assert_array_equal(
        align(previous, labels, grid), _align_everywhere(previous, labels, grid)
    )


def test_ids_are_carried_the_same_on_a_canvas_round_the_regions():
    previous = np.zeros((300, 400), np.int64)
    labels = np.zeros((300, 400), np.int64)
    previous[100:120, 150:170], previous[100:120, 170:200] = 4, 9
    labels[100:120, 150:185], labels[100:120, 185:200], labels[130:135, 150:160] = 1, 2, 3
    tight = carry_ids(previous[95:140, 145:205], labels[95:140, 145:205], next_id=12)
    wide = carry_ids(previous, labels, next_id=12)
    assert np.array_equal(wide.labels[95:140, 145:205], tight.labels)
    assert not wide.labels[:95].any() and (wide.ids, wide.events) == (tight.ids, tight.events)
