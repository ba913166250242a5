"""Per-leg planning for footprint robots: door poses, legs joined continuously, both modes on a
generated building, the best flat planner, and typed errors for bad parameters."""

import math
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_kinematic import _planner, _rooms

from maps.grid import OCCUPIED, OccupancyGrid
from maps.sim.floorplan import generate_floor_plan
from planners.benchmark import best_flat, far_queries
from planners.cspace import HeadingCSpace
from planners.errors import InvalidQueryError, PlannerParameterError
from planners.kinematic import POSE_SPACING, end_poses
from planners.kinematic_hierarchical import Budget, KinematicHierarchicalPlanner
from planners.legs import Crossing, door_poses
from planners.robots import Footprint, RobotSpecError, parse_robot, rectangle
from planners.sweep import footprint_collisions
from segmentation.graph import region_graph
from segmentation.regions import Regions
from topomap.topomap import TopoMap

CAR = "reeds-shepp:radius=1,footprint=0.9x0.6"


def _door(planner, before=1, after=2):
    """The two-room map's door, crossed from region ``before`` into ``after``."""
    (door,) = planner.graph.edges[1, 2]["doors"]
    return Crossing(door.centre, (door.start, door.end), before, after)


@pytest.mark.parametrize(
    ("spec", "headings"),
    [
        ("rect:0.6x0.4", 2),
        ("reeds-shepp:radius=0.5,footprint=0.6x0.4", 2),
        ("dubins:radius=0.5,footprint=0.6x0.4", 1),
    ],
)
def test_door_poses_head_across_the_door_from_before_into_after(spec, headings):
    planner = _planner(spec)
    for before, after, east in ((1, 2, True), (2, 1, False)):
        poses = door_poses(_door(planner, before, after), planner.labels, planner.cspace)
        x, y, yaw = poses[0]
        assert abs(x - 4.1) < 0.05 and abs(y - 2.0) < 0.1  # in the door, mid-wall
        assert math.cos(yaw) == pytest.approx(1.0 if east else -1.0)
        if headings == 2:  # and the other way round
            assert len(poses) == 2
            assert math.cos(poses[1][2]) == pytest.approx(-math.cos(yaw))
        else:  # a forward-only car: any valid pose on the portal crossing it the same way
            assert 1 < len(poses) <= planner.cspace.headings + 1  # the pose and the others
            across = np.array(poses)
            assert np.all(np.abs(across[:, 0] - 4.1) < 0.05)  # on the portal
            assert np.ptp(across[:, 1]) > 0.1 and np.ptp(across[:, 2]) > 0.1
            assert np.all(np.cos(across[:, 2]) * (1 if east else -1) > 0)  # the same way
            assert planner.cspace.valid_many(across).all()


def test_a_door_the_footprint_does_not_fit_has_no_pose():
    planner = _planner("rect:0.6x0.4", door=1.0)
    wide = HeadingCSpace(planner.cspace.grid, Footprint(rectangle(0.6, 1.1)))
    assert door_poses(_door(planner), planner.labels, wide) == []


def _continuous_and_clear(path, cspace, start, goal):
    poses = path.poses
    ends = poses[[0, -1]] - np.array([start, goal])
    ends[:, 2] = np.angle(np.exp(1j * ends[:, 2]))  # headings equal modulo a turn
    assert np.allclose(ends, 0)
    assert np.hypot(*np.diff(poses[:, :2], axis=0).T).max() <= POSE_SPACING + 1e-9
    assert footprint_collisions(cspace.grid, cspace.robot.polygon, poses) == 0


@pytest.mark.parametrize("mode", ["legs", "union"])
def test_legs_join_continuously_through_the_door(mode):
    planner = _planner(CAR, mode=mode)
    start, goal = (1.0, 1.0, 0.0), (7.0, 3.0, math.pi / 2)
    path = planner.plan(start, goal)
    _continuous_and_clear(path, planner.cspace, start, goal)
    assert path.regions == (1, 2) and path.planner == planner.name


@pytest.fixture(scope="module")
def building():
    """A generated 20 x 15 m building, segmented, with a rectangle's configuration space, the
    two planners (the union given more time: it is the slower mode) and far-apart queries."""
    grid = generate_floor_plan("flat", random_state=3).grid
    topo = TopoMap.from_grid(grid, random_state=0)
    cspace = HeadingCSpace(grid, parse_robot("rect:0.7x0.5"), headings=32)
    planners = {
        mode: KinematicHierarchicalPlanner(
            cspace, topo.regions.labels, topo.graph, mode=mode, time_limit=limit
        )
        for mode, limit in (("legs", 5.0), ("union", 30.0))
    }
    planners["legs"].prepare()
    pairs = far_queries(planners["legs"].doors.space, 12, random_state=0)
    pairs = [p for p in pairs if all(len(cspace.free_headings(*end)) for end in p)]
    return cspace, planners, pairs[:6]


