import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy import ndimage

from maps.errors import InvalidMapError, InvalidScanError
from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import select_keyframes
from maps.sim.exploration import wander
from maps.sim.floorplan import generate_floor_plan
from maps.sim.laser import LaserModel, simulate_keyframes, simulate_scans


def square_room(side_cells=200, resolution=0.05):
    free = np.zeros((side_cells, side_cells), bool)
    free[1:-1, 1:-1] = True
    return OccupancyGrid.from_masks(free, resolution)


@given(x=st.floats(1.0, 9.0), y=st.floats(1.0, 9.0), yaw=st.floats(-math.pi, math.pi))
@settings(max_examples=30, deadline=None)
def test_ranges_in_a_square_room_are_analytic(x, y, yaw):
    grid = square_room()  # free space spans [0.05, 9.95] m on both axes
    model = LaserModel(fov=2 * math.pi, beams=360, max_range=30.0)
    (frame,) = simulate_scans(grid, [(x, y, yaw)], model)
    angles = yaw + frame.scan.angles
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (9.95 - x) / c, (0.05 - x) / c)
        ty = np.where(s > 0, (9.95 - y) / s, (0.05 - y) / s)
    expected = np.minimum(
        np.where(np.abs(c) < 1e-12, np.inf, tx), np.where(np.abs(s) < 1e-12, np.inf, ty)
    )
    np.testing.assert_allclose(frame.scan.ranges, expected, atol=1e-5)


@given(x=st.floats(-2.0, 6.0), y=st.floats(-2.0, 5.0), yaw=st.floats(-math.pi, math.pi))
@settings(max_examples=30, deadline=None)
def test_rays_end_at_the_edge_of_a_map_without_walls(x, y, yaw):
    # every cell free: a ray stops where it leaves the grid ([0, 4] x [0, 3] m); a pose off
    # the grid sees nothing (range 0, below min_range: -inf)
    grid = OccupancyGrid.from_masks(np.ones((30, 40), bool), 0.1)
    model = LaserModel(fov=2 * math.pi, beams=90, max_range=30.0, min_range=0.0)
    (frame,) = simulate_scans(grid, [(x, y, yaw)], model)
    near_edge = min(abs(x), abs(x - 4), abs(y), abs(y - 3)) < 1e-6  # on it: either
    assume(not near_edge)
    inside = 0 < x < 4 and 0 < y < 3
    if not inside:
        assert (frame.scan.ranges == 0).all()
        return
    angles = yaw + frame.scan.angles
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c > 0, (4.0 - x) / c, -x / c)
        ty = np.where(s > 0, (3.0 - y) / s, -y / s)
    expected = np.minimum(
        np.where(np.abs(c) < 1e-12, np.inf, tx), np.where(np.abs(s) < 1e-12, np.inf, ty)
    )
    np.testing.assert_allclose(frame.scan.ranges, expected, atol=1e-5)


@pytest.mark.parametrize("yaw", [math.pi, 0.0, math.pi / 2, -math.pi / 2])
def test_ray_along_a_cell_boundary_in_a_corridor(yaw):
    # a pose on a cell corner in a 0.2 m wide, 99.9 m long corridor; beams along grid lines.
    # The one at yaw = pi has a direction of (-1, -1.2e-16): it must step cell by cell, not
    # creep along the boundary it starts on (the caster once took 40 s for that one ray)
    free = np.zeros((2000, 2000), bool)
    free[998:1002, 1:-1] = True  # x in [0.05, 99.95] m, y in [49.9, 50.1] m
    grid = OccupancyGrid.from_masks(free, 0.05)
    model = LaserModel(fov=math.pi, beams=3, max_range=60.0)  # beams at -90, 0, 90 degrees
    (frame,) = simulate_scans(grid, [(50.0, 50.0, yaw)], model)
    along_x = abs(math.cos(yaw)) > 0.5
    expected = [0.1, 49.95, 0.1] if along_x else [49.95, 0.1, 49.95]
    np.testing.assert_allclose(frame.scan.ranges, expected, atol=1e-6)


def test_max_range_noise_dropout_and_seed():
    grid = square_room()
    far = simulate_scans(grid, [(5.0, 5.0, 0.0)], LaserModel(max_range=2.0))[0]
    assert np.all(np.isposinf(far.scan.ranges))
    model = LaserModel(noise=0.05, dropout=0.2)
    a = simulate_scans(grid, [(5.0, 5.0, 0.0)] * 50, model, random_state=3)
    b = simulate_scans(grid, [(5.0, 5.0, 0.0)] * 50, model, random_state=3)
    ranges = np.array([k.scan.ranges for k in a])
    np.testing.assert_array_equal(ranges, np.array([k.scan.ranges for k in b]))
    assert 0.15 < np.isinf(ranges).mean() < 0.25
    errors = ranges[:, 90][np.isfinite(ranges[:, 90])] - 4.95
    assert 0.03 < errors.std() < 0.07


