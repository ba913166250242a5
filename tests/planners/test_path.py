"""Shortening: shortcuts and sliding door crossings keep paths valid and never lengthen them."""

import numpy as np
import pytest

from planners.path import PlannedPath, polyline_length, shortcut, tighten
from planners.workspace import Workspace


def test_slide_moves_the_crossing_to_the_straight_line(two_rooms):
    space = Workspace(two_rooms(door=1.6), robot_radius=0.2)
    door_x, mid_y = 4.15, 2.1
    start, goal = (2.0, 1.9), (6.0, 2.3)
    detour = np.array([start, (door_x, mid_y + 0.3), goal])
    portal = ((door_x, mid_y - 0.5), (door_x, mid_y + 0.5))
    slid = tighten(space, detour, {1: portal})
    assert space.path_free(slid)
    assert polyline_length(slid) == pytest.approx(np.hypot(4.0, 0.4), abs=1e-3)


def test_shortcut_keeps_validity_and_drops_points(two_rooms):
    space = Workspace(two_rooms(), robot_radius=0.2)
    zigzag = np.array([(1.0, 1.0), (1.5, 2.0), (2.0, 1.0), (2.5, 2.0), (3.0, 1.0)])
    kept = shortcut(space, zigzag)
    assert list(kept) == [0, 4]
    through_door = np.array([(1.0, 1.0), (4.15, 2.1), (7.0, 1.0)])
    assert list(shortcut(space, through_door)) == [0, 1, 2]


def test_path_reports_length_and_json():
    path = PlannedPath(np.array([(0.0, 0.0), (3.0, 4.0)]), "test", (1,), {"search": 0.5})
    assert path.length == 5.0 and path.total_seconds == 0.5
    assert path.to_dict()["waypoints"] == [[0.0, 0.0], [3.0, 4.0]]


def test_tighten_pulls_a_detour_around_the_door_jamb(two_rooms):
    space = Workspace(two_rooms(door=1.0), robot_radius=0.2)
    detour = np.array([(1.0, 1.0), (2.0, 3.5), (3.6, 2.1), (4.15, 2.1), (7.0, 1.0)])
    assert space.path_free(detour)
    tight = tighten(space, detour, {3: ((4.15, 1.85), (4.15, 2.35))})
    assert space.path_free(tight)
    # taut: the corners of the inflated door jambs, at most 1 % longer than exact
    from planners.visibility import VisibilityGraph

    exact = VisibilityGraph(space).plan((1.0, 1.0), (7.0, 1.0)).length
    assert exact <= polyline_length(tight) <= 1.01 * exact