@settings(
    max_examples=6, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(query=st.integers(0, 5))
def test_legs_give_valid_paths_on_a_generated_building(building, query):
    cspace, planners, pairs = building
    start, goal = pairs[query]
    path = planners["legs"].plan(start, goal)  # points: the valid heading nearest 0
    _continuous_and_clear(path, cspace, path.poses[0], path.poses[-1])
    assert np.allclose(path.poses[[0, -1], :2], [start, goal])


def test_the_union_gives_a_valid_path_on_a_generated_building(building):
    cspace, planners, pairs = building
    start, goal = pairs[0]
    path = planners["union"].plan(start, goal)
    _continuous_and_clear(path, cspace, path.poses[0], path.poses[-1])
    assert np.allclose(path.poses[[0, -1], :2], [start, goal])


@pytest.mark.parametrize(
    "spec",
    ["reeds-shepp:radius=-1,footprint=0.9x0.6", "reeds-shepp:radius=0,footprint=0.9x0.6",
     "rect:0.9x-0.6", "dubins:radius=inf,footprint=0.9x0.6"],
)  # fmt: skip
def test_non_positive_or_infinite_sizes_are_typed_errors(spec):
    with pytest.raises(RobotSpecError, match="must be positive and finite"):
        parse_robot(spec)
    with pytest.raises(RobotSpecError, match="not a simple polygon"):
        Footprint(np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]))


def test_bad_planner_parameters_are_typed_errors():
    grid, labels = _rooms(1.0)
    graph = region_graph(Regions(grid, labels))
    space = HeadingCSpace(grid, parse_robot("rect:0.6x0.4"))
    for option, named in (
        ({"mode": "both"}, "'both'"),
        ({"submap_margin": -1.0}, "-1.0"),
        ({"door_margin": -0.1}, "-0.1"),
        ({"time_limit": 0.0}, "0.0"),
    ):
        with pytest.raises(PlannerParameterError, match=named):
            KinematicHierarchicalPlanner(space, labels, graph, **option)


def test_a_start_in_collision_is_named():
    planner = _planner(CAR)
    with pytest.raises(InvalidQueryError, match=r"start \(0\.3, 2, 1\.5\) puts the footprint"):
        planner.plan((0.3, 2.0, 1.5), (7.0, 2.0, 0.0))


def test_the_best_flat_planner_is_the_fastest_then_the_surest():
    rows = [
        {"planner": "hierarchical", "median_s": 0.1, "success": 1.0},
        {"planner": "flat_rrtconnect", "median_s": 5.0, "success": 0.3},
        {"planner": "flat_kpiece1", "median_s": 2.0, "success": 0.6},
        {"planner": "flat_prm", "median_s": 2.0, "success": 0.8},
    ]
    assert best_flat(rows) == "flat_prm"
    assert best_flat(rows[:1]) is None


def test_a_portal_along_a_narrow_passage_gets_poses_along_the_passage():
    """A door's portal may be a cell or two lying along a narrow gap (the opening of a disc's
    free space): its normal points into the gap's walls, where the car has no valid pose. The
    door pose heads along the passage instead (before: no pose, so the legs on both sides
    merged into one hard query through the gap)."""
    planner = _planner(CAR, door=0.85)  # the 0.9 x 0.6 m car fits only lengthwise
    door = _door(planner)
    x, y = door.point
    along = Crossing(door.point, ((x - 0.025, y), (x + 0.025, y)), 1, 2)  # normal: north
    poses = door_poses(along, planner.labels, planner.cspace)
    assert len(poses) == 2
    assert math.cos(poses[0][2]) == pytest.approx(1.0, abs=0.02)  # east, from room 1 into 2
    assert math.cos(poses[1][2]) == pytest.approx(-1.0, abs=0.02)
    assert all(planner.cspace.valid(*pose) for pose in poses)
    backwards = Crossing(door.point, along.portal, 2, 1)
    assert math.cos(door_poses(backwards, planner.labels, planner.cspace)[0][2]) < -0.99


