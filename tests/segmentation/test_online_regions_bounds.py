"""The dense regions of the online engines refuse, before allocating, to grow beyond memory."""

import numpy as np
import pytest

from maps.errors import MapTooLargeError
from maps.scan import Keyframe, LaserScan
from segmentation.online_regions import OnlineRegions


def test_a_keyframe_far_from_the_others_is_refused_before_the_arrays_grow(monkeypatch):
    monkeypatch.setattr("maps.limits._memory_bytes", lambda: 2**26)  # a million cells
    scan = LaserScan(np.full(90, 2.0), -np.pi, 2 * np.pi / 90)
    regions = OnlineRegions(resolution=0.1, reach=4.0)
    regions.add(0, Keyframe((0.0, 0.0, 0.0), scan, scan_index=3), region=1)
    shape, graph = regions.label_image()[0].shape, dict(regions.graph.nodes(data=True))
    with pytest.raises(MapTooLargeError, match=r"online regions .* cells.*scan 7 at \(2000, 0\)"):
        regions.add(1, Keyframe((2000.0, 0.0, 0.0), scan, scan_index=7), region=2)
    assert regions.label_image()[0].shape == shape  # nothing changed
    assert dict(regions.graph.nodes(data=True)) == graph and regions.region_at(0.5, 0.0) == 1


def test_keyframes_are_checked_as_they_would_be_added_before_anything_changes(monkeypatch):
    monkeypatch.setattr("maps.limits._memory_bytes", lambda: 2**26)  # a million cells
    scan = LaserScan(np.full(90, 2.0), -np.pi, 2 * np.pi / 90)
    regions = OnlineRegions(resolution=0.1, reach=4.0)
    regions.add(0, Keyframe((0.0, 0.0, 0.0), scan), region=1)
    near = [Keyframe((x, 0.0, 0.0), scan, scan_index=i) for i, x in enumerate((10.0, 20.0), 1)]
    shape = regions.label_image()[0].shape
    regions.check(near)
    with pytest.raises(MapTooLargeError, match=r"scan 7 at \(2000, 0\)"):
        regions.check([*near, Keyframe((2000.0, 0.0, 0.0), scan, scan_index=7)])
    assert regions.label_image()[0].shape == shape  # checking grows nothing
    for index, keyframe in enumerate(near, 1):
        regions.add(index, keyframe, region=1)
