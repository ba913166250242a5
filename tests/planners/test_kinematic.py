"""Footprint robots: specs, the configuration space against an independent footprint sweep,
and the hierarchical and flat OMPL planners (collision-free, continuous, door-fit, fallback
routes, seeds, typed errors)."""

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from maps.grid import OCCUPIED, OccupancyGrid
from maps.sim.floorplan import generate_floor_plan
from planners.cspace import HeadingCSpace
from planners.errors import InvalidQueryError, NoPathError, PlannerParameterError, PlanningError
from planners.kinematic import POSE_SPACING, FlatKinematicPlanner, KinematicOMPL
from planners.kinematic_hierarchical import KinematicHierarchicalPlanner
from planners.robots import Dubins, Footprint, ReedsShepp, RobotSpecError, parse_robot, rectangle
from planners.sweep import footprint_collisions
from segmentation.errors import RegionNotFoundError
from segmentation.graph import region_graph
from segmentation.regions import Regions

ROOT = Path(__file__).resolve().parents[2]
ROBOTS = [
    "rect:0.6x0.4",
    "dubins:radius=0.5,footprint=0.6x0.4",
    "reeds-shepp:radius=0.5,footprint=0.6x0.4",
]


@pytest.mark.parametrize(
    ("spec", "kind"),
    [("rect:0.6x0.4", Footprint), (ROBOTS[1], Dubins), (ROBOTS[2], ReedsShepp)],
)
def test_specs_give_their_models(spec, kind):
    robot = parse_robot(spec)
    assert type(robot) is kind and robot.width == pytest.approx(0.4)


@pytest.mark.parametrize(
    ("spec", "named"),
    [
        ("rect:0.6", "'0.6'"),
        ("rect:0x0.4", "'0'"),
        ("dubins:radius=nan,footprint=0.6x0.4", "'nan'"),
        ("dubins:footprint=0.6x0.4", "radius=R"),
        ("reeds-shepp:radius=1,footprint=1x1,speed=2", "speed"),
        ("tank:1", "'tank:1'"),
        ("rect:1e6x0.1", "footprint length must be at most 10 m, got '1e6'"),
        ("disc:1000", "robot radius must be at most 10 m"),
        ("dubins:radius=1,footprint=1e5x1e5", "footprint length must be at most 10 m"),
        ("reeds-shepp:radius=50,footprint=1x1", "turning radius must be at most 10 m"),
        ("dubins:radius=1e-9,footprint=0.5x0.3", "turning radius must be at least 0.01 m"),
    ],
)
def test_bad_specs_are_typed_errors_naming_the_value(spec, named):
    with pytest.raises(RobotSpecError, match=named) as caught:
        parse_robot(spec)
    assert isinstance(caught.value, PlanningError) and isinstance(caught.value, ValueError)


def test_a_footprint_too_large_for_its_kernel_is_refused_before_building_it():
    with pytest.raises(RobotSpecError, match=r"reaches 14\.1 m"):
        Footprint(rectangle(10, 10) * 2)
    grid = OccupancyGrid(np.zeros((20, 20), np.int8), resolution=0.005)
    with pytest.raises(PlannerParameterError, match=r"spans 2973 cells of 0\.005 m, more than 501"):
        HeadingCSpace(grid, parse_robot("rect:10x10"))


def _blobs(seed: int) -> OccupancyGrid:
    rng = np.random.default_rng(seed)
    cells = np.zeros((30, 30), np.int8)
    for r, c in rng.integers(0, 30, size=(6, 2)):
        cells[r : r + rng.integers(1, 4), c : c + rng.integers(1, 4)] = OCCUPIED
    return OccupancyGrid(cells, resolution=0.1, origin=(1.0, -2.0, float(rng.uniform(-1, 1))))


@given(
    seed=st.integers(0, 10_000),
    u=st.floats(0.1, 0.9),
    v=st.floats(0.1, 0.9),
    yaw=st.floats(-math.pi, math.pi),
)
def test_valid_states_pass_the_sweep_and_clear_ones_are_valid(seed, u, v, yaw):
    grid = _blobs(seed)
    robot = Footprint(rectangle(0.7, 0.3))
    space = HeadingCSpace(grid, robot, headings=32)
    xmin, ymin, xmax, ymax = grid.bounds()
    x, y = xmin + u * (xmax - xmin), ymin + v * (ymax - ymin)
    valid = space.valid(x, y, yaw)
    assert valid == space.valid_many([(x, y, yaw)])[0]
    if valid:  # sound: the footprint touches no blocked cell
        assert footprint_collisions(grid, robot.polygon, [(x, y, yaw)]) == 0
    # not far from exact: a footprint clear by the bin, the margin and a cell's diagonal is valid
    slack = 0.7 / 2 * 2 * math.pi / 32 + 0.05 + 0.1 * math.sqrt(2) + 0.01
    grown = Footprint(rectangle(0.7 + 2 * slack, 0.3 + 2 * slack))
    if footprint_collisions(grid, grown.polygon, [(x, y, yaw)]) == 0:
        assert valid