@pytest.mark.parametrize("spec", [CAR, "rect:0.9x0.6"])
def test_a_leg_the_robot_drives_straight_needs_no_planner(spec):
    """A leg whose start and door pose the state space's own curve joins validly (a
    Reeds-Shepp path, a line) is that curve: no confined set-up, no OMPL search, poses still
    at most 5 cm apart; through a wall the motion is refused and OMPL plans."""
    planner = _planner(spec)
    start, goal = (1.5, 2.0, 0.0), (6.5, 1.5, 0.0)
    path = planner.plan(start, goal)
    _continuous_and_clear(path, planner.cspace, start, goal)
    assert path.regions == (1, 2)
    assert not planner._kept  # no submap's OMPL set-up was made
    whole = planner._whole
    assert whole.direct((1.0, 2.0, 0.0), [(3.0, 2.0, 0.0)]).shape == (2, 3)
    assert whole.direct((1.0, 2.0, 0.0), (7.0, 1.0, 0.0)) is None  # the wall is in the way
    vertices, _ = whole.search((1.0, 2.0, 0.0), (3.0, 2.0, math.pi), 1.0)
    assert vertices is not None and len(vertices) == 2  # the direct motion (a car: a cusp)


@pytest.mark.parametrize("spec", [CAR, "rect:0.9x0.6"])
def test_a_pose_heading_exactly_west_is_planned_from_and_to(spec):
    """A heading of exactly pi is out of OMPL's SO(2) bounds [-pi, pi): a door pose or a
    start facing west was never a valid state of any set-up, so its legs failed (3 of 100
    office queries, all on a corridor cut into parts along its axis, whose door poses face
    due west)."""
    planner = _planner(spec)
    start, goal = (7.0, 2.0, math.pi), (1.0, 1.0, math.pi)
    assert planner._whole.admits(start) and planner._whole.admits(goal)
    path = planner.plan(start, goal)
    _continuous_and_clear(path, planner.cspace, start, goal)
    assert path.regions == (2, 1)
    ompl = planner._submaps(next(planner._routes(start, goal)), [2])
    assert ompl.admits(start)


def _corridor_and_side_room(door_y: float = 3.5):
    """An L-shaped corridor (region 1: east along y 0.1-2.1 m, then north along x 8.1-10.1 m),
    cut into near-convex parts at its corner, and a room (region 2) west of its north arm
    behind a 1 m door centred at ``door_y``, just past the corner."""
    res = 0.05
    h, w = round(8.2 / res), round(10.2 / res)
    cells = np.full((h, w), OCCUPIED, np.int8)

    def free(x0, x1, y0, y1):  # metres, y up
        cells[h - round(y1 / res) : h - round(y0 / res), round(x0 / res) : round(x1 / res)] = 0

    free(0.1, 10.1, 0.1, 2.1)
    free(8.1, 10.1, 0.1, 8.1)
    free(3.1, 8.0, 2.3, 8.1)
    free(7.9, 8.2, door_y - 0.5, door_y + 0.5)
    grid = OccupancyGrid(cells, res)
    x, y = np.meshgrid(np.arange(w) * res, (h - np.arange(h)) * res)
    labels = np.where((x < 8.05) & (y > 2.2), 2, 1) * grid.free
    return grid, labels.astype(np.int32)


def test_a_forward_only_car_ends_legs_only_at_doors_between_regions():
    """A fixed pose at the cut between two parts of one corridor, heading along it, leaves a
    forward-only car (turning radius 1 m) too little room to turn into a side door just past
    it: the door-graph route failed there (as at many legs of the office queries).
    Its legs now end only at the doors between regions; a car that reverses keeps them all."""
    grid, labels = _corridor_and_side_room()
    graph = region_graph(Regions(grid, labels))
    start, goal = (1.0, 1.1, 0.0), (5.0, 5.0, math.pi)
    for spec, ends in (("dubins:radius=1,footprint=0.9x0.6", 1), (CAR, 3)):
        cspace = HeadingCSpace(grid, parse_robot(spec))
        planner = KinematicHierarchicalPlanner(cspace, labels, graph, time_limit=5.0)
        route = next(planner._routes(start, goal))
        assert route.kind == "parts" and len(route.crossings) == 3  # two cuts, then the door
        assert sum(planner._ends(route, c) for c in route.crossings) == ends
        seconds = dict.fromkeys(("route_search", "submaps", "planning", "simplification"), 0.0)
        poses = planner._legs(route, [start], [goal], Budget(time.perf_counter() + 2.0, 1), seconds)
        assert poses is not None  # the first route, within its 2 s
        assert footprint_collisions(grid, cspace.robot.polygon, poses) == 0


def test_a_car_given_a_point_stands_for_every_valid_heading_there():
    """A car that reverses may stand wedged at the heading nearest 0 (a campus start across
    a doorway); a point is every valid heading for it, as for a forward-only car."""
    car, rect = (_planner(spec).cspace for spec in (CAR, "rect:0.9x0.6"))
    poses = end_poses(car, (2.0, 2.0), "start")
    assert len(poses) == len(car.free_headings(2.0, 2.0)) > 1
    assert abs(poses[0][2]) <= math.pi / 32  # the heading nearest 0 first
    assert len(end_poses(rect, (2.0, 2.0), "start")) == 1
