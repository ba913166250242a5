"""Bad input through the Python API: typed errors naming the value, no hang, no silent answer
(found by a review that called every public function with wrong values, 2026-12-06)."""

from __future__ import annotations

import json
import math
import re
import time

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import sparse

from maps.errors import InvalidMapError, InvalidScanError, RandomStateError
from maps.grid import OccupancyGrid
from maps.scan import Keyframe
from maps.seeding import as_generator
from maps.sim.floorplan import generate_floor_plan
from maps.sim.laser import LaserModel
from planners.errors import InvalidQueryError
from segmentation.errors import ExportFormatError, ParameterError, SegmentationError
from segmentation.spectral import SpectralSegmenter
from topomap.errors import LabelError
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def topo() -> TopoMap:
    return TopoMap.from_grid(generate_floor_plan("flat", random_state=0).grid, random_state=0)


@pytest.mark.parametrize("seed", [-1, 1.5, True, "x", np.random.RandomState(0)])
def test_a_random_state_that_is_no_seed_is_a_typed_error(seed):
    with pytest.raises(RandomStateError, match="random_state must be a whole number >= 0"):
        as_generator(seed)


def test_numpy_numbers_are_numbers_and_an_origin_that_is_none_is_refused():
    cells = np.zeros((4, 4), np.int8)
    grid = OccupancyGrid(cells, np.float32(0.05), np.array([1, 2, 0]))
    assert grid.origin == (1.0, 2.0, 0.0) and isinstance(grid.resolution, float)
    assert SpectralSegmenter(p=np.float32(0.3))._validate_params() is None
    for origin in (None, 5, (0.0, 0.0)):
        with pytest.raises(InvalidMapError, match="origin must be three finite numbers"):
            OccupancyGrid(cells, 0.05, origin)


@pytest.mark.parametrize("beams", [1, 10**9, 2.5])
def test_a_laser_of_absurd_beams_or_noise_is_refused_before_tracing(beams):
    with pytest.raises(InvalidScanError, match="whole number of beams"):
        LaserModel(beams=beams)
    with pytest.raises(InvalidScanError, match="noise >= 0"):
        LaserModel(noise=math.nan)


def test_k_means_restarts_and_the_k_range_are_bounded(topo):
    with pytest.raises(ParameterError, match="n_init must be at most"):
        SpectralSegmenter(n_init=100_000).fit(topo.keyframes)
    start = time.perf_counter()  # a huge spread walks only the k that can be (2 .. n - 1)
    SpectralSegmenter(spread=10**10, random_state=0).fit(topo.keyframes[:30])
    assert time.perf_counter() - start < 30


def test_a_similarity_that_fails_is_named(topo):
    def broken(a, b):
        return 1 / 0

    with pytest.raises(ParameterError, match=r"similarity .*broken.* failed .*\(ZeroDivisionError"):
        SpectralSegmenter(criterion=broken).fit(topo.keyframes[:20])


def test_keyframes_that_are_nowhere_on_the_map_are_refused(topo):
    far = [
        Keyframe((k.pose[0] + 1000.0, k.pose[1], k.pose[2]), k.scan, scan_index=k.scan_index)
        for k in topo.keyframes
    ]
    with pytest.raises(SegmentationError, match=r"none of the .* keyframes stands on the map"):
        TopoMap.from_keyframes(far, topo.grid)


@given(st.sampled_from([math.nan, math.inf, None, "1"]), st.booleans())
def test_a_point_that_is_no_point_is_no_region_query(topo, value, first):
    point = (value, 1.0) if first else (1.0, value)
    with pytest.raises(ParameterError, match="a point is two finite numbers"):
        topo.region_at(*point)


@pytest.mark.parametrize("start", [("a", "b"), {"x": 1}, (1 + 0j, 2.0), (math.nan, 1.0)])
def test_a_start_that_is_no_point_is_a_query_error(topo, start):
    with pytest.raises(InvalidQueryError, match="start must be two finite numbers"):
        topo.plan(start, 2)


