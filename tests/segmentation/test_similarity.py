import math

import numpy as np
import pytest
from scipy.spatial.distance import directed_hausdorff

import maps
from maps.sim.laser import LaserModel, simulate_scans
from segmentation.cloud import ScanCloud
from segmentation.errors import ParameterError, SegmentationError
from segmentation.similarity import (
    Hausdorff,
    NearestNeighbour,
    Pairwise,
    SharedFeatures,
    as_criterion,
    candidate_pairs,
    corners,
)
from segmentation.virtual import virtual_keyframes
from topomap.cli.naive import naive_nearest_neighbour


@pytest.fixture(scope="module")
def flat_keyframes():
    plan = maps.generate_floor_plan("flat", random_state=3)
    return virtual_keyframes(plan.grid, 1.5, random_state=0)


def test_nearest_neighbour_equals_the_all_pairs_reference(flat_keyframes):
    fast = NearestNeighbour().affinity(flat_keyframes).toarray()
    slow = naive_nearest_neighbour(flat_keyframes)
    assert fast.shape == slow.shape == (len(flat_keyframes),) * 2
    np.testing.assert_allclose(fast, slow, atol=1e-9)
    assert np.all(np.diag(fast) == 0) and np.all(fast == fast.T)
    assert 0 < fast.max() <= 1
    # pairs seeing nothing in common are absent from the sparse matrix
    assert (fast == 0).mean() > 0.1


def test_hausdorff_matches_scipy_on_candidate_pairs(flat_keyframes):
    criterion = Hausdorff()
    affinity = criterion.affinity(flat_keyframes).toarray()
    cloud = ScanCloud.from_keyframes(flat_keyframes, criterion.resolution)
    points = cloud.split()
    i, j = candidate_pairs(cloud, criterion.reach)
    distance = np.array(
        [
            max(
                directed_hausdorff(points[a], points[b])[0],
                directed_hausdorff(points[b], points[a])[0],
            )
            for a, b in zip(i, j, strict=True)
        ]
    )
    np.testing.assert_allclose(affinity[i, j], 1 - distance / distance.max(), atol=1e-9)


def test_corners_of_an_l_shaped_wall():
    along_x = np.column_stack([np.linspace(3.0, 0.0, 31), np.full(31, 2.0)])
    along_y = np.column_stack([np.zeros(30), np.linspace(1.9, -1.0, 30)])
    found = corners(np.vstack([along_x, along_y]))
    assert len(found) == 1
    np.testing.assert_allclose(found[0], [0.0, 2.0], atol=0.11)
    assert len(corners(along_x)) == 0  # a straight wall has none


def test_two_views_of_one_room_share_its_four_corners():
    grid = maps.OccupancyGrid.from_masks(np.pad(np.ones((60, 80), bool), 2), 0.05)
    frames = simulate_scans(
        grid,
        [[1.5, 1.5, 0.0], [2.5, 1.8, 1.0]],
        LaserModel(fov=2 * math.pi, beams=720, max_range=10),
    )
    shared = SharedFeatures().affinity(frames).toarray()
    assert shared[0, 1] == shared[1, 0] == 4


def test_rooms_behind_a_wall_are_not_similar(two_rooms):
    # a wall thicker than the tolerance keeps the two sides' points apart
    grid = two_rooms(door=0.0, wall=0.3)
    frames = simulate_scans(
        grid, [[2, 2, 0], [2.5, 2.5, 0], [6, 2, 0]], LaserModel(fov=2 * math.pi)
    )
    affinity = NearestNeighbour().affinity(frames).toarray()
    assert affinity[0, 1] > 0.3
    assert affinity[0, 2] < 0.1 and affinity[1, 2] < 0.1


def test_a_callable_is_a_criterion(flat_keyframes):
    calls = []

    def overlap(a, b):
        calls.append(1)
        return float(len(a) + len(b))

    affinity = as_criterion(overlap).affinity(flat_keyframes[:6])
    assert len(calls) > 0 and affinity.nnz == 2 * len(calls)
    with pytest.raises(ParameterError, match="finite"):
        Pairwise(lambda a, b: math.nan).affinity(flat_keyframes[:6])


def test_bad_criteria_and_scans(flat_keyframes):
    with pytest.raises(ParameterError, match="known: auto, features, hausdorff, nn, view"):
        as_criterion("cosine")
    with pytest.raises(ParameterError, match="tolerance"):
        NearestNeighbour(tolerance=-1)
    with pytest.raises(SegmentationError, match="no keyframes"):
        NearestNeighbour().affinity([])
    blind = maps.Keyframe((0, 0, 0), maps.LaserScan(np.full(5, np.inf), 0.0, 0.1), scan_index=7)
    with pytest.raises(SegmentationError, match="scan_index 7"):
        NearestNeighbour().affinity([*flat_keyframes[:3], blind])
