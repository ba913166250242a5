import json
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from maps.grid import OccupancyGrid
from topomap.cli import main

ROOT = Path(__file__).resolve().parents[2]


def test_demo_writes_picture_map_and_summary(tmp_path):
    assert main(["demo", "--out", str(tmp_path), "--size", "flat", "--seed", "1"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["robot"]["rooms_unreachable"] == 0
    assert summary["robot"]["keyframes"] > 10
    assert summary["map"]["true_free_cells_found"] > 0.9
    assert summary["map"]["free_cells_not_free_in_truth"] < 0.03
    assert set(summary["seconds"]) == {"generate", "drive", "build_map"}
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
    [("simulate_robot_run.py", ["3"]), ("map_from_carmen_log.py", ["LOG", "OUT"])],
)
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


def test_module_entry_point():
    done = subprocess.run(
        [sys.executable, "-m", "topomap", "--help"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0 and "demo" in done.stdout
