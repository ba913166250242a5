import json

import networkx as nx
import numpy as np
import pytest
import shapely
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import maps
from segmentation.errors import ExportFormatError
from segmentation.export import (
    read_geojson,
    read_graphml,
    read_label_image,
    read_node_link,
    write_geojson,
    write_graphml,
    write_label_image,
    write_node_link,
)
from segmentation.graph import region_graph
from segmentation.regions import Regions, consecutive


def assert_same_graph(a: nx.Graph, b: nx.Graph, *, edges: bool = True) -> None:
    assert a.graph["resolution"] == b.graph["resolution"]
    assert tuple(a.graph["origin"]) == tuple(b.graph["origin"])
    assert sorted(a.nodes) == sorted(b.nodes)
    for node, data in a.nodes(data=True):
        other = b.nodes[node]
        assert set(data) == set(other)
        assert shapely.equals_exact(data["polygon"], other["polygon"], tolerance=0)
        assert {k: v for k, v in data.items() if k != "polygon"} == {
            k: v for k, v in other.items() if k != "polygon"
        }
    if edges:
        assert sorted(a.edges) == sorted(b.edges)
        for u, v, data in a.edges(data=True):
            assert data == b.edges[u, v]


@st.composite
def segmentations(draw):
    labels = draw(
        arrays(
            np.int32, st.tuples(st.integers(2, 12), st.integers(2, 12)), elements=st.integers(0, 4)
        )
    )
    resolution = draw(st.sampled_from([0.05, 0.1, 0.25]))
    origin = (draw(st.floats(-50, 50)), draw(st.floats(-50, 50)), draw(st.sampled_from([0.0, 0.5])))
    grid = maps.OccupancyGrid.from_masks(labels > 0, resolution, origin)
    labels = consecutive(labels)
    return Regions(grid, labels), draw(st.lists(st.integers(0, int(labels.max())), max_size=20))


@given(segmentations())
def test_graph_exports_read_back_equal(tmp_path_factory, case):
    regions, keyframe_regions = case
    graph = region_graph(regions, np.array(keyframe_regions, np.int64))
    folder = tmp_path_factory.mktemp("export")
    assert_same_graph(graph, read_graphml(write_graphml(graph, folder / "g.graphml")))
    assert_same_graph(graph, read_node_link(write_node_link(graph, folder / "g.json")))
    assert_same_graph(graph, read_geojson(write_geojson(graph, folder / "r.geojson")), edges=False)
    image = read_label_image(write_label_image(regions.labels, folder / "r.png"))
    np.testing.assert_array_equal(image, regions.labels)


def test_graph_nodes_and_doors(two_rooms):
    grid = two_rooms(door=1.0)
    labels = np.zeros(grid.shape, np.int32)
    rows, cols = np.nonzero(grid.free)
    x, _ = grid.cell_to_world(rows, cols)
    labels[rows, cols] = np.where(x < 4.15, 1, 2)
    regions = Regions(grid, labels)
    graph = region_graph(regions, np.array([1, 1, 2, 0]))
    assert sorted(graph.nodes) == [1, 2] and list(graph.edges) == [(1, 2)]
    assert graph.nodes[1]["keyframes"] == 2 and graph.nodes[2]["keyframes"] == 1
    assert graph.nodes[1]["area_m2"] == pytest.approx(4.0 * 4.0 + 0.5 * 0.05 * 20, rel=0.05)
    assert regions.at(graph.nodes[1]["x"], graph.nodes[1]["y"]) == 1
    (door,) = graph.edges[1, 2]["doors"]
    assert door.width == pytest.approx(1.0, abs=0.06)
    assert np.hypot(*np.subtract(door.end, door.start)) == pytest.approx(door.width)


def test_unreadable_files_are_named(tmp_path):
    bad = tmp_path / "g.graphml"
    bad.write_text("<graphml><oops")
    with pytest.raises(ExportFormatError, match=r"g\.graphml"):
        read_graphml(bad)
    bad_json = tmp_path / "g.json"
    bad_json.write_text(json.dumps({"nodes": [{"id": 1}], "edges": []}))
    with pytest.raises(ExportFormatError, match=r"g\.json"):
        read_node_link(bad_json)
    features = {
        "type": "FeatureCollection",
        "properties": {"resolution": 0.05, "origin": [0, 0, 0]},
        "features": [{"type": "Feature", "geometry": None, "properties": {}}],
    }
    bad_geo = tmp_path / "r.geojson"
    bad_geo.write_text(json.dumps(features))
    with pytest.raises(ExportFormatError, match=r"r\.geojson feature 0"):
        read_geojson(bad_geo)
    with pytest.raises(FileNotFoundError):
        read_label_image(tmp_path / "missing.png")


def test_nothing_is_overwritten_without_asking(tmp_path, two_rooms):
    grid = two_rooms()
    regions = Regions(grid, grid.free.astype(np.int32))
    graph = region_graph(regions)
    path = write_graphml(graph, tmp_path / "g.graphml")
    before = path.read_bytes()
    with pytest.raises(FileExistsError):
        write_graphml(graph, path)
    assert path.read_bytes() == before
    write_graphml(graph, path, overwrite=True)