def test_a_route_for_a_robot_of_no_width_or_through_doors_that_are_none(topo):
    a, b = sorted(topo.graph.nodes)[:2]
    for radius in (-1.0, math.nan):
        with pytest.raises(InvalidQueryError, match="robot's width"):
            topo.route(a, b, robot_radius=radius)
    for closed in ([(999, 998)], [("a", "b")], [(1,)]):
        with pytest.raises(InvalidQueryError, match="share a door to close"):
            topo.route(a, b, closed=closed)


@pytest.mark.parametrize("name", ["a\x1bb", "a\x00", "\ud800", "x\ufffe", None, 3])
def test_a_name_graphml_cannot_hold_is_refused_and_nothing_changes(topo, name):
    region = sorted(topo.graph.nodes)[0]
    before = topo.graph.nodes[region]["name"]
    with pytest.raises(LabelError, match="a region name"):
        topo.rename(region, name)
    assert topo.graph.nodes[region]["name"] == before


@pytest.mark.parametrize("query", ["²", "9" * 5000])
def test_digits_that_are_no_id_are_looked_up_as_names(topo, query):
    from segmentation.errors import RegionNotFoundError

    with pytest.raises(RegionNotFoundError):
        topo.region(query)


def test_a_classifier_that_fails_is_named(topo):
    def broken(features):
        return 1 / 0

    with pytest.raises(LabelError, match=r"classifier broken failed .*ZeroDivisionError"):
        topo.label(broken)


@pytest.mark.parametrize(
    ("field", "value", "shown"),
    [("method", "bogus", "field 'method' is 'bogus'"), ("next_id", "1e400", "OverflowError")],
)
def test_a_saved_folder_with_a_field_out_of_bounds_is_refused(topo, tmp_path, field, value, shown):
    topo.save(tmp_path / "t")
    about_path = tmp_path / "t" / "topomap.json"
    about = json.loads(about_path.read_text())
    about[field] = value
    text = json.dumps(about).replace('"1e400"', "1e400")
    about_path.write_text(text)
    with pytest.raises(ExportFormatError, match=shown):
        TopoMap.load(tmp_path / "t")


def test_settings_of_the_wrong_kind_are_parameter_errors(topo):
    from segmentation.pipeline import MapSegmenter

    with pytest.raises(ParameterError, match=r"p is 0\.3, not an estimator: p__x cannot be set"):
        SpectralSegmenter().set_params(p__x=1)
    for settings, shown in (
        ({"spectral": None}, "spectral must be a SpectralSegmenter"),
        ({"laser": "x"}, "laser must be a LaserModel"),
        ({"on_stage": 5}, "on_stage must be a function"),
    ):
        with pytest.raises(ParameterError, match=shown):
            MapSegmenter(**settings).segment(topo.grid)
    with pytest.raises(ParameterError, match="the map must be an OccupancyGrid"):
        MapSegmenter().segment(np.zeros((5, 5), np.int8))


def test_scans_and_cells_that_are_not_numbers_are_typed_errors():
    from maps.scan import LaserScan

    with pytest.raises(InvalidMapError, match="rows of different lengths"):
        OccupancyGrid([[0, 0], [0]], 0.05)
    with pytest.raises(InvalidScanError, match="angle_min must be a number"):
        LaserScan(np.ones(3), "0", 0.1)
    with pytest.raises(InvalidScanError, match="ranges must be numbers"):
        LaserScan(["a", "b"], 0.0, 0.1)
    scan = LaserScan(np.ones(3), 0.0, 0.1)
    with pytest.raises(InvalidScanError, match="scan is a LaserScan"):
        Keyframe((0.0, 0.0, 0.0), "x")
    for index in (None, math.nan, -1, 1.5):
        with pytest.raises(InvalidScanError, match="scan_index must be an integer >= 0"):
            Keyframe((0.0, 0.0, 0.0), scan, scan_index=index)


