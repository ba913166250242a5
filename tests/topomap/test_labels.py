"""Region features, the classifier hook, default rules, the forest, names and renaming."""

import numpy as np
import pytest

from maps.grid import OccupancyGrid
from maps.sim.floorplan import generate_floor_plan
from segmentation.errors import RegionNotFoundError
from segmentation.export import read_geojson, read_graphml
from segmentation.graph import region_graph
from segmentation.regions import Regions
from topomap.classifiers import ForestClassifier, RuleClassifier, classify, rule_classifier
from topomap.errors import LabelError
from topomap.features import FEATURE_UNITS, FEATURES, feature_matrix, region_features
from topomap.labels import find_region
from topomap.topomap import TopoMap


def _rectangles() -> tuple[Regions, object]:
    """A 20 x 2 m corridor above a 6 x 5 m room, 5 cm cells."""
    labels = np.zeros((150, 420), np.int32)
    labels[10:50, 10:410] = 1  # corridor, 2 m deep
    labels[50:150, 40:160] = 2  # room below it
    free = labels > 0
    grid = OccupancyGrid(np.where(free, 0, 100).astype(np.int8), 0.05)
    regions = Regions(grid, labels)
    return regions, region_graph(regions)


def test_features_measure_the_shapes():
    regions, graph = _rectangles()
    f = region_features(regions, graph)
    assert list(f["id"]) == [1, 2]
    assert f["area_m2"] == pytest.approx([40.0, 30.0], rel=0.01)
    assert f["width_m"][0] == pytest.approx(2.0, abs=0.15)
    assert f["slenderness"][0] > 4 > f["slenderness"][1]
    assert f["elongation"][0] == pytest.approx(10.0, rel=0.05)
    assert list(f["doors"]) == [1.0, 1.0]
    assert f["compactness"][1] > f["compactness"][0]
    assert feature_matrix(f).shape == (2, len(FEATURES))


def test_furniture_does_not_make_a_room_a_corridor():
    regions, _ = _rectangles()
    labels = regions.labels.copy()
    labels[60:80, 60:140] = 0  # a 4 x 1 m table in the room
    labels[140:150, 40:160] = 0  # shelves along its far wall
    furnished = Regions(regions.grid, labels)
    f = region_features(furnished, region_graph(furnished))
    assert rule_classifier(f) == ["corridor", "room"]


def test_hook_accepts_functions_and_estimators_and_checks_them():
    regions, graph = _rectangles()
    f = region_features(regions, graph)
    assert classify(None, f) == ["corridor", "room"]
    assert classify(lambda features: ["Aisle", "hall"], f) == ["corridor", "hall"]

    def too_few(features):
        return ["room"]

    with pytest.raises(LabelError, match="classifier too_few returned 1 labels for 2 regions"):
        classify(too_few, f)
    with pytest.raises(LabelError, match=r"unknown labels \['kitchen'\]"):
        classify(lambda features: ["room", "kitchen"], f)
    forest = ForestClassifier(n_estimators=10).fit(feature_matrix(f), ["corridor", "room"])
    assert classify(forest, f) == ["corridor", "room"]


def test_forest_is_a_scikit_learn_estimator():
    from sklearn.base import clone

    rng = np.random.default_rng(1)
    x = rng.random((40, len(FEATURES)))
    y = ["room" if v < 0.5 else "corridor" for v in x[:, 0]]
    forest = ForestClassifier(n_estimators=7, min_samples_leaf=2, random_state=4)
    copied = clone(forest)
    given = {"min_samples_leaf": 2, "n_estimators": 7, "random_state": 4}
    assert copied.get_params() == forest.get_params() == given
    first = forest.fit(x, y).predict(x)
    assert forest.fit(x, y).predict(x) == first and forest.classes_ == ["corridor", "room"]
    assert not hasattr(copied, "forest_")  # the clone is unfitted
    with pytest.raises(LabelError, match="n_estimators must be an integer >= 1, got 0"):
        copied.set_params(n_estimators=0).fit(x, y)


