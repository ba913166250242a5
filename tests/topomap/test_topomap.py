import csv

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import maps
from maps.errors import MapFileNotFoundError, OutputExistsError
from maps.scan import select_keyframes
from maps.sim.floorplan import generate_floor_plan
from segmentation.errors import ExportFormatError, SegmentationError
from segmentation.metrics import score
from topomap.cli.evaluate import SHIFTS, evaluate, floor_plans
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def flat():
    return maps.generate_floor_plan("flat", random_state=1)


def test_a_generated_flat_is_segmented_into_its_rooms(flat):
    topo = TopoMap.from_grid(flat.grid, random_state=0)
    assert score(topo.regions.labels, flat.labels).mcc > 0.9
    # the regions are the spectral partition; the door rule is the baseline beside it
    assert topo.spectral is topo.regions
    doors = TopoMap.from_grid(flat.grid, random_state=0, method="doors")
    assert score(doors.regions.labels, flat.labels).mcc > 0.8
    stages = {
        "condition",
        "places",
        "keyframes",
        "spectral",
        "regions",
        "cover",
        "graph",
        "labels",
    }
    assert set(topo.seconds) == stages
    # every region is a node, touching regions are joined, and the doors are door-sized
    assert sorted(topo.graph.nodes) == topo.regions.ids
    widths = [d.width for _, _, doors in topo.graph.edges(data="doors") for d in doors]
    assert widths and np.median(widths) < 1.5
    for node, data in topo.graph.nodes(data=True):
        assert topo.region_at(data["x"], data["y"]) == node
    again = TopoMap.from_grid(flat.grid, random_state=0)
    np.testing.assert_array_equal(again.regions.labels, topo.regions.labels)


def test_robot_keyframes_give_regions_and_a_keyframe_table(flat, tmp_path):
    route = maps.wander(flat.grid, flat.labels, random_state=0)
    scans = maps.simulate_scans(flat.grid, route.poses, maps.LaserModel(noise=0.01), random_state=0)
    keyframes = select_keyframes(scans)
    topo = TopoMap.from_keyframes(keyframes, flat.grid, random_state=0)
    assert score(topo.regions.labels, flat.labels).mcc > 0.7
    rows = list(csv.DictReader(topo.save_keyframes(tmp_path / "k.csv").open()))
    assert len(rows) == len(keyframes)
    assert list(rows[0]) == ["scan_index", "x", "y", "theta", "region"]
    for row, frame in zip(rows, keyframes, strict=True):
        assert int(row["scan_index"]) == frame.scan_index
        assert int(row["region"]) == topo.region_at(float(row["x"]), float(row["y"]))


def test_a_real_floor_plan_beats_the_classic_segmentations(data_dir):
    (plan,) = [p for p in floor_plans(data_dir / "ipa") if p.name == "office_b"]
    spectral, doors = evaluate(plan)
    assert spectral["variant"] == "spectral" and doors["variant"] == "doors"
    # anchors.csv on office_b: ipa distance MCC 0.949, MAORIS 0.999; ours must not fall behind
    for found in (spectral, doors):
        assert found["mcc"] > 0.95 and found["recall"] > 0.95 and found["precision"] > 0.95


def test_a_slam_map_one_cell_over_gets_the_same_rooms(data_dir):
    (plan,) = [p for p in floor_plans(data_dir / "rose2_partial") if p.name == "map6"]
    spectral, doors, released = evaluate(plan, shifts=SHIFTS)
    assert released["variant"] == "rose2_released"
    # when the wall gaps were found on the 0.1 m working grid, this map's MCC moved by 0.16
    # with where the grid's 2 x 2 blocks fell (0.647 / 0.806 / 0.718 / 0.658); 0.03 since, and
    # 0.07 with the finer places of 2026-12-03 (a place depth of 0.2 m, not 0.3: borderline
    # saddles of a cluttered map flip with the blocks, docs/segmentation.md)
    assert spectral["mcc_spread"] < 0.1  # the door baseline's: 0.15 on the same places
    for found in (spectral, doors):
        assert found["mcc"] > 0.7


