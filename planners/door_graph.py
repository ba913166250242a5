"""The hierarchical planner's preprocessing: near-convex submaps, their doors, the door graph.

:func:`plan_layout` fills the free cells no region holds, cuts the regions into near-convex
parts (:mod:`planners.submaps`) and places doors on the openings between parts where the
robot fits (:func:`planners.doors.find_doors`). :func:`build_door_graph` then builds, for
every part, the exact visibility graph of its free space with its doors as extra nodes
(:class:`~planners.visibility.VisibilityGraph`), and keeps, for every two doors, the
shortest path between them inside the part that joins them best: the door graph.

Both depend only on the robot's free space and the labels: :func:`door_graph_key` names those
inputs, so a door graph saved with the regions (:mod:`planners.prepared`) is reused only for
the map, the regions and the robot it was built for.
"""

from __future__ import annotations

import hashlib
import logging
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from planners.doors import DOOR_SPACING, Door, find_doors
from planners.errors import PlannerParameterError
from planners.submaps import convex_parts
from planners.visibility import VisibilityGraph
from planners.workspace import Workspace
from segmentation.transitions import find_transitions

log = logging.getLogger(__name__)

#: Metres a submap reaches beyond its part, so legs can pass the doorways they end in.
SUBMAP_MARGIN = 0.5
#: The version of what :func:`plan_layout` and :func:`build_door_graph` make; part of
#: :func:`door_graph_key`, raised whenever their results change, so older saved door graphs
#: are rebuilt rather than reused.
DOOR_GRAPH_VERSION = 1
#: Items in, items out: a progress bar around the parts being prepared (``iter``: none).
Progress = Callable[[list[int]], Iterable[int]]


@dataclass(frozen=True, eq=False)
class Layout:
    """The submaps and doors of a map.

    Attributes
    ----------
    labels
        Region id of every cell, free cells in no region given the nearest region's.
    parts
        Near-convex part id of every free cell (0 = none), numbered from 1.
    region_of
        The region each part belongs to.
    doors
        The doors between parts, where the robot fits.
    """

    labels: NDArray[np.int32]
    parts: NDArray[np.int32]
    region_of: dict[int, int]
    doors: list[Door]

    def doors_of(self) -> dict[int, list[int]]:
        """The doors (indices into :attr:`doors`) of every part, in index order."""
        found: dict[int, list[int]] = {part: [] for part in self.region_of}
        for index, door in enumerate(self.doors):
            found[door.a].append(index)
            found[door.b].append(index)
        return found


@dataclass(frozen=True, eq=False)
class DoorGraph:
    """Every part's visibility graph (its doors are its sites, in :meth:`Layout.doors_of`
    order) and the door graph's edges: door ``a[k]`` to door ``b[k]`` (``a < b``), the
    shortest path between them inside ``part[k]``, ``costs[k]`` metres long."""

    part_graphs: Mapping[int, VisibilityGraph]
    a: NDArray[np.intp]
    b: NDArray[np.intp]
    costs: NDArray[np.float64]
    part: NDArray[np.intp]
    seconds: float


def plan_layout(space: Workspace, labels: NDArray[np.integer]) -> Layout:
    """The submaps and doors of ``labels`` (aligned with ``space.grid``) for ``space``'s robot.

    Raises
    ------
    PlannerParameterError
        Labels of another shape than the map, or that give no region to any free cell.
    """
    labels = np.asarray(labels)
    if labels.shape != space.grid.shape:
        raise PlannerParameterError(f"labels have shape {labels.shape}, the map {space.grid.shape}")
    filled = fill_unlabelled(labels, space.grid.free)
    # cut where the robot's free space (not the map's) is concave: thin walls count
    parts, region_of = convex_parts(np.where(space.free, filled, 0))
    if space.free.any() and not region_of:
        raise PlannerParameterError("the labels give no region to any free cell of the map")
    doors = find_doors(space, parts, find_transitions(space.grid, parts))
    return Layout(filled, parts, region_of, doors)


