"""Route graphs for Nav2: the building's doors and regions, the planner's portals, the GeoJSON
file the route server reads, and a real map."""

import itertools
import json
import math

import networkx as nx
import numpy as np
import pytest

from maps.errors import OutputExistsError
from maps.sim.floorplan import generate_floor_plan
from planners.nav2_route import RouteGraphError, read_nav2_route, route_geojson, write_nav2_route
from planners.route_graph import building_route_graph, planner_route_graph
from topomap.cli.evaluate import floor_plans
from topomap.topomap import TopoMap

#: The keys the route server's GeoJSON parser reads (nav2_route geojson_graph_file_loader).
NODE_KEYS = {"id", "frame", "metadata"}
EDGE_KEYS = {"id", "startid", "endid", "cost", "overridable", "metadata"}


@pytest.fixture(scope="module")
def planner():
    plan = generate_floor_plan((16.0, 12.0), random_state=3)
    return TopoMap.from_grid(plan.grid, random_state=3).planner(0.2)


@pytest.fixture(scope="module")
def route(planner):
    return building_route_graph(planner)


def _kind(route, kind):
    return [n for n, meta in route.nodes(data="metadata") if meta["kind"] == kind]


def test_the_file_has_the_keys_nav2_route_reads_and_reads_back_equal(route, tmp_path):
    path = write_nav2_route(route, tmp_path / "route.geojson")
    raw = json.loads(path.read_text())
    assert raw["type"] == "FeatureCollection"
    ids = [f["properties"]["id"] for f in raw["features"]]
    assert len(ids) == len(set(ids)) == route.number_of_nodes() + route.number_of_edges()
    for feature in raw["features"]:
        props, geometry = feature["properties"], feature["geometry"]
        assert feature["type"] == "Feature"
        if geometry["type"] == "Point":
            assert set(props) == NODE_KEYS and props["frame"] == "map"
            assert len(geometry["coordinates"]) == 2
        else:
            assert geometry["type"] == "MultiLineString" and set(props) == EDGE_KEYS
            assert isinstance(props["overridable"], bool) and props["cost"] > 0
        assert "null" not in json.dumps(props["metadata"])  # the server's parser refuses null
    back = read_nav2_route(path)
    assert nx.utils.graphs_equal(back, route)  # nodes, edges and every attribute
    for a, b, data in route.edges(data=True):
        assert back.edges[a, b] == data
    with pytest.raises(OutputExistsError):
        write_nav2_route(route, path)


def test_building_graph_has_a_door_node_per_opening_and_straight_free_edges(planner, route):
    doors, regions = _kind(route, "door"), _kind(route, "region")
    openings = sum(len(d) for _, _, d in planner.graph.edges(data="doors"))
    assert 1 <= len(doors) <= openings
    assert {route.nodes[n]["metadata"]["region"] for n in regions} == set(planner.graph.nodes)
    for node in regions:  # at the region's most open point, inside it
        data = route.nodes[node]
        region = data["metadata"]["region"]
        assert planner.region_at(data["x"], data["y"]) == region
        assert data["metadata"]["name"] == planner.graph.nodes[region]["name"]
    for node in doors:  # on the boundary of its two regions, where the robot fits
        data, meta = route.nodes[node], route.nodes[node]["metadata"]
        assert planner.space.point_free(data["x"], data["y"])
        near = {
            planner.region_at(data["x"] + dx, data["y"] + dy)
            for dx, dy in itertools.product((-0.06, 0.0, 0.06), repeat=2)
        }
        assert set(meta["regions"]) <= near
        assert meta["door_width_m"] >= meta["passable_width_m"] > 0
    for a, b, data in route.edges(data=True):
        ends = [(route.nodes[n]["x"], route.nodes[n]["y"]) for n in (a, b)]
        assert data["line"] == tuple(ends)  # straight: what nav2_route drives
        assert data["cost"] == pytest.approx(math.dist(*ends))
        assert planner.space.segment_free(*ends)
        assert route.has_edge(b, a)


