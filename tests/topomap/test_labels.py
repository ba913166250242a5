"""Region features, the classifier hook, default rules, the forest, names and renaming."""

import json

import numpy as np
import pytest

from maps.floorplan import generate_floor_plan
from maps.grid import OccupancyGrid
from segmentation.export import read_geojson, read_graphml
from segmentation.graph import region_graph
from segmentation.regions import Regions
from topomap.labels import (
    FEATURES,
    ForestClassifier,
    LabelError,
    classify,
    feature_matrix,
    find_region,
    region_features,
    rule_classifier,
)
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


def test_forest_saves_as_json_and_reloads_the_same(tmp_path):
    rng = np.random.default_rng(0)
    x = rng.random((60, len(FEATURES)))
    y = ["room" if v < 0.5 else "corridor" for v in x[:, 2]]
    forest = ForestClassifier(n_estimators=20, random_state=3).fit(x, y)
    path = forest.save(tmp_path / "forest.json")
    assert json.loads(path.read_text())["format"] == "topomap-forest-1"
    again = ForestClassifier.load(path)
    test = rng.random((40, len(FEATURES)))
    assert again.predict(test) == forest.predict(test)
    (tmp_path / "bad.json").write_text('{"x": [[1]]}')
    with pytest.raises(LabelError, match=r"bad.json: not a topomap forest file"):
        ForestClassifier.load(tmp_path / "bad.json")


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
    with pytest.raises(LabelError, match=r"no region named 'lab 9'; known names: .*kitchen"):
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
