"""Bad input in the maps package (issue 24): every case ends in a typed error that names the
file, line, field or value, or in the correct result; never a crash, a silent wrong answer or
an allocation the machine cannot make."""

from __future__ import annotations

import math
import os
import random
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.rosbag1 import Writer as Writer1
from rosbags.typesys import Stores, get_typestore

from maps.carmen import read_carmen
from maps.errors import (
    InvalidMapError,
    InvalidScanError,
    LogFormatError,
    MapFormatError,
    MapTooLargeError,
    OutputExistsError,
    OutputIsAFolderError,
    OutputNotAFolderError,
    OutputNotWritableError,
    OutputPathError,
    TopomapError,
    TransformError,
)
from maps.files import OutputFolder, check_output_file, check_output_folder, write_text, written
from maps.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from maps.map_server import load_map, read_image
from maps.mapping import grid_from_keyframes
from maps.rosbag import read_rosbag, read_rosbag_map
from maps.scan import Keyframe, LaserScan
from maps.tf import TransformTree
from tests.maps.test_rosbag import _write
from topomap.saving import load

YAML = "image: img.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nnegate: 0\n"
THRESHOLDS = "occupied_thresh: 0.65\nfree_thresh: 0.196\n"


def _map(tmp_path, text=YAML + THRESHOLDS, image=b"P5\n2 1\n255\n\xfe\x00"):
    (tmp_path / "img.pgm").write_bytes(image)
    path = tmp_path / "map.yaml"
    path.write_text(text)
    return path


def _png_header(width, height):
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (
        b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + chunk + struct.pack(">I", zlib.crc32(chunk))
    )


# ---------------------------------------------------------------- sizes and numbers
@pytest.mark.parametrize(
    "image",
    [b"P5\n2000000000 2000000000\n255\n\x00", _png_header(2_000_000_000, 2_000_000_000)],
    ids=["pgm", "png"],
)
def test_a_huge_image_header_is_refused_before_decoding(tmp_path, image):
    with pytest.raises(MapTooLargeError) as info:
        load_map(_map(tmp_path, image=image))
    message = str(info.value)
    assert "img.pgm" in message and "2000000000 x 2000000000 cells" in message
    assert info.value.field == "image" and "\n" not in message


@pytest.mark.parametrize(
    ("value", "shown"),
    [("1" + "0" * 400, "401-digit"), ("1e-8", "1e-08"), ("1e300", "1e+300"), (".nan", "nan")],
)
def test_an_absurd_resolution_is_refused_with_its_field(tmp_path, value, shown):
    text = (YAML + THRESHOLDS).replace("resolution: 0.1", f"resolution: {value}")
    with pytest.raises(MapFormatError) as info:
        load_map(_map(tmp_path, text))
    assert info.value.field == "resolution" and shown in str(info.value)
    assert len(str(info.value)) < 300


def test_an_origin_far_away_is_refused(tmp_path):
    text = (YAML + THRESHOLDS).replace("origin: [0, 0, 0]", "origin: [1e300, 0, 0]")
    with pytest.raises(MapFormatError) as info:
        load_map(_map(tmp_path, text))
    assert info.value.field == "origin"


def test_an_origin_written_as_map_server_reads_it_is_a_number(tmp_path):
    text = (YAML + THRESHOLDS).replace("origin: [0, 0, 0]", "origin: [1e3, -2.5e1, 0]")
    assert load_map(_map(tmp_path, text)).origin == (1000.0, -25.0, 0.0)


def _frames(poses):
    scan = LaserScan(np.array([1.0, 1.0, 1.0]), -0.5, 0.5, 0.0, 10.0)
    return [Keyframe(p, scan, scan_index=i) for i, p in enumerate(poses)]


def test_keyframes_far_apart_are_refused_with_the_size_and_the_far_scan():
    frames = _frames([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (1e6, 0.0, 0.0)])
    with pytest.raises(MapTooLargeError) as info:
        grid_from_keyframes(frames, 0.05)
    assert "cells" in str(info.value) and "scan 2" in str(info.value)


