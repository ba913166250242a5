"""A map on a canvas far larger than what it knows (a SLAM package's preallocated grid):
segmented, measured and drawn on its known part, the same whatever the canvas round it."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from maps import generate_floor_plan
from maps.errors import InvalidMapError
from maps.grid import UNKNOWN, OccupancyGrid
from segmentation.graph import region_graph
from segmentation.pipeline import MapSegmenter
from segmentation.regions import CANVAS_MARGIN, Regions
from segmentation.spectral import SpectralSegmenter
from topomap.cli.drawing import draw_regions


@given(
    st.integers(1, 30),
    st.integers(1, 30),
    st.data(),
    st.floats(-math.pi, math.pi),
    st.floats(-50.0, 50.0),
)
@settings(max_examples=60, deadline=None)
def test_a_crop_keeps_every_cell_where_it_is_in_the_map_frame(height, width, data, yaw, x):
    grid = OccupancyGrid(np.zeros((height, width), np.int8), 0.05, (x, -x / 2, yaw))
    r0 = data.draw(st.integers(0, height - 1))
    r1 = data.draw(st.integers(r0 + 1, height))
    c0 = data.draw(st.integers(0, width - 1))
    c1 = data.draw(st.integers(c0 + 1, width))
    part = grid.cropped(slice(r0, r1), slice(c0, c1))
    rows, cols = np.mgrid[r0:r1, c0:c1]
    expected = grid.cell_to_world(rows.ravel(), cols.ravel())
    found = part.cell_to_world((rows - r0).ravel(), (cols - c0).ravel())
    np.testing.assert_allclose(found, expected, atol=1e-9)
    back = part.world_to_cell(*expected)
    np.testing.assert_array_equal(back[0], (rows - r0).ravel())
    np.testing.assert_array_equal(back[1], (cols - c0).ravel())


@pytest.mark.parametrize(
    "rows, cols",
    [(slice(0, 0), slice(0, 2)), (slice(-1, 2), slice(0, 2)), (slice(0, 5), slice(0, 2))],
)
def test_a_crop_off_the_grid_is_refused(rows, cols):
    with pytest.raises(InvalidMapError, match="inside the 4 x 3 cells"):
        OccupancyGrid(np.zeros((4, 3), np.int8), 0.1).cropped(rows, cols)


def test_the_known_box_holds_every_known_cell_and_the_margin_within_the_grid():
    cells = np.full((300, 200), UNKNOWN, np.int8)
    cells[100, 5] = 100  # a wall cell near the left edge
    cells[150:160, 50:60] = 0
    rows, cols = OccupancyGrid(cells, 0.1).known_box(3.0)
    assert (rows, cols) == (slice(70, 190), slice(0, 90))  # 30 cells round, cut at the edge
    assert OccupancyGrid(np.full((5, 5), UNKNOWN, np.int8), 0.1).known_box(1.0) == (
        slice(0, 5),
        slice(0, 5),
    )


@pytest.fixture(scope="module")
def flat() -> OccupancyGrid:
    return generate_floor_plan("flat", random_state=0).grid


def test_any_canvas_wider_than_the_margin_gives_the_same_regions(flat):
    beyond = math.ceil(CANVAS_MARGIN / flat.resolution) + 5
    pipeline = MapSegmenter(SpectralSegmenter(random_state=0))
    small = flat.padded(beyond, beyond, beyond, beyond)
    large = flat.padded(beyond + 150, beyond + 40, beyond + 300, beyond + 7)
    first = pipeline.segment(small, random_state=0)
    second = pipeline.segment(large, random_state=0)
    assert first.regions.labels.shape == small.shape
    assert second.regions.labels.shape == large.shape
    inner = second.regions.labels[40 : 40 + small.shape[0], 150 : 150 + small.shape[1]]
    np.testing.assert_array_equal(inner, first.regions.labels)
    assert small.cell_to_world(0, 0) == pytest.approx(large.cell_to_world(40, 150))
    assert len(first.regions.ids) >= 3
    for found, grid in ((first, small), (second, large)):
        conditioned = found.conditioned
        assert conditioned.free.shape == conditioned.space.shape == grid.shape
        assert conditioned.grid.shape == grid.shape
        assert found.coverage.labels.shape == grid.shape
        assert not found.regions.labels[grid.unknown & ~conditioned.clutter].any()
    x, y = first.regions.grid.cell_to_world(*np.argwhere(first.regions.labels == 1)[0])
    assert first.regions.at(float(x), float(y)) == second.regions.at(float(x), float(y)) == 1


def test_the_graph_of_regions_on_a_canvas_is_that_of_their_known_part(flat):
    found = MapSegmenter(SpectralSegmenter(random_state=0)).segment(flat, random_state=0)
    beyond = math.ceil(CANVAS_MARGIN / flat.resolution) + 200
    canvas = flat.padded(beyond, beyond, beyond, beyond)
    labels = np.zeros(canvas.shape, np.int32)
    labels[beyond : beyond + flat.shape[0], beyond : beyond + flat.shape[1]] = found.regions.labels
    regions = Regions(canvas, labels)
    part = regions.known_part()
    assert part.grid.shape[0] < canvas.shape[0] and part.grid.shape[1] < canvas.shape[1]
    graph, tight = region_graph(regions), region_graph(found.regions)
    assert graph.graph["origin"] == canvas.origin  # the map's frame, as the files say
    assert sorted(graph.edges) == sorted(tight.edges)
    for node, data in tight.nodes(data=True):
        assert graph.nodes[node]["x"] == pytest.approx(data["x"])
        assert graph.nodes[node]["y"] == pytest.approx(data["y"])
        assert graph.nodes[node]["polygon"].equals(data["polygon"])
        assert graph.nodes[node]["area_m2"] == pytest.approx(data["area_m2"])


def test_the_picture_shows_the_known_part_not_the_canvas(flat, tmp_path):
    found = MapSegmenter(SpectralSegmenter(random_state=0)).segment(flat, random_state=0)
    graph = region_graph(found.regions)
    canvas = flat.padded(2000, 1000, 3000, 500)
    labels = np.zeros(canvas.shape, np.int32)
    labels[1000 : 1000 + flat.shape[0], 2000 : 2000 + flat.shape[1]] = found.regions.labels
    tight = cv2.imread(str(draw_regions(tmp_path / "tight.png", flat, found.regions.labels, graph)))
    wide = cv2.imread(str(draw_regions(tmp_path / "wide.png", canvas, labels, graph)))
    assert abs(wide.shape[0] - tight.shape[0]) <= 0.1 * tight.shape[0]
    assert abs(wide.shape[1] - tight.shape[1]) <= 0.1 * tight.shape[1]
    assert (wide != 192).any(axis=2).mean() > 0.3  # the building, not a sea of unknown grey


def test_the_planner_plans_on_the_known_part_the_same_paths(flat):
    from topomap import TopoMap

    beyond = math.ceil(CANVAS_MARGIN / flat.resolution) + 5
    near = TopoMap.from_grid(flat.padded(beyond, beyond, beyond, beyond))
    far = TopoMap.from_grid(flat.padded(beyond + 120, beyond + 30, beyond + 200, beyond + 9))
    nodes = sorted(near.graph.nodes(data=True), key=lambda node: node[1]["x"])
    start, goal = (nodes[0][1]["x"], nodes[0][1]["y"]), (nodes[-1][1]["x"], nodes[-1][1]["y"])
    paths = []
    for topo in (near, far):
        planner = topo.planner(0.2)
        assert planner.space.grid.shape == topo.regions.known_part().grid.shape
        assert planner.space.grid.shape[1] < topo.grid.shape[1]
        paths.append(planner.plan(start, goal))
    np.testing.assert_allclose(paths[0].waypoints, paths[1].waypoints)
    assert paths[0].length > 5.0 and len(paths[0].regions) >= 2


def test_a_saved_canvas_map_is_checked_on_its_known_part(flat, tmp_path, monkeypatch):
    """Loading a folder checks every outline against the regions' cells (and the pieces they
    enclose) on the map's known part, not over the whole canvas (an 8000 x 8000 canvas: 3.6 s
    and 1.0 GB -> 1.9 s and 0.75 GB); an outline that is not its region's is still refused."""
    import networkx as nx
    from shapely import affinity

    import segmentation.regions
    from segmentation.errors import ExportFormatError
    from segmentation.export import read_graphml, write_graphml
    from topomap import TopoMap

    canvas = flat.padded(900, 700, 1100, 600)
    TopoMap.from_grid(canvas, random_state=0).save(tmp_path / "canvas")
    shapes = []
    fill = segmentation.regions.fill_enclosed

    def recorded(labels, *args, **kwargs):
        shapes.append(labels.shape)
        return fill(labels, *args, **kwargs)

    monkeypatch.setattr(segmentation.regions, "fill_enclosed", recorded)
    topo = TopoMap.load(tmp_path / "canvas")
    assert shapes == [topo.regions.known_part().grid.shape]
    assert shapes[0][0] < 0.6 * canvas.shape[0] and shapes[0][1] < 0.5 * canvas.shape[1]
    graph = read_graphml(tmp_path / "canvas" / "graph.graphml")
    assert isinstance(graph, nx.Graph)
    moved = affinity.translate(graph.nodes[1]["polygon"], 2.0, 0.0)
    graph.nodes[1]["polygon"] = moved
    write_graphml(graph, tmp_path / "canvas" / "graph.graphml", overwrite=True)
    with pytest.raises(ExportFormatError, match="region 1 field 'polygon'"):
        TopoMap.load(tmp_path / "canvas")


@pytest.mark.parametrize(
    ("left", "top", "right", "bottom"), [(1, 0, 0, 0), (0, 1, 0, 0), (1, 1, 0, 0), (7, 13, 40, 3)]
)
def test_a_real_slam_map_in_another_image_gives_the_same_regions(
    data_dir, left, top, right, bottom
):
    """ROSE²'s map9 (a gmapping map with its wall lines broken by doors and rays) one cell
    over or padded otherwise, under the canvas margin: the wall lines, and so the regions,
    are the same (the Hough transform runs on the box round the walls)."""
    from topomap.cli.evaluate import floor_plans

    (plan,) = [p for p in floor_plans(data_dir / "rose2_partial") if p.name == "map9"]
    grid = plan.grid()
    pipeline = MapSegmenter(SpectralSegmenter(random_state=0))
    found = pipeline.segment(grid, random_state=0).regions.labels
    moved = pipeline.segment(grid.padded(left, top, right, bottom), random_state=0)
    height, width = grid.shape
    np.testing.assert_array_equal(
        moved.regions.labels[top : top + height, left : left + width], found
    )
    assert len(np.unique(found)) > 10
