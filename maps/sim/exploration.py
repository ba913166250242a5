"""A wandering robot: a collision-free route through every reachable room of a map."""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from skimage.graph import MCP_Geometric

from maps.errors import InvalidMapError
from maps.geometry import polyline_length
from maps.grid import OccupancyGrid
from maps.seeding import RandomState, as_generator

#: Side of the cells the route is searched on, metres (the grid is pooled to about this).
SEARCH_CELL = 0.1


@dataclass(frozen=True)
class Route:
    """Poses ``(n, 3)`` of a robot driving through a building, and the rooms it went through."""

    poses: NDArray[np.float64]
    visited: tuple[int, ...]
    unreachable: tuple[int, ...]

    @property
    def length(self) -> float:
        """Distance driven, metres."""
        return polyline_length(self.poses)


def _visible(passable: NDArray[np.bool_], a: NDArray[np.float64], b: NDArray[np.float64]) -> bool:
    """Whether the segment between cell coordinates ``a`` and ``b`` crosses only cells next to
    ``passable`` ones (``passable`` is the eroded mask, so every point is within reach)."""
    n = int(np.ceil(np.hypot(*(b - a)) * 2)) + 2
    t = np.linspace(0.0, 1.0, n)[:, None]
    cells = np.floor(a + t * (b - a)).astype(int)
    return bool(passable[cells[:, 0], cells[:, 1]].all())


def _shortcut(passable: NDArray[np.bool_], path: NDArray[np.float64]) -> NDArray[np.float64]:
    """Drop the waypoints of a cell path that a straight, passable segment can skip."""
    kept = [0]
    i, n = 0, len(path)
    while i < n - 1:
        reach = 1
        while i + 2 * reach < n and _visible(passable, path[i], path[i + 2 * reach]):
            reach *= 2
        lo, hi = i + reach, min(i + 2 * reach, n - 1)
        while lo < hi:  # the farthest visible waypoint in (lo, hi]
            mid = (lo + hi + 1) // 2
            if _visible(passable, path[i], path[mid]):
                lo = mid
            else:
                hi = mid - 1
        kept.append(lo)
        i = lo
    return path[kept]


def _sample(points: NDArray[np.float64], step: float, turn_step: float) -> NDArray[np.float64]:
    """Poses every ``step`` metres along a polyline, turning in place at its corners."""
    poses: list[NDArray[np.float64]] = []
    heading: float | None = None
    for a, b in pairwise(points):
        length = float(np.hypot(*(b - a)))
        if length < 1e-9:
            continue
        new = math.atan2(b[1] - a[1], b[0] - a[0])
        if heading is not None:
            turn = (new - heading + math.pi) % (2 * math.pi) - math.pi
            n_turn = int(abs(turn) // turn_step)
            yaws = heading + turn * np.arange(1, n_turn + 1) / (n_turn + 1)
            poses.append(np.column_stack((np.full(n_turn, a[0]), np.full(n_turn, a[1]), yaws)))
        n = max(math.ceil(length / step), 1)
        t = np.arange(n)[:, None] / n
        xy = a + t * (b - a)
        poses.append(np.column_stack((xy, np.full(n, new))))
        heading = new
    poses.append(np.array([[*points[-1], heading or 0.0]]))
    out = np.vstack(poses)
    out[:, 2] = (out[:, 2] + math.pi) % (2 * math.pi) - math.pi
    return out


def wander(
    grid: OccupancyGrid,
    labels: NDArray[np.integer],
    *,
    robot_radius: float = 0.25,
    step: float = 0.05,
    turn_step: float = math.radians(10),
    random_state: RandomState = None,
) -> Route:
    """Drive through every reachable room of ``labels`` (0 = no room), nearest room first.

    The robot starts deep inside a random room, goes to the most open point of the nearest
    room it has not been through yet, and so on, keeping away from walls (the path cost grows
    near obstacles) and more than ``robot_radius`` from them; rooms it passes through count
    as visited. Poses are sampled every ``step`` metres and every ``turn_step`` radians of a
    turn in place, like a laser at a fixed rate.
    """
    labels = np.asarray(labels)
    if labels.shape != grid.shape:
        raise InvalidMapError(f"labels have shape {labels.shape}, the grid {grid.shape}")
    if not step > 0 or not turn_step > 0 or not robot_radius >= 0:
        raise InvalidMapError("step and turn_step must be > 0 and robot_radius >= 0")
    rng = as_generator(random_state)
    f = max(1, int(round(SEARCH_CELL / grid.resolution)))
    h, w = grid.shape[0] // f * f, grid.shape[1] // f * f
    clearance = grid.clearance()[:h, :w]
    fine_ok = clearance > robot_radius + grid.resolution / 2
    passable = fine_ok.reshape(h // f, f, w // f, f).all(axis=(1, 3))
    pooled = clearance.reshape(h // f, f, w // f, f).min(axis=(1, 3))
    room_of = labels[f // 2 : h : f, f // 2 : w : f]
    costs = np.where(passable, 1.0 + 2.0 * robot_radius / np.maximum(pooled, 1e-6), np.inf)
    targets: dict[int, tuple[int, int]] = {}
    for label in np.unique(room_of[passable]):
        if label == 0:
            continue
        inside = passable & (room_of == label)
        best = np.argmax(np.where(inside, pooled, -1.0))
        targets[int(label)] = (int(best // inside.shape[1]), int(best % inside.shape[1]))
    every = set(np.unique(labels[labels > 0]).tolist())
    if not targets:
        raise InvalidMapError("no room has space for the robot")
    order = sorted(targets)
    first = order[int(rng.integers(len(order)))]
    current = targets.pop(first)
    visited, legs = [first], []
    mcp = MCP_Geometric(costs, fully_connected=False)
    while targets:
        ends = list(targets.values())
        cumulative, _ = mcp.find_costs([current], ends, find_all_ends=False)
        reached = [lab for lab, cell in targets.items() if np.isfinite(cumulative[cell])]
        if not reached:
            break
        goal = targets[reached[0]]
        path = np.array(mcp.traceback(goal))
        # a room the path really goes through (a metre or more, not just a door) is visited
        passed, counts = np.unique(room_of[path[:, 0], path[:, 1]], return_counts=True)
        through = {
            int(lab) for lab, n in zip(passed, counts, strict=True) if n * SEARCH_CELL >= 1.0
        }
        for label in [reached[0], *sorted(through - {reached[0]})]:
            if label in targets:
                visited.append(label)
                del targets[label]
        legs.append(path)
        current = goal
    # a segment sampled every half cell whose samples fall in cells with all eight neighbours
    # passable stays in passable cells between the samples too
    safe = ndimage.binary_erosion(fine_ok, np.ones((3, 3)))
    # each leg is shortened on its own, so the route still goes into every room it visits;
    # waypoints are the centres of the fine cells in the middle of the coarse path cells
    fine = [np.array([current]) * f + f // 2 + 0.5] if not legs else []
    fine += [_shortcut(safe, leg * f + f // 2 + 0.5)[(i > 0) :] for i, leg in enumerate(legs)]
    points = np.vstack(fine)
    x, y = grid.cell_to_world(points[:, 0] - 0.5, points[:, 1] - 0.5)
    poses = _sample(np.column_stack((x, y)), step, turn_step)
    return Route(poses, tuple(visited), tuple(sorted(every - set(visited))))