@pytest.mark.parametrize("path", [None, 5, "a\x00b"])
def test_a_path_that_is_no_path_is_a_typed_error(topo, tmp_path, path):
    from maps.carmen import read_carmen
    from maps.errors import LogFormatError, MapFormatError, OutputPathError

    for write in (topo.save, topo.grid.save, topo.to_rosbag):
        with pytest.raises(OutputPathError, match="no path to write an output to"):
            write(path)
    with pytest.raises((ExportFormatError, MapFormatError)):
        TopoMap.load(path)
    with pytest.raises(LogFormatError):
        read_carmen(path)
    with pytest.raises(OutputPathError, match="File name too long"):
        topo.save(tmp_path / ("x" * 300))


def test_overwrite_that_is_no_yes_or_no_keeps_the_folder(topo, tmp_path):
    from maps.errors import OutputPathError

    topo.save(tmp_path / "saved")
    before = (tmp_path / "saved" / "graph.json").read_bytes()
    with pytest.raises(OutputPathError, match="overwrite must be True or False, got 'no'"):
        topo.save(tmp_path / "saved", overwrite="no")
    assert (tmp_path / "saved" / "graph.json").read_bytes() == before


@pytest.mark.parametrize(
    ("affinity", "shown"),
    [
        (np.ones((2, 3)), "must be a square matrix"),
        (np.array([[0.0, np.nan], [np.nan, 0.0]]), "finite and >= 0"),
        (np.array([[0.0, -1.0], [-1.0, 0.0]]), "finite and >= 0"),
        ("x", "must be a square matrix"),
        (None, "must be a square matrix"),
        (np.array([[0.0, 1j], [1j, 0.0]]), "real numbers"),
        (np.array([[0.0, 1.0], [0.5, 0.0]]), "symmetric"),
        (np.array([["a", "b"], ["b", "a"]]), "a matrix of numbers"),
        (sparse.csr_matrix((10**9, 10**9)), "more than the 100000 this partition takes"),
    ],
)
def test_an_affinity_that_is_no_affinity_is_refused(affinity, shown):
    with pytest.raises(ParameterError, match=shown):
        SpectralSegmenter().fit_affinity(affinity)


@pytest.mark.parametrize("criterion", ["nn", "features", "view"])
def test_no_keyframes_and_a_stream_of_keyframes_are_named_with_any_criterion(criterion, topo):
    with pytest.raises(SegmentationError, match="no keyframes"):
        SpectralSegmenter(criterion=criterion).fit([])
    assert SpectralSegmenter().fit_affinity(np.zeros((0, 0))).n_regions_ == 0
    with pytest.raises(ParameterError, match="a list of Keyframes"):
        SpectralSegmenter(criterion=criterion).fit(iter(topo.keyframes))


def test_map_building_and_inflation_settings_out_of_range(topo):
    from maps.mapping import grid_from_keyframes

    for options, shown in (
        ({"occupied_ratio": math.nan}, "occupied_ratio must be a finite number"),
        ({"occupied_ratio": 2.0}, "occupied_ratio must lie in"),
        ({"margin": -5.0}, "margin must lie in"),
    ):
        with pytest.raises(InvalidScanError, match=shown):
            grid_from_keyframes(topo.keyframes[:5], 0.05, **options)
    for radius in ("x", None, -1.0):
        with pytest.raises(InvalidMapError, match="inflation radius must"):
            topo.grid.inflate(radius)


def test_planner_and_online_arguments_below_the_facade(topo):
    from planners.errors import PlannerParameterError
    from planners.flat import FlatPlanner
    from planners.workspace import Workspace
    from segmentation.errors import RegionNotFoundError
    from segmentation.incremental import IncrementalSegmenter

    with pytest.raises(RegionNotFoundError, match="no region 999"):
        topo.planner().centre(999)
    space = Workspace(topo.grid, 0.2)
    for options, shown in (
        ({"time_limit": "x"}, "time_limit must be a number"),
        ({"time_limit": 0}, "time_limit must lie in"),
        ({"bounds": (5.0, 5.0, 0.0, 0.0)}, "xmin < xmax"),
    ):
        with pytest.raises(PlannerParameterError, match=shown):
            FlatPlanner(space, **options)
    for options, shown in (
        ({"pipeline": None}, "pipeline must be a MapSegmenter"),
        ({"region_resolution": 1e-9}, "region_resolution must lie in"),
    ):
        with pytest.raises(ParameterError, match=shown):
            IncrementalSegmenter(**options).fit(topo.keyframes)
    online = IncrementalSegmenter(random_state=0).fit(topo.keyframes[:40])
    with pytest.raises(SegmentationError, match="partial_fit takes a Keyframe or a list"):
        online.partial_fit(None)


