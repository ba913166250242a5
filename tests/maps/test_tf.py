import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from maps.errors import InvalidMapError, TransformError
from maps.grid import OccupancyGrid
from maps.tf import TransformTree, quaternion_from_yaw, yaw_from_quaternion

IDENTITY = (0.0, 0.0, 0.0, 1.0)


def test_interpolated_chain_and_mount():
    tree = TransformTree(tolerance=0.1)
    for t, x in [(0.0, 0.0), (1.0, 2.0)]:
        tree.add("map", "odom", (x, 0.0, 0.0), IDENTITY, stamp=t)
    for t, yaw in [(0.0, 0.0), (2.0, math.pi)]:
        tree.add("odom", "base_link", (0.0, 1.0, 0.0), quaternion_from_yaw(yaw), stamp=t)
    tree.add("base_link", "laser", (0.3, 0.0, 0.1), IDENTITY)
    poses, mirrored = tree.lookup("map", "laser", [0.5, 1.05])
    # at 0.5 s: odom at x = 1, base_link at (0, 1) turned pi/4, the laser 0.3 m ahead of it
    a = math.pi / 4
    assert poses[0] == pytest.approx([1 + 0.3 * math.cos(a), 1 + 0.3 * math.sin(a), a])
    # 1.05 s is past map -> odom's last stamp but within the tolerance: held at x = 2
    assert poses[1, 0] == pytest.approx(2 + 0.3 * math.cos(1.05 * math.pi / 2))
    assert not mirrored
    # the inverse look-up goes up from the laser and down again
    back, _ = tree.lookup("laser", "map", [0.5])
    c, s = math.cos(a), math.sin(a)
    x, y = 1 + 0.3 * c, 1 + 0.3 * s
    assert back[0] == pytest.approx([-(c * x + s * y), s * x - c * y, -a])
    with pytest.raises(TransformError, match=r"map -> odom \(2 stamps, 0.000 .. 1.000 s\)") as err:
        tree.lookup("map", "laser", [1.5])
    assert err.value.stamp == 1.5 and err.value.target == "map"
    partial, _ = tree.lookup("map", "laser", [0.5, 1.5], partial=True)
    assert np.isfinite(partial[0]).all() and np.isnan(partial[1]).all()


def test_upside_down_laser_is_mirrored(caplog):
    tree = TransformTree()
    tree.add("base_link", "laser", (0.3, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))  # rolled by pi
    # a camera's optical frame (z forward) is tilted 90 degrees: said only when looked up
    tree.add("base_link", "optical", (0.0, 0.0, 0.5), (-0.5, 0.5, -0.5, 0.5))
    poses, mirrored = tree.lookup("base_link", "laser", [0.0])
    assert mirrored and poses[0] == pytest.approx([0.3, 0.0, 0.0])
    assert not caplog.records
    tree.lookup("base_link", "optical", [0.0])
    assert "base_link -> optical, tilted 90 degrees" in caplog.text


def test_tree_refuses_bad_links():
    tree = TransformTree()
    tree.add("odom", "base_link", (0.0, 0.0, 0.0), IDENTITY, stamp=1.0)
    with pytest.raises(TransformError, match="two parents"):
        tree.add("map", "base_link", (0.0, 0.0, 0.0), IDENTITY)
    with pytest.raises(TransformError, match="both static and timed"):
        tree.add("odom", "base_link", (0.0, 0.0, 0.0), IDENTITY)
    with pytest.raises(TransformError, match="'camera'"):
        tree.chain("odom", "camera")


