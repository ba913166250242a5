"""The region adjacency graph: a node per region, an edge per pair of touching regions."""

from __future__ import annotations

import networkx as nx
import numpy as np
from numpy.typing import NDArray

from segmentation.distinct import label_counts
from segmentation.regions import Regions
from segmentation.transitions import Transition, find_transitions
from segmentation.virtual import most_open_cells


def region_graph(
    regions: Regions,
    keyframe_regions: NDArray[np.integer] | None = None,
    *,
    min_width: float = 0.0,
) -> nx.Graph:
    """Build the region adjacency graph of ``regions``: an edge where a robot ``min_width``
    metres wide crosses from one region to the other.

    Parameters
    ----------
    regions
        The segmentation.
    keyframe_regions
        Region id of each keyframe (0 = none), to count keyframes per region.
    min_width
        Metres: openings whose :attr:`~segmentation.transitions.Transition.passable` width
        is not more than this are no doors (by default, only those no robot crosses: gaps of
        no free cell pair). :class:`~topomap.topomap.TopoMap` passes twice the radius of the
        robot the map is segmented for, which is what its planner's free space keeps.

    Returns
    -------
    networkx.Graph
        Node ``id`` (the region's value in the label image) with ``area_m2`` (its cells:
        the floor), ``polygon`` (shapely, map-frame metres; round the furniture inside),
        ``x``, ``y`` (the region's most open free cell: farthest from walls, furniture and
        unknown space, so a robot can stand there) and ``keyframes``.
        Edge ``(a, b)`` with ``doors``: a tuple of :class:`Transition`, widest first, and
        ``width``, the widest door's width; two regions that only touch through narrower
        gaps have no edge. Graph attributes: ``resolution``, ``origin``.

    Examples
    --------
    >>> import numpy as np, maps
    >>> grid = maps.OccupancyGrid(np.zeros((4, 6), np.int8), resolution=0.5)
    >>> labels = np.array([[1, 1, 1, 2, 2, 2]] * 4, np.int32)
    >>> graph = region_graph(Regions(grid, labels))
    >>> sorted(graph.edges), round(graph.edges[1, 2]["width"], 6)
    ([(1, 2)], 2.0)
    """
    counts = np.zeros(len(regions.cell_counts), np.int64)
    if keyframe_regions is not None:
        found = np.bincount(np.asarray(keyframe_regions, np.int64), minlength=len(counts))
        counts[: len(found)] = found[: len(counts)]
    graph = nx.Graph(resolution=regions.grid.resolution, origin=tuple(regions.grid.origin))
    regions = regions.known_part()
    grid = regions.grid
    on_free = np.where(grid.free, regions.labels, 0)
    ids = np.flatnonzero(label_counts(on_free))  # the ids on free cells, ascending
    ids = ids[ids > 0]
    rows, cols = most_open_cells(grid.free_clearance(), on_free, ids)
    xs, ys = grid.cell_to_world(rows, cols)
    open_point = {
        int(r): (float(x), float(y)) for r, x, y in zip(on_free[rows, cols], xs, ys, strict=True)
    }
    for region, polygon in regions.polygons.items():
        if region not in open_point:  # no free cell: a point inside the polygon
            point = polygon.representative_point()
            open_point[region] = (float(point.x), float(point.y))
        graph.add_node(
            region,
            area_m2=regions.area(region),
            polygon=polygon,
            x=open_point[region][0],
            y=open_point[region][1],
            keyframes=int(counts[region]),
        )
    doors: dict[tuple[int, int], list[Transition]] = {}
    for transition in find_transitions(regions.grid, regions.labels):
        if not transition.passable > min_width:
            continue
        doors.setdefault((transition.a, transition.b), []).append(transition)
    for (a, b), found_doors in doors.items():
        found_doors.sort(key=lambda t: -t.width)
        graph.add_edge(a, b, doors=tuple(found_doors), width=found_doors[0].width)
    return graph
