"""Regions of a growing map: a later, larger map of the same building keeps the ids of the
regions that did not change.

A robot that keeps exploring saves bigger and bigger maps of one building (ROSE²'s
*incremental partial maps*). Each is segmented whole; then its regions are matched to the
previous map's, cell by cell, and take over their ids. The previous map is first laid where
its walls fit the new map's best (:func:`maps.registration.register`: a SLAM re-run or a map
saved with another origin moves the frame), then refused if it still does not fit
(:func:`check_same_building`):

- ``q`` *lies in* ``r`` when more than half of the previous region ``q``'s cells are in the new
  region ``r``; ``r`` *comes from* ``q`` when more than half of the cells of ``r`` that the
  previous map had in a region are ``q``'s.
- a new region that some previous regions lie in keeps the oldest (lowest) of their ids: one
  region kept, or several merged;
- otherwise one that comes from a previous region is its largest part: a region split keeps its
  id on its largest piece;
- every other region is new and gets an id no region ever had.

Every change is an event: ``kept``, ``merged`` (with the ``absorbed`` ids), ``split`` (a piece
of ``source`` that did not keep its id), ``created`` and ``removed``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.grid import OccupancyGrid
from maps.registration import Placement, register
from segmentation.errors import SegmentationError

#: More than this share of the cells makes "most of" a region.
MOST = 0.5
#: How far a wall may move between two maps of one building, metres: a loop closure
#: re-aligns a stretch of map by decimetres. Between ROSE²'s growing snapshots, as laid on
#: each other, 12 % of the walls of three moved further than this (40 % further than 0.1 m);
#: an office shifted by a corridor's width has nearly all of them in free space.
WALL_SLACK = 0.5


class MapMismatchError(SegmentationError):
    """The previous map is no map of the new one's building, even laid where it fits best."""


@dataclass(frozen=True)
class Carried:
    """The new regions with the ids carried over from the previous map.

    Attributes
    ----------
    labels
        The new label image with carried ids.
    ids
        New segmentation id -> carried id.
    events
        What happened to each region, in id order (see the module docstring).
    next_id
        The lowest id no region has had.
    """

    labels: NDArray[np.int32]
    ids: dict[int, int]
    events: list[dict[str, Any]]
    next_id: int


def align(
    previous: OccupancyGrid, labels: NDArray[np.integer | np.bool_], grid: OccupancyGrid
) -> NDArray[np.int32]:
    """The previous map's ``labels`` on the cells of ``grid`` (0 where it had none), matched by
    the map frame (any resolutions and origins): each cell takes the label of the previous cell
    its centre falls in.

    Examples
    --------
    >>> old = OccupancyGrid(np.zeros((2, 2), np.int8), 1.0)
    >>> new = OccupancyGrid(np.zeros((2, 3), np.int8), 1.0, origin=(-1.0, 0.0, 0.0))
    >>> align(old, np.array([[1, 2], [3, 4]]), new).tolist()
    [[0, 1, 2], [0, 3, 4]]
    """
    out, labels = np.zeros(grid.shape, np.int32), np.asarray(labels)
    labelled = np.flatnonzero(labels.any(axis=1)), np.flatnonzero(labels.any(axis=0))
    if len(labelled[0]) == 0:
        return out
    # only the cells of grid over the previous labels' box (a SLAM canvas: a small part)
    part = (
        slice(int(labelled[0][0]), int(labelled[0][-1]) + 1),
        slice(int(labelled[1][0]), int(labelled[1][-1]) + 1),
    )
    previous, labels = previous.cropped(*part), labels[part]
    corners = np.array([[0, 0], [0, 1], [1, 0], [1, 1]]) * previous.shape  # cell edges
    x, y = previous.cell_to_world(corners[:, 0] - 0.5, corners[:, 1] - 0.5)
    r, c = grid.world_to_cell(x, y)
    top, bottom = max(int(r.min()) - 1, 0), min(int(r.max()) + 2, grid.shape[0])
    left, right = max(int(c.min()) - 1, 0), min(int(c.max()) + 2, grid.shape[1])
    if top >= bottom or left >= right:
        return out
    rows, cols = np.mgrid[top:bottom, left:right]
    r, c = previous.world_to_cell(*grid.cell_to_world(rows, cols))
    inside = previous.contains(r, c)
    window = out[top:bottom, left:right]
    window[inside] = labels[r[inside], c[inside]]
    return out