def build_door_graph(space: Workspace, layout: Layout, progress: Progress = iter) -> DoorGraph:
    """The door graph of ``layout`` in ``space``, the parts passed through ``progress``."""
    clock = time.perf_counter()
    space.precompute()
    boxes = ndimage.find_objects(layout.parts)
    doors_of = layout.doors_of()
    graphs: dict[int, VisibilityGraph] = {}
    a, b, cost, part_of = [], [], [], []
    for part in progress(list(doors_of)):
        doors = doors_of[part]
        sub = part_space(space, layout.parts, boxes, part)
        sites = np.array([layout.doors[d].point for d in doors]).reshape(-1, 2)
        graph = graphs[part] = VisibilityGraph(sub, sites)
        n = len(graph.corners)
        k, m = np.triu_indices(len(doors), 1)
        dist = graph.site_distances()[k, n + m]
        found = np.isfinite(dist)
        ids = np.asarray(doors, np.intp)
        a.append(ids[k[found]])
        b.append(ids[m[found]])
        cost.append(dist[found])
        part_of.append(np.full(found.sum(), part))
    a_, b_, cost_, part_ = (np.concatenate([*x, []]) for x in (a, b, cost, part_of))
    order = np.lexsort((cost_, b_, a_))  # the cheapest part for every door pair
    first = np.ones(len(order), bool)
    first[1:] = (np.diff(a_[order]) != 0) | (np.diff(b_[order]) != 0)
    keep = order[first]
    seconds = time.perf_counter() - clock
    log.info(
        "door graph: %d parts, %d doors, %d edges in %.2f s",
        len(layout.region_of),
        len(layout.doors),
        len(keep),
        seconds,
    )
    return DoorGraph(
        graphs,
        a_[keep].astype(np.intp),
        b_[keep].astype(np.intp),
        np.maximum(cost_[keep], 1e-9),
        part_[keep].astype(np.intp),
        seconds,
    )


def part_space(space: Workspace, labels: NDArray[np.int32], boxes: list, index: int) -> Workspace:
    """The free space of the cells labelled ``index`` (``boxes``: their bounding boxes, from
    ``ndimage.find_objects``) and :data:`SUBMAP_MARGIN` around them."""
    box = boxes[index - 1]
    h, w = labels.shape
    m = max(1, round(SUBMAP_MARGIN / space.grid.resolution))
    rows = slice(max(box[0].start - m, 0), min(box[0].stop + m, h))
    cols = slice(max(box[1].start - m, 0), min(box[1].stop + m, w))
    inside = ndimage.binary_dilation(labels[rows, cols] == index, iterations=m)
    return space.crop(rows, cols, inside)


def door_graph_key(space: Workspace, labels: NDArray[np.integer]) -> str:
    """A name (SHA-256, hex) of everything a door graph is made from: the map's cells,
    resolution and origin, the robot radius, the labels, :data:`SUBMAP_MARGIN`,
    :data:`~planners.doors.DOOR_SPACING` and :data:`DOOR_GRAPH_VERSION`.

    Examples
    --------
    >>> from maps.grid import OccupancyGrid
    >>> grid = OccupancyGrid(np.zeros((4, 4), np.int8), resolution=0.1)
    >>> labels = np.ones((4, 4), np.int32)
    >>> key = door_graph_key(Workspace(grid, 0.1), labels)
    >>> key == door_graph_key(Workspace(grid, 0.2), labels), len(key)
    (False, 64)
    """
    grid = space.grid
    about = (DOOR_GRAPH_VERSION, grid.shape, grid.resolution, tuple(grid.origin))
    sizes = (space.robot_radius, SUBMAP_MARGIN, DOOR_SPACING)
    digest = hashlib.sha256(repr((about, sizes)).encode())
    digest.update(np.ascontiguousarray(grid.cells, np.int8).data)
    digest.update(np.ascontiguousarray(labels, np.int32).data)
    return digest.hexdigest()


def fill_unlabelled(labels: NDArray[np.integer], free: NDArray[np.bool_]) -> NDArray[np.int32]:
    """Labels where free cells in no region take the label of the nearest labelled cell."""
    labels = labels.astype(np.int32)
    missing = free & (labels == 0)
    if missing.any() and (labels > 0).any():
        # only the nearest cells' indices (int32, no distances), read at the missing cells:
        # a tenth of the memory of distances and full-size index lookups on a large map
        nearest = np.empty((2, *labels.shape), np.int32)
        ndimage.distance_transform_edt(
            labels == 0, return_distances=False, return_indices=True, indices=nearest
        )
        labels[missing] = labels[nearest[0][missing], nearest[1][missing]]
    return labels  # type: ignore[return-value]