def test_a_plan_moved_by_a_cell_is_scored_against_its_own_rooms(data_dir):
    (plan,) = [p for p in floor_plans(data_dir / "ipa") if p.name == "office_b"]
    spectral, doors = evaluate(plan, shifts=SHIFTS)
    for found in (spectral, doors):  # the four pooling phases of a 0.05 m plan, each cropped back
        assert found["mcc"] > 0.9 and found["recall"] > 0.95 and 0 <= found["mcc_spread"] < 0.1


@pytest.mark.slow
@settings(max_examples=4)
@given(st.integers(0, 1000), st.sampled_from([0.0, 0.4]))
def test_a_saved_map_reads_back_equal(tmp_path_factory, seed, furniture):
    plan = generate_floor_plan("flat", furniture=furniture, random_state=seed)
    topo = TopoMap.from_grid(plan.grid, random_state=seed)
    topo.rename(next(iter(topo.graph.nodes)), "kitchen")
    folder = tmp_path_factory.mktemp("saved")
    topo.save(folder)
    again = TopoMap.load(folder)
    assert again.grid == topo.grid
    assert np.array_equal(again.regions.labels, topo.regions.labels)
    assert sorted(again.graph.edges) == sorted(topo.graph.edges)
    for region, data in topo.graph.nodes(data=True):
        loaded = again.graph.nodes[region]
        assert (loaded["name"], loaded["label"]) == (data["name"], data["label"])
        assert loaded["polygon"].equals(data["polygon"])
    assert again.region("kitchen") == topo.region("kitchen")
    # the regions are the spectral partition, and the fitted partition survives too
    assert again.method == "spectral"
    assert np.array_equal(again.spectral.labels, topo.spectral.labels)
    assert np.array_equal(again.segmenter.labels_, topo.segmenter.labels_)
    assert again.segmenter.n_regions_ == topo.segmenter.n_regions_
    assert again.segmenter.silhouette_by_k_ == pytest.approx(topo.segmenter.silhouette_by_k_)
    with pytest.raises(SegmentationError, match="read back from files"):
        again.keyframes  # noqa: B018
    again.save(folder / "again")  # saved once more, the partition stays
    twice = TopoMap.load(folder / "again")
    assert np.array_equal(twice.segmenter.labels_, topo.segmenter.labels_)
    with pytest.raises(OutputExistsError):
        topo.save(folder)
    doors = TopoMap.from_grid(plan.grid, random_state=seed, method="doors")
    doors.save(folder / "doors")
    with pytest.raises(SegmentationError, match="read back from files"):
        TopoMap.load(folder / "doors").spectral  # noqa: B018


def test_files_that_do_not_belong_together_are_refused(tmp_path, flat):
    topo = TopoMap.from_grid(flat.grid, random_state=0)
    topo.save(tmp_path)
    other = generate_floor_plan("flat", random_state=5)
    other.grid.save(tmp_path / "map.yaml", overwrite=True)
    with pytest.raises(ExportFormatError, match=r"map\.pgm: changed|regions\.png"):
        TopoMap.load(tmp_path)
    with pytest.raises(MapFileNotFoundError):
        TopoMap.load(tmp_path / "nothing")


def test_a_pipeline_and_options_together_are_refused(flat):
    from segmentation.errors import ParameterError
    from segmentation.pipeline import MapSegmenter

    with pytest.raises(ParameterError, match="not both"):
        TopoMap.from_grid(flat.grid, pipeline=MapSegmenter(), robot_radius=5.0)


def test_reprs_are_one_short_line(flat):
    topo = TopoMap.from_grid(flat.grid, random_state=0)
    found = topo.segmentation
    shown = [topo, found, found.conditioned, topo.regions, topo.grid, topo.keyframes[0]]
    shown.append(topo.keyframes[0].scan)
    for value in shown:
        text = repr(value)
        assert "\n" not in text and len(text) < 240, text[:300]
    regions = len(topo.regions.ids)
    assert repr(topo).startswith(f"TopoMap({regions} regions, ")