def check_same_building(previous: OccupancyGrid, grid: OccupancyGrid) -> None:
    """Refuse ``grid`` as a later map of ``previous``'s building in its frame: less than half
    of the previous map's free cells free in it, or
    more than half of the previous map's walls on it lying in its free space, farther than
    :data:`WALL_SLACK` from its walls (a map in another frame: an office's rooms overlap
    their shifted selves, their walls do not).

    Raises
    ------
    MapMismatchError
        Saying which.

    Examples
    --------
    >>> cells = np.zeros((9, 9), np.int8)
    >>> cells[:, 4] = 100  # a wall down the middle
    >>> check_same_building(OccupancyGrid(cells, 1.0), OccupancyGrid(cells, 1.0))
    >>> check_same_building(OccupancyGrid(cells, 1.0), OccupancyGrid(cells, 1.0, (3.0, 0, 0)))
    Traceback (most recent call last):
    ...
    segmentation.growing.MapMismatchError: 100% of the previous map's walls lie in this one's \
free space: a map in another frame, or another building
    """
    free = align(previous, previous.free, grid).astype(bool)
    area = int(np.count_nonzero(previous.free)) * previous.resolution**2
    kept = int(np.count_nonzero(free & grid.free)) * grid.resolution**2 / max(area, 1e-12)
    if kept < MOST:
        raise MapMismatchError(
            f"only {kept:.0%} of the previous map's free cells are free in this one: another "
            "building, or a map in another frame"
        )
    walls = align(previous, previous.occupied, grid).astype(bool)
    slack = round(WALL_SLACK / grid.resolution)
    near = ndimage.maximum_filter(grid.occupied, size=2 * slack + 1)
    lost = int(np.count_nonzero(walls & grid.free & ~near)) / max(1, int(np.count_nonzero(walls)))
    if lost > MOST:
        raise MapMismatchError(
            f"{lost:.0%} of the previous map's walls lie in this one's free space: a map in "
            "another frame, or another building"
        )


def lay(previous: OccupancyGrid, grid: OccupancyGrid, *, aligned: bool = False) -> Placement:
    """Where ``previous`` lies on ``grid``: the move that fits its walls best
    (:func:`maps.registration.register`; none when ``aligned``, the frames known to be one),
    checked by :func:`check_same_building`.

    Raises
    ------
    MapMismatchError
        ``grid`` is no map of ``previous``'s building, the move found named.

    Examples
    --------
    >>> cells = np.zeros((60, 80), np.int8)
    >>> cells[[0, -1], :] = cells[:, [0, 30, -1]] = 100  # two rooms
    >>> cells[20:40, 30] = 0  # a door
    >>> old = OccupancyGrid(cells, 0.1)
    >>> print(lay(old, OccupancyGrid(cells, 0.1, (1.3, -0.7, 0.0))))
    shifted (1.30, -0.70) m and turned 0.0 degrees
    >>> lay(old, OccupancyGrid(cells, 0.1, (1.3, -0.7, 0.0)), aligned=True)
    Traceback (most recent call last):
    ...
    segmentation.growing.MapMismatchError: 81% of the previous map's walls lie in this one's \
free space: a map in another frame, or another building
    """
    placement = Placement() if aligned else register(previous, grid)
    try:
        check_same_building(placement.moved(previous), grid)
    except MapMismatchError as err:
        if aligned:
            raise
        raise MapMismatchError(f"{err} (laid where it fits best: {placement})") from None
    return placement


