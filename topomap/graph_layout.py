"""How the region graph is shown: a colour per place type, and its edges drawn door to door.

Pictures, RViz markers and the browser viewer draw the same thing: each region's name once at
its most open point (the graph node's ``x``, ``y``), each door as its portal segment, and the
graph's edges as short segments inside each region joining the region's point and the middles
of its doors (the shortest tree over them). A hall with sixty doors is drawn as a tree along
its doors, not as a star of sixty lines hiding its own name.
"""

from __future__ import annotations

import networkx as nx
import numpy as np
from numpy.typing import NDArray
from scipy.sparse.csgraph import minimum_spanning_tree
from scipy.spatial.distance import cdist

#: RGB colours (0..1) of the place types (:data:`topomap.labels.PLACE_TYPES`), and of the rest.
LABEL_COLOURS: dict[str, tuple[float, float, float]] = {
    "room": (0.40, 0.65, 0.95),
    "corridor": (0.98, 0.75, 0.30),
    "hall": (0.55, 0.85, 0.45),
    "doorway": (0.90, 0.45, 0.75),
}
OTHER_COLOUR = (0.70, 0.70, 0.70)

Segment = tuple[tuple[float, float], tuple[float, float]]


def label_colour(label: str | None) -> tuple[float, float, float]:
    """The colour of place type ``label`` (grey for none or another).

    Examples
    --------
    >>> label_colour("corridor"), label_colour(None)
    ((0.98, 0.75, 0.3), (0.7, 0.7, 0.7))
    """
    return LABEL_COLOURS.get(str(label), OTHER_COLOUR)


def edge_segments(graph: nx.Graph) -> list[tuple[int, Segment]]:
    """The region graph's edges as ``(region, segment)`` pairs, door to door: per region, the
    shortest tree over its most open point and the middles of the widest door of each of its
    edges (so every edge is drawn as the path region point -> door -> other region's point).

    Examples
    --------
    >>> from segmentation.transitions import Transition
    >>> graph = nx.Graph()
    >>> graph.add_node(1, x=0.0, y=0.0)
    >>> graph.add_node(2, x=4.0, y=0.0)
    >>> door = Transition(1, 2, (2.0, -0.5), (2.0, 0.5), (2.0, 0.0), 1.0)
    >>> graph.add_edge(1, 2, doors=(door,))
    >>> edge_segments(graph)
    [(1, ((0.0, 0.0), (2.0, 0.0))), (2, ((4.0, 0.0), (2.0, 0.0)))]
    """
    found: list[tuple[int, Segment]] = []
    for region in sorted(graph.nodes):
        data = graph.nodes[region]
        points = [(float(data["x"]), float(data["y"]))]
        for other in sorted(graph[region]):
            doors = graph.edges[region, other].get("doors") or ()
            if doors:
                points.append((float(doors[0].centre[0]), float(doors[0].centre[1])))
        if len(points) < 2:
            continue
        tree = minimum_spanning_tree(_distances(points)).tocoo()
        for i, j in sorted(zip(tree.row.tolist(), tree.col.tolist(), strict=True)):
            found.append((region, (points[i], points[j])))
    return found


def _distances(points: list[tuple[float, float]]) -> NDArray[np.float64]:
    """Pairwise distances, with coincident points a hair apart (a zero would drop the edge
    from the sparse tree)."""
    distances = np.maximum(cdist(points, points), 1e-9)
    np.fill_diagonal(distances, 0.0)
    return distances
