"""The Nav2 route graph export: written, read back, and checked against the planner."""

import json

import numpy as np
import pytest

from maps.errors import OutputExistsError
from maps.floorplan import generate_floor_plan
from planners.nav2_route import RouteGraphError, read_nav2_route, write_nav2_route
from planners.path import polyline_length
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def planner():
    plan = generate_floor_plan((16.0, 12.0), random_state=3)
    return TopoMap.from_grid(plan.grid, random_state=3).planner(0.2)


def test_route_graph_reads_back_with_valid_ids_references_and_geometry(planner, tmp_path):
    path = write_nav2_route(planner, tmp_path / "route.geojson")
    raw = json.loads(path.read_text())
    ids = [f["properties"]["id"] for f in raw["features"]]
    assert len(ids) == len(set(ids))  # unique over nodes and edges together
    graph = read_nav2_route(path)
    doors = [n for n, d in graph.nodes(data=True) if d["metadata"]["kind"] == "door"]
    regions = [n for n, d in graph.nodes(data=True) if d["metadata"]["kind"] == "region"]
    assert len(doors) == len(planner.doors) and len(regions) >= 1
    assert all(d["frame"] == "map" for _, d in graph.nodes(data=True))
    for a, b, edge in graph.edges(data=True):
        assert graph.has_edge(b, a)  # one feature per direction
        assert np.array_equal(graph.edges[b, a]["line"], edge["line"][::-1])
        start = (graph.nodes[a]["x"], graph.nodes[a]["y"])
        end = (graph.nodes[b]["x"], graph.nodes[b]["y"])
        assert np.allclose(edge["line"][0], start, atol=1e-3)
        assert np.allclose(edge["line"][-1], end, atol=1e-3)
        length = polyline_length(edge["line"])
        assert edge["cost"] == pytest.approx(length, abs=1e-3)
        assert edge["metadata"]["length_m"] == pytest.approx(length, abs=1e-3)
        assert length >= np.hypot(start[0] - end[0], start[1] - end[1]) - 1e-3
        assert {"region", "name", "label", "door_width_m"} <= set(edge["metadata"])
        # rounding to 0.1 mm may touch a wall corner; the path itself stays in free space
        assert planner.space.collisions(edge["line"], step=0.01) <= 2
    for node in doors:
        assert graph.nodes[node]["metadata"]["door_width_m"] > 0
    with pytest.raises(OutputExistsError):
        write_nav2_route(planner, path)


def test_reading_a_graph_with_a_dangling_edge_fails(tmp_path):
    broken = {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [0.0, 0.0]},
                "properties": {"id": 0, "frame": "map"},
            },
            {
                "type": "Feature",
                "geometry": {"type": "MultiLineString", "coordinates": [[[0, 0], [1, 0]]]},
                "properties": {"id": 1, "startid": 0, "endid": 7},
            },
        ],
    }
    path = tmp_path / "broken.geojson"
    path.write_text(json.dumps(broken))
    with pytest.raises(RouteGraphError, match="edge 1 endid names no node"):
        read_nav2_route(path)