def test_no_poses_make_no_scans(topo):
    from maps.sim.laser import simulate_scans

    assert simulate_scans(topo.grid, []) == []


@pytest.mark.parametrize(
    ("change", "shown"),
    [
        ({"data": [0.5, 0, 0, 100]}, "whole numbers"),
        ({"data": ["a", "b", "c", "d"]}, "whole numbers"),
        ({"orientation": {"x": 0, "y": 0, "z": 0, "w": 0}}, "is no rotation"),
    ],
)
def test_a_map_message_of_fractions_or_no_rotation_is_refused(change, shown):
    grid = OccupancyGrid(np.array([[0, 100], [-1, 0]], np.int8), 0.5)
    fields = grid.to_msg_fields()
    if "data" in change:
        fields["data"] = change["data"]
    else:
        fields["info"]["origin"]["orientation"] = change["orientation"]
    with pytest.raises(InvalidMapError, match=shown):
        OccupancyGrid.from_msg_fields(fields)


@pytest.mark.parametrize(
    "partition",
    [
        {"labels": [0, -1], "clusters": 1, "silhouette_by_k": {}},
        {"labels": [0.5, 1], "clusters": 2, "silhouette_by_k": {}},
        {"labels": [0, 3], "clusters": 2, "silhouette_by_k": {}},
        {"labels": [0, 1], "clusters": -3, "silhouette_by_k": {}},
        {"labels": [0, 1], "clusters": 2, "silhouette_by_k": {"2": "nan"}},
    ],
)
def test_a_saved_partition_that_no_fit_makes_is_refused(topo, tmp_path, partition):
    topo.save(tmp_path / "t")
    about_path = tmp_path / "t" / "topomap.json"
    about = json.loads(about_path.read_text())
    about["partition"] = partition
    about_path.write_text(json.dumps(about))
    with pytest.raises(ExportFormatError, match=r"partition: labels 0\.\.clusters-1"):
        TopoMap.load(tmp_path / "t")


@pytest.mark.parametrize("bad", ["x", None, 3])
def test_keyframes_that_are_no_keyframes_are_named_before_any_work(topo, bad):
    from maps.scan import select_keyframes
    from segmentation.pipeline import MapSegmenter
    from segmentation.virtual import virtual_keyframes

    first = virtual_keyframes(topo.grid, 2.0, random_state=0)[0]
    for call in (
        lambda: TopoMap.from_keyframes([first, bad]),
        lambda: TopoMap.from_keyframes([first, bad], grid=topo.grid),
        lambda: MapSegmenter().segment(topo.grid, [first, bad]),
        lambda: select_keyframes([first, bad]),
    ):
        with pytest.raises(
            InvalidScanError, match=f"keyframes must be Keyframes; item 1 is {bad!r}"
        ):
            call()


def test_a_pose_whose_yaw_is_no_angle_and_a_stamp_that_is_no_time_are_refused():
    from maps.scan import LaserScan

    scan = LaserScan(np.ones(3), -0.1, 0.1)
    with pytest.raises(InvalidScanError, match="yaw must lie within 10000 rad"):
        Keyframe((0.0, 0.0, 1e300), scan)
    with pytest.raises(InvalidScanError, match="three finite numbers"):
        Keyframe("abc", scan)
    for stamp in (math.nan, "x"):
        with pytest.raises(InvalidScanError, match="stamp must be a finite number"):
            Keyframe((0.0, 0.0, 0.0), scan, stamp=stamp)


