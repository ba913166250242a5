import csv
import gzip
import json
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from maps.errors import MapTooLargeError
from maps.scan import Keyframe, LaserScan
from topomap.cli.main import main
from topomap.cli.online import run_online
from topomap.errors import UsageError
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def intel_online(data_dir, tmp_path_factory):
    out = tmp_path_factory.mktemp("online")
    log = data_dir / "carmen" / "intel-corrected.log.gz"
    argv = ["-q", "segment", "--scans", str(log), "--online", "--out", str(out)]
    status = main([*argv, "--seed-keyframes", "250", "--frames", "150"])
    return status, out


@pytest.mark.slow
def test_segment_online_writes_the_offline_files_events_and_a_gif(intel_online):
    status, out = intel_online
    assert status == 0
    for name in ("regions.png", "graph.graphml", "graph.json", "regions.geojson", "map.yaml"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    # the folder reads back as an offline one's, for view, plan and export
    topo = TopoMap.load(out)
    assert len(topo.regions.ids) == summary["regions"]
    assert {n: topo.graph.nodes[int(n)]["name"] for n in summary["names"]} == summary["names"]
    assert summary["seed_keyframes"] == 250
    with Image.open(out / "regions.gif") as gif:
        # a frame at the seed and one every 150 keyframes after it
        assert getattr(gif, "n_frames", 1) == 1 + (summary["keyframes"] - 250) // 150
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    assert {e["kind"] for e in events} <= {"created", "grown", "merged", "split", "moved"}
    with (out / "keyframes.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == summary["keyframes"]
    # the region a keyframe got on arrival is the one its arrival (its first event) names
    arrivals: dict[int, int] = {}
    for event in events:
        arrivals.setdefault(event["keyframe"], event["region"])
    for index, row in enumerate(rows[250:], start=250):
        assert int(row["region_on_arrival"]) == arrivals[index]
    # final regions: the arrivals replayed through the keyframes the re-partitions moved
    final = [int(row["region_on_arrival"]) for row in rows]
    for event in events:
        if event["kind"] == "moved":
            for member in event["members"]:
                assert final[member] == event["source"]
                final[member] = event["region"]
    assert final == [int(row["region_final"]) for row in rows]


@pytest.mark.slow
def test_segment_online_refuses_to_overwrite_and_bad_options(intel_online, data_dir, capsys):
    _, out = intel_online
    log = str(data_dir / "carmen" / "intel-corrected.log.gz")
    assert main(["-q", "segment", "--scans", log, "--online", "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err
    fresh = str(out / "again")
    argv = ["-q", "segment", "--scans", log, "--online"]
    assert main([*argv, "--out", fresh, "--online-method", "centres", "--theta", "1.5"]) == 2
    assert "argument --theta: must lie in [0, 1], got 1.5" in capsys.readouterr().err
    assert main(["-q", "segment", "--scans", log, "--online", "--out", fresh, "--frames", "0"]) == 2
    assert "--frames must be" in capsys.readouterr().err


@pytest.fixture
def short_log(data_dir, tmp_path):
    """The first 40 scans of Intel's log."""
    with gzip.open(data_dir / "carmen" / "intel-corrected.log.gz", "rt") as log:
        lines = [line for line in log if line.startswith("FLASER")][:40]
    path = tmp_path / "short.log"
    path.write_text("".join(lines))
    return path


def _online(log, out, *options):
    argv = ["-q", "segment", "--scans", str(log), "--online", "--out", str(out)]
    return main([*argv, "--seed-keyframes", "10", "--k", "2", *options])


@pytest.mark.parametrize("name", ["graph.json", "map.pgm", "segmentation.png", "regions.gif"])
def test_online_checks_every_output_before_any_work(short_log, tmp_path, capsys, monkeypatch, name):
    monkeypatch.setattr("topomap.cli.commands.segment.read_keyframes", _never)
    out = tmp_path / "out"
    out.mkdir()
    (out / name).write_text("mine")
    assert _online(short_log, out, "--frames", "10") == 2
    assert f"{name} exists; pass --force to replace it" in capsys.readouterr().err
    assert [p.name for p in out.iterdir()] == [name] and (out / name).read_text() == "mine"


def _never(*_args, **_kwargs):
    raise AssertionError("the log was read before the outputs were checked")


def test_a_failed_online_run_leaves_nothing_and_names_the_log(
    short_log, tmp_path, capsys, monkeypatch
):
    def too_large(*_args, **_kwargs):  # as the online regions refuse a scan 9 km away
        raise MapTooLargeError("online regions of 90000 x 80 cells is larger than memory allows")

    monkeypatch.setattr("topomap.cli.online.run_online", too_large)
    assert _online(short_log, tmp_path / "out") == 2
    assert "short.log: online regions of 90000 x 80 cells" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["short.log"]


def test_online_writes_its_folder_at_once_and_honours_no_picture(short_log, tmp_path):
    out = tmp_path / "out"
    assert _online(short_log, out, "--no-picture") == 0
    names = sorted(p.name for p in out.iterdir())
    assert "segmentation.png" not in names and "summary.json" in names
    summary = json.loads((out / "summary.json").read_text())
    assert sorted([*summary["written"], "summary.json"]) == names
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out", "short.log"]


def test_online_refuses_a_k_beyond_its_keyframes_and_takes_the_default_criterion(
    short_log, tmp_path, capsys
):
    assert _online(short_log, tmp_path / "centres", "--online-method", "centres") == 0
    keyframes = json.loads((tmp_path / "centres" / "summary.json").read_text())["keyframes"]
    assert 10 < keyframes <= 40  # the options left unset are the segmenter's, either method
    assert _online(short_log, tmp_path / "out", "--k", str(keyframes + 1)) == 2
    shown = f"--k must lie in 1..{keyframes} (the keyframes), got {keyframes + 1}"
    assert shown in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_online_refuses_a_run_without_a_region(short_log, tmp_path, capsys):
    blind = tmp_path / "blind.log"
    with short_log.open() as log:  # every beam 2 cm: valid, but no free space seen
        lines = [line.split() for line in log]
    blind.write_text(
        "".join(
            " ".join([*t[:2], *["0.02"] * int(t[1]), *t[2 + int(t[1]) :]]) + "\n" for t in lines
        )
    )
    assert _online(blind, tmp_path / "out") == 2
    assert "blind.log: no region" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@given(
    st.lists(st.tuples(st.integers(0, 5), st.integers(0, 3)), min_size=2, max_size=60),
)
def test_agreement_is_scikit_learns_adjusted_rand_index(pairs):
    from sklearn.metrics import adjusted_rand_score

    from topomap.cli.online import agreement

    online, offline = (np.array(side) for side in zip(*pairs, strict=True))
    assert agreement(online, offline) == pytest.approx(
        adjusted_rand_score(offline, online), abs=1e-4
    )


def test_online_quality_compares_with_the_offline_partition_at_both_resolutions():
    import maps
    from segmentation.incremental import IncrementalSegmenter
    from topomap.cli.bench_online import _quality
    from topomap.cli.online import agreement

    plan = maps.generate_floor_plan("flat", random_state=0)
    route = maps.wander(plan.grid, plan.labels, random_state=0)
    scans = maps.simulate_scans(plan.grid, route.poses, maps.LaserModel(), random_state=0)
    keyframes = maps.select_keyframes(scans)
    windows = IncrementalSegmenter().resolution  # what the windows are partitioned on
    on_windows = maps.grid_from_keyframes(keyframes, windows)
    records, offline, _ = _quality("flat", keyframes, on_windows, None, 0.5, 0)
    for record in records:  # one offline partition: both figures are the same
        assert record["ari_online_resolution"] == record["ari"]
        assert record["offline_across_resolutions"] == 1.0
    on_other = maps.grid_from_keyframes(keyframes, 2 * windows)
    other, other_offline, labels = _quality("flat", keyframes, on_other, None, 0.5, 0)
    run = next(r for r in other if r["method"] == "windows")
    kept = (other_offline > 0) & (offline > 0)
    expected = agreement(other_offline[kept], offline[kept])  # against the first run's offline
    assert run["offline_across_resolutions"] == pytest.approx(expected)
    assert run["ari"] == agreement(
        labels["windows"][other_offline > 0], other_offline[other_offline > 0]
    )


@pytest.mark.parametrize("method", ["windows", "centres"])
def test_online_skips_a_scan_with_no_valid_beam_as_offline(short_log, tmp_path, method):
    lines = short_log.read_text().splitlines(keepends=True)
    tokens = lines[22].split()  # a keyframe, and so is the next line
    beams = int(tokens[1])
    readings = ["nan", "inf", "-1", "0.001", "1e6"] * beams  # each kind of invalid reading
    pose = tokens[2 + beams : 5 + beams]
    pose[2] = str(float(pose[2]) + math.pi)  # turned away: kept as a keyframe
    blind = " ".join([*tokens[:2], *readings[:beams], *pose, *tokens[5 + beams :]]) + "\n"
    holed = tmp_path / "holed.log"
    holed.write_text("".join([*lines[:23], blind, *lines[23:]]))
    outs = {}
    for log in (short_log, holed):
        outs[log] = tmp_path / log.stem
        assert _online(log, outs[log], "--online-method", method, "--no-picture") == 0
    without, with_blind = (json.loads((outs[log] / "summary.json").read_text()) for log in outs)
    assert (
        without["keyframes_without_valid_beam"],
        with_blind["keyframes_without_valid_beam"],
    ) == (0, 1)
    for name in ("events.jsonl", "graph.json", "map.pgm", "regions.png"):
        assert (outs[short_log] / name).read_bytes() == (outs[holed] / name).read_bytes(), name
    rows = [(outs[log] / "keyframes.csv").read_text().splitlines() for log in outs]
    shifted = [row.split(",", 1)[1] for row in rows[1]]  # the scans after it: one line later
    assert [row.split(",", 1)[1] for row in rows[0]] == shifted


def test_online_refuses_a_run_larger_than_memory_before_any_fit(tmp_path, capsys, monkeypatch):
    from tests.maps.test_carmen import _line

    monkeypatch.setattr("maps.limits._memory_bytes", lambda: 2**26)  # a million cells
    walk = [(2.0 * i, 0.0) for i in range(30)] + [(60.0, 2.0 * i) for i in range(30)]
    log = tmp_path / "walk.log"  # an L of 60 m each way: 1300 x 1320 cells of 5 cm
    log.write_text("".join(_line([3.0] * 90, (x, y, 0.0)) for x, y in walk))
    assert main(["-q", "segment", "--scans", str(log), "--out", str(tmp_path / "offline")]) == 2
    offline = capsys.readouterr().err.strip().removeprefix("topomap: error: ")
    assert "larger than memory allows" in offline and "the keyframes span 65 x 66 m" in offline

    def never(*_args, **_kwargs):
        raise AssertionError("the online pass started before the map's extent was checked")

    monkeypatch.setattr("topomap.cli.online.run_online", never)
    for method in ("windows", "centres"):
        assert _online(log, tmp_path / "out", "--online-method", method) == 2
        assert capsys.readouterr().err.strip() == f"topomap: error: {log}: {offline}"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["walk.log"]


@pytest.mark.parametrize("seed", [None, 2])
def test_online_refuses_fewer_than_two_keyframes_by_their_count(seed):
    scan = LaserScan(np.full(181, 2.0), -math.pi / 2, math.pi / 180, 0.0, 30.0)
    with pytest.raises(UsageError, match="at least 2 keyframes, got 1"):
        run_online([Keyframe((0.0, 0.0, 0.0), scan)], seed_keyframes=seed)