def test_bad_laser_models():
    for kwargs in ({"beams": 1}, {"fov": 0.0}, {"max_range": math.inf}, {"dropout": 2.0}):
        with pytest.raises(InvalidScanError):
            LaserModel(**kwargs)
    with pytest.raises(InvalidScanError):
        simulate_scans(square_room(), [(1.0, float("nan"), 0.0)])


def test_map_from_simulated_keyframes_matches_the_room():
    grid = square_room()
    rng = np.random.default_rng(0)
    poses = np.column_stack((rng.uniform(2, 8, 40), rng.uniform(2, 8, 40), rng.uniform(-3, 3, 40)))
    frames = simulate_scans(grid, poses, LaserModel(fov=2 * math.pi, beams=720))
    built = grid_from_keyframes(frames, 0.05)
    xs, ys = grid.cell_to_world(*np.nonzero(grid.free))
    assert built.is_free(xs, ys).mean() > 0.97
    wall_x, wall_y = grid.cell_to_world(*np.nonzero(grid.occupied))
    rows, cols = built.world_to_cell(wall_x, wall_y)
    inside = built.contains(rows, cols)
    assert built.occupied[rows[inside], cols[inside]].mean() > 0.9
    with pytest.raises(InvalidScanError):
        grid_from_keyframes([])


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("size", ["flat", (40.0, 30.0)])
def test_generated_ground_truth(size, seed):
    plan = generate_floor_plan(size, furniture=0.3, random_state=seed)
    labels, free = plan.labels, plan.grid.free
    assert set(plan.types) <= {"room", "corridor", "hall"} and "corridor" in plan.types
    assert np.all(labels[free] > 0), "every free cell belongs to a room"
    for label in range(1, plan.n_rooms + 1):
        floor = free & (labels == label)
        assert ndimage.label(floor)[1] == 1, f"space {label} is one piece"
    assert ndimage.label(free)[1] == 1, "every space is reachable"
    for door in plan.doors:
        assert 0.8 <= door.width <= 1.2
        assert plan.grid.is_free(door.x, door.y)
    again = generate_floor_plan(size, furniture=0.3, random_state=seed)
    assert again.grid == plan.grid and np.array_equal(again.labels, plan.labels)


def test_office_and_campus_sizes():
    office = generate_floor_plan("office", random_state=0)
    counts = {t: office.types.count(t) for t in set(office.types)}
    assert 40 <= counts["room"] <= 120 and counts["hall"] >= 1 and counts["corridor"] >= 3
    campus = generate_floor_plan("campus", resolution=0.2, random_state=0)
    assert campus.types.count("room") >= 200
    with pytest.raises(InvalidMapError):
        generate_floor_plan("castle")
    with pytest.raises(InvalidMapError):
        generate_floor_plan((5.0, 5.0))


@pytest.mark.parametrize("seed", [0, 1])
def test_wandering_robot_visits_every_room_without_collision(seed):
    plan = generate_floor_plan("flat", furniture=0.3, random_state=seed)
    route = wander(plan.grid, plan.labels, robot_radius=0.25, random_state=seed)
    assert set(route.visited) == set(range(1, plan.n_rooms + 1)) and not route.unreachable
    assert plan.grid.inflate(0.25).is_free(route.poses[:, 0], route.poses[:, 1]).all()
    steps = np.hypot(*np.diff(route.poses[:, :2], axis=0).T)
    assert steps.max() <= 0.05 + 1e-9
    visited_cells = plan.labels[plan.grid.world_to_cell(route.poses[:, 0], route.poses[:, 1])]
    assert set(np.unique(visited_cells)) >= set(range(1, plan.n_rooms + 1))
    frames = simulate_scans(plan.grid, route.poses, random_state=seed)
    keyframes = select_keyframes(frames)
    assert 10 < len(keyframes) < len(frames)


def test_keyframes_simulated_alone_equal_those_kept_from_every_scan():
    plan = generate_floor_plan("flat", random_state=4)
    route = wander(plan.grid, plan.labels, random_state=4)
    model = LaserModel(beams=91)
    every = select_keyframes(simulate_scans(plan.grid, route.poses, model), distance=0.4)
    alone = simulate_keyframes(plan.grid, route.poses, model, distance=0.4)
    assert len(alone) < len(route.poses) / 4
    assert [k.scan_index for k in alone] == [k.scan_index for k in every]
    for a, b in zip(alone, every, strict=True):
        assert a.pose == b.pose
        np.testing.assert_array_equal(a.scan.ranges, b.scan.ranges)