def test_forest_saves_with_skops_and_reloads_the_same(tmp_path):
    import skops.io

    rng = np.random.default_rng(0)
    x = rng.random((60, len(FEATURES)))
    y = ["room" if v < 0.5 else "corridor" for v in x[:, 2]]
    forest = ForestClassifier(n_estimators=20, random_state=3).fit(x, y)
    path = forest.save(tmp_path / "forest.skops")
    again = ForestClassifier.load(path)
    test = rng.random((40, len(FEATURES)))
    assert again.predict(test) == forest.predict(test)
    (tmp_path / "bad.skops").write_text('{"x": [[1]]}')
    with pytest.raises(LabelError, match=r"bad.skops: not a topomap forest file"):
        ForestClassifier.load(tmp_path / "bad.skops")
    skops.io.dump({"format": "topomap-forest-2", "features": ["area_m2"]}, tmp_path / "old.skops")
    with pytest.raises(LabelError, match=r"old.skops: features \['area_m2'\] are not"):
        ForestClassifier.load(tmp_path / "old.skops")
    # a file holding a type a forest is not made of is refused before anything is built
    skops.io.dump({"format": "topomap-forest-2", "x": RuleClassifier()}, tmp_path / "odd.skops")
    with pytest.raises(LabelError, match=r"odd.skops: holds types .*RuleClassifier"):
        ForestClassifier.load(tmp_path / "odd.skops")


def test_feature_table_is_what_a_classifier_receives():
    plan = generate_floor_plan("flat", random_state=4)
    topo = TopoMap.from_grid(plan.grid, random_state=4)
    table = topo.feature_table()
    assert list(table) == ["id", *FEATURES, "links"] and set(FEATURES) == set(FEATURE_UNITS)
    assert table["id"].tolist() == sorted(topo.graph.nodes)
    # links: one row (a, b, widest opening) per edge of the region graph
    assert sorted(map(tuple, table["links"][:, :2].astype(int).tolist())) == sorted(
        tuple(sorted(e)) for e in topo.graph.edges
    )
    widths = {tuple(sorted(e)): w for *e, w in topo.graph.edges(data="width")}
    assert [widths[int(a), int(b)] for a, b, _ in table["links"]] == table["links"][:, 2].tolist()
    seen = {}

    def spy(features):
        seen.update(features)
        return ["room"] * len(features["id"])

    topo.label(spy)
    assert {k: v.tolist() for k, v in seen.items()} == {k: v.tolist() for k, v in table.items()}
    # the areas are the regions' floor in m^2 (furniture holes filled: never less)
    for region, area in zip(table["id"].astype(int), table["area_m2"], strict=True):
        assert area >= topo.regions.area(region) * 0.99


def test_label_keeps_the_names_a_user_gave(tmp_path):
    plan = generate_floor_plan("flat", random_state=4)
    topo = TopoMap.from_grid(plan.grid, random_state=4)
    corridor = topo.region("corridor 1")
    first = topo.region("room 1")
    rooms = [r for r in topo.graph if topo.graph.nodes[r]["label"] == "room"]
    last = topo.region(f"room {len(rooms)}")
    topo.rename(corridor, "main hallway")
    topo.rename(first, "office")
    topo.rename(last, "room 1")  # a name the numbering would give another room
    topo.label()
    assert topo.graph.nodes[corridor]["name"] == "main hallway"
    assert topo.graph.nodes[first]["name"] == "office"
    assert topo.graph.nodes[last]["name"] == "room 1"
    names = [topo.graph.nodes[r]["name"] for r in topo.graph]
    assert len(set(names)) == len(names)
    topo.label(lambda features: ["room"] * len(features["id"]))
    assert topo.graph.nodes[corridor]["name"] == "main hallway"
    assert topo.graph.nodes[corridor]["label"] == "room"
    topo.save(tmp_path / "saved")
    again = TopoMap.load(tmp_path / "saved")
    again.label()
    assert again.graph.nodes[corridor]["name"] == "main hallway"


def test_names_of_only_digits_are_refused():
    plan = generate_floor_plan("flat", random_state=4)
    topo = TopoMap.from_grid(plan.grid, random_state=4)
    first = sorted(topo.graph.nodes)[0]
    old = topo.graph.nodes[first]["name"]
    with pytest.raises(LabelError, match="only digits"):
        topo.rename(first, " 3 ")
    assert topo.graph.nodes[first]["name"] == old