def carry_ids(
    previous: NDArray[np.integer], labels: NDArray[np.integer], next_id: int | None = None
) -> Carried:
    """Give the regions of ``labels`` the ids of the ``previous`` regions they continue.

    Parameters
    ----------
    previous
        The previous regions on the new map's cells (:func:`align`).
    labels
        The new regions.
    next_id
        The lowest id no region ever had (by default one more than the highest previous id).

    Examples
    --------
    A room that grew keeps its id; one split in two keeps it on its larger piece:

    >>> old = np.array([[5, 5, 7, 7, 7, 7]])
    >>> new = np.array([[1, 1, 1, 2, 2, 3]])
    >>> found = carry_ids(old, new)
    >>> found.labels.tolist(), [e["event"] for e in found.events]
    ([[5, 5, 5, 7, 7, 8]], ['kept', 'kept', 'split'])
    """
    previous = np.asarray(previous, np.int64)
    labels = np.asarray(labels, np.int64)
    if previous.shape != labels.shape:
        raise SegmentationError(f"previous regions {previous.shape} on a {labels.shape} map")
    whole = labels
    some = (previous > 0) | (labels > 0)  # the box of either's regions (on a SLAM canvas: small)
    rows, cols = np.flatnonzero(some.any(axis=1)), np.flatnonzero(some.any(axis=0))
    if len(rows):
        box = slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1)
        previous, labels = previous[box], labels[box]
    old_ids = [int(v) for v in np.unique(previous) if v > 0]
    new_ids = [int(v) for v in np.unique(labels) if v > 0]
    fresh = max(old_ids, default=0) + 1 if next_id is None else int(next_id)
    both = (previous > 0) & (labels > 0)
    pairs, overlap = np.unique(
        np.column_stack([previous[both], labels[both]]), axis=0, return_counts=True
    )
    old_size = dict(zip(*np.unique(previous[previous > 0], return_counts=True), strict=True))
    known = dict(zip(*np.unique(labels[both], return_counts=True), strict=True))
    lies_in: dict[int, list[int]] = {}  # new region -> previous regions mostly inside it
    parts: dict[int, list[tuple[int, int]]] = {}  # previous region -> (overlap, new) it makes
    for (q, r), count in zip(pairs.tolist(), overlap.tolist(), strict=True):
        if count > MOST * old_size[q]:
            lies_in.setdefault(r, []).append(q)
        elif count > MOST * known[r]:
            parts.setdefault(q, []).append((count, r))
    ids: dict[int, int] = {}
    events: list[dict[str, Any]] = []
    for r, inside in lies_in.items():
        kept = min(inside)
        ids[r] = kept
        if len(inside) > 1:
            events.append({"event": "merged", "region": kept, "absorbed": sorted(inside)[1:]})
        else:
            events.append({"event": "kept", "region": kept})
    taken = set(ids.values())
    for q, pieces in parts.items():
        for rank, (_, r) in enumerate(sorted(pieces, key=lambda p: (-p[0], p[1]))):
            if r in ids:
                continue
            if rank == 0 and q not in taken:
                ids[r] = q
                taken.add(q)
                events.append({"event": "kept", "region": q})
            else:
                ids[r] = fresh
                events.append({"event": "split", "region": fresh, "source": q})
                fresh += 1
    for r in new_ids:
        if r not in ids:
            ids[r] = fresh
            events.append({"event": "created", "region": fresh})
            fresh += 1
    gone = set(old_ids) - set(ids.values())
    events += [{"event": "removed", "region": q} for q in sorted(gone)]
    lookup = np.zeros(max(new_ids, default=0) + 1, np.int64)
    for r, carried in ids.items():
        lookup[r] = carried
    out = np.where(whole > 0, lookup[np.maximum(whole, 0)], 0).astype(np.int32)
    events.sort(key=lambda e: (e["region"], e["event"]))
    return Carried(out, {int(k): int(v) for k, v in ids.items()}, events, fresh)