def test_routes_over_the_graph_are_as_long_as_planned_paths(planner, route):
    regions = {route.nodes[n]["metadata"]["region"]: n for n in _kind(route, "region")}
    for a, b in itertools.combinations(sorted(regions), 2):
        start, goal = (route.nodes[regions[r]] for r in (a, b))
        length = nx.shortest_path_length(route, regions[a], regions[b], weight="cost")
        planned = planner.plan((start["x"], start["y"]), (goal["x"], goal["y"]))
        # the graph crosses doors at their middles: never much shorter than the (near-optimal)
        # planner, a little longer at most
        assert 0.97 * planned.length <= length <= 1.2 * planned.length + 0.5


def test_the_planner_graph_is_kept_apart_with_its_portals(planner, route, tmp_path):
    fine = planner_route_graph(planner)
    portals = [n for n, meta in fine.nodes(data="metadata") if meta["kind"] == "portal"]
    assert len(portals) == len(planner.doors) > len(_kind(route, "door"))
    back = read_nav2_route(write_nav2_route(fine, tmp_path / "planner.geojson"))
    assert nx.utils.graphs_equal(back, fine)
    for a, b, data in fine.edges(data=True):
        assert data["line"][0] == (fine.nodes[a]["x"], fine.nodes[a]["y"])
        assert data["line"][-1] == (fine.nodes[b]["x"], fine.nodes[b]["y"])
        steps = np.diff(np.asarray(data["line"]), axis=0)
        assert data["cost"] == pytest.approx(np.hypot(*steps.T).sum())


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
    path.write_text("{not json")
    with pytest.raises(RouteGraphError, match="not a GeoJSON FeatureCollection"):
        read_nav2_route(path)


def test_the_route_servers_sample_layout_reads(tmp_path):
    """Features laid out as in nav2_route's graphs/sample_graph.geojson: edges without
    coordinates, operations keyed by name."""
    open_door = {"type": "open_door", "trigger": "ON_ENTER"}
    sample = {
        "type": "FeatureCollection",
        "name": "graph",
        "features": [
            {"type": "Feature", "geometry": {"type": "Point", "coordinates": [0.0, 0.0]},
             "properties": {"id": 0, "frame": "map"}},
            {"type": "Feature", "geometry": {"type": "Point", "coordinates": [1.0, 0.0]},
             "properties": {"id": 1, "frame": "map"}},
            {"type": "Feature", "geometry": {"type": "MultiLineString"},
             "properties": {"id": 2, "startid": 0, "endid": 1, "overridable": False,
                            "cost": 10.0, "operations": {"open_door": open_door}}},
        ],
    }  # fmt: skip
    path = tmp_path / "sample.geojson"
    path.write_text(json.dumps(sample))
    graph = read_nav2_route(path)
    edge = graph.edges[0, 1]
    assert (edge["cost"], edge["overridable"], edge["line"]) == (10.0, False, ())
    assert edge["operations"]["open_door"]["trigger"] == "ON_ENTER"
    assert route_geojson(graph)["features"][2]["properties"]["operations"] == edge["operations"]


@pytest.mark.slow
def test_real_slam_map_has_about_one_door_node_per_real_door(data_dir):
    """ROSE²'s last Bremen map (76 x 33 m, a real cluttered SLAM map)."""
    found = {m.name: m for m in floor_plans(data_dir / "rose2_partial")}
    topo = TopoMap.from_grid(found["map17"].grid())
    planner = topo.planner(0.2)
    route = building_route_graph(planner)
    doors = _kind(route, "door")
    openings = sum(len(d) for _, _, d in topo.graph.edges(data="doors"))
    # every pair of regions the planner's portals join has a door node between them
    joined = {
        tuple(sorted((planner.region_of[d.a], planner.region_of[d.b]))) for d in planner.doors
    }
    joined = {pair for pair in joined if pair[0] != pair[1]}
    pairs = {tuple(route.nodes[n]["metadata"]["regions"]) for n in doors}
    assert joined <= pairs
    assert len(pairs) <= len(doors) <= openings
    assert 3 * len(doors) < len(planner.doors)  # not the planner's portals
    for a, b in route.edges:
        assert planner.space.segment_free(
            (route.nodes[a]["x"], route.nodes[a]["y"]), (route.nodes[b]["x"], route.nodes[b]["y"])
        )