def test_a_map_whose_picture_would_not_fit_in_memory_is_refused_before_building(monkeypatch):
    # drawing map.png holds about 58 bytes per cell (tracemalloc, 4 million cells): with
    # 1 GiB, 20 million cells (0.96 GB at 48 bytes a cell) fit the bound but not the picture
    monkeypatch.setattr("maps.limits._memory_bytes", lambda: 2**30)
    frames = _frames([(0.0, 0.0, 0.0), (110.0, 110.0, 0.0), (220.0, 220.0, 0.0)])
    with pytest.raises(MapTooLargeError, match=r"4460 x 4460 cells.*at most 16777216 cells"):
        grid_from_keyframes(frames, 0.05)


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ({"resolution": 0.0001}, "resolution"),
        ({"max_range": 0.0}, "max_range"),
        ({"max_range": math.nan}, "max_range"),
    ],
)
def test_mapping_options_out_of_range_are_refused(options, name):
    with pytest.raises(InvalidScanError, match=name):
        grid_from_keyframes(_frames([(0.0, 0.0, 0.0)]), **options)


def test_poses_and_transforms_far_away_are_refused(tmp_path):
    with pytest.raises(InvalidScanError, match="within"):
        _frames([(1e300, 0.0, 0.0)])
    tree = TransformTree()
    with pytest.raises(TransformError, match="odom -> base_link"):
        tree.add("odom", "base_link", (1e300, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), stamp=1.0)
    with pytest.raises(TransformError, match="rotation"):
        tree.add("odom", "base_link", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), stamp=1.0)


# ---------------------------------------------------------------- parser gaps
def test_a_deeply_nested_yaml_is_one_located_line(tmp_path):
    path = tmp_path / "map.yaml"
    path.write_text("[" * 20_000 + "]" * 20_000)
    with pytest.raises(MapFormatError) as info:
        load_map(path)
    assert "map.yaml" in str(info.value) and "nested too deeply" in str(info.value)


def test_a_yaml_error_is_one_line_with_its_line(tmp_path):
    path = tmp_path / "map.yaml"
    path.write_text("image: a.pgm\nresolution: [0.1\n")
    with pytest.raises(MapFormatError) as info:
        load_map(path)
    assert "\n" not in str(info.value) and info.value.line == 3 and "line 2" in str(info.value)


def test_a_yaml_naming_a_field_twice_is_refused_with_both_lines(tmp_path):
    # PyYAML keeps the last value, map_server's yaml-cpp the first: neither is safe to guess
    path = _map(tmp_path, YAML + THRESHOLDS + "resolution: 5\n")
    with pytest.raises(MapFormatError) as info:
        load_map(path)
    assert info.value.line == 7 and "'resolution' twice (first on line 2)" in str(info.value)


def _bag(tmp_path):
    store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "run.bag"
    with Writer1(path) as writer:
        _write(writer, store, True)
    return path.read_bytes()


def test_corrupt_or_truncated_ros1_bags_end_in_located_errors(tmp_path):
    data = _bag(tmp_path)
    rng = random.Random(0)
    bad = tmp_path / "bad.bag"
    for trial in range(120):
        if trial % 2:
            cut = data[: rng.randrange(len(data))]
        else:
            flipped = bytearray(data)
            for _ in range(5):
                flipped[rng.randrange(len(flipped))] = rng.randrange(256)
            cut = bytes(flipped)
        bad.write_bytes(cut)
        try:
            read_rosbag(bad)
        except TopomapError as err:
            assert "bad.bag" in str(err) and "\n" not in str(err)


