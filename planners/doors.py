"""Doors: the passable openings between labelled pieces of the map, where the robot fits.

The hierarchical planner places one door per metre of every opening between its near-convex
submaps (:data:`DOOR_SPACING`); the building's route graph places one per opening between
regions (``spacing=math.inf``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from planners.workspace import Point, Workspace
from segmentation.regions import boundary_pairs
from segmentation.transitions import Transition

#: Longest stretch of an opening one door stands for, metres.
DOOR_SPACING = 1.0


@dataclass(frozen=True)
class Door:
    """A passable opening between labels ``a < b`` (submaps, or regions): ``portal`` spans
    the part of the opening the robot fits through, ``point`` is its middle, ``width`` its
    length in metres; ``opening`` is the whole opening it lies in."""

    a: int
    b: int
    point: Point
    portal: tuple[Point, Point]
    width: float
    opening: Transition


def find_doors(
    space: Workspace,
    labels: NDArray[np.int32],
    openings: list[Transition],
    spacing: float = DOOR_SPACING,
) -> list[Door]:
    """Doors of every opening of ``labels`` where the robot fits (an opening too narrow gets
    none): one per stretch of at most ``spacing`` metres of the opening's usable boundary, so
    a search sees where along a wide opening a path crosses (``math.inf``: one per opening).
    Each door's point is the boundary point nearest the middle of its stretch, its portal the
    stretch.

    Examples
    --------
    >>> from maps.grid import OccupancyGrid
    >>> from segmentation.transitions import find_transitions
    >>> cells = np.zeros((40, 80), np.int8)
    >>> cells[:, 39:41] = 100
    >>> cells[10:34, 39:41] = 0  # a 2.4 m opening
    >>> labels = np.where(np.arange(80) < 40, 1, 2)[None].repeat(40, 0).astype(np.int32)
    >>> space = Workspace(OccupancyGrid(cells, resolution=0.1), 0.2)
    >>> openings = find_transitions(space.grid, labels)
    >>> len(find_doors(space, labels, openings)), len(find_doors(space, labels, openings, math.inf))
    (2, 1)
    """
    ra, ca, rb, cb = boundary_pairs(labels)
    usable = space.free[ra, ca] & space.free[rb, cb]
    ra, ca, rb, cb = ra[usable], ca[usable], rb[usable], cb[usable]
    xa, ya = space.grid.cell_to_world(ra, ca)
    xb, yb = space.grid.cell_to_world(rb, cb)
    middles = np.column_stack([(xa + xb) / 2, (ya + yb) / 2])
    # the pairs of each two labels found by one sort, not by a pass over all per opening
    base = int(labels.max(initial=0)) + 1
    key = labels[ra, ca].astype(np.int64) * base + labels[rb, cb]
    order = np.argsort(key, kind="stable")
    key, middles = key[order], middles[order]
    doors = []
    for opening in openings:
        wanted = opening.a * base + opening.b
        here = middles[np.searchsorted(key, wanted) : np.searchsorted(key, wanted, "right")]
        gap = np.hypot(*(here - np.asarray(opening.centre)).T)
        points = here[gap <= opening.width / 2 + space.grid.resolution]
        if not len(points):
            continue
        axis = np.subtract(opening.end, opening.start)
        along = (points - points.mean(axis=0)) @ (axis / max(float(np.hypot(*axis)), 1e-12))
        order = np.argsort(along, kind="stable")
        stretches = max(1, math.ceil((along.max() - along.min()) / spacing))
        for piece in np.array_split(order, stretches):
            stretch = points[piece]
            middle = stretch[np.argmin(np.abs(along[piece] - along[piece].mean()))]
            ends = (_point(stretch[0]), _point(stretch[-1]))
            width = math.dist(*ends) + space.grid.resolution
            doors.append(Door(opening.a, opening.b, _point(middle), ends, width, opening))
    return doors


def _point(xy: NDArray[np.float64]) -> Point:
    return (float(xy[0]), float(xy[1]))
