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


def passage_axis(cspace: HeadingCSpace, x: float, y: float, yaw: float) -> float:
    """The axis a footprint passes ``(x, y)`` along: ``yaw`` when it or its opposite is a
    valid heading there, else the middle of the valid headings there taken as axes (a narrow
    passage admits the headings around its axis and their opposites), the valid heading
    nearest it; ``yaw`` when none is valid.

    A door's portal is the opening of a disc's free space: across a narrow gap it may be a
    cell or two long, lying along the passage rather than across it, so its normal can point
    into the gap's walls."""
    yaws = cspace.free_headings(x, y)
    if len(yaws) == 0 or cspace.valid(x, y, yaw) or cspace.valid(x, y, yaw + math.pi):
        return yaw
    middle = 0.5 * math.atan2(np.sin(2 * yaws).mean(), np.cos(2 * yaws).mean())
    apart = np.abs(np.angle(np.exp(2j * (yaws - middle))))  # axial distance, doubled
    return float(yaws[np.argmin(apart)])


def crossing_heading(
    crossing: Crossing, labels: NDArray[np.integer], cspace: HeadingCSpace
) -> float:
    """Heading across ``crossing`` pointing from ``before`` into ``after``: normal to its
    portal, or along the passage the footprint fits there (:func:`passage_axis`) when no
    heading on that normal is valid and the passage leads from ``before`` on one side into
    ``after`` on the other; of the two ways, the side whose cells, out to the footprint's
    circumradius, are more often labelled ``after`` (and less often ``before``) wins."""
    (ax, ay), (bx, by) = crossing.portal
    normal = np.array([ay - by, bx - ax], float)
    if not np.hypot(*normal) > 0:  # a one-cell portal: across the line to the point
        normal = np.array([1.0, 0.0])
    normal /= np.hypot(*normal)
    grid = cspace.grid
    row, col = grid.world_to_cell(*crossing.point)
    x, y = (float(v) for v in grid.cell_to_world(row, col))
    yaw = math.atan2(normal[1], normal[0])
    ahead, behind = _sides(crossing, labels, cspace, yaw)
    axis = passage_axis(cspace, x, y, yaw)
    if axis != yaw:
        along = _sides(crossing, labels, cspace, axis)
        if along[0] * along[1] < 0:  # before on one side, after on the other
            yaw, (ahead, behind) = axis, along
    return yaw if ahead - behind >= 0 else math.remainder(yaw + math.pi, math.tau)


def _sides(
    crossing: Crossing, labels: NDArray[np.integer], cspace: HeadingCSpace, yaw: float
) -> tuple[int, int]:
    """Cells labelled ``after`` less those labelled ``before`` out to the footprint's
    circumradius from ``crossing.point``, ahead along ``yaw`` and behind."""
    grid = cspace.grid
    steps = np.arange(1, max(2, math.ceil(cspace.robot.circumradius / grid.resolution)) + 1)
    offsets = np.concatenate([steps, -steps])[:, None] * grid.resolution
    points = np.asarray(crossing.point) + offsets * np.array([math.cos(yaw), math.sin(yaw)])
    rows, cols = grid.world_to_cell(points[:, 0], points[:, 1])
    h, w = labels.shape
    inside = (rows >= 0) & (rows < h) & (cols >= 0) & (cols < w)
    found = np.zeros(len(points), np.int64)
    found[inside] = labels[rows[inside], cols[inside]]
    score = (found == crossing.after).astype(int) - (found == crossing.before)
    return int(score[: len(steps)].sum()), int(score[len(steps) :].sum())


def door_poses(
    crossing: Crossing, labels: NDArray[np.integer], cspace: HeadingCSpace
) -> list[Pose]:
    """The valid poses across ``crossing``: on its point (the middle of its cell), heading
    across it or along the passage there (see :func:`crossing_heading`), and the opposite
    heading when the robot reverses or turns in place
    (:attr:`planners.robots.Footprint.reverses`); for a forward-only car, after that pose,
    the valid poses on the portal's other cells at headings crossing it the same way
    (:func:`_across`). Empty when none is valid."""
    yaw = crossing_heading(crossing, labels, cspace)
    yaws = [yaw, math.remainder(yaw + math.pi, math.tau)] if cspace.robot.reverses else [yaw]
    # the middle of the point's cell: an opening's point lies on a cell edge, where crops
    # of the map could round it into different cells
    row, col = cspace.grid.world_to_cell(*crossing.point)
    x, y = (float(v) for v in cspace.grid.cell_to_world(row, col))
    poses = [(x, y, a) for a in yaws if cspace.valid(x, y, a)]
    if cspace.robot.reverses:
        return poses
    return poses + [p for p in _across(crossing, cspace, yaw) if p not in poses]


def _across(crossing: Crossing, cspace: HeadingCSpace, yaw: float) -> list[Pose]:
    """A forward-only car's other valid poses across ``crossing``: the reference point on
    any cell of the portal, heading any way that crosses it the way ``yaw`` does (the
    configuration space's heading bins less than a right angle from it), at most as many
    as there are heading bins, spread evenly. A car may pass a door anywhere along it and
    at a slant: a single pose on its point, normal to it, can lie too close to the leg's
    start for the car to turn onto (a start 0.65 m from a door, 0.25 m to one side of its
    point, at a 1 m turning radius: no path found in 5 s; 0.05 m further along the door,
    the car's own curve from the start is valid)."""
    grid = cspace.grid
    (ax, ay), (bx, by) = crossing.portal
    steps = max(1, math.ceil(math.hypot(bx - ax, by - ay) / grid.resolution))
    t = np.linspace(0.0, 1.0, steps + 1)
    rows, cols = grid.world_to_cell(ax + t * (bx - ax), ay + t * (by - ay))
    rows, cols = np.atleast_1d(rows).tolist(), np.atleast_1d(cols).tolist()
    cells = list(dict.fromkeys(zip(rows, cols, strict=True)))
    bins = np.arange(cspace.headings) * (math.tau / cspace.headings)
    ahead = bins[np.cos(bins - yaw) > 1e-9]
    candidates = []
    for row, col in cells:
        x, y = (float(v) for v in grid.cell_to_world(row, col))
        candidates += [(x, y, float(math.remainder(a, math.tau))) for a in ahead]
    if not candidates:
        return []
    valid = cspace.valid_many(np.array(candidates))
    found = [pose for pose, ok in zip(candidates, valid, strict=True) if ok]
    if len(found) > cspace.headings:
        found = [
            found[i] for i in np.linspace(0, len(found) - 1, cspace.headings).round().astype(int)
        ]
    return found