def test_any_folder_is_not_a_ros2_bag(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    for read in (read_rosbag, read_rosbag_map):
        with pytest.raises(LogFormatError, match=r"metadata\.yaml") as info:
            read(tmp_path)
        assert str(tmp_path) in str(info.value)


def _message(width=2, height=1, data=(0, 100)):
    grid = OccupancyGrid(np.array([[0, 100]], np.int8), 0.5)
    fields = grid.to_msg_fields()
    fields["info"].update(width=width, height=height)
    fields["data"] = list(data)
    return fields


@pytest.mark.parametrize(
    ("message", "shown"),
    [
        (_message(width=-2, height=-1), "info.width"),
        (_message(width=2.5), "info.width"),
        (_message(width=0, height=0, data=()), "empty"),
        (_message(width=2_000_000_000, height=2_000_000_000), "2000000000 x 2000000000 cells"),
    ],
)
def test_occupancy_grid_messages_with_bad_sizes(message, shown):
    with pytest.raises((InvalidMapError, MapTooLargeError), match=shown):
        OccupancyGrid.from_msg_fields(message)


# ---------------------------------------------------------------- silent wrong answers
@pytest.mark.parametrize("maxval", [1, 15, 100, 1000, 4095])
def test_pgm_maxval_is_scaled_as_map_server_does(tmp_path, maxval):
    big = maxval > 255
    dtype = ">u2" if big else np.uint8
    values = np.array([maxval, 0, maxval // 2], dtype)  # white, black, mid grey
    path = tmp_path / "img.pgm"
    path.write_bytes(f"P5\n3 1\n{maxval}\n".encode() + values.tobytes())
    pixels = read_image(path)
    assert pixels.tolist()[0] == [255, 0, int(maxval // 2) * 255 // maxval]
    cells = load_map(_map(tmp_path, image=path.read_bytes())).cells
    assert cells[0, 0] == FREE and cells[0, 1] == OCCUPIED


def test_ascii_pgm_and_truncated_pgm(tmp_path):
    path = tmp_path / "img.pgm"
    path.write_bytes(b"P2\n# a comment\n3 1\n100\n100 0 50\n")
    assert read_image(path).tolist() == [[255, 0, 127]]
    path.write_bytes(b"P5\n3 2\n255\n\x00\x00")
    with pytest.raises(MapFormatError, match="cut short") as info:
        read_image(path)
    assert "img.pgm" in str(info.value)
    path.write_bytes(b"P5\n3 1\n255\n\x00\x00\xff" if False else b"P5\n1 1\n10\n\x20")
    with pytest.raises(MapFormatError, match="above maxval 10"):
        read_image(path)


def test_pnm_numbers_too_long_and_headers_too_long_for_4_kb(tmp_path):
    path = tmp_path / "img.pgm"
    for image, shown in [
        (b"P5\n" + b"9" * 400 + b" 2\n255\n\0\0", r"width has 400 digits \(at most 10\)"),
        (b"P2\n1 1\n255\n" + b"9" * 23 + b"\n", "pixel value 9{23} is above maxval 255"),
        (b"P5\n10 10\n255", "cut short: 0 bytes, expected 100"),
    ]:
        path.write_bytes(image)
        with pytest.raises(MapFormatError, match=shown):
            read_image(path)
    path.write_bytes(b"P5\n#" + b"x" * 5000 + b"\n2 1\n255\n\xfe\x00")
    assert read_image(path).tolist() == [[254, 0]]


@pytest.mark.parametrize(
    "head",
    [b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR", b"\xff\xd8\xff\xe0\0\x10JFIF", b"P5\n2 1\n255\n", b"P2 1 1"],
)
def test_an_image_given_as_the_map_yaml_is_named_as_an_image(tmp_path, head):
    path = tmp_path / "rose_map.png"  # ROSE²'s maps are plain images
    path.write_bytes(head + bytes(range(256)))
    with pytest.raises(MapFormatError, match=r"rose_map\.png: an image, not a map YAML"):
        load_map(path)
    for text in ("P5: a word that starts like a PGM\n", "P5 : a key spaced from its colon\n"):
        path.write_text(text)
        with pytest.raises(MapFormatError, match="field 'image'"):
            load_map(path)


def test_a_map_file_that_is_no_regular_file_or_cannot_be_read(tmp_path, monkeypatch):
    yaml = _map(tmp_path)
    image = tmp_path / "img.pgm"
    long_name = "a" * 300 + ".pgm"
    os.mkfifo(tmp_path / "fifo.pgm")
    (tmp_path / "dir.pgm").mkdir()
    for name, shown in [
        ("fifo.pgm", "image 'fifo.pgm' of .*map.yaml is a FIFO, not a regular file"),
        ("dir.pgm", "image 'dir.pgm' of .*map.yaml is a folder, not a regular file"),
        ("/dev/zero", "image '/dev/zero' of .*map.yaml is a device, not a regular file"),
        (long_name, r"cannot be read \(File name too long\)"),
    ]:
        yaml.write_text(f"image: {name}\n" + (YAML + THRESHOLDS).split("\n", 1)[1])
        with pytest.raises(MapFormatError, match=shown) as info:
            load_map(yaml)
        assert info.value.field == "image"
    with pytest.raises(MapFormatError, match=r"cannot be read \(File name too long\)"):
        load(tmp_path / ("x" * 300))
    yaml = _map(tmp_path)
    for denied in (yaml, image):
        with monkeypatch.context() as patch:
            patch.setattr(Path, "open", _denied(Path.open, denied))
            with pytest.raises(MapFormatError, match=r"cannot be read \(Permission denied\)"):
                load_map(yaml)


def _flaser(n, values, pose=(1.0, 2.0, 0.5)):
    return (
        f"FLASER {n} {' '.join(map(str, values))} {' '.join(map(str, pose))} 1 2 0.5 7.0 host 7.0\n"
    )


@pytest.mark.parametrize("n", [2, 4])
def test_flaser_with_a_count_that_does_not_match_its_ranges(tmp_path, n):
    path = tmp_path / "bad.log"
    path.write_text(_flaser(3, [1.0, 2.0, 3.0]).replace("FLASER 3", f"FLASER {n}"))
    with pytest.raises(LogFormatError) as info:
        read_carmen(path)
    assert info.value.line == 1 and info.value.field == "n" and "bad.log" in str(info.value)


@pytest.mark.parametrize("n", ["524289", "1e9", "99999999999999999999999"])
def test_a_beam_count_no_line_can_hold_is_quoted_as_written(tmp_path, n):
    path = tmp_path / "huge.log"
    path.write_text(_flaser(3, [1.0, 2.0, 3.0]) + f"FLASER {n} 1 2 3\n")
    with pytest.raises(LogFormatError, match=f"line 2, field 'n': a count of {n} values") as info:
        read_carmen(path)
    assert "does not fit in a line of at most 1048576 characters" in str(info.value)


@pytest.mark.parametrize("n", [1, 2, 4, 5])
def test_flaser_without_host_name_whose_count_is_off_is_refused(tmp_path, n):
    path = tmp_path / "nohost.log"
    good = _flaser(3, [1.0, 2.0, 3.0]).rsplit(" host ", 1)[0] + "\n"  # ... 7.0, no host
    path.write_text(good + good.replace("FLASER 3", f"FLASER {n}"))
    with pytest.raises(LogFormatError, match=r"10 numbers and no host name.*n '\d'") as info:
        read_carmen(path)
    assert info.value.line == 2 and info.value.field == "n" and "nohost.log" in str(info.value)


@pytest.mark.parametrize(
    ("tail", "shown"), [(" host 7.0 extra", "2 fields after"), (" host", "0 fields after")]
)
def test_a_laser_line_with_fields_after_its_host_name_is_refused(tmp_path, tail, shown):
    path = tmp_path / "tail.log"
    path.write_text(_flaser(3, [1.0, 2.0, 3.0]).replace(" host 7.0", tail))
    with pytest.raises(LogFormatError, match=shown):
        read_carmen(path)


@pytest.mark.parametrize("reading", ["nan", "-1", "inf", "0", "1e-300", "1e9"])
def test_a_log_without_one_valid_beam_is_refused(tmp_path, reading):
    path = tmp_path / "blind.log"
    path.write_text(_flaser(3, [reading] * 3) * 2)
    with pytest.raises(LogFormatError, match=r"blind\.log: 2 scans of 6 beams read.*no beam"):
        read_carmen(path)
    path.write_text(_flaser(3, [reading] * 3) + _flaser(3, [reading, 2.0, reading]))
    assert len(read_carmen(path)) == 2  # one beam is enough


def test_a_good_flaser_line_is_read_exactly(tmp_path):
    path = tmp_path / "ok.log"
    path.write_text(_flaser(3, [1.0, 2.0, 3.0]))
    (frame,) = read_carmen(path)
    assert frame.pose == (1.0, 2.0, 0.5) and frame.scan.ranges.tolist() == [1.0, 2.0, 3.0]


@pytest.mark.parametrize("max_range", [0.0, math.nan, -1.0, math.inf])
def test_carmen_max_range_must_be_positive_and_finite(tmp_path, max_range):
    path = tmp_path / "ok.log"
    path.write_text(_flaser(3, [1.0, 2.0, 3.0]))
    with pytest.raises(InvalidScanError, match="max_range"):
        read_carmen(path, max_range=max_range)


@pytest.mark.parametrize("text", ["", "# only a comment\nODOM 1 2 3 0 0 0 1 h 1\n"])
def test_a_log_without_laser_lines_names_the_file(tmp_path, text):
    path = tmp_path / "empty.log"
    path.write_text(text)
    with pytest.raises(LogFormatError, match=r"empty\.log.*no laser lines"):
        read_carmen(path)


def test_a_pose_far_away_in_a_log_names_line_and_field(tmp_path):
    path = tmp_path / "far.log"
    path.write_text(_flaser(3, [1.0, 2.0, 3.0]) + _flaser(3, [1.0, 2.0, 3.0], (1e300, 0.0, 0.0)))
    with pytest.raises(LogFormatError) as info:
        read_carmen(path)
    assert info.value.line == 2 and info.value.field == "x"


def test_a_heading_that_is_no_angle_names_line_and_field(tmp_path):
    path = tmp_path / "turned.log"
    turns = _flaser(3, [1.0, 2.0, 3.0], (1.0, 2.0, 6000.0))  # unwrapped: a thousand turns
    path.write_text(turns + _flaser(3, [1.0, 2.0, 3.0], (1.0, 2.0, 1e300)))
    with pytest.raises(LogFormatError, match=r"1e\+300 rad is no heading") as info:
        read_carmen(path)
    assert info.value.line == 2 and info.value.field == "theta"
    path.write_text(turns)
    assert read_carmen(path)[0].pose[2] == pytest.approx(6000.0)


@pytest.mark.parametrize("offset", [(150.0, 0.0), (0.0, -11000.0)])
def test_a_laser_jumping_far_between_lines_names_both_lines_and_poses(tmp_path, offset):
    path = tmp_path / "jump.log"
    far = (1.0 + offset[0], 2.0 + offset[1], 0.5)
    path.write_text("".join(_flaser(3, [1.0, 2.0, 3.0], pose) for pose in [(1, 2, 0.5), far]))
    with pytest.raises(LogFormatError) as info:
        read_carmen(path)
    assert info.value.line == 2 and info.value.field == "x"
    assert "jump.log" in str(info.value) and "line 1" in str(info.value)
    assert f"({far[0]:g}, {far[1]:g})" in str(info.value) and "(1, 2)" in str(info.value)


def test_a_laser_moving_100_m_between_lines_is_read(tmp_path):
    path = tmp_path / "ok.log"
    poses = [(1.0, 2.0, 0.5), (101.0, 2.0, 0.5)]
    path.write_text("".join(_flaser(3, [1.0, 2.0, 3.0], pose) for pose in poses))
    assert [frame.pose for frame in read_carmen(path)] == poses


# ---------------------------------------------------------------- outputs
def test_output_paths_are_checked(tmp_path):
    (tmp_path / "file").write_text("mine")
    (tmp_path / "folder").mkdir()
    with pytest.raises(OutputNotAFolderError, match="is a file"):
        check_output_file(tmp_path / "file" / "map.yaml", overwrite=True)
    with pytest.raises(OutputIsAFolderError, match="is a folder"):
        check_output_file(tmp_path / "folder", overwrite=True)
    with pytest.raises(OutputExistsError):
        write_text(tmp_path / "file", "theirs")
    assert (tmp_path / "file").read_text() == "mine"
    assert write_text(tmp_path / "a" / "b" / "c.txt", "x").read_text() == "x"  # missing parents


def _denied(real, *denied):
    """``real`` (a Path method), raising PermissionError for the paths ``denied``, as it does
    for a user without the rights (root has them all: chmod cannot show it)."""

    def method(self, *args, **kwargs):
        if any(self == path for path in denied):
            raise PermissionError(13, "Permission denied", str(self))
        return real(self, *args, **kwargs)

    return method


def test_an_output_folder_without_rights_is_refused_before_any_work(tmp_path, monkeypatch):
    locked = tmp_path / "locked"
    locked.mkdir()
    monkeypatch.setattr(os, "access", lambda path, mode: Path(path) != locked)
    for out in (locked, locked / "new" / "out"):
        with pytest.raises(OutputNotWritableError, match="locked is not writable") as info:
            OutputFolder(out, ["map.yaml"])
        assert isinstance(info.value, PermissionError) and str(out) in str(info.value)
    monkeypatch.setattr(Path, "exists", _denied(Path.exists, locked / "out"))
    with pytest.raises(OutputNotWritableError, match="Permission denied"):
        check_output_file(locked / "out" / "map.yaml", overwrite=False)


def test_an_output_folder_that_cannot_be_made_is_a_typed_error(tmp_path, monkeypatch):
    out = tmp_path / "out"
    folder = OutputFolder(out, ["map.yaml"])
    monkeypatch.setattr(Path, "mkdir", _denied(Path.mkdir, folder.staging))
    with pytest.raises(OutputNotWritableError, match=r"cannot write .*out: Permission denied"):
        folder.__enter__()
    assert list(tmp_path.iterdir()) == []


def test_an_output_under_a_dangling_link_or_a_folder_the_system_refuses(tmp_path, monkeypatch):
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "missing")
    for folder in (link, link / "sub"):
        with pytest.raises(OutputNotAFolderError, match=r"out is a symbolic link to .*missing"):
            check_output_folder(folder)
    refused = tmp_path / "proc" / "nope"

    def mkdir(self, *args, **kwargs):
        raise FileNotFoundError(2, "No such file or directory", str(self))

    monkeypatch.setattr(Path, "mkdir", mkdir)
    with pytest.raises(OutputPathError, match=r"cannot write .*nope: No such file or directory"):
        write_text(refused / "x.html", "x")


def test_a_log_or_bag_that_cannot_be_read_is_a_typed_error(tmp_path, monkeypatch):
    log, bag = tmp_path / "run.log", tmp_path / "run"
    log.write_text(_flaser(3, [1.0, 2.0, 3.0]))
    bag.mkdir()
    monkeypatch.setattr(Path, "open", _denied(Path.open, log))
    monkeypatch.setattr(Path, "is_file", _denied(Path.is_file, bag / "metadata.yaml"))
    for path, reader in ((log, read_carmen), (bag, read_rosbag)):
        with pytest.raises(LogFormatError, match=r"cannot be read.*Permission denied") as info:
            reader(path)
        assert info.value.path == str(path)


def test_a_damaged_gzip_log_is_a_located_error(tmp_path):
    import gzip

    data = bytearray(gzip.compress(_flaser(3, [1.0, 2.0, 3.0]).encode() * 200))
    data[30:60] = bytes(b ^ 0xFF for b in data[30:60])  # damaged inside the deflate stream
    path = tmp_path / "run.log.gz"
    path.write_bytes(bytes(data))
    with pytest.raises(LogFormatError, match="cannot be read as a text log") as info:
        read_carmen(path)
    assert info.value.path == str(path)


def test_a_log_line_or_a_log_too_long_is_refused_before_it_is_read(tmp_path, monkeypatch):
    import maps.carmen

    long = tmp_path / "long.log"
    long.write_text(_flaser(3, [1.0, 2.0, 3.0]) + "#" * (maps.carmen.MAX_LINE_CHARS + 5))
    with pytest.raises(LogFormatError, match="line 2: line longer than"):
        read_carmen(long)
    many = tmp_path / "many.log"
    many.write_text(_flaser(3, [1.0, 2.0, 3.0]) + "\n" * 20)
    monkeypatch.setattr(maps.carmen, "MAX_LOG_LINES", 10)
    with pytest.raises(LogFormatError, match="more than 10 lines"):
        read_carmen(many)


@pytest.mark.parametrize("token", ["1_0", "nan_", "2_0.5"])
def test_a_number_with_an_underscore_is_no_number_in_a_log(tmp_path, token):
    path = tmp_path / "run.log"
    path.write_text(_flaser(3, [1.0, token, 3.0]))
    with pytest.raises(LogFormatError, match=f"line 1, field 'range 1'.*{token}"):
        read_carmen(path)
    path.write_text(_flaser(3, [1.0, 2.0, 3.0], pose=(token, 2.0, 0.5)))
    with pytest.raises(LogFormatError, match=f"field 'x'.*{token}"):
        read_carmen(path)


@pytest.mark.parametrize(
    "start, step, field", [(1e300, 0.01, "start_angle"), (-1.5, 1e300, "angular_resolution")]
)
def test_a_robotlaser_line_wider_than_a_turn_is_refused(tmp_path, start, step, field):
    path = tmp_path / "run.log"
    ranges = " ".join(["1.0"] * 3)
    path.write_text(
        f"ROBOTLASER1 0 {start} 3.14 {step} 80 0.01 0 3 {ranges} 0 1 2 0.5 1 2 0.5 0 0 0 0 0 "
        "7.0 host 7.0\n"
    )
    with pytest.raises(LogFormatError, match=f"line 1, field '{field}'.*field of view"):
        read_carmen(path)


def test_a_fifo_is_no_log(tmp_path):
    fifo = tmp_path / "run.log"
    os.mkfifo(fifo)
    with pytest.raises(LogFormatError, match="CARMEN log is a FIFO, not a regular file"):
        read_carmen(fifo)  # never opened: opening a FIFO would wait for a writer


def test_a_folder_of_outputs_replaces_the_old_one_whole(tmp_path):
    (tmp_path / "frames").mkdir()
    (tmp_path / "frames" / "old.png").write_text("old")
    with OutputFolder(tmp_path, ["a"], overwrite=True) as work:
        (work / "a").write_text("a")
        (work / "frames").mkdir()
        (work / "frames" / "new.png").write_text("new")
    assert [p.name for p in (tmp_path / "frames").iterdir()] == ["new.png"]


def test_a_disk_full_while_writing_is_a_typed_error_naming_the_file(tmp_path, monkeypatch):
    import errno
    import pickle

    import cv2

    from maps.errors import OutputWriteError

    path = tmp_path / "map.yaml"
    path.write_text("old")
    full = pytest.raises(OutputWriteError, match=r"could not write .*map\.yaml: No space")
    with full as info, written(path, overwrite=True) as partial:
        partial.write_text("half")
        raise OSError(errno.ENOSPC, "No space left on device")
    assert info.value.errno == errno.ENOSPC and info.value.filename == str(path)
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["map.yaml"]
    again = pickle.loads(pickle.dumps(info.value))  # crosses process pools whole
    assert type(again) is OutputWriteError and str(again) == str(info.value)
    monkeypatch.setattr(cv2, "imwrite", lambda *args: False)  # libpng: "Write Error"
    grid = OccupancyGrid(np.zeros((4, 4), np.int8), 0.1)
    with pytest.raises(OutputWriteError, match=r"new\.pgm: the image encoder wrote nothing"):
        grid.save(tmp_path / "new.yaml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.yaml"]


def test_an_interrupted_write_leaves_the_old_file(tmp_path):
    path = tmp_path / "map.yaml"
    path.write_text("old")
    with pytest.raises(KeyboardInterrupt), written(path, overwrite=True) as partial:
        partial.write_text("half")
        raise KeyboardInterrupt
    assert path.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["map.yaml"]


def test_an_interrupted_folder_leaves_nothing(tmp_path):
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt), OutputFolder(out, ["a", "b"]) as work:
        (work / "a").write_text("a")
        raise KeyboardInterrupt
    assert not out.exists() and list(tmp_path.iterdir()) == []
    with OutputFolder(out, ["a", "b"]) as work:
        (work / "a").write_text("a")
        (work / "b").write_text("b")
    assert sorted(p.name for p in out.iterdir()) == ["a", "b"]


def test_save_map_refuses_a_folder_in_place_of_its_image(tmp_path):
    (tmp_path / "m.pgm").mkdir()
    grid = OccupancyGrid(np.zeros((2, 2), np.int8), 0.1)
    with pytest.raises(OutputIsAFolderError, match=r"m\.pgm"):
        grid.save(tmp_path / "m.yaml")
    assert not (tmp_path / "m.yaml").exists()


# ---------------------------------------------------------------- property-based
_fields = st.dictionaries(
    st.sampled_from(
        ["image", "resolution", "origin", "negate", "mode", "occupied_thresh", "free_thresh"]
    ),
    st.one_of(
        st.none(),
        st.booleans(),
        st.integers(-(10**400), 10**400),
        st.floats(allow_nan=True, allow_infinity=True),
        st.text(max_size=8),
        st.lists(st.one_of(st.integers(-(10**30), 10**30), st.floats()), max_size=4),
    ),
)


@settings(max_examples=150)
@given(fields=_fields)
def test_any_yaml_fields_load_or_fail_typed(tmp_path_factory, fields):
    import yaml

    folder = tmp_path_factory.mktemp("yaml")
    (folder / "img.pgm").write_bytes(b"P5\n2 1\n255\n\xfe\x00")
    doc = {"image": "img.pgm", "resolution": 0.1, "origin": [0, 0, 0], "negate": 0}
    doc.update({"occupied_thresh": 0.65, "free_thresh": 0.196}, **fields)
    path = folder / "map.yaml"
    path.write_text(yaml.safe_dump(doc))
    try:
        grid = load_map(path)
    except TopomapError as err:
        assert "map.yaml" in str(err) or "img" in str(err) or "image" in str(err)
        assert "\n" not in str(err)
    else:
        assert grid.shape == (1, 2) and math.isfinite(grid.resolution)


@settings(max_examples=150)
@given(
    magic=st.sampled_from(["P2", "P5", "P6"]),
    width=st.integers(0, 10**12),
    height=st.integers(0, 10**12),
    maxval=st.integers(0, 70000),
    body=st.binary(max_size=64),
)
def test_any_pnm_header_reads_or_fails_typed(tmp_path_factory, magic, width, height, maxval, body):
    path = tmp_path_factory.mktemp("pnm") / "img.pgm"
    path.write_bytes(f"{magic}\n{width} {height}\n{maxval}\n".encode() + body)
    try:
        pixels = read_image(path)
    except TopomapError as err:
        assert "img.pgm" in str(err)
    else:
        assert pixels.shape[:2] == (height, width) and pixels.dtype == np.uint8


_token = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-5, 400).map(str),
    st.sampled_from(["host", "x", "1e309", "-0", ""]),
)


@settings(max_examples=200)
@given(
    kind=st.sampled_from(["FLASER", "RLASER", "ROBOTLASER1"]), tokens=st.lists(_token, max_size=30)
)
def test_any_laser_line_reads_or_fails_located(tmp_path_factory, kind, tokens):
    path = tmp_path_factory.mktemp("log") / "run.log"
    path.write_text(f"{kind} {' '.join(tokens)}\n")
    try:
        frames = read_carmen(path)
    except LogFormatError as err:
        assert "run.log" in str(err)
    except InvalidScanError:
        pass  # a scan that makes no sense (a zero angle step), named by its field
    else:
        assert all(np.isfinite(f.pose).all() for f in frames)


def test_unknown_cells_stay_unknown():  # the constants the readers rely on
    assert (UNKNOWN, FREE, OCCUPIED) == (-1, 0, 100)
