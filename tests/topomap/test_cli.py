import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import maps
from maps.grid import OccupancyGrid
from tests.strategies import map_cells
from topomap.classifiers import PLACE_TYPES, ForestClassifier, RuleClassifier
from topomap.cli.main import main
from topomap.features import FEATURES

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_demo_writes_picture_map_and_summary(tmp_path):
    assert main(["demo", "--out", str(tmp_path), "--size", "flat", "--seed", "1"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["robot"]["rooms_unreachable"] == 0
    assert summary["robot"]["keyframes"] > 10
    assert summary["map"]["true_free_cells_found"] > 0.9
    assert summary["map"]["free_cells_not_free_in_truth"] < 0.03
    assert set(summary["seconds"]) == {
        "generate",
        "drive",
        "build_map",
        "segment_log",
        "segment_online",
        "segment_plan",
        "plan_paths",
    }
    assert summary["segment_plan"]["spectral"]["mcc"] > 0.8
    assert "mcc" in summary["segment_plan"]["doors_baseline"]
    online = summary["segment_online"]
    assert online["method"] == "windows" and online["regions"] >= 2
    # the online engine ends near the offline result of the same keyframes
    assert online["ari_online_vs_offline"] > 0.6
    assert online["spectral"]["mcc"] > 0.5
    assert (tmp_path / "segment_online" / "regions.gif").stat().st_size > 0
    for planner in ("hierarchical", "flat_rrtconnect"):
        assert 1.0 <= summary["plan"][planner]["length_over_shortest_median"] < 1.5
    assert cv2.imread(str(tmp_path / "paths.png")) is not None
    picture = cv2.imread(str(tmp_path / "map.png"))
    assert picture is not None and picture.shape[0] > 200
    assert OccupancyGrid.load(tmp_path / "map.yaml").free.sum() > 1000


def test_map_from_real_log(tmp_path, data_dir):
    log = data_dir / "carmen" / "intel-corrected.log.gz"
    assert main(["map", str(log), "--out", str(tmp_path)]) == 0
    grid = OccupancyGrid.load(tmp_path / "map.yaml")
    # the Intel lab is about 30 x 30 m of rooms around a corridor ring
    assert 200 < grid.free.sum() * grid.resolution**2 < 900
    assert main(["map", str(log), "--out", str(tmp_path)]) == 2  # no silent overwrite


def test_generate_writes_map_and_ground_truth(tmp_path):
    assert main(["generate", "--size", "flat", "--seed", "2", "--out", str(tmp_path)]) == 0
    grid = OccupancyGrid.load(tmp_path / "map.yaml")
    labels = cv2.imread(str(tmp_path / "rooms.png"), cv2.IMREAD_UNCHANGED)
    rooms = json.loads((tmp_path / "rooms.json").read_text())
    assert labels.shape == grid.shape and labels.dtype == np.uint16
    assert int(labels.max()) == len(rooms) and np.all(labels[grid.free] > 0)


def test_bench_sim_prints_a_table_and_writes_json(tmp_path, capsys):
    assert main(["bench", "sim", "--out", str(tmp_path), "--scans", "50", "--beams", "181"]) == 0
    records = json.loads((tmp_path / "results.json").read_text())
    assert records[0]["scans"] == 50 and records[0]["seconds"] > 0
    assert "| scans | beams |" in capsys.readouterr().out


def test_bad_input_gives_a_clear_error(tmp_path, capsys):
    bad = tmp_path / "bad.log"
    bad.write_text("FLASER 3 1 2\n")
    assert main(["map", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "bad.log" in err and "line 1" in err


@pytest.mark.parametrize(
    ("script", "args"),
    [
        ("simulate_robot_run.py", ["3"]),
        ("map_from_carmen_log.py", ["LOG", "OUT"]),
        ("segment_generated_building.py", ["OUT"]),
        ("segment_a_slam_map.py", ["LOG", "OUT"]),
        ("plan_to_a_named_region.py", []),
    ],
)
@pytest.mark.slow
def test_examples_run(tmp_path, data_dir, script, args):
    args = [
        str(data_dir / "carmen" / "aces-corrected.log.gz")
        if a == "LOG"
        else str(tmp_path)
        if a == "OUT"
        else a
        for a in args
    ]
    done = subprocess.run(
        [sys.executable, str(ROOT / "examples" / script), *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "keyframes" in done.stdout
    assert "leaked" not in done.stderr  # nothing left for OMPL's bindings to report at exit


def test_module_entry_point():
    done = subprocess.run(
        [sys.executable, "-m", "topomap", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0 and "demo" in done.stdout


def _check_segment_outputs(out: Path, map_image: Path) -> np.ndarray:
    labels = cv2.imread(str(out / "regions.png"), cv2.IMREAD_UNCHANGED)
    image = cv2.imread(str(map_image), cv2.IMREAD_UNCHANGED)
    assert labels.dtype == np.uint16 and labels.shape == image.shape[:2]
    ids = sorted(int(v) for v in np.unique(labels) if v)
    geo = json.loads((out / "regions.geojson").read_text())
    assert sorted(f["properties"]["id"] for f in geo["features"]) == ids
    for feature in geo["features"]:
        cells = (labels == feature["properties"]["id"]).sum()
        assert feature["properties"]["area_m2"] == pytest.approx(cells * 0.05**2)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["regions"] == len(ids)
    assert {"spectral", "regions", "graph"} <= set(summary["seconds"])
    graph = json.loads((out / "graph.json").read_text())
    assert sorted(n["id"] for n in graph["nodes"]) == ids and "edges" in graph
    assert (out / "graph.graphml").read_text().startswith("<?xml")
    assert cv2.imread(str(out / "segmentation.png")) is not None
    return labels


def test_segment_a_map(tmp_path):
    assert main(["generate", "--size", "flat", "--seed", "1", "--out", str(tmp_path / "g")]) == 0
    out = tmp_path / "seg"
    assert main(["segment", str(tmp_path / "g" / "map.yaml"), "--out", str(out)]) == 0
    labels = _check_segment_outputs(out, tmp_path / "g" / "map.pgm")
    rooms = cv2.imread(str(tmp_path / "g" / "rooms.png"), cv2.IMREAD_UNCHANGED)
    assert len(np.unique(labels)) - 1 == len(np.unique(rooms)) - 1  # one region per room
    assert main(["segment", str(tmp_path / "g" / "map.yaml"), "--out", str(out)]) == 2


@pytest.mark.slow
def test_segment_a_real_log(tmp_path, data_dir):
    log = data_dir / "carmen" / "intel-corrected.log.gz"
    assert main(["segment", "--scans", str(log), "--out", str(tmp_path)]) == 0
    labels = _check_segment_outputs(tmp_path, tmp_path / "map.pgm")
    # the Intel lab: a corridor ring with a few dozen rooms around it
    assert 15 <= len(np.unique(labels)) - 1 <= 80
    rows = (tmp_path / "keyframes.csv").read_text().splitlines()
    assert rows[0] == "scan_index,x,y,theta,region"
    assert len(rows) - 1 == json.loads((tmp_path / "summary.json").read_text())["keyframes"]


def test_eval_segment_scores_against_ground_truth(tmp_path, data_dir):
    data = tmp_path / "data"
    data.mkdir()
    for name in ["lab_ipa.yaml", "lab_ipa.png", "lab_ipa_gt_labels.png", "anchors.csv"]:
        (data / name).symlink_to(data_dir / "ipa" / name)
    out = tmp_path / "out"
    assert main(["eval", "segment", str(data), "--out", str(out)]) == 0
    results = json.loads((out / "results.json").read_text())
    assert [(r["map"], r["variant"]) for r in results["maps"]] == [
        ("lab_ipa", "spectral"),
        ("lab_ipa", "doors"),
    ]
    methods = {m["method"] for m in results["means"]}
    assert {"spectral", "doors", "ipa_distance", "ipa_morphological"} <= methods
    for found in results["maps"]:
        assert found["mcc"] > 0.5 and found["rooms"] == 10
        assert 0 < found["rose2_iou"] <= 100
    # a second run refuses to overwrite, unless --force; with it the results are new
    assert main(["eval", "segment", str(data), "--out", str(out)]) == 2
    (out / "results.json").write_text("{}")
    assert main(["eval", "segment", str(data), "--out", str(out), "--force"]) == 0
    again = json.loads((out / "results.json").read_text())["maps"]
    assert [r["mcc"] for r in again] == [r["mcc"] for r in results["maps"]]


def _eval_one_plan(tmp_path: Path, data_dir: Path, plan: str, option: str) -> dict:
    """``topomap eval segment`` with ``option`` on the ipa ``plan`` alone: its results."""
    data = tmp_path / "data"
    data.mkdir()
    for name in [f"{plan}.yaml", f"{plan}.png", f"{plan}_gt_labels.png"]:
        (data / name).symlink_to(data_dir / "ipa" / name)
    out = tmp_path / "out"
    assert main(["eval", "segment", str(data), option, "--out", str(out)]) == 0
    return json.loads((out / "results.json").read_text())


def test_eval_segment_turns_each_map_and_its_rooms_alike(tmp_path, data_dir):
    results = _eval_one_plan(tmp_path, data_dir, "lab_ipa", "--rotations")
    spectral = {
        (r["rotation"], r["turned_back"]): r for r in results["maps"] if r["variant"] == "spectral"
    }
    turns = [3.0, 17.0, 30.0, 45.0]
    assert sorted(spectral) == [(0.0, False)] + [(d, b) for d in turns for b in (False, True)]
    for found in spectral.values():
        # the rooms turned with the map: all ten found again, the regions on them
        assert found["rooms"] == 10 and found["mcc"] > 0.6
    means = {(m["method"], m["rotation"], m["turned_back"]) for m in results["means"]}
    assert {("spectral", 30.0, False), ("doors", 45.0, True)} <= means


def test_eval_segment_resamples_each_map_and_its_rooms_alike(tmp_path, data_dir):
    results = _eval_one_plan(tmp_path, data_dir, "office_a", "--resolutions")
    spectral = {r["cell_factor"]: r for r in results["maps"] if r["variant"] == "spectral"}
    assert sorted(spectral) == [0.5, 1.0, 2.0]
    for found in spectral.values():
        # the rooms resampled with the map: all 27 found again, the regions on them
        assert found["rooms"] == 27 and found["mcc"] > 0.9
    means = {(m["method"], m["cell_factor"]) for m in results["means"]}
    assert {("spectral", 2.0), ("doors", 0.5)} <= means


def test_eval_segment_grows_each_maps_walls_and_takes_their_cells_from_its_rooms(
    tmp_path, data_dir
):
    results = _eval_one_plan(tmp_path, data_dir, "lab_ipa", "--thicker")
    spectral = {r["grown_walls"]: r for r in results["maps"] if r["variant"] == "spectral"}
    assert sorted(spectral) == [0, 1]
    for found in spectral.values():  # the same ten rooms, a cell narrower
        assert found["rooms"] == 10 and found["mcc"] > 0.6
    means = {(m["method"], m["grown_walls"]) for m in results["means"]}
    assert {("spectral", 1), ("doors", 0), ("doors", 1)} <= means


def test_eval_segment_maps_each_map_half_a_cell_over_and_its_rooms_alike(tmp_path, data_dir):
    results = _eval_one_plan(tmp_path, data_dir, "lab_ipa", "--half-cell")
    spectral = {r["half_cell_over"]: r for r in results["maps"] if r["variant"] == "spectral"}
    assert sorted(spectral) == [False, True]
    for found in spectral.values():  # the same ten rooms, drawn half a cell over
        assert found["rooms"] == 10 and found["mcc"] > 0.6
    means = {(m["method"], m["half_cell_over"]) for m in results["means"]}
    assert {("spectral", True), ("doors", True), ("doors", False)} <= means


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 12), st.integers(1, 12), st.data())
def test_half_a_cell_over_a_cell_is_occupied_where_one_of_four_up_and_left_was(
    height: int, width: int, data: st.DataObject
) -> None:
    from topomap.cli.evaluate import half_cell_over

    cells = map_cells(data, height, width)
    grid, rooms = half_cell_over(OccupancyGrid(cells, 0.05), np.ones(cells.shape, np.int32))
    assert grid.shape == cells.shape and grid.resolution == 0.05
    padded = np.pad(cells, ((1, 0), (1, 0)), constant_values=-1)
    for r in range(height):
        for c in range(width):
            four = padded[r : r + 2, c : c + 2]
            assert grid.occupied[r, c] == (four == 100).any()
            assert grid.free[r, c] == (not (four == 100).any() and (four == 0).any())
    assert (rooms[grid.occupied] == 0).all() and (rooms[~grid.occupied] == 1).all()


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 12), st.integers(1, 12), st.integers(0, 2), st.data())
def test_thickened_walls_take_the_cells_beside_them_and_nothing_else(
    height: int, width: int, grown: int, data: st.DataObject
) -> None:
    from topomap.cli.evaluate import thickened

    cells = map_cells(data, height, width)
    rooms = np.array(
        data.draw(st.lists(st.integers(0, 3), min_size=cells.size, max_size=cells.size))
    ).reshape(cells.shape)
    grid, thick_rooms = thickened(OccupancyGrid(cells, 0.05), rooms, grown)
    rows, cols = np.indices(cells.shape)
    walls = np.argwhere(cells == 100)
    near = np.zeros(cells.shape, bool)  # within `grown` cells of a wall, 8-neighbourhood
    for r, c in walls:
        near |= (np.abs(rows - r) <= grown) & (np.abs(cols - c) <= grown)
    near |= cells == 100
    assert (grid.occupied == near).all()
    assert (grid.cells[~near] == cells[~near]).all()  # free and unknown elsewhere as they were
    assert (thick_rooms == (rooms if grown == 0 else np.where(near, 0, rooms))).all()


@settings(max_examples=40, deadline=None)
@given(
    st.integers(1, 9),
    st.integers(1, 9),
    st.data(),
)
def test_resampled_cells_are_what_a_mapper_makes_and_a_split_map_comes_back(
    height: int, width: int, data: st.DataObject
) -> None:
    from topomap.cli.evaluate import resampled

    cells = map_cells(data, 2 * height, 2 * width)
    rooms = np.array(
        data.draw(st.lists(st.integers(0, 3), min_size=cells.size, max_size=cells.size))
    ).reshape(cells.shape)
    grid = OccupancyGrid(cells, 0.05)
    coarse, coarse_rooms = resampled(grid, rooms, 2.0)
    blocks = cells.reshape(height, 2, width, 2)
    occupied = (blocks == 100).any(axis=(1, 3))
    assert coarse.resolution == 0.1 and coarse.shape == (height, width)
    assert (coarse.occupied == occupied).all()
    assert (coarse.free == (~occupied & (blocks == 0).any(axis=(1, 3)))).all()
    assert (coarse_rooms[occupied] == 0).all()
    room_blocks = rooms.reshape(height, 2, width, 2)
    for r, c in zip(*np.nonzero(coarse_rooms), strict=True):  # a room of the block, the most
        counts = np.bincount(room_blocks[r, :, c, :].ravel(), minlength=4)[1:]
        assert counts[coarse_rooms[r, c] - 1] == counts.max() > 0
    split, split_rooms = resampled(grid, rooms, 0.5)
    back, back_rooms = resampled(split, split_rooms, 2.0)
    assert (back.cells == cells).all() and (back_rooms == np.where(grid.occupied, 0, rooms)).all()


def _intel_labels(tmp_path: Path, name: str) -> Path:
    """A labels folder holding the Intel log's entry of ``tests/data/labels/<name>`` only."""
    drawn = json.loads((Path(__file__).parents[1] / "data/labels" / name).read_text())
    labels = tmp_path / "labels"
    labels.mkdir()
    (labels / name).write_text(json.dumps({"intel": drawn["intel"]}))
    return labels


def test_eval_corridors_finds_intels_ring_corridor_in_one_region(tmp_path, data_dir):
    # the ring's corners have wide doors off them: a corridor with doors along it
    labels = _intel_labels(tmp_path, "carmen.json")
    out = tmp_path / "out"
    command = ["eval", "corridors", str(data_dir / "carmen"), "--hand-labels", str(labels)]
    assert main([*command, "--out", str(out)]) == 0
    (intel,) = json.loads((out / "results.json").read_text())["logs"]
    assert intel["log"] == "intel" and intel["largest_share"] > 0.8 and intel["pieces"] <= 2


def test_eval_logs_scores_the_keyframes_against_the_drawn_rooms(tmp_path, data_dir, capsys):
    labels = _intel_labels(tmp_path, "carmen_rooms.json")
    out = tmp_path / "out"
    command = ["eval", "logs", str(data_dir / "carmen"), "--hand-labels", str(labels)]
    assert main([*command, "--out", str(out)]) == 0
    records = json.loads((out / "results.json").read_text())["logs"]
    assert [(r["method"], r["input"]) for r in records] == [
        (method, source) for method in ("spectral", "doors") for source in ("keyframes", "map")
    ]
    for record in records:
        assert record["log"] == "intel" and record["rooms"] == 24 and record["in_rooms"] >= 0.97
        assert record["regions"] > 10 and 0.5 < record["mcc"] <= 1
        assert 50 < record["rose2_iou"] <= 100
    # most keyframes stand in the ring corridor: the ARI is mostly whether it is one region
    assert 0.55 <= records[0]["keyframe_ari"] <= 1
    assert records[0]["mcc"] != records[1]["mcc"]  # the robot's keyframes, then the map's
    assert "| intel | spectral |" in capsys.readouterr().out


def test_eval_logs_maps_the_logs_on_cells_of_the_resolution_given(tmp_path, data_dir, capsys):
    labels = _intel_labels(tmp_path, "carmen_rooms.json")
    out = tmp_path / "out"
    command = ["eval", "logs", str(data_dir / "carmen"), "--hand-labels", str(labels)]
    assert main([*command, "--resolution", "0.1", "--out", str(out)]) == 0
    records = json.loads((out / "results.json").read_text())["logs"]
    assert {r["resolution"] for r in records} == {0.1} and records[0]["rooms"] == 24
    # on 0.1 m cells too the ring corridor, where most keyframes stand, is one region
    assert records[0]["input"] == "keyframes" and records[0]["keyframe_ari"] >= 0.55
    for bad in ("0", "-0.1", "nan"):
        assert main([*command, "--resolution", bad, "--out", str(out)]) == 2
    assert "--resolution" in capsys.readouterr().err


def test_eval_runs_scores_both_methods_on_each_run(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["eval", "runs", "--sizes", "flat", "--seeds", "3", "--out", str(out)]) == 0
    results = json.loads((out / "results.json").read_text())
    assert [(r["seed"], r["method"]) for r in results["runs"]] == [
        (seed, method) for seed in (0, 1, 2) for method in ("spectral", "doors")
    ]
    for run in results["runs"]:
        assert run["keyframes"] > 50 and run["rooms"] >= 5
        assert 0.5 < run["mcc"] <= 1 and 0.5 < run["keyframe_ari"] <= 1
    spectral, doors = results["runs"][::2], results["runs"][1::2]
    assert any(s["mcc"] != d["mcc"] for s, d in zip(spectral, doors, strict=True))  # both ran
    means = results["means"][0]
    assert means["method"] == "spectral" and means["runs"] == 3
    assert means["min_mcc"] == min(r["mcc"] for r in spectral)
    assert "| flat | spectral | 3 |" in capsys.readouterr().out
    # both methods are always scored: no --method
    assert main(["eval", "runs", "--method", "doors", "--out", str(out)]) == 2
    for fov in ("0", "361", "90.5"):
        assert main(["eval", "runs", "--fov", fov, "--out", str(out)]) == 2
    lidar = ["eval", "runs", "--sizes", "flat", "--seeds", "1", "--fov", "360", "--force"]
    assert main([*lidar, "--out", str(out)]) == 0
    runs = json.loads((out / "results.json").read_text())["runs"]
    assert [r["fov"] for r in runs] == [360, 360] and runs[0]["keyframe_ari"] > 0.9
    # a usage error naming the size
    assert main(["eval", "runs", "--sizes", "castle", "--out", str(out)]) == 2
    assert "unknown building size(s) ['castle']" in capsys.readouterr().err


def test_corridor_systems_join_corridors_that_meet_without_a_door():
    from maps.sim.floorplan import FloorPlan

    labels = np.array([[4, 4, 1, 1, 2, 2, 0, 3, 3], [4, 4, 1, 1, 2, 2, 0, 3, 3]], np.int32)
    grid = OccupancyGrid.from_masks(labels > 0, 0.5)
    types = ("corridor", "corridor", "corridor", "room")  # 3 stands apart, 4 is a room
    drawn = FloorPlan(grid, labels, types, doors=(), rects=())
    assert drawn.corridor_systems()[0].tolist() == [4, 4, 1, 1, 1, 1, 0, 3, 3]
    plan = maps.generate_floor_plan("office", random_state=1)
    systems = plan.corridor_systems()
    for index, kind in enumerate(plan.types, start=1):
        cells = systems[plan.labels == index]
        if kind != "corridor":  # every other space keeps its own label
            assert (cells == index).all()
    corridor_ids = [i for i, kind in enumerate(plan.types, start=1) if kind == "corridor"]
    assert len(np.unique(systems[np.isin(plan.labels, corridor_ids)])) == 1
    assert (plan.rooms_on(plan.grid, systems) == systems).all()


def test_rotated_keeps_every_label_and_holds_the_whole_image():
    from topomap.cli.evaluate import rotated

    labels = np.zeros((40, 60), np.int32)
    labels[5:15, 5:25], labels[20:35, 30:55] = 1, 2
    turned = rotated(labels, 30.0, 0)
    assert turned.shape[0] > 40 and turned.shape[1] > 60
    counts = np.bincount(turned.ravel(), minlength=3)
    assert abs(counts[1] - 200) <= 20 and abs(counts[2] - 375) <= 30  # area kept
    assert (rotated(rotated(labels, 90.0, 0), -90.0, 0) == labels).all()


def test_bench_segment_writes_records(tmp_path, capsys):
    args = [
        "bench",
        "segment",
        "--out",
        str(tmp_path),
        "--sizes",
        "40",
        "80",
        "--naive-up-to",
        "40",
        "--building",
        "flat",
    ]
    assert main(args) == 0
    records = json.loads((tmp_path / "results.json").read_text())
    assert [(r["method"], r["keyframes"]) for r in records] == [
        ("topomap", 40),
        ("naive", 40),
        ("topomap", 80),
    ]
    assert all(r["seconds"] > 0 for r in records)
    assert "speed-up" in capsys.readouterr().out


def test_bench_maps_command_times_the_segment_command_in_parts(tmp_path, capsys):
    from segmentation.export import write_label_image

    plan = maps.generate_floor_plan("flat", random_state=0)
    data = tmp_path / "data"
    data.mkdir()
    plan.grid.save(data / "flat.yaml")
    write_label_image(plan.labels, data / "flat_gt_labels.png")
    out = tmp_path / "out"
    assert main(["-q", "bench", "maps", "--command", str(data), "--out", str(out)]) == 0
    (record,) = json.loads((out / "command.json").read_text())
    assert record["map"] == "flat" and record["seconds"] > 0
    parts = record["startup_s"] + record["segmentation_s"] + record["outputs_s"]
    assert record["startup_s"] > 0 and record["segmentation_s"] > 0 and record["cpu_s"] > 0
    assert parts == pytest.approx(record["seconds"], abs=0.01) or parts > record["seconds"]
    assert "| mean |" in capsys.readouterr().out
    again = ["-q", "bench", "maps", "--command", str(data), "--out", str(out), "--force"]
    assert main([*again, "--canvas", "1200"]) == 0
    plain, canvas = json.loads((out / "command.json").read_text())
    assert (plain["map"], canvas["map"]) == ("flat", "flat@1200")
    assert canvas["seconds"] > 0 and canvas["segmentation_s"] > 0
    assert main([*again, "--canvas", "0"]) == 2  # a usage error, before any work


def test_bench_maps_times_the_pipeline_topomap_segment_runs(monkeypatch):
    from segmentation.pipeline import MAP_CRITERION, MapSegmenter
    from topomap.cli.bench_maps import time_segmentation

    used = []
    segment = MapSegmenter.segment

    def spy(self, *args, **kwargs):
        used.append(self)
        return segment(self, *args, **kwargs)

    monkeypatch.setattr(MapSegmenter, "segment", spy)
    record = time_segmentation("flat", maps.generate_floor_plan("flat", random_state=0).grid)
    (pipeline,) = used
    # the command's similarity (not the paper's nn, SpectralSegmenter's own default) and its
    # large maps' blocks on every core
    assert pipeline.spectral.criterion == MAP_CRITERION and pipeline.n_jobs == -1
    assert record["regions"] > 1 and record["seconds"] > 0


def test_segment_bad_input(tmp_path, capsys):
    walls = maps_grid_without_free_space(tmp_path)
    assert main(["segment", str(walls), "--out", str(tmp_path / "o")]) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith(f"topomap: error: {walls}: the map has no free space a robot")
    assert "radius 0.2 m fits in (cells: free " in line  # the counts, not a Python dict
    assert main(["segment", "--out", str(tmp_path / "o")]) == 2
    assert "one of the arguments map --scans is required" in capsys.readouterr().err
    assert main(["segment", str(walls), "--scans", "x.log", "--out", str(tmp_path / "o")]) == 2
    assert "not allowed with argument" in capsys.readouterr().err
    assert main(["segment", str(walls), "--out", str(tmp_path / "o"), "--p", "2"]) == 2
    assert "p must lie" in capsys.readouterr().err


def maps_grid_without_free_space(folder: Path) -> Path:
    grid = OccupancyGrid(np.full((20, 20), 100, np.int8), 0.05)
    return grid.save(folder / "walls.yaml")


def _flat_map(folder: Path) -> Path:
    assert main(["generate", "--size", "flat", "--seed", "3", "--out", str(folder)]) == 0
    return folder / "map.yaml"


def test_plan_prints_a_valid_path_and_draws_it(tmp_path, capsys):
    from planners.visibility import VisibilityGraph
    from planners.workspace import Workspace

    yaml = _flat_map(tmp_path / "flat")
    space = Workspace(OccupancyGrid.load(yaml), 0.2)
    from planners.benchmark import far_queries

    ((start, goal),) = far_queries(space, 1, random_state=0)
    capsys.readouterr()
    picture = tmp_path / "path.png"
    arguments = ["plan", str(yaml), "--start", "{},{}".format(*start)]
    arguments += ["--goal", "{},{}".format(*goal), "--draw", str(picture), "--compare"]
    assert main(arguments) == 0
    result = json.loads(capsys.readouterr().out)
    waypoints = np.array(result["waypoints"])
    assert np.allclose(waypoints[[0, -1]], [start, goal], atol=1e-3)
    assert space.collisions(waypoints) == 0
    # not longer than 10% over the exact shortest path (the visibility graph, another planner)
    shortest = VisibilityGraph(space).plan(start, goal).length
    assert shortest - 1e-6 <= result["length_m"] <= 1.1 * shortest
    assert result["regions"] and len(result["region_names"]) == len(result["regions"])
    assert cv2.imread(str(picture)) is not None


def test_plan_with_saved_regions_and_a_region_goal(tmp_path, capsys):
    yaml = _flat_map(tmp_path / "flat")
    assert main(["segment", str(yaml), "--out", str(tmp_path / "seg")]) == 0
    capsys.readouterr()
    grid = OccupancyGrid.load(yaml)
    rows, cols = np.nonzero(grid.inflate(0.3).free)
    x, y = grid.cell_to_world(rows[0], cols[0])
    arguments = ["plan", str(yaml), "--start", f"{x},{y}", "--goal", "2"]
    assert main([*arguments, "--regions", str(tmp_path / "seg")]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["regions"][-1] == 2


def test_plan_from_a_region_to_a_region_by_id_and_by_name(tmp_path, capsys):
    yaml = _flat_map(tmp_path / "flat")
    assert main(["segment", str(yaml), "--out", str(tmp_path / "seg")]) == 0
    graph = json.loads((tmp_path / "seg" / "graph.json").read_text())
    names = {node["id"]: node["name"] for node in graph["nodes"]}
    capsys.readouterr()
    saved = ["--regions", str(tmp_path / "seg")]
    assert main(["plan", str(yaml), "--start", "1", "--goal", "2", *saved]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["regions"][0] == 1 and result["regions"][-1] == 2
    assert main(["plan", str(yaml), "--start", names[2], "--goal", "1", *saved]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["regions"][0] == 2 and result["regions"][-1] == 1
    # a footprint robot needs its heading at the start
    assert main(["plan", str(yaml), "--start", "1", "--goal", "2", "--robot", "rect:0.6x0.4"]) == 2
    assert "starts at a pose" in capsys.readouterr().err


def test_plan_a_footprint_robot_given_by_its_size_and_turning_radius(tmp_path, capsys):
    from planners.robots import parse_robot
    from planners.sweep import footprint_collisions

    yaml = _flat_map(tmp_path / "flat")
    assert main(["segment", str(yaml), "--out", str(tmp_path / "seg")]) == 0
    grid = OccupancyGrid.load(yaml)
    rows, cols = np.nonzero(grid.inflate(0.8).free)
    x, y = grid.cell_to_world(rows[len(rows) // 2], cols[len(cols) // 2])
    capsys.readouterr()
    arguments = ["plan", str(yaml), "--start", f"{x},{y},0", "--goal", "2"]
    arguments += ["--regions", str(tmp_path / "seg"), "--robot", "reeds-shepp"]
    assert main([*arguments, "--footprint", "0.6", "0.4", "--turning-radius", "0.5"]) == 0
    result = json.loads(capsys.readouterr().out)
    poses = np.array(result["poses"])
    assert np.allclose(poses[0], [x, y, 0.0], atol=1e-3) and result["regions"][-1] == 2
    robot = parse_robot("reeds-shepp:radius=0.5,footprint=0.6x0.4")
    assert footprint_collisions(grid, robot.polygon, poses) == 0


def test_plan_rejects_a_start_in_a_wall(tmp_path, capsys):
    yaml = _flat_map(tmp_path / "flat")
    grid = OccupancyGrid.load(yaml)
    rows, cols = np.nonzero(grid.occupied)
    x, y = (float(v) for v in grid.cell_to_world(rows[0], cols[0]))
    capsys.readouterr()
    assert main(["plan", str(yaml), f"--start={x},{y}", "--goal", "3,3"]) == 2
    assert f"start ({x:g}, {y:g}) lies in a wall" in capsys.readouterr().err
    assert main(["plan", str(yaml), "--start=-0.05,-0.05", "--goal", "3,3"]) == 2
    assert "start (-0.05, -0.05) lies in an unknown cell" in capsys.readouterr().err
    assert main(["plan", str(yaml), "--start", "1,2,3,4", "--goal", "3,3"]) == 2
    assert "argument --start: expected X,Y in metres, got '1,2,3,4'" in capsys.readouterr().err
    assert main(["plan", str(yaml), "--start", "1;2", "--goal", "3,3"]) == 2  # a name
    assert "no region named '1;2'; known names: " in capsys.readouterr().err


def test_plan_refuses_a_bad_start_before_preparing_the_planner(tmp_path, capsys):
    yaml = _flat_map(tmp_path / "flat")
    assert main(["-q", "segment", str(yaml), "--out", str(tmp_path / "seg")]) == 0
    prepared = list(tmp_path.joinpath("seg").glob("door_graph_*"))
    argv = ["-q", "plan", str(yaml), "--regions", str(tmp_path / "seg"), "--goal", "2"]
    assert main([*argv, "--start=1e308,1e308"]) == 2
    assert "start (1e+308, 1e+308) lies outside the map" in capsys.readouterr().err
    assert list(tmp_path.joinpath("seg").glob("door_graph_*")) == prepared  # none prepared


def test_plan_on_a_real_floor_plan(data_dir, capsys):
    from planners.benchmark import far_queries
    from planners.workspace import Workspace

    yaml = data_dir / "ipa" / "Freiburg52_scan.yaml"
    space = Workspace(OccupancyGrid.load(yaml), 0.2)
    ((start, goal),) = far_queries(space, 1, random_state=1)
    arguments = ["plan", str(yaml), "--start", "{},{}".format(*start)]
    assert main([*arguments, "--goal", "{},{}".format(*goal)]) == 0
    waypoints = np.array(json.loads(capsys.readouterr().out)["waypoints"])
    assert space.collisions(waypoints) == 0 and space.path_free(waypoints)


@pytest.mark.slow
def test_bench_plan_writes_one_record_per_planner_and_query(tmp_path):
    out = tmp_path / "bench"
    arguments = ["bench", "plan", "--sizes", "flat", "--queries", "3", "--out", str(out)]
    cache = ["--cache", str(tmp_path / "cache")]
    assert main([*arguments, "--time-limit", "5", *cache]) == 0
    records = json.loads((out / "results.json").read_text())
    assert len(records) == 15
    assert {r["planner"] for r in records} == {
        "hierarchical",
        "grid_mcp",
        "flat_rrtconnect",
        "flat_prm",
        "flat_bitstar",
    }
    for record in records:
        assert record["map"] == "generated-flat" and record["success"]
        assert record["collisions"] == 0
        assert record["length_m"] >= record["optimal_m"] - 1e-3
    preprocessing = json.loads((out / "preprocessing.json").read_text())
    assert preprocessing["generated-flat"]["segmentation"] > 0
    assert "| generated-flat | hierarchical | 1.0 |" in (out / "results.md").read_text()
    assert cv2.imread(str(out / "times.png")) is not None
    assert (out / "ompl" / "generated-flat.log").read_text().startswith("topomap version")


@pytest.mark.slow
def test_bench_plan_runs_only_the_planners_named(tmp_path):
    out = tmp_path / "bench"
    arguments = ["bench", "plan", "--sizes", "flat", "--queries", "3", "--out", str(out)]
    robot = ["--robot", "rect:0.9x0.6", "--time-limit", "5", "--planners", "hierarchical"]
    assert main([*arguments, *robot]) == 0
    records = json.loads((out / "results.json").read_text())
    assert len(records) == 3 and {r["planner"] for r in records} == {"hierarchical"}


@pytest.mark.slow
def test_bench_plan_runs_only_the_disc_planners_named(tmp_path):
    out = tmp_path / "bench"
    arguments = ["bench", "plan", "--sizes", "flat", "--queries", "2", "--out", str(out)]
    chosen = ["--planners", "hierarchical", "grid_mcp", "--cache", str(tmp_path / "cache")]
    assert main([*arguments, *chosen]) == 0
    records = json.loads((out / "results.json").read_text())
    assert len(records) == 4 and {r["planner"] for r in records} == {"hierarchical", "grid_mcp"}
    assert all(r["success"] and r["collisions"] == 0 for r in records)
    preprocessing = json.loads((out / "preprocessing.json").read_text())
    assert "prm_roadmap" not in preprocessing["generated-flat"]


def test_bench_plan_refuses_an_unknown_map_size(tmp_path, capsys):
    arguments = ["bench", "plan", "--sizes", "office", "rooms9", "--out", str(tmp_path / "b")]
    assert main(arguments) == 2
    assert "rooms9" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("robot", "named"),
    [(["--robot", "rect:0.9x0.6"], "flat_est"), ([], "flat_est for a disc robot")],
)
def test_bench_plan_refuses_planners_it_cannot_run(tmp_path, capsys, robot, named):
    arguments = ["bench", "plan", "--sizes", "flat", "--out", str(tmp_path / "bench"), *robot]
    assert main([*arguments, "--planners", "hierarchical", "flat_est"]) == 2
    assert named in capsys.readouterr().err


@pytest.mark.slow
def test_eval_labels_on_the_place_labelled_plans(tmp_path, data_dir, capsys):
    out = tmp_path / "labels"
    model = tmp_path / "forest.skops"
    args = ["eval", "labels", str(data_dir / "ipa_places"), "--out", str(out)]
    assert main([*args, "--save-model", str(model)]) == 0
    printed = capsys.readouterr().out
    assert "| rules (LOBO) | ipa_places |" in printed and "margins of the default" in printed
    results = json.loads((out / "results.json").read_text())
    scores = {(r["method"], r["source"]): r for r in results["scores"]}
    assert scores[("rules (LOBO)", "ipa_places")]["macro-F1"] > (
        scores[("always room (LOBO)", "ipa_places")]["macro-F1"] + 0.2
    )
    assert set(results["margins"]) == set(RuleClassifier.thresholds())
    for margin in results["margins"].values():
        assert margin["lowest"] <= margin["value"] <= margin["highest"]
    regions = len(results["regions"])
    assert regions > 30 and sum(r["regions"] for r in results["per_map"]) == regions
    assert len(list(out.glob("ipa_places_*_labels.png"))) == 5
    assert ForestClassifier.load(model).predict(np.zeros((1, len(FEATURES)))) in (
        [[p] for p in PLACE_TYPES]
    )