def _collection(*features):
    point = {"type": "Point", "coordinates": [0.0, 0.0]}
    nodes = [
        {"type": "Feature", "geometry": point, "properties": {"id": 0, "frame": "map"}},
        {"type": "Feature", "geometry": point, "properties": {"id": 1, "frame": "map"}},
    ]
    return {"type": "FeatureCollection", "features": [*nodes, *features]}


ONE_COORDINATE = {"geometry": {"type": "Point", "coordinates": [1]}, "properties": {"id": 3}}


def _edge(key=2, start=0, end=1, coordinates=((0, 0), (1, 0)), **properties):
    line = {"type": "MultiLineString", "coordinates": [[list(p) for p in coordinates]]}
    properties = {"id": key, "startid": start, "endid": end, **properties}
    return {"type": "Feature", "geometry": line, "properties": properties}


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"features": {"a": 1}}, "'features' is not a list"),
        ({"features": [], "properties": [1]}, "not a GeoJSON FeatureCollection"),
        (_collection(5), "feature 2: 'int' object has no attribute"),
        (_collection({"properties": [1]}), "feature 2:"),
        (_collection({"geometry": {"type": "Point"}, "properties": {"id": 3}}), "no 'coordinates'"),
        (
            _collection(ONE_COORDINATE),
            "feature 2: list index out of range",
        ),
        (_collection(_edge(coordinates=[(math.nan, 0)])), "x must be a finite number"),
        (_collection(_edge(coordinates=[("a", 0)])), "x must be a number, got 'a'"),
        (_collection(_edge(coordinates=[(1e300, 0)])), r"x must lie in"),
        (_collection(_edge(cost="abc")), "cost must be a number"),
        (_collection(_edge(cost=math.nan)), "cost must be a finite number"),
        (_collection(_edge(cost=-5)), "cost must be 0 or more"),
        (_collection(_edge(overridable="false")), "overridable must be true or false"),
        (_collection(_edge(metadata=None)), "metadata must be an object"),
        (_collection(_edge(end=[1])), "startid and endid must be node ids"),
        (_collection(_edge(key=True)), "feature 2: a missing or repeated id"),
        (_collection(_edge(), _edge(key=3)), "feature 3: edge 3 repeats edge 2 from node 0 to 1"),
    ],
)
def test_a_damaged_route_graph_is_refused_naming_the_feature(tmp_path, data, message):
    path = tmp_path / "route.geojson"
    path.write_text(json.dumps(data))  # NaN written as JSON's NaN, as Python's json reads it
    with pytest.raises(RouteGraphError, match=message) as info:
        read_nav2_route(path)
    assert str(path) in str(info.value)


def test_a_missing_unreadable_or_huge_route_graph_is_refused(tmp_path, monkeypatch):
    from maps.errors import MapFileNotFoundError
    from planners import nav2_route

    with pytest.raises(MapFileNotFoundError, match="route graph not found"):
        read_nav2_route(tmp_path / "missing.geojson")
    with pytest.raises(RouteGraphError, match="cannot be read"):
        read_nav2_route(tmp_path)
    path = tmp_path / "route.geojson"
    path.write_text(json.dumps(_collection(_edge())))
    monkeypatch.setattr(nav2_route, "MAX_ROUTE_BYTES", 100)
    with pytest.raises(RouteGraphError, match="more than a route graph's 100 bytes"):
        read_nav2_route(path)