def test_generated_building_gets_unique_names_saved_in_exports(tmp_path):
    plan = generate_floor_plan("flat", random_state=4)
    topo = TopoMap.from_grid(plan.grid, random_state=4)
    names = [topo.graph.nodes[r]["name"] for r in topo.graph]
    assert len(set(names)) == len(names)
    assert any(n.startswith("corridor ") for n in names)
    corridor = find_region(topo.graph, "corridor 1")
    truth = np.bincount(plan.labels[topo.regions.labels == corridor]).argmax()
    assert plan.types[truth - 1] == "corridor"
    assert topo.region("Aisle 1") == corridor
    topo.save(tmp_path)
    saved = read_graphml(tmp_path / "graph.graphml")
    assert saved.nodes[corridor]["name"] == "corridor 1"
    features = read_geojson(tmp_path / "regions.geojson")
    assert features.nodes[corridor]["label"] == "corridor"


def test_rename_refuses_taken_and_unknown_names():
    plan = generate_floor_plan("flat", random_state=4)
    topo = TopoMap.from_grid(plan.grid, random_state=4)
    first, second = sorted(topo.graph.nodes)[:2]
    old = topo.graph.nodes[second]["name"]
    topo.rename(first, "kitchen")
    assert topo.region("Kitchen") == first
    with pytest.raises(LabelError, match="'KITCHEN' is taken by region"):
        topo.rename(second, "KITCHEN")
    assert topo.graph.nodes[second]["name"] == old
    with pytest.raises(
        RegionNotFoundError, match=r"no region named 'lab 9'.*known names: .*kitchen"
    ):
        topo.region("lab 9")


def test_plan_to_a_named_region():
    plan = generate_floor_plan("flat", random_state=4)
    topo = TopoMap.from_grid(plan.grid, random_state=4)
    space = topo.planner().space
    rows, cols = np.nonzero(space.free)
    start = plan.grid.cell_to_world(rows[0], cols[0])
    path = topo.plan(start, "corridor 1")
    assert topo.region_at(*path.waypoints[-1]) == topo.region("corridor 1")
    assert space.collisions(path.waypoints) == 0


def test_plan_route_and_region_take_the_same_queries():
    plan = generate_floor_plan("flat", random_state=4)
    topo = TopoMap.from_grid(plan.grid, random_state=4)
    corridor = topo.region("corridor 1")
    room = next(r for r, label in topo.graph.nodes(data="label") if label == "room")
    name = topo.graph.nodes[room]["name"]
    for query in ("Aisle 1", "  CORRIDOR   1 ", corridor, str(corridor)):
        assert topo.region(query) == corridor
        assert topo.route(query, name).regions[0] == corridor
        path = topo.plan(query, name)  # a region start too: its most open point
        assert topo.region_at(*path.waypoints[0]) == corridor
        assert topo.region_at(*path.waypoints[-1]) == room
    for bad in ("corridr 1", 999):
        for ask in (topo.region, lambda q: topo.route(q, name), lambda q: topo.plan(q, name)):
            with pytest.raises(RegionNotFoundError):
                ask(bad)
    with pytest.raises(RegionNotFoundError, match=r"did you mean 'corridor 1'\?"):
        topo.plan(corridor, "corridr 1")


def test_unknown_names_are_listed_in_natural_order():
    import networkx as nx

    from segmentation.names import find_region

    graph = nx.Graph()
    graph.add_nodes_from((i, {"name": f"room {i}"}) for i in (10, 2, 1))
    with pytest.raises(RegionNotFoundError, match=r"known names: room 1, room 2, room 10$"):
        find_region(graph, "kitchen")


def _corridor_with_open_area() -> tuple[Regions, object]:
    """A 30 x 2 m corridor (id 1) with an 8 x 6 m open area on its side, one region, and a
    4 x 5 m office (id 2, 3) at each end below it, at 10 cm cells."""
    labels = np.zeros((140, 340), np.int32)
    labels[70:90, 20:320] = 1  # the corridor, y 7-9 m
    labels[10:70, 130:210] = 1  # the open area joined to it
    labels[91:141, 20:60] = 2
    labels[90:91, 35:45] = 2  # a 1 m door
    labels[91:141, 280:320] = 3
    labels[90:91, 295:305] = 3
    grid = OccupancyGrid(np.where(labels > 0, 0, 100).astype(np.int8), 0.1)
    regions = Regions(grid, labels)
    return regions, region_graph(regions)