@given(
    cells=arrays(
        np.int8, st.tuples(st.integers(1, 12), st.integers(1, 12)), elements=st.integers(-1, 100)
    ),
    resolution=st.floats(0.01, 1.0),
    x=st.floats(-100, 100),
    y=st.floats(-100, 100),
    yaw=st.floats(-3.1, 3.1),
)
def test_msg_fields_round_trip(cells, resolution, x, y, yaw):
    grid = OccupancyGrid(cells, resolution, (x, y, yaw))
    fields = grid.to_msg_fields(frame_id="map", stamp=12.25)
    assert fields["header"] == {"stamp": {"sec": 12, "nanosec": 250_000_000}, "frame_id": "map"}
    # the message's first row is the bottom of the map
    assert fields["data"][: cells.shape[1]] == cells[-1].tolist()
    back = OccupancyGrid.from_msg_fields(fields)
    assert np.array_equal(back.cells, grid.cells) and back.resolution == grid.resolution
    assert back.origin == pytest.approx(grid.origin, abs=1e-9)


def test_msg_fields_errors_name_the_field():
    fields = OccupancyGrid(np.zeros((2, 3), np.int8), 0.1).to_msg_fields()
    with pytest.raises(InvalidMapError, match=r"'data' holds 5 values.*3 \* 2"):
        OccupancyGrid.from_msg_fields({**fields, "data": [0] * 5})
    with pytest.raises(InvalidMapError, match=r"'data' must lie in -1\.\.100"):
        OccupancyGrid.from_msg_fields({**fields, "data": [0, 0, 0, 0, 0, 101]})
    del fields["info"]["resolution"]
    with pytest.raises(InvalidMapError, match="'resolution'"):
        OccupancyGrid.from_msg_fields(fields)
    fields["info"]["resolution"] = 0.1
    turned = {"x": 0.0, "y": 0.0, "z": 1.0, "w": 1.0}  # a quarter turn, not normalised
    fields["info"]["origin"]["orientation"] = turned
    assert OccupancyGrid.from_msg_fields(fields).origin[2] == pytest.approx(math.pi / 2)
    fields["info"]["origin"]["orientation"] = {**turned, "w": math.inf}
    with pytest.raises(InvalidMapError, match=r"'info\.origin\.orientation' is no rotation"):
        OccupancyGrid.from_msg_fields(fields)


@given(yaw=st.floats(-3.1, 3.1), length=st.floats(1e-6, 1e300))
def test_the_yaw_of_a_quaternion_of_any_length_is_its_rotation(yaw, length):
    # tf2 normalises a message's quaternion; (0, 0, 1, 1) is a quarter turn
    quaternion = [length * v for v in quaternion_from_yaw(yaw)]
    assert yaw_from_quaternion(*quaternion) == pytest.approx(yaw, abs=1e-9)


poses = st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-3.1, 3.1))


@given(chain=st.lists(poses, min_size=1, max_size=5), stamp=st.floats(0.0, 1.0))
def test_lookup_composes_the_chain_and_inverts(chain, stamp):
    """Frames f0 -> f1 -> ... each at a pose in its parent: complex numbers give the truth."""
    tree = TransformTree()
    position, heading = 0j, 0.0
    for k, (x, y, yaw) in enumerate(chain):
        # every other link is timed, constant in time
        at = None if k % 2 else 0.0
        tree.add(f"f{k}", f"f{k + 1}", (x, y, 0.0), quaternion_from_yaw(yaw), stamp=at)
        if at is not None:
            tree.add(f"f{k}", f"f{k + 1}", (x, y, 0.0), quaternion_from_yaw(yaw), stamp=1.0)
        position += complex(x, y) * np.exp(1j * heading)
        heading += yaw
    last = f"f{len(chain)}"
    (pose,), _ = tree.lookup("f0", last, [stamp])
    assert pose[:2] == pytest.approx([position.real, position.imag], abs=1e-6)
    assert np.angle(np.exp(1j * (pose[2] - heading))) == pytest.approx(0.0, abs=1e-9)
    (back,), _ = tree.lookup(last, "f0", [stamp])
    inverse = -position * np.exp(-1j * heading)
    assert back[:2] == pytest.approx([inverse.real, inverse.imag], abs=1e-6)
