"""The prepared door graph saved to a file: read back it plans what it planned; a file made
for another map, other regions, another robot or another version is refused, never used."""

import numpy as np
import pytest

from maps.sim.floorplan import generate_floor_plan
from planners.benchmark import far_queries
from planners.errors import DoorGraphFileError, StaleDoorGraphError
from planners.hierarchical import HierarchicalPlanner
from planners.prepared import read_prepared, write_prepared
from planners.workspace import Workspace
from topomap.topomap import TopoMap


@pytest.fixture(scope="module")
def office():
    """A generated office, its regions, and its planner prepared and written to a file."""
    topo = TopoMap.from_grid(generate_floor_plan("office", random_state=4).grid, random_state=0)
    planner = topo.planner(0.2)
    return topo, planner, planner.prepared()


def test_a_door_graph_read_back_plans_the_same_paths(office, tmp_path):
    topo, planner, prepared = office
    path = write_prepared(prepared, tmp_path / "door_graph.npz")
    space = Workspace(topo.grid, 0.2)
    again = HierarchicalPlanner(
        space, topo.regions.labels, topo.graph, prepared=read_prepared(path, space)
    )
    assert again.restored and not planner.restored
    assert len(again.doors) == len(planner.doors) and again.region_of == planner.region_of
    for start, goal in far_queries(planner.space, 8, random_state=1):
        expected, found = planner.plan(start, goal), again.plan(start, goal)
        assert np.array_equal(found.waypoints, expected.waypoints)
        assert found.regions == expected.regions
    # closing a door works on the graph read back as on the one built
    a, b = next(iter(topo.graph.edges))
    again.close_door(a, b)
    assert again.door_matrix().nnz < planner.door_matrix().nnz


def test_a_door_graph_for_another_robot_is_refused(office, tmp_path):
    topo, _, prepared = office
    path = write_prepared(prepared, tmp_path / "door_graph.npz")
    with pytest.raises(StaleDoorGraphError, match=r"robot radius of 0\.2 m, not 0\.3 m"):
        read_prepared(path, Workspace(topo.grid, 0.3))
    smaller = type(topo.grid)(topo.grid.cells[1:], topo.grid.resolution, topo.grid.origin)
    with pytest.raises(StaleDoorGraphError, match="another map"):
        read_prepared(path, Workspace(smaller, 0.2))


def test_a_door_graph_for_other_regions_or_another_map_is_refused(office):
    topo, _, prepared = office
    space = Workspace(topo.grid, 0.2)
    labels = topo.regions.labels.copy()
    rows, cols = np.nonzero(labels)
    labels[rows[0], cols[0]] = labels.max() + 1  # one cell changes region
    with pytest.raises(StaleDoorGraphError, match="another map or other regions"):
        HierarchicalPlanner(space, labels, topo.graph, prepared=prepared)
    cells = topo.grid.cells.copy()
    cells[rows[-1], cols[-1]] = 100  # one more occupied cell
    other = Workspace(type(topo.grid)(cells, topo.grid.resolution, topo.grid.origin), 0.2)
    with pytest.raises(StaleDoorGraphError, match="another map"):
        HierarchicalPlanner(other, topo.regions.labels, topo.graph, prepared=prepared)


def test_damaged_foreign_and_newer_files_are_typed_errors(office, tmp_path):
    topo, _, prepared = office
    space = Workspace(topo.grid, 0.2)
    good = write_prepared(prepared, tmp_path / "good.npz")
    cut = tmp_path / "cut.npz"
    cut.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    text = tmp_path / "text.npz"
    text.write_text("not a door graph")
    for bad in (cut, text):
        with pytest.raises(DoorGraphFileError, match="not a door graph file"):
            read_prepared(bad, space)
    with np.load(good) as found:
        arrays = {name: found[name] for name in found.files}
    newer = tmp_path / "newer.npz"
    np.savez(newer, **{**arrays, "version": np.array(99)})
    with pytest.raises(DoorGraphFileError, match="version 99"):
        read_prepared(newer, space)
    short = tmp_path / "short.npz"
    np.savez(short, **{**arrays, "corners_sizes": arrays["corners_sizes"][:-1]})
    with pytest.raises(DoorGraphFileError, match="damaged"):
        read_prepared(short, space)
    with pytest.raises(FileNotFoundError):
        read_prepared(tmp_path / "missing.npz", space)


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("labels", 10**6),
        ("labels", 0),
        ("sites", np.nan),
        ("door_geometry", np.nan),
        ("indptr", 1000),
    ],
)
def test_an_edited_file_is_refused_as_damaged(office, tmp_path, name, value):
    topo, _, prepared = office
    space = Workspace(topo.grid, 0.2)
    with np.load(write_prepared(prepared, tmp_path / "good.npz")) as found:
        arrays = {key: found[key] for key in found.files}
    edited = arrays[name].astype(np.float64 if np.isnan(value) else arrays[name].dtype)
    edited[...] = value
    np.savez_compressed(tmp_path / "edited.npz", **{**arrays, name: edited})
    with pytest.raises(DoorGraphFileError, match="do not match their checksum"):
        read_prepared(tmp_path / "edited.npz", space)


def test_writing_never_overwrites_without_asking(office, tmp_path):
    from maps.errors import OutputExistsError

    _, _, prepared = office
    path = write_prepared(prepared, tmp_path / "door_graph.npz")
    with pytest.raises(OutputExistsError):
        write_prepared(prepared, path)
    assert write_prepared(prepared, path, overwrite=True) == path
    assert [p.name for p in tmp_path.iterdir()] == ["door_graph.npz"]  # no temporary left
