"""Door poses for per-leg planning: where and how a footprint robot stands across a door.

A route through submaps (or regions) crosses one opening between each two in a row. Per-leg
planning fixes a pose on each crossing: the robot's reference point on the opening's point,
heading across the opening from the submap it leaves into the one it enters (and the other
way round for a robot that reverses or turns in place: either heading crosses the door).
A leg is then one OMPL query from one door pose to any valid pose of the next door, inside
the submaps between them. A crossing where no pose is valid (an opening that only an oblique
pass fits) is no leg boundary: the legs on both sides become one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planners.cspace import HeadingCSpace
from planners.kinematic import Pose
from planners.workspace import Point


@dataclass(frozen=True)
class Crossing:
    """Where a route passes from the cells labelled ``before`` into those labelled
    ``after``: ``point`` on the opening, ``portal`` the ends of its segment (metres)."""

    point: Point
    portal: tuple[Point, Point]
    before: int
    after: int


def crossing_heading(
    crossing: Crossing, labels: NDArray[np.integer], cspace: HeadingCSpace
) -> float:
    """Heading across ``crossing`` (normal to its portal) pointing from ``before`` into
    ``after``: the side of the portal whose cells, out to the footprint's circumradius, are
    more often labelled ``after`` (and less often ``before``) wins."""
    (ax, ay), (bx, by) = crossing.portal
    normal = np.array([ay - by, bx - ax], float)
    if not np.hypot(*normal) > 0:  # a one-cell portal: across the line to the point
        normal = np.array([1.0, 0.0])
    normal /= np.hypot(*normal)
    grid = cspace.grid
    steps = np.arange(1, max(2, math.ceil(cspace.robot.circumradius / grid.resolution)) + 1)
    offsets = np.concatenate([steps, -steps])[:, None] * grid.resolution * normal
    points = np.asarray(crossing.point) + offsets
    rows, cols = grid.world_to_cell(points[:, 0], points[:, 1])
    h, w = labels.shape
    inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
    found = np.zeros(len(points), np.int64)
    found[inside] = labels[rows[inside], cols[inside]]
    side = np.where(np.arange(len(points)) < len(steps), 1, -1)
    vote = int(np.sum(side * ((found == crossing.after).astype(int) - (found == crossing.before))))
    if vote < 0:
        normal = -normal
    return math.atan2(normal[1], normal[0])


def door_poses(
    crossing: Crossing, labels: NDArray[np.integer], cspace: HeadingCSpace
) -> list[Pose]:
    """The valid poses across ``crossing``: on its point (the middle of its cell), heading
    across it (see :func:`crossing_heading`), and the opposite heading when the robot reverses
    or turns in place (:attr:`planners.robots.Footprint.reverses`). Empty when none is
    valid."""
    yaw = crossing_heading(crossing, labels, cspace)
    yaws = [yaw, math.remainder(yaw + math.pi, math.tau)] if cspace.robot.reverses else [yaw]
    # the middle of the point's cell: an opening's point lies on a cell edge, where crops
    # of the map could round it into different cells
    row, col = cspace.grid.world_to_cell(*crossing.point)
    x, y = (float(v) for v in cspace.grid.cell_to_world(row, col))
    return [(x, y, a) for a in yaws if cspace.valid(x, y, a)]
