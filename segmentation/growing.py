"""Regions of a growing map: a later, larger map of the same building keeps the ids of the
regions that did not change.

A robot that keeps exploring saves bigger and bigger maps of one building (ROSE²'s
*incremental partial maps*). Each is segmented whole; then its regions are matched to the
previous map's, cell by cell in the map frame, and take over their ids:

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
from segmentation.errors import SegmentationError

#: More than this share of the cells makes "most of" a region.
MOST = 0.5
#: How far a wall may move between two maps of one building, metres: a loop closure
#: re-aligns a stretch of map by decimetres. Between ROSE²'s growing snapshots, as laid on
#: each other, 12 % of the walls of three moved further than this (40 % further than 0.1 m);
#: an office shifted by a corridor's width has nearly all of them in free space.
WALL_SLACK = 0.5


class MapMismatchError(SegmentationError):
    """The previous map cannot be laid on the new one (another resolution or frame)."""


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
    the map frame: each cell takes the label of the previous cell its centre falls in.

    Raises
    ------
    MapMismatchError
        The two maps differ in resolution or in the yaw of their origins.

    Examples
    --------
    >>> old = OccupancyGrid(np.zeros((2, 2), np.int8), 1.0)
    >>> new = OccupancyGrid(np.zeros((2, 3), np.int8), 1.0, origin=(-1.0, 0.0, 0.0))
    >>> align(old, np.array([[1, 2], [3, 4]]), new).tolist()
    [[0, 1, 2], [0, 3, 4]]
    """
    if not np.isclose(previous.resolution, grid.resolution, rtol=1e-6):
        raise MapMismatchError(
            f"the previous map has {previous.resolution} m cells and this one "
            f"{grid.resolution} m: a growing map keeps its resolution"
        )
    if not np.isclose(previous.origin[2], grid.origin[2], atol=1e-6):
        raise MapMismatchError(
            f"the previous map's origin has yaw {previous.origin[2]} and this one's "
            f"{grid.origin[2]}: the maps are not in one frame"
        )
    rows, cols = np.indices(grid.shape)
    x, y = grid.cell_to_world(rows, cols)
    r, c = previous.world_to_cell(x, y)
    inside = previous.contains(r, c)
    out = np.zeros(grid.shape, np.int32)
    out[inside] = labels[r[inside], c[inside]]
    return out


def check_same_building(previous: OccupancyGrid, grid: OccupancyGrid) -> None:
    """Refuse ``grid`` as a later map of ``previous``'s building in its frame (:func:`align`'s
    checks, then two more): less than half of the previous map's free cells free in it, or
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
    kept = int(np.count_nonzero(free & grid.free)) / max(1, int(np.count_nonzero(previous.free)))
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
    out = np.where(labels > 0, lookup[np.maximum(labels, 0)], 0).astype(np.int32)
    events.sort(key=lambda e: (e["region"], e["event"]))
    return Carried(out, {int(k): int(v) for k, v in ids.items()}, events, fresh)
