"""Region-level routes: regions and doors, closed doors, names."""

import networkx as nx
import pytest

from planners.errors import NoPathError
from planners.region_route import region_route
from segmentation.errors import RegionNotFoundError
from segmentation.transitions import Transition


def _corridor_with_rooms() -> nx.Graph:
    """Rooms 1-3 along a corridor 4; room 1 also opens straight into room 2."""
    graph = nx.Graph()
    for region, (x, y, name) in {
        1: (0.0, 2.0, "room 1"),
        2: (4.0, 2.0, "room 2"),
        3: (8.0, 2.0, "room 3"),
        4: (4.0, 0.0, "corridor 1"),
    }.items():
        graph.add_node(region, x=x, y=y, name=name)

    def door(a, b, x, y, width=0.9):
        return Transition(a, b, (x - width / 2, y), (x + width / 2, y), (x, y), width)

    graph.add_edge(1, 4, doors=(door(1, 4, 0.0, 1.0),))
    graph.add_edge(2, 4, doors=(door(2, 4, 4.0, 1.0),))
    graph.add_edge(3, 4, doors=(door(3, 4, 8.0, 1.0),))
    graph.add_edge(1, 2, doors=(door(1, 2, 2.0, 2.0, 0.8), door(1, 2, 2.0, 3.0, 1.2)))
    return graph


def test_route_takes_the_shorter_chain_and_the_widest_door():
    route = region_route(_corridor_with_rooms(), "room 1", 2)
    assert route.regions == (1, 2) and route.names == ("room 1", "room 2")
    assert route.doors[0].width == 1.2
    assert route.length == pytest.approx(2 * (2.0**2 + 1.0**2) ** 0.5)


def test_closed_doors_reroute_or_fail():
    graph = _corridor_with_rooms()
    route = region_route(graph, 1, 3, closed=[(2, 1)])
    assert route.regions == (1, 4, 3)
    assert [(d.a, d.b) for d in route.doors] == [(1, 4), (3, 4)]
    with pytest.raises(NoPathError, match="open doors"):
        region_route(graph, 1, 3, closed=[(1, 2), (4, 1)])


def test_unknown_region_lists_the_names():
    with pytest.raises(RegionNotFoundError, match="corridor 1, room 1, room 2, room 3"):
        region_route(_corridor_with_rooms(), "kitchen", 1)


@pytest.mark.parametrize("closed", [None, 5, 1.5])
def test_closed_that_is_no_list_of_pairs_is_refused(closed):
    from planners.errors import InvalidQueryError

    with pytest.raises(InvalidQueryError, match="closed is a list of region pairs"):
        region_route(_corridor_with_rooms(), 1, 3, closed=closed)