def test_a_corridor_with_an_open_area_joined_is_a_corridor():
    regions, graph = _corridor_with_open_area()
    f = region_features(regions, graph)
    # the floor is wide (the open area) and the region not long for that width ...
    assert f["width_m"][0] > rule_classifier.corridor_width_m
    assert f["slenderness"][0] < rule_classifier.corridor_length
    # ... but its axis is 2 m wide over 20 m and more: walked along, a corridor
    assert f["axis_width_median_m"][0] == pytest.approx(2.0, abs=0.2)
    assert rule_classifier(f) == ["corridor", "room", "room"]
    # the same region with one neighbour only (a dead end) is not passed through: a room
    dead_end = {k: v if k == "links" else v.copy() for k, v in f.items()}
    dead_end["doors"][0] = 1
    assert rule_classifier(dead_end)[0] == "room"


def test_an_office_off_a_corridor_is_not_joined_to_it():
    # a furnished 5 x 5 m office measures 3.3 m wide (clutter), passed through, opening onto
    # the corridor wider than a door (a SLAM map's open door and rays): its axis is wider
    # than a corridor's, so the corridor does not go on into it
    table = {
        "id": np.array([1.0, 2.0, 3.0]),
        "area_m2": np.array([40.0, 22.0, 20.0]),
        "width_m": np.array([2.0, 3.3, 3.0]),
        "slenderness": np.array([10.0, 1.9, 2.2]),
        "doors": np.array([2.0, 2.0, 2.0]),
        "extent_m": np.array([2.0, 5.0, 4.5]),
        "solidity": np.array([1.0, 0.93, 0.9]),
        "axis_width_median_m": np.array([2.0, 3.35, 2.4]),
        "corridor_axis_m": np.array([18.0, 1.1, 2.5]),
        "door_width_max_m": np.array([2.0, 2.0, 2.0]),
        "dead_ends": np.array([0.0, 0.0, 0.0]),
        "links": np.array([[1, 2, 2.0], [1, 3, 2.0], [2, 3, 0.9]]),
    }
    # the office (axis 3.35 m) stays a room; a corridor piece (axis 2.4 m) is joined
    assert rule_classifier(table) == ["corridor", "room", "corridor"]


def test_a_long_narrow_room_behind_a_door_is_a_room():
    # a 2.5 x 10 m office with one door (0.9 m) and a 2 x 10 m corridor end piece that goes
    # on to the rest of the corridor through a 2 m opening: both one neighbour (which leads
    # on to others), both slender
    table = {
        "id": np.array([1.0, 2.0]),
        "area_m2": np.array([25.0, 20.0]),
        "width_m": np.array([2.5, 2.0]),
        "slenderness": np.array([4.0, 5.0]),
        "doors": np.array([1.0, 1.0]),
        "extent_m": np.array([2.5, 2.0]),
        "solidity": np.array([1.0, 1.0]),
        "axis_width_median_m": np.array([2.5, 2.0]),
        "corridor_axis_m": np.array([7.5, 8.0]),
        "door_width_max_m": np.array([0.9, 2.0]),
        "dead_ends": np.array([0.0, 0.0]),
    }
    assert rule_classifier(table) == ["room", "corridor"]


def test_a_strip_of_floor_between_furniture_is_no_corridor():
    # two 1.4 x 6 m strips, each one neighbour through an opening wider than a door (no
    # dead end behind a door): a clear one, its axis as wide as its floor, is a corridor's
    # end; one between furniture, 0.7 m along most of its axis (narrower than any door), is
    # the floor of a furnished room (ROSE²'s map8-map14 show one)
    table = {
        "id": np.array([1.0, 2.0]),
        "area_m2": np.array([8.4, 8.4]),
        "width_m": np.array([1.4, 1.4]),
        "slenderness": np.array([4.3, 4.3]),
        "doors": np.array([1.0, 1.0]),
        "extent_m": np.array([1.4, 1.4]),
        "solidity": np.array([1.0, 0.56]),
        "axis_width_median_m": np.array([1.4, 0.7]),
        "corridor_axis_m": np.array([5.0, 3.6]),
        "door_width_max_m": np.array([1.85, 1.85]),
        "dead_ends": np.array([0.0, 0.0]),
    }
    assert rule_classifier(table) == ["corridor", "room"]
    assert rule_classifier.corridor_axis_min_m < 1.4