def test_grids_larger_than_memory_are_refused_before_any_pass_over_them():
    from maps.errors import MapTooLargeError

    huge = np.broadcast_to(np.int8(0), (1 << 20, 1 << 20))  # a view: nothing allocated
    start = time.perf_counter()
    with pytest.raises(MapTooLargeError, match="larger than memory allows"):
        OccupancyGrid(huge, 0.05)
    with pytest.raises(MapTooLargeError):
        OccupancyGrid.from_masks(np.broadcast_to(True, (1 << 20, 1 << 20)), 0.05)
    with pytest.raises(MapTooLargeError):
        OccupancyGrid(np.zeros((4, 4), np.int8), 0.05).padded(1 << 16, 1 << 16)
    assert time.perf_counter() - start < 5
    with pytest.raises(InvalidMapError, match="boolean"):
        OccupancyGrid.from_masks(np.array([[np.nan, 1.0]]), 0.05)


def test_facade_arguments_of_the_wrong_kind_are_parameter_errors(topo):
    with pytest.raises(ParameterError, match="pipeline must be a MapSegmenter, got 'x'"):
        TopoMap.from_grid(topo.grid, pipeline="x")
    for grid, kind in ((None, "NoneType"), (topo.grid.cells, "ndarray")):
        with pytest.raises(ParameterError, match=f"as an OccupancyGrid, got a {kind}"):
            topo.update(grid)
    for radius in ([0.2], True, math.nan):
        with pytest.raises(ParameterError, match="robot_radius must be"):
            topo.planner(radius)


def test_settings_that_are_no_counts_or_flags_and_fitted_names_before_fit():
    from segmentation.errors import NotFittedError
    from segmentation.incremental import IncrementalSegmenter
    from segmentation.online import OnlineSegmenter
    from segmentation.pipeline import MapSegmenter

    grid = generate_floor_plan("flat", random_state=0).grid
    for model, shown in (
        (SpectralSegmenter(k=True), "k must be an integer"),
        (SpectralSegmenter(connected="yes"), "connected must be True or False"),
        (OnlineSegmenter(theta=True), "theta must lie in"),
        (OnlineSegmenter(dense="x"), "dense must be True or False"),
        (IncrementalSegmenter(neighbours=True), "neighbours must be an integer"),
        (IncrementalSegmenter(background="x"), "background must be True or False"),
    ):
        with pytest.raises(ParameterError, match=shown):
            model._validate_params()
    for model, name in (
        (SpectralSegmenter(), "labels_"),
        (OnlineSegmenter(), "events_"),
        (IncrementalSegmenter(), "regions_"),
    ):
        with pytest.raises(NotFittedError, match=f"not fitted: call fit before reading {name}"):
            getattr(model, name)
        assert not hasattr(model, name)
    with pytest.raises(ParameterError, match="on_stage raised ZeroDivisionError at stage"):
        MapSegmenter(on_stage=lambda name: 1 / 0).segment(grid)
    with pytest.raises(ParameterError, match="within ±1024"):
        MapSegmenter(n_jobs=10**9).segment(grid)


def test_footprint_planner_options_and_scans_of_the_wrong_kind_are_typed(topo):
    from maps.scan import LaserScan
    from planners.errors import PlannerParameterError

    for options, shown in (
        ({"routes": "x"}, "routes must be an integer >= 1, got 'x'"),
        ({"routes": 1.5}, "routes must be an integer >= 1, got 1.5"),
        ({"door_margin": "x"}, "door_margin must be a number"),
        ({"submap_margin": math.inf}, "submap_margin must be a finite number"),
    ):
        with pytest.raises(PlannerParameterError, match=shown):
            topo.kinematic_planner("rect:0.5x0.3", **options)
    with pytest.raises(InvalidScanError, match="ranges must be numbers"):
        LaserScan([10**400], 0.0, 0.1)
    with pytest.raises(InvalidScanError, match="not a LaserScan message"):
        LaserScan.from_msg_fields(None)


@pytest.mark.parametrize("value", [["RRT"], {"routes": 2}])
@pytest.mark.parametrize(
    "name",
    ["planner", "time_limit", "routes", "mode", "door_margin", "submap_margin", "random_state"],
)
def test_a_footprint_planner_option_that_is_no_key_is_a_typed_error_naming_it(
    topo, monkeypatch, name, value
):
    from planners.errors import PlannerParameterError

    monkeypatch.setattr("planners.cspace.HeadingCSpace._build", _never_built)
    shown = rf"{name}.* {re.escape(repr(value))}"
    with pytest.raises((PlannerParameterError, RandomStateError), match=shown):
        topo.kinematic_planner("rect:0.5x0.3", **{name: value})


