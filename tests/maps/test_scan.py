import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from maps.errors import InvalidScanError
from maps.scan import Keyframe, LaserScan, select_keyframes


def test_rep117_readings():
    scan = LaserScan(np.array([1.0, np.inf, -np.inf, np.nan, 0.01, 40.0]), 0.0, 0.1, 0.05, 30.0)
    assert scan.valid.tolist() == [True, False, False, False, False, False]
    assert scan.no_return.tolist() == [False, True, False, False, False, True]
    assert len(scan.points()) == 1


def test_keyframe_points_are_in_the_map_frame():
    scan = LaserScan(np.array([2.0, 2.0]), 0.0, math.pi / 2)
    frame = Keyframe((1.0, 1.0, math.pi / 2), scan)
    np.testing.assert_allclose(frame.points(), [[1.0, 3.0], [-1.0, 1.0]], atol=1e-12)


@pytest.mark.parametrize("pose", [(0.0, float("nan"), 0.0), (0.0, 0.0, float("inf")), (1.0, 2.0)])
def test_bad_pose_is_rejected(pose):
    with pytest.raises(InvalidScanError, match="pose"):
        Keyframe(pose, LaserScan(np.ones(2), 0.0, 0.1))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"ranges": np.ones(3), "angle_min": 0.0, "angle_increment": 0.0},
        {"ranges": np.ones(3), "angle_min": float("nan"), "angle_increment": 0.1},
        {"ranges": np.ones(0), "angle_min": 0.0, "angle_increment": 0.1},
        {
            "ranges": np.ones(3),
            "angle_min": 0.0,
            "angle_increment": 0.1,
            "range_min": 5.0,
            "range_max": 1.0,
        },
    ],
)
def test_bad_scans_are_rejected(kwargs):
    with pytest.raises(InvalidScanError):
        LaserScan(**kwargs)


@pytest.mark.parametrize(
    ("ranges", "angle_min", "increment", "shown"),
    [
        (np.ones(3), 1e30, 0.1, "angle_min is 1e\\+30 rad: no angle"),
        (np.ones(3), 0.0, 1e30, "span 2e\\+30 rad: a scan turns once at most"),
        (np.ones(10**6), -math.pi, 0.01, "1000000 beams 0.01 rad apart"),
    ],
)
def test_a_scan_turning_more_than_once_or_at_no_angle_is_refused(
    ranges, angle_min, increment, shown
):
    with pytest.raises(InvalidScanError, match=shown):
        LaserScan(ranges, angle_min, increment)


@pytest.mark.parametrize("beams", [360, 361])
def test_a_full_turn_scan_is_a_scan(beams):
    """360 beams a degree apart, or 361 closing the circle, as 360 degree lidars' drivers
    publish them."""
    scan = LaserScan(np.ones(beams), -math.pi, math.radians(1.0))
    assert len(scan.points()) == beams


def test_keyframe_rule_turning_in_place():
    scan = LaserScan(np.ones(2), 0.0, 0.1)
    frames = [Keyframe((0.0, 0.0, math.radians(10 * i)), scan, i) for i in range(37)]
    kept = select_keyframes(frames, distance=1.0, angle=math.radians(25))
    assert [k.scan_index for k in kept] == [0, 3, 6, 9, 12, 15, 18, 21, 24, 27, 30, 33, 36]


@given(
    steps=st.lists(
        st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-math.pi, math.pi)),
        min_size=1,
        max_size=40,
    ),
    distance=st.floats(0.05, 2.0),
    angle=st.floats(0.05, 1.5),
)
def test_keyframe_rule_property(steps, distance, angle):
    scan = LaserScan(np.ones(2), 0.0, 0.1)
    poses = np.cumsum(np.array(steps), axis=0)
    frames = [Keyframe(tuple(p), scan, i) for i, p in enumerate(poses)]
    kept = select_keyframes(frames, distance=distance, angle=angle)
    assert kept[0] is frames[0]
    kept_ids = {k.scan_index for k in kept}
    last = frames[0]
    for frame in frames[1:]:
        moved = math.dist(frame.pose[:2], last.pose[:2]) > distance
        turned = abs((frame.pose[2] - last.pose[2] + math.pi) % (2 * math.pi) - math.pi) > angle
        assert (frame.scan_index in kept_ids) == (moved or turned)
        if moved or turned:
            last = frame
