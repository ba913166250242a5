"""The tiles of :class:`maps.mapping.MapBuilder` hold the same counts as one array."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import maps
import maps.mapping
from maps.mapping import MapBuilder


@pytest.fixture(scope="module")
def flat_keyframes():
    plan = maps.generate_floor_plan("flat", random_state=1)
    route = maps.wander(plan.grid, plan.labels, random_state=1)
    scans = maps.simulate_scans(plan.grid, route.poses, maps.LaserModel(), random_state=1)
    return maps.select_keyframes(scans)[:40]


def _grown(keyframes, tile: int, monkeypatch) -> MapBuilder:
    monkeypatch.setattr(maps.mapping, "TILE", tile)
    builder = MapBuilder(0.1)
    for keyframe in keyframes:
        builder.add(keyframe)
    return builder


@settings(max_examples=15, deadline=None)
@given(
    tile=st.integers(3, 40),
    shift=st.tuples(st.floats(-300, 300), st.floats(-300, 300)),
    order=st.randoms(use_true_random=False),
)
def test_any_tiles_hold_the_map_of_one_tile(flat_keyframes, tile, shift, order):
    """Growing in every direction (keyframes in any order, anywhere), tiles of a few cells give
    the grid of tiles larger than the map, whole and in parts."""
    keyframes = [
        dataclasses.replace(k, pose=(k.pose[0] + shift[0], k.pose[1] + shift[1], k.pose[2]))
        for k in flat_keyframes
    ]
    order.shuffle(keyframes)
    with pytest.MonkeyPatch.context() as monkeypatch:
        one = _grown(keyframes, 2048, monkeypatch).grid()
        small = _grown(keyframes, tile, monkeypatch)
        assert len(small._tiles) > 1
        whole = small.grid()
        at = np.array(keyframes[0].pose[:2])
        part = small.grid(at - 2.3, at + 1.7)
    assert whole.origin == one.origin and np.array_equal(whole.cells, one.cells)
    rows, cols = np.nonzero(part.free | part.occupied)
    assert len(rows) > 0
    r, c = one.world_to_cell(*part.cell_to_world(rows, cols))
    assert np.array_equal(part.cells[rows, cols], one.cells[r, c])


@settings(max_examples=15, deadline=None)
@given(tile=st.integers(3, 40), cut=st.integers(1, 39), shift=st.floats(-50, 50))
def test_a_snapshot_keeps_the_map_of_its_keyframes_as_later_ones_arrive(
    flat_keyframes, tile, cut, shift
):
    """The snapshot's grid is the map of the keyframes before it (the grid
    grid_from_keyframes makes of them, on the same cells), however many tiles later keyframes
    write to, and the builder's own grid is the map of all of them."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(maps.mapping, "TILE", tile)
        moved = [
            dataclasses.replace(k, pose=(k.pose[0] + shift, k.pose[1] - shift, k.pose[2]))
            for k in flat_keyframes
        ]
        builder = MapBuilder(0.1)
        for keyframe in moved[:cut]:
            builder.add(keyframe)
        before = builder.snapshot()
        for keyframe in moved[cut:]:
            builder.add(keyframe)
        for found, keyframes in ((before, moved[:cut]), (builder, moved)):
            grid = found.grid()
            expected = maps.grid_from_keyframes(keyframes, 0.1)
            assert np.array_equal(grid.cells, expected.cells)
            assert np.allclose(grid.origin, expected.origin, atol=1e-6)
