"""``topomap batch`` on a real dask.distributed LocalCluster of 2 worker processes."""

import csv
import json
import os

import numpy as np
import pytest

from maps.errors import FormatError, MapFileNotFoundError
from maps.sim.floorplan import generate_floor_plan
from tests.maps.bags import Robot, tf_bag
from topomap.cli.batch import dask_client, run_batch
from topomap.cli.inputs import find_inputs
from topomap.cli.main import main
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def client():
    with dask_client(workers=2) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        yield client


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    """Three generated flats as map YAMLs, and a map YAML whose image is missing."""
    folder = tmp_path_factory.mktemp("maps")
    grids = {}
    for seed in range(3):
        grids[f"flat-{seed}"] = generate_floor_plan("flat", random_state=seed).grid
        grids[f"flat-{seed}"].save(folder / f"flat-{seed}.yaml")
    (folder / "broken.yaml").write_text(
        "image: nowhere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return folder, grids


def _index(out):
    with (out / "index.csv").open() as stream:
        return {row["name"]: row for row in csv.DictReader(stream)}


@pytest.mark.slow
def test_batch_isolates_failures_skips_done_and_forces(tmp_path, client, plans):
    folder, grids = plans
    out = tmp_path / "out"
    records = run_batch([str(folder)], out, client=client)
    by_name = {r["name"]: r for r in records}
    assert sorted(by_name) == ["broken", "flat-0", "flat-1", "flat-2"]
    assert by_name["broken"]["status"] == "failed"
    assert "nowhere.pgm" in by_name["broken"]["error"]
    assert not (out / "broken").exists()
    for name, grid in grids.items():
        record = by_name[name]
        assert record["status"] == "ok"
        # the same regions as the facade run here, in this process
        assert record["regions"] == TopoMap.from_grid(grid).graph.number_of_nodes()
        files = {p.name for p in (out / name).iterdir()}
        assert {"regions.png", "graph.graphml", "graph.json", "regions.geojson"} <= files
        assert json.loads((out / name / "result.json").read_text())["status"] == "ok"
    index = _index(out)
    assert {n: r["status"] for n, r in index.items()} == {
        n: r["status"] for n, r in by_name.items()
    }
    assert float(index["flat-1"]["seconds"]) > 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"] == {"ok": 3, "skipped": 0, "failed": 1}
    assert summary["run"]["workers"] == 2
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no partial folder left

    # a re-run skips what is done (untouched) and retries the failure
    stamp = os.stat(out / "flat-0" / "result.json").st_mtime_ns
    again = {r["name"]: r for r in run_batch([str(folder / "*.yaml")], out, client=client)}
    assert [again[f"flat-{s}"]["status"] for s in range(3)] == ["skipped"] * 3
    assert again["flat-0"]["regions"] == by_name["flat-0"]["regions"]
    assert again["broken"]["status"] == "failed"
    assert os.stat(out / "flat-0" / "result.json").st_mtime_ns == stamp

    # --force redoes one input; the records of the others stay in the index
    forced = run_batch([str(folder / "flat-0.yaml")], out, client=client, force=True)
    assert forced[0]["status"] == "ok"
    assert os.stat(out / "flat-0" / "result.json").st_mtime_ns != stamp
    assert set(_index(out)) == set(by_name)


def test_find_inputs_names_and_errors(tmp_path, plans):
    folder, _ = plans
    other = tmp_path / "b"
    other.mkdir()
    (other / "flat-0.yaml").write_text((folder / "flat-0.yaml").read_text())
    (other / "intel.log.gz").write_bytes(b"")
    (other / "run.bag").write_bytes(b"")
    bag = other / "ros2"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    (other / "notes.yaml").write_text("title: not a map\n")
    jobs = find_inputs([str(folder / "flat-0.yaml"), str(other), str(folder / "flat-0.yaml")])
    assert [(j.kind, j.name) for j in jobs] == [
        ("map", f"{folder.name}__flat-0"),
        ("map", f"{tmp_path.name}__b__flat-0"),
        ("log", "intel"),
        ("bag", "ros2"),
        ("bag", "run"),
    ]
    with pytest.raises(MapFileNotFoundError, match="missing"):
        find_inputs([str(tmp_path / "missing")])
    with pytest.raises(MapFileNotFoundError, match=r"\*\.nothing"):
        find_inputs([str(tmp_path / "*.nothing")])
    with pytest.raises(FormatError, match=r"notes\.yaml.*not a map_server YAML"):
        find_inputs([str(other / "notes.yaml")])


@pytest.mark.slow
def test_blocks_on_the_dask_cluster_equal_the_sequential_run(client):
    """joblib's Dask backend (the current ``distributed.Client``) runs the blocks on the
    cluster's worker processes: the same labels as one block after the other."""
    from distributed import get_task_stream
    from joblib import parallel_config

    from segmentation.base import clone
    from segmentation.blocks import BlockSpectralSegmenter, keyframe_blocks
    from segmentation.refine import basins
    from segmentation.spectral import SpectralSegmenter
    from segmentation.virtual import virtual_keyframes

    plan = generate_floor_plan("flat", random_state=2)
    keyframes = virtual_keyframes(plan.grid, 0.8, random_state=0)
    blocks, places = keyframe_blocks(plan.grid, basins(plan.grid), keyframes, places=3)
    model = BlockSpectralSegmenter(SpectralSegmenter(random_state=0), blocks, places)
    sequential = clone(model).fit(keyframes)
    with get_task_stream(client) as stream, parallel_config(backend="dask"):
        parallel = clone(model, n_jobs=-1).fit(keyframes)
    ran_on = {task["worker"] for task in stream.data}  # the blocks ran on the cluster
    assert ran_on and ran_on <= set(client.scheduler_info()["workers"])
    assert len(places) >= 2
    assert np.array_equal(parallel.labels_, sequential.labels_)
    assert parallel.n_regions_ == sequential.n_regions_
    assert len(parallel.segmenters_) == len(sequential.segmenters_)


@pytest.mark.slow
def test_batch_command(tmp_path, plans, client, capsys):
    folder, _ = plans
    out = tmp_path / "out"
    bag = tf_bag(tmp_path, "sqlite3", Robot())  # a ROS 2 bag: scans placed by tf
    inputs = [str(folder / "flat-*.yaml"), str(bag)]
    assert main(["batch", *inputs, "--out", str(out), "--workers", "2"]) == 0
    printed = capsys.readouterr()
    assert "4 done, 0 skipped" in printed.out
    assert "inputs" in printed.err  # the progress bar
    written = {p.name for p in (out / bag.name).iterdir()}
    assert {"map.yaml", "keyframes.csv", "graph.json"} <= written
    result = json.loads((out / bag.name / "result.json").read_text())
    assert "placed in map by map -> odom -> base_link -> laser" in result["placed"]
    assert main(["batch", str(folder), "--out", str(out), "--workers", "1"]) == 1
    assert "0 done, 3 skipped (done before), 1 failed" in capsys.readouterr().out
    assert len(_index(out)) == 5  # the bag's record is kept
    assert main(["batch", str(tmp_path / "none*.yaml"), "--out", str(out)]) == 2
    # an existing cluster, by its scheduler's address
    remote = tmp_path / "remote"
    address = client.scheduler.address
    command = ["batch", str(folder / "flat-1.yaml"), "--out", str(remote)]
    assert main([*command, "--scheduler", address]) == 0
    summary = json.loads((remote / "summary.json").read_text())
    assert summary["run"]["scheduler"] == address and summary["counts"]["ok"] == 1


@pytest.mark.slow
def test_batch_on_real_data(tmp_path, client, data_dir):
    log = data_dir / "carmen" / "aces-corrected.log.gz"
    plan = data_dir / "ipa" / "Freiburg52_scan.yaml"
    records = run_batch([str(log), str(plan)], tmp_path, client=client)
    assert [(r["name"], r["kind"], r["status"]) for r in records] == [
        ("aces-corrected", "log", "ok"),
        ("Freiburg52_scan", "map", "ok"),
    ]
    assert all(r["regions"] >= 5 for r in records)
    written = {p.name for p in (tmp_path / "aces-corrected").iterdir()}
    assert {"map.yaml", "map.pgm", "keyframes.csv", "regions.geojson"} <= written
