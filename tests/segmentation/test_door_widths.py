"""Doors measured by the free space they leave: an opening's clear width is the widest disc
that crosses it, and the region graph keeps only doors the robot fits through."""

import json

import numpy as np
import pytest

from maps.grid import OCCUPIED, OccupancyGrid
from planners.errors import NoPathError
from segmentation.export import read_node_link, write_node_link
from segmentation.graph import region_graph
from segmentation.regions import Regions
from topomap.topomap import TopoMap


def _rooms(doors_cells: list[int], resolution: float = 0.05) -> tuple[OccupancyGrid, np.ndarray]:
    """Two 4 x 4 m rooms, a 0.1 m wall between them with openings of the given widths (in
    cells, 5 cells of wall between two), labelled 1 (left) and 2 (right)."""
    size, wall = round(4.0 / resolution), round(0.1 / resolution)
    cells = np.zeros((size, 2 * size + wall), np.int8)
    cells[:, size : size + wall] = OCCUPIED
    top = 5
    for width in doors_cells:
        cells[top : top + width, size : size + wall] = 0
        top += width + 5
    labels = np.ones(cells.shape, np.int32)
    labels[:, size + wall // 2 :] = 2
    labels[cells == OCCUPIED] = 0
    return OccupancyGrid(cells, resolution), labels


def test_the_clear_width_is_the_free_space_across_the_opening():
    grid, labels = _rooms([1, 5, 19, 20])  # 5 cm, 25 cm, 95 cm and 1 m openings
    doors = region_graph(Regions(grid, labels)).edges[1, 2]["doors"]
    widths = sorted(d.clear_width for d in doors)
    # discs centred on cells: an even number of cells across loses one
    assert widths == pytest.approx([0.05, 0.25, 0.95, 0.95], abs=1e-6)
    # the rule of the planner's inflation: a disc of radius r crosses when 2 r is less
    for door in doors:
        inflated = grid.inflate(door.clear_width / 2 - 0.01).free
        row, col = grid.world_to_cell(*door.centre)
        assert inflated[row - 2 : row + 3, col - 2 : col + 3].any()


def test_gaps_no_robot_fits_through_are_no_doors():
    grid, labels = _rooms([1, 2, 3])  # gaps of 5-15 cm, as thin rays leave in real maps
    regions = Regions(grid, labels)
    assert region_graph(regions).has_edge(1, 2)  # every gap a free cell pair crosses
    assert not region_graph(regions, min_width=0.4).has_edge(1, 2)
    grid, labels = _rooms([1, 19])
    (door,) = region_graph(Regions(grid, labels), min_width=0.4).edges[1, 2]["doors"]
    assert door.clear_width == pytest.approx(0.95, abs=1e-6)


def test_a_map_segmented_for_a_robot_keeps_the_doors_it_fits_through(tmp_path):
    grid, _ = _rooms([2, 18])
    topo = TopoMap.from_grid(grid, random_state=0, robot_radius=0.2)
    doors = [d for _, _, found in topo.graph.edges(data="doors") for d in found]
    assert doors and min(d.passable for d in doors) > 0.4
    # every door of the graph is one the planner for that robot crosses, and no other
    planner = topo.planner(0.2)
    crossed = {
        tuple(sorted((planner.region_of[d.a], planner.region_of[d.b]))) for d in planner.doors
    }
    assert {tuple(sorted(e)) for e in topo.graph.edges} == {p for p in crossed if p[0] != p[1]}


def test_route_honours_the_robot_width_and_closed_doors():
    # rooms 1 | 2 over 3 | 4: 1-2 through 0.5 m, 1-3 and 4-2 through 1.5 m, 3-4 through 0.75 m
    cells = np.zeros((60, 120), np.int8)
    cells[:, 59:61] = cells[29:31, :] = OCCUPIED
    cells[5:15, 59:61] = 0
    cells[29:31, 20:50] = cells[29:31, 70:100] = 0
    cells[40:55, 59:61] = 0
    grid = OccupancyGrid(cells, 0.05)
    labels = np.zeros(cells.shape, np.int32)
    labels[:30, :60], labels[:30, 60:], labels[30:, :60], labels[30:, 60:] = 1, 2, 3, 4
    labels[cells == OCCUPIED] = 0
    regions = Regions(grid, labels)
    topo = TopoMap(grid, regions, region_graph(regions))
    assert topo.route(1, 2, robot_radius=0.2).regions == (1, 2)
    wide = topo.route(1, 2, robot_radius=0.3)  # too wide for the 0.5 m door
    assert wide.regions == (1, 3, 4, 2) and min(d.passable for d in wide.doors) > 0.6
    with pytest.raises(NoPathError, match="open doors"):
        topo.route(1, 2, robot_radius=0.3, closed=[(3, 1)])
    with pytest.raises(NoPathError):
        topo.route(1, 2, robot_radius=0.4)  # wider than the 0.75 m door between 3 and 4


def test_clear_widths_read_back_and_older_files_read_as_not_measured(tmp_path):
    grid, labels = _rooms([5, 19])
    graph = region_graph(Regions(grid, labels))
    path = write_node_link(graph, tmp_path / "graph.json")
    assert read_node_link(path).edges[1, 2]["doors"] == graph.edges[1, 2]["doors"]
    # doors written before the clear width was measured: seven numbers each
    saved = json.loads(path.read_text())
    (edge,) = saved["edges"]
    edge["doors"] = json.dumps([door[:7] for door in json.loads(edge["doors"])])
    path.write_text(json.dumps(saved))
    older = read_node_link(path).edges[1, 2]["doors"]
    assert [d.width for d in older] == [d.width for d in graph.edges[1, 2]["doors"]]
    assert {d.clear_width for d in older} == {float("inf")}