def test_a_footprint_planner_option_or_robot_it_does_not_take_is_a_typed_error(topo, monkeypatch):
    from planners.errors import PlannerParameterError
    from planners.robots import RobotSpecError

    monkeypatch.setattr("planners.cspace.HeadingCSpace._build", _never_built)
    with pytest.raises(PlannerParameterError, match="unknown option planer='RRT'; the options"):
        topo.kinematic_planner("rect:0.5x0.3", planer="RRT")
    for robot in (["rect:0.5x0.3"], {"rect": "0.5x0.3"}):
        with pytest.raises(RobotSpecError, match=re.escape(repr(robot))):
            topo.kinematic_planner(robot)  # type: ignore[arg-type]


def _never_built(*_args, **_kwargs):
    raise AssertionError("the configuration space was built before the options were checked")


def test_the_planners_own_methods_name_a_region_or_point_that_is_none(topo):
    from planners.errors import InvalidQueryError
    from segmentation.errors import RegionNotFoundError

    planner = topo.planner()
    for region in (999, -1, 0, [1], True):
        with pytest.raises(RegionNotFoundError):
            planner.region_space(region)
        with pytest.raises(RegionNotFoundError):
            planner.centre(region)
    with pytest.raises(RegionNotFoundError, match="a region is an integer id"):
        planner.close_door([], [])
    wall = topo.grid.cell_to_world(0, 0)
    for point, shown in (((math.nan, 0.0), "two finite numbers"), (wall, "lies in")):
        with pytest.raises(InvalidQueryError, match=shown):
            planner.reach(point)


def test_online_engines_and_outputs_given_the_wrong_kind_of_thing(topo, tmp_path):
    from segmentation.events import OnlineStateError
    from segmentation.incremental import IncrementalSegmenter
    from segmentation.online import OnlineSegmenter
    from topomap.errors import ExportError

    with pytest.raises(OnlineStateError, match="flush before fit"):
        IncrementalSegmenter().flush()
    for model in (OnlineSegmenter(), IncrementalSegmenter()):
        with pytest.raises(InvalidScanError, match="a list of Keyframes, got None"):
            model.fit(None)
    with pytest.raises(ParameterError, match="segmenter must be a SpectralSegmenter"):
        OnlineSegmenter(segmenter="x").fit([])
    for door_graphs in ("0.2", [None], [math.nan]):
        with pytest.raises(ExportFormatError, match="door_graphs"):
            topo.save(tmp_path / "saved", door_graphs=door_graphs)
    with pytest.raises(ExportFormatError, match="progress must be a function"):
        topo.save(tmp_path / "saved", progress=5)
    with pytest.raises(ExportError, match="stamp must be seconds"):
        topo.to_rosbag(tmp_path / "bag", stamp=math.nan)
    with pytest.raises(ExportError, match="paths must be planned paths"):
        topo.to_rosbag(tmp_path / "bag", paths=["x"])
    assert list(tmp_path.iterdir()) == []


def test_image_options_and_the_planners_lower_methods_are_checked(topo):
    from maps.errors import MapFormatError
    from planners.errors import InvalidQueryError

    image = np.full((10, 10), 254, np.uint8)
    for options, field in (
        ({"free_thresh": math.nan}, "free_thresh"),
        ({"free_thresh": 0.9, "occupied_thresh": 0.5}, "free_thresh"),
        ({"negate": "yes"}, "negate"),
    ):
        with pytest.raises(MapFormatError, match=f"field '{field}'"):
            OccupancyGrid.from_image(image, 0.1, **options)
    with pytest.raises(MapFormatError, match="1-4 channels"):
        OccupancyGrid.from_image(np.zeros((4, 4, 5), np.uint8), 0.1)
    planner = topo.planner()
    for call in (lambda: planner.leg(999, 0, 1), lambda: planner.path_in_part(-1, 10**6, 0)):
        with pytest.raises(InvalidQueryError, match="is not a door of part"):
            call()