def _rooms(door: float, width: float = 4.0) -> tuple[OccupancyGrid, np.ndarray]:
    """Two rooms ``width`` m wide and a 0.1 m wall between them with a ``door``, labelled."""
    res = 0.05
    h, w = round(width / res), round(8.2 / res)
    cells = np.full((h, w), OCCUPIED, np.int8)
    cells[2:-2, 2:-2] = 0
    cells[:, w // 2 - 1 : w // 2 + 1] = OCCUPIED
    top = h // 2 - round(door / res) // 2
    cells[top : top + round(door / res), w // 2 - 1 : w // 2 + 1] = 0
    grid = OccupancyGrid(cells, res)
    labels = np.where(np.arange(w) < w // 2, 1, 2)[None].repeat(h, 0) * grid.free
    return grid, labels.astype(np.int32)


def _planner(spec, door=1.0, **options):
    grid, labels = _rooms(door)
    graph = region_graph(Regions(grid, labels))
    space = HeadingCSpace(grid, parse_robot(spec))
    return KinematicHierarchicalPlanner(space, labels, graph, time_limit=5.0, **options)


def _check(path, grid, robot, start, goal):
    poses = path.poses
    assert np.allclose(poses[0], start) and np.allclose(poses[-1], goal)
    steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    assert steps.max() <= POSE_SPACING + 1e-9  # continuous
    assert footprint_collisions(grid, robot.polygon, poses) == 0


@pytest.mark.parametrize("spec", ROBOTS)
def test_hierarchical_paths_cross_the_door_without_collision(spec):
    planner = _planner(spec)
    start, goal = (1.0, 1.0, 0.0), (7.0, 3.0, math.pi / 2)
    path = planner.plan(start, goal)
    _check(path, planner.cspace.grid, planner.cspace.robot, start, goal)
    assert path.regions == (1, 2)
    assert {"route_search", "submaps", "planning", "simplification"} <= set(path.seconds)
    flat = FlatKinematicPlanner(planner.cspace, time_limit=5.0).plan(start, goal)
    _check(flat, planner.cspace.grid, planner.cspace.robot, start, goal)


def test_a_door_narrower_than_the_robot_is_no_door():
    planner = _planner("rect:0.6x0.5", door=0.65)
    # the width plus what the configuration space grows the footprint by on both sides
    assert planner.min_width == pytest.approx(0.5 + 2 * planner.cspace.growth)
    assert 0.65 < planner.min_width < 0.7
    with pytest.raises(NoPathError, match=rf"at least {planner.min_width:g} m wide"):
        planner.plan((1.0, 2.0), (7.0, 2.0))


@pytest.mark.parametrize("mode", ["legs", "union"])
def test_a_failed_route_falls_back_to_the_next(monkeypatch, mode):
    planner = _planner("rect:0.6x0.4", mode=mode)
    calls = []
    along = getattr(KinematicHierarchicalPlanner, f"_{mode}")

    def first_fails(self, route, *rest):
        calls.append(list(route.ids))
        return None if len(calls) == 1 else along(self, route, *rest)

    monkeypatch.setattr(KinematicHierarchicalPlanner, f"_{mode}", first_fails)
    path = planner.plan((1.0, 1.0, 0.0), (7.0, 3.0, 0.0))
    assert len(calls) == 2 and calls[1] == [1, 2]  # then the region route, whole regions
    _check(path, planner.cspace.grid, planner.cspace.robot, (1.0, 1.0, 0.0), (7.0, 3.0, 0.0))
    monkeypatch.setattr(KinematicHierarchicalPlanner, f"_{mode}", lambda *args: None)
    with pytest.raises(NoPathError, match=r"routes tried: door graph .*; regions \[1, 2\]"):
        planner.plan((1.0, 1.0, 0.0), (7.0, 3.0, 0.0))


def test_bad_queries_are_typed_errors():
    planner = _planner("rect:0.6x0.4")
    with pytest.raises(InvalidQueryError, match=r"start \(4\.1, 0\.5, 0\)"):
        planner.plan((4.1, 0.5, 0.0), (7.0, 2.0))  # in the wall
    with pytest.raises(InvalidQueryError, match="goal must be finite"):
        planner.plan((1.0, 2.0), (7.0, math.inf))
    with pytest.raises(RegionNotFoundError, match="no region 9"):
        planner.plan((1.0, 2.0), 9)


@pytest.mark.parametrize("value", [["RRT"], {"RRT": 1}, "x"])
def test_options_of_the_wrong_kind_are_typed_errors_naming_the_value(value, monkeypatch):
    grid, labels = _rooms(1.0)
    space = HeadingCSpace(grid, parse_robot("rect:0.6x0.4"), headings=8)
    shown = re.escape(repr(value))
    with pytest.raises(PlannerParameterError, match=f"unknown OMPL planner {shown}"):
        FlatKinematicPlanner(space, value)  # type: ignore[arg-type]
    for name in ("headings", "margin"):
        with pytest.raises(PlannerParameterError, match=f"{name} .*{shown}"):
            HeadingCSpace(grid, space.robot, **{name: value})
    with pytest.raises(RobotSpecError, match=f"corners, got {shown}"):
        Footprint(value)  # type: ignore[arg-type]

    def never(*_args):
        raise AssertionError("the door graph was made before the options were checked")

    monkeypatch.setattr("planners.kinematic_hierarchical.HierarchicalPlanner", never)
    graph = region_graph(Regions(grid, labels))
    for name in ("planner", "mode"):
        with pytest.raises(PlannerParameterError, match=f"{name}.* {shown}"):
            KinematicHierarchicalPlanner(space, labels, graph, **{name: value})


@given(st.floats(-1e17, 1e17, allow_nan=False), st.booleans())
def test_a_heading_of_many_turns_is_checked_where_ompl_puts_it(yaw, beside_the_wall):
    from planners.kinematic import check_pose, ompl_yaw

    grid, _ = _rooms(1.0)
    space = HeadingCSpace(grid, parse_robot(ROBOTS[1]))
    x, y = (1.0, 0.45) if beside_the_wall else (1.0, 1.0)  # some headings collide there
    heading = ompl_yaw(yaw)  # the state OMPL plans from, whatever the turns
    if space.valid(x, y, heading):
        assert check_pose(space, (x, y, yaw), "start") == (x, y, heading)
    else:
        with pytest.raises(InvalidQueryError, match="in collision"):
            check_pose(space, (x, y, yaw), "start")


_SEEDED = """
import json, math, sys
sys.path[:0] = [".", "tests/planners"]
from test_kinematic import _planner
path = _planner("dubins:radius=0.5,footprint=0.6x0.4", random_state=7).plan(
    (1.0, 1.0, 0.0), (7.0, 3.0, math.pi / 2))
print(json.dumps(path.poses.round(9).tolist()))
"""


def test_the_same_seed_gives_the_same_path():
    runs = [
        subprocess.run(
            [sys.executable, "-c", _SEEDED],
            capture_output=True,
            text=True,
            check=True,
            timeout=120,
            cwd=ROOT,
        )
        for _ in range(2)
    ]
    assert json.loads(runs[0].stdout) == json.loads(runs[1].stdout)
    assert "leaked" not in runs[0].stderr  # OMPL's bindings report nothing at exit


CAR = "dubins:radius=1,footprint=0.9x0.6"


def _ahead(cspace, pose, turn):
    """Metres a forward-only car drives from ``pose`` straight (``turn`` 0) or on its
    tightest circle left (1) or right (-1) before its footprint collides (at most 3 m)."""
    x, y, yaw = pose
    radius = cspace.robot.turning_radius
    for s in np.arange(0.01, 3.0, 0.01):
        a = yaw + turn * s / radius
        if turn == 0:
            p = (x + s * math.cos(yaw), y + s * math.sin(yaw), yaw)
        else:
            p = (
                x + turn * radius * (math.sin(a) - math.sin(yaw)),
                y - turn * radius * (math.cos(a) - math.cos(yaw)),
                a,
            )
        if not cspace.valid(*p):
            return s - 0.01
    return 3.0


def test_a_forward_only_car_starting_at_a_wall_leaves_at_another_heading():
    """A point start whose heading nearest 0 faces the wall 0.4 m ahead, beside the door: a
    forward-only car (1 m turning radius) cannot drive away at that heading (1 of 10 office
    queries failed so), but a point stands for any heading, so both planners start at one
    the car can leave from; the paths are continuous and collision-free by the sweep."""
    planner = _planner(CAR)
    planner.time_limit = 1.0
    grid, robot = planner.cspace.grid, planner.cspace.robot
    start, goal = (3.2, 0.6), (6.0, 2.0)
    facing = (*start, 0.0)  # the front 0.4 m from the dividing wall
    assert planner.cspace.valid(*facing)
    assert max(_ahead(planner.cspace, facing, turn) for turn in (-1, 0, 1)) < 0.5
    with pytest.raises(NoPathError):
        planner.plan(facing, goal)
    flat = FlatKinematicPlanner(planner.cspace, "RRT", time_limit=5.0)
    for path in (planner.plan(start, goal), flat.plan(start, goal)):
        poses = path.poses
        assert np.allclose(poses[0, :2], start) and np.allclose(poses[-1, :2], goal)
        assert abs(math.remainder(poses[0, 2], math.tau)) > 0.5  # not the heading at the wall
        assert np.hypot(*np.diff(poses[:, :2], axis=0).T).max() <= POSE_SPACING + 1e-9
        assert footprint_collisions(grid, robot.polygon, poses) == 0


def test_a_failed_leg_is_planned_again_with_the_leg_before(monkeypatch):
    """When a leg fails (its start, the previous leg's door pose, may be one the car cannot
    leave), the two legs are planned as one from the previous leg's start, before the next
    route is tried."""
    planner = _planner(CAR)
    calls = []
    solve = KinematicHierarchicalPlanner._solve

    def second_leg_fails_once(self, route, ids, start, *rest):
        calls.append(list(ids))
        return None if len(calls) == 2 else solve(self, route, ids, start, *rest)

    monkeypatch.setattr(KinematicHierarchicalPlanner, "_solve", second_leg_fails_once)
    start, goal = (1.0, 1.0, 0.0), (7.0, 3.0, math.pi / 2)
    path = planner.plan(start, goal)
    assert calls == [[1], [2], [1, 2]]  # the door graph's route: one leg per room, then both
    _check(path, planner.cspace.grid, planner.cspace.robot, start, goal)


#: The legs' vertices of an office Dubins query whose B-spline smoothing went through walls.
_SMOOTHED_INTO_WALLS = [
    [86.775, 55.425000000000004, -1.5707963267948966],
    [86.575, 50.425000000000004, -1.5707963267948966],
    [86.65437955352459, 49.59059088180519, -1.4439977213614343],
    [90.63957627642158, 48.55908094995035, -1.2116199364766718],
    [88.31942046635281, 47.14099814346618, -3.1125062640150607],
    [80.30721406861515, 48.33710275210529, 1.4929467849428342],
    [29.842703888171496, 49.62511092400137, -3.130955864459022],
    [12.820468242921265, 48.83934821452893, -3.095427406773048],
    [9.993809054444732, 49.77907935692707, 1.768064080235126],
    [10.025, 50.425000000000004, 1.5707963267948966],
    [10.875, 58.425000000000004, 1.4726215563702154],
]


def test_smoothing_never_leaves_the_checked_motions():
    """OMPL's B-spline smoothing returned a path through walls for these vertices on the
    generated office (in about half of the runs: it shortcuts at random first); the
    simplified path must stay collision-free by the sweep whatever the draw."""
    grid = generate_floor_plan("office", random_state=0).grid
    cspace = HeadingCSpace(grid, parse_robot(CAR))
    ompl = KinematicOMPL(cspace, "RRT")
    vertices = np.array(_SMOOTHED_INTO_WALLS)
    raw, _ = ompl.smooth(vertices, simplify=False)
    assert footprint_collisions(grid, cspace.robot.polygon, raw) == 0
    for _ in range(16):
        poses, _ = ompl.smooth(vertices)
        assert np.allclose(poses[[0, -1]], vertices[[0, -1]])
        assert footprint_collisions(grid, cspace.robot.polygon, poses) == 0


_PRM_GOAL_SET = """
import sys
sys.path.insert(0, "tests/planners")
from test_kinematic import CAR, _planner
from planners.kinematic import KinematicOMPL, end_poses
cspace = _planner(CAR.replace("dubins", "reeds-shepp")).cspace
goals = end_poses(_planner(CAR).cspace, (6.0, 2.0), "goal")  # every heading: a goal set
for name in ("PRM", "PRMstar"):
    start = end_poses(cspace, (3.2, 0.6), "start")[0]
    poses, _ = KinematicOMPL(cspace, name).solve(start, goals, 2.0)
    assert poses is not None
print("solved")
"""


def test_prm_takes_a_goal_set_and_refuses_a_forward_only_car():
    """OMPL's PRM and PRM* given a goal set waited forever on a lock (a benchmark of a
    forward-only car, whose point ends are every valid heading, hung): they plan now (in a
    subprocess, so that a hang fails the test instead of stopping the suite). On a Dubins
    space they are refused: they travel roadmap edges both ways, and the flat PRM's Dubins
    paths went through walls (hundreds of poses by the sweep)."""
    run = subprocess.run(
        [sys.executable, "-c", _PRM_GOAL_SET],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "solved"
    cspace = _planner(CAR).cspace
    for name in ("PRM", "PRMstar"):
        with pytest.raises(PlannerParameterError, match="forward-only"):
            FlatKinematicPlanner(cspace, name)
