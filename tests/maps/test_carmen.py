import gzip
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from maps.carmen import read_carmen
from maps.errors import InvalidScanError, LogFormatError, MapFileNotFoundError

LOGS = {"intel": (910, 180), "freiburg-079": (4791, 360), "aces": (440, 180), "csail": (406, 361)}


@pytest.mark.parametrize(("name", "expected"), LOGS.items())
def test_real_logs(data_dir, name, expected):
    frames = read_carmen(data_dir / "carmen" / f"{name}-corrected.log.gz")
    scans, beams = expected
    assert len(frames) == scans
    assert {len(f.scan) for f in frames} == {beams}
    assert [f.scan_index for f in frames] == list(range(scans))
    first = frames[0].scan
    assert first.angle_min == -math.pi / 2
    assert first.angle_increment == pytest.approx(math.pi / (180 if beams < 300 else 360))
    # no-return readings (the sensor maximum) became +inf
    assert all(np.all(f.scan.ranges[np.isfinite(f.scan.ranges)] < 50) for f in frames)


def test_intel_first_line_is_read_exactly(data_dir):
    path = data_dir / "carmen" / "intel-corrected.log.gz"
    with gzip.open(path, "rt") as log:
        line = next(x for x in log if x.startswith("FLASER")).split()
    frame = read_carmen(path)[0]
    np.testing.assert_array_equal(frame.scan.ranges[:5], np.array(line[2:7], float))
    assert frame.pose == tuple(float(v) for v in line[182:185])


def _line(ranges, pose=(1.0, 2.0, 0.5)):
    values = " ".join(str(r) for r in ranges)
    return f"FLASER {len(ranges)} {values} {pose[0]} {pose[1]} {pose[2]} 0 0 0 12.5 host 12.5\n"


def test_plain_text_robotlaser_and_comments(tmp_path):
    robot = (
        "ROBOTLASER1 0 -1.0 2.0 0.5 80.0 0.01 0 5 1 2 3 4 5 0 "
        "3.0 4.0 0.1 2.9 4.0 0.1 0 0 0 0 0 99.0 host 99.0\n"
    )
    path = tmp_path / "log.log"
    path.write_text("# comment\nODOM 1 2 3 0 0 0 1 h 1\n" + _line([1.0] * 181) + robot)
    first, second = read_carmen(path)
    assert first.scan.angle_increment == pytest.approx(math.pi / 180)
    assert first.pose == (1.0, 2.0, 0.5) and first.stamp == 12.5
    assert second.scan.angle_min == -1.0 and second.scan.angle_increment == 0.5
    assert second.pose == (3.0, 4.0, 0.1) and second.scan_index == 1


@pytest.mark.parametrize(
    ("text", "field"),
    [
        ("FLASER 3 1.0 2.0\n", "ranges"),
        ("FLASER 3 1.0 x 2.0 0 0 0\n", "range 1"),
        ("FLASER 3 1.0 1.0 2.0 0 nan 0\n", "y"),
        ("FLASER 3 1.0 1.0 2.0 0 0\n", "theta"),
        ("FLASER three 1.0\n", "n"),
        ("FLASER 2.5 1.0\n", "n"),
        ("FLASER 1 1.0 0 0 0 0 0 0 nan host 7\n", "ipc_timestamp"),
        ("FLASER 1 1.0 0 0 0 0 0 0 -inf\n", "ipc_timestamp"),
        ("ROBOTLASER1 0 -1 2 0.5 80 0.01 0 0 0 3 4 0.1 3 4 0.1 0 0 0 0 0 9 h 9\n", "num_readings"),
    ],
)
def test_bad_lines_name_line_and_field(tmp_path, text, field):
    path = tmp_path / "bad.log"
    path.write_text(_line([1.0, 2.0]) + text)
    with pytest.raises(LogFormatError) as info:
        read_carmen(path)
    assert info.value.line == 2 and info.value.field == field
    assert "bad.log" in str(info.value) and "line 2" in str(info.value)


def test_a_byte_order_mark_is_no_part_of_the_first_line(tmp_path):
    path = tmp_path / "notepad.log"
    path.write_text(_line([1.0, 2.0]) * 2, encoding="utf-8-sig")
    assert [frame.scan_index for frame in read_carmen(path)] == [0, 1]


def test_bad_max_range(tmp_path):
    path = tmp_path / "ok.log"
    path.write_text(_line([1.0, 2.0]))
    with pytest.raises(InvalidScanError, match="max_range"):
        read_carmen(path, max_range=0.0)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(MapFileNotFoundError):
        read_carmen(tmp_path / "none.log")
    path = tmp_path / "broken.gz"
    path.write_bytes(b"\x1f\x8b" + b"\x00" * 30)
    with pytest.raises(LogFormatError):
        read_carmen(path)


@given(st.text(alphabet=st.sampled_from("FLASER0123456789 .-nax\n"), max_size=200))
def test_reader_never_crashes_on_garbage(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("log") / "x.log"
    path.write_text(text)
    try:
        frames = read_carmen(path)
    except LogFormatError:
        return
    for frame in frames:
        assert np.all(np.isfinite(frame.pose))
