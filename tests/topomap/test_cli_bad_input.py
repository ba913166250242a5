"""Bad input at the command line and in saved folders (issue 24): exit 2 and one located
line for bad input, 130 and one line for Ctrl-C; outputs checked before any work, written
under temporary names, never over a user's file without --force; a changed or half-written
saved folder is refused."""

from __future__ import annotations

import dataclasses
import importlib
import itertools
import json
import math
import re
from pathlib import Path

import cv2
import networkx as nx
import numpy as np
import pytest
import shapely
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from shapely import affinity

from maps.errors import MapFileNotFoundError, MapFormatError, OutputExistsError
from maps.grid import OccupancyGrid
from maps.sim.floorplan import generate_floor_plan
from segmentation.errors import ExportFormatError
from segmentation.export import read_graphml, write_graphml
from segmentation.regions import Regions
from topomap import saving
from topomap.cli.batch import BatchOptions, process, scheduler_address
from topomap.cli.inputs import Job, find_inputs
from topomap.cli.main import main
from topomap.errors import LabelError, SchedulerError
from topomap.topomap import TopoMap


def _error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("topomap: error:") or "error: argument" in err[0]
    return err[0]


@pytest.fixture(scope="module")
def plan_map(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("plan")
    generate_floor_plan("flat", random_state=0).grid.save(folder / "map.yaml")
    return folder / "map.yaml"


@pytest.fixture(scope="module")
def saved(tmp_path_factory, plan_map) -> Path:
    out = tmp_path_factory.mktemp("saved") / "topo"
    assert main(["-q", "segment", str(plan_map), "--out", str(out)]) == 0
    return out


def _copy(saved: Path, to: Path) -> Path:
    import shutil

    return Path(shutil.copytree(saved, to / "copy"))


# ---------------------------------------------------------------- numbers out of range
@pytest.mark.parametrize(
    ("argv", "shown"),
    [
        (["segment", "MAP", "--robot-radius", "1000"], "--robot-radius"),
        (["segment", "MAP", "--robot-radius", "nan"], "--robot-radius"),
        (["segment", "MAP", "--clutter-size", "-1"], "--clutter-size"),
        (["map", "LOG", "--max-range", "0"], "--max-range"),
        (["map", "LOG", "--max-range", "nan"], "--max-range"),
        (["map", "LOG", "--resolution", "0.0001"], "--resolution"),
        (["generate", "--resolution", "1e300"], "--resolution"),
        (["generate", "--seed", "-1"], "--seed"),
        (["generate", "--furniture", "1000"], "--furniture"),
        (["demo", "--seed", "-1"], "--seed"),
        (["demo", "--jobs", "0"], "--jobs"),
        (["segment", "MAP", "--jobs", "0"], "--jobs"),
        (["view", "REGIONS", "--max-paths", "-1"], "--max-paths"),
        (["plan", "MAP", "--start", "1,1", "--goal", "2", "--robot-radius", "1000"], "radius"),
        (["bench", "sim", "--scans", "-5"], "--scans"),
        (["bench", "plan", "--queries", "10000000000"], "--queries"),
        (["bench", "plan", "--budget", "nan"], "--budget"),
        (["bench", "batch", "--maps", "100000000"], "--maps"),
        (["bench", "online", "--seed-fraction", "nan"], "--seed-fraction"),
        (["bench", "online", "--offline-up-to", "-5"], "--offline-up-to"),
        (["eval", "runs", "--seeds", "100000000"], "--seeds"),
        (["segment", "MAP", "--map-topic", "/map", "--stamp", "nan"], "--stamp"),
        (["batch", "MAP", "--stamp", "inf"], "--stamp"),
    ],
)
def test_numbers_out_of_range_are_usage_errors(tmp_path, capsys, argv, shown):
    argv = [str(tmp_path / "x") if a in ("MAP", "LOG", "REGIONS") else a for a in argv]
    assert main([*argv, "--out", str(tmp_path / "out")] if argv[0] != "plan" else argv) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert shown in line and "must" in line
    assert not (tmp_path / "out").exists()


def test_an_image_header_too_large_is_one_line(tmp_path, capsys):
    (tmp_path / "img.pgm").write_bytes(b"P5\n2000000000 2000000000\n255\n\x00")
    (tmp_path / "map.yaml").write_text(
        "image: img.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    assert main(["segment", str(tmp_path / "map.yaml"), "--out", str(tmp_path / "o")]) == 2
    line = _error_line(capsys)
    assert "img.pgm" in line and "2000000000 x 2000000000 cells" in line
    comment = b"#" + b"x" * (2 << 20) + b"\n"  # a header comment over the bytes read of it
    (tmp_path / "img.pgm").write_bytes(b"P5\n" + comment + b"80 50\n255\n" + bytes(4000))
    assert main(["segment", str(tmp_path / "map.yaml"), "--out", str(tmp_path / "o")]) == 2
    line = _error_line(capsys)
    assert "img.pgm" in line and "header runs past 1048576 bytes before its width" in line


def test_a_generated_building_too_large_for_memory_is_refused_before_it_is_drawn(tmp_path, capsys):
    argv = ["generate", "--size", "campus", "--resolution", "0.001", "--out", str(tmp_path / "o")]
    assert main(["-q", *argv]) == 2
    assert "building of 301000 x 201000 cells" in _error_line(capsys)
    assert not (tmp_path / "o").exists()


def test_demo_into_a_file_and_the_hand_labels_from_any_folder(tmp_path, capsys, monkeypatch):
    from topomap.cli.main import build_parser

    mine = tmp_path / "mine.txt"
    mine.write_text("mine")
    assert main(["-q", "demo", "--out", str(mine)]) == 2
    assert "mine.txt is a file, not a folder" in _error_line(capsys)
    monkeypatch.chdir(tmp_path)  # not the repository
    args = build_parser().parse_args(["eval", "corridors", "data"])
    assert (Path(args.hand_labels) / "carmen.json").is_file()


def test_points_west_and_south_of_the_origin_are_values_not_options():
    from topomap.cli.main import build_parser

    parser = build_parser()
    args = parser.parse_args(["plan", "m.yaml", "--start", "-55.6,4.5", "--goal", "-.5,-18"])
    assert args.start == (-55.6, 4.5) and args.goal == (-0.5, -18.0)
    args = parser.parse_args(["export", "m.yaml", "--path", "-1,2", "-3.5,-4"])
    assert args.path == [[(-1.0, 2.0), (-3.5, -4.0)]]


# ---------------------------------------------------------------- outputs
def test_out_that_is_a_file_or_under_a_file(tmp_path, capsys, plan_map):
    mine = tmp_path / "mine.txt"
    mine.write_text("mine")
    for out in (mine, mine / "sub"):
        assert main(["segment", str(plan_map), "--out", str(out)]) == 2
        assert "mine.txt is a file, not a folder" in _error_line(capsys)
    assert mine.read_text() == "mine"


def test_a_folder_in_the_place_of_an_output_file(tmp_path, capsys):
    (tmp_path / "map.pgm").mkdir()
    assert main(["generate", "--size", "flat", "--out", str(tmp_path)]) == 2
    assert "map.pgm is a folder" in _error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.pgm"]


def test_a_missing_parent_folder_is_made(tmp_path):
    out = tmp_path / "a" / "b" / "c"
    assert main(["-q", "generate", "--size", "flat", "--out", str(out)]) == 0
    assert (out / "map.yaml").is_file()
    assert not [p for p in (tmp_path / "a" / "b").iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("case", ["parent is a file", "parent refuses a folder"])
def test_view_refuses_an_output_folder_that_cannot_be_made_before_any_work(
    tmp_path, capsys, saved, monkeypatch, case
):
    parent = tmp_path / "parent"
    if case == "parent is a file":
        parent.write_text("mine")
    else:  # as the system refuses it (/proc, a read-only disk; root's chmod cannot show it)
        parent.mkdir()
        real = Path.mkdir

        def mkdir(self, *args, **kwargs):
            if parent in self.parents:
                raise PermissionError(13, "Permission denied", str(self))
            return real(self, *args, **kwargs)

        monkeypatch.setattr(Path, "mkdir", mkdir)
    loaded, load = [], TopoMap.load
    monkeypatch.setattr(TopoMap, "load", lambda folder: loaded.append(folder) or load(folder))
    out = parent / "new" / "map.html"
    assert main(["-q", "view", str(saved), "--out", str(out)]) == 2
    assert str(parent / "new") in _error_line(capsys)
    assert loaded == []  # refused before the regions were read
    assert not (parent / "new").exists()


def _interrupt(*_args, **_kwargs):
    raise KeyboardInterrupt


def test_an_interrupted_segment_leaves_no_file(tmp_path, capsys, plan_map, monkeypatch):
    monkeypatch.setattr("topomap.cli.drawing.draw_regions", _interrupt)
    out = tmp_path / "out"
    assert main(["-q", "segment", str(plan_map), "--out", str(out)]) == 130
    assert capsys.readouterr().err.strip() == (
        "topomap: interrupted; no output was left half-written"
    )
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_an_interrupted_forced_segment_keeps_the_old_folder(tmp_path, saved, monkeypatch, plan_map):
    folder = _copy(saved, tmp_path)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    monkeypatch.setattr("topomap.cli.drawing.draw_regions", _interrupt)
    argv = [
        "-q",
        "segment",
        str(plan_map),
        "--out",
        str(folder),
        "--force",
        "--robot-radius",
        "0.3",
    ]
    assert main(argv) == 130
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    TopoMap.load(folder)


@pytest.mark.parametrize("source", [["MAP"], ["--scans", "LOG"], ["LOG"]])
def test_a_stamp_for_no_bag_map_is_a_usage_error(tmp_path, capsys, plan_map, source):
    log = tmp_path / "run.log"
    log.write_text("")
    argv = [str(plan_map) if a == "MAP" else str(log) if a == "LOG" else a for a in source]
    assert main(["segment", *argv, "--stamp", "12.5", "--out", str(tmp_path / "out")]) == 2
    assert "--stamp goes with a bag's map (--map-topic), not" in _error_line(capsys)
    assert not (tmp_path / "out").exists()


def test_plan_draw_is_never_overwritten_without_force(tmp_path, capsys, plan_map):
    drawing = tmp_path / "path.png"
    drawing.write_bytes(b"mine")
    argv = ["plan", str(plan_map), "--start", "1,1", "--goal", "2,2", "--draw", str(drawing)]
    assert main(argv) == 2
    assert "path.png exists; pass --force" in _error_line(capsys)
    assert drawing.read_bytes() == b"mine"


@pytest.mark.parametrize("name", ["path.txt", "path"])
def test_plan_draw_that_is_no_png_is_refused_before_planning(tmp_path, capsys, plan_map, name):
    argv = [
        "plan",
        str(plan_map),
        "--start",
        "1,1",
        "--goal",
        "2,2",
        "--draw",
        str(tmp_path / name),
    ]
    assert main(argv) == 2
    assert f"--draw '{tmp_path / name}': the picture is a PNG" in _error_line(capsys)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("out", ["", " "])
def test_an_empty_output_path_is_a_usage_error(tmp_path, capsys, plan_map, monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    assert main(["segment", str(plan_map), "--out", out]) == 2
    assert "--out: an output path cannot be empty" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["map", "segment", "batch"])
def test_an_empty_fixed_frame_is_a_usage_error(tmp_path, capsys, command):
    argv = [command, str(tmp_path / "run.bag"), "--fixed-frame", ""]
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    assert "--fixed-frame: frame name '' is empty" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_export_refuses_a_folder_as_its_file(tmp_path, capsys, plan_map):
    (tmp_path / "route.geojson").mkdir()
    argv = ["export", str(plan_map), "--nav2-route", str(tmp_path / "route.geojson")]
    assert main(argv) == 2
    assert "route.geojson is a folder" in _error_line(capsys)


def test_export_writes_nothing_when_a_path_fails_or_two_outputs_collide(tmp_path, capsys, plan_map):
    route, bag = tmp_path / "route.geojson", tmp_path / "bag"
    argv = ["-q", "export", str(plan_map), "--nav2-route", str(route), "--rosbag", str(bag)]
    assert main([*argv, "--path", "1,1", "999,999"]) == 2
    assert "outside the map" in _error_line(capsys)
    assert not route.exists() and not bag.exists()
    same = [
        "-q",
        "export",
        str(plan_map),
        "--nav2-route",
        str(route),
        "--planner-graph",
        str(route),
    ]
    assert main(same) == 2
    assert "must be different files" in _error_line(capsys)
    assert not route.exists()


@pytest.mark.parametrize(
    ("argv", "shown"),
    [
        (
            ["export", "MAP", "--nav2-route", "OUT", "--storage", "sqlite3"],
            "--storage is the bag's",
        ),
        (["plan", "MAP", "--start", "1", "--goal", "2", "--compare"], "--compare draws a flat"),
        (
            ["segment", "--scans", "MAP", "--online", "--jobs", "2", "--out", "OUT"],
            "--jobs partitions a large map's blocks",
        ),
        (["segment", "MAP", "--distance", "0.3", "--out", "OUT"], "--distance spaces a log's"),
        (
            ["segment", "--scans", "LOG", "--scan-topic", "/scan", "--out", "OUT"],
            "--scan-topic name a bag's topics; ",
        ),
        (
            ["map", "LOG", "--scan-topic", "/scan", "--pose-topic", "/odom", "--out", "OUT"],
            "--scan-topic and --pose-topic name a bag's topics; ",
        ),
    ],
)
def test_an_option_that_would_do_nothing_is_a_usage_error(tmp_path, capsys, saved, argv, shown):
    out, log = tmp_path / "route.geojson", tmp_path / "run.log"
    log.write_text("FLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 0 0 robot 0.0\n")
    names = {"MAP": str(saved / "map.yaml"), "OUT": str(out), "LOG": str(log)}
    argv = [names.get(a, a) for a in argv]
    assert main(["-q", *argv]) == 2
    assert shown in _error_line(capsys)
    assert not out.exists()


def test_export_refuses_a_route_graph_a_robot_fits_nowhere_in(tmp_path, capsys, saved):
    route, fine = tmp_path / "route.geojson", tmp_path / "fine.geojson"
    argv = ["-q", "export", str(saved / "map.yaml"), "--regions", str(saved)]
    argv += ["--nav2-route", str(route), "--planner-graph", str(fine), "--robot-radius", "9"]
    assert main(argv) == 2
    assert "has room for a robot of radius 9 m, the route graph would be empty" in _error_line(
        capsys
    )
    assert not route.exists() and not fine.exists()


# ---------------------------------------------------------------- saved folders
def _graph_edit(folder: Path, old: str, new: str) -> None:
    path = folder / "graph.graphml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def test_doors_nested_past_the_recursion_limit_are_a_format_error(tmp_path, saved):
    import networkx as nx

    graph = nx.read_graphml(saved / "graph.graphml")
    doors = next(iter(graph.edges(data=True)))[2]["doors"]
    folder = _copy(saved, tmp_path / "nested")
    _graph_edit(folder, doors, "[" * 5000 + "]" * 5000)
    with pytest.raises(ExportFormatError, match="not a topomap region graph: RecursionError"):
        TopoMap.load(folder)


def test_a_changed_saved_folder_is_refused(tmp_path, saved):
    import networkx as nx

    graph = nx.read_graphml(saved / "graph.graphml")
    first = next(iter(graph.nodes))
    area = graph.nodes[first]["area_m2"]
    cases = {
        "area": (f">{area}<", f">{area * 2}<", "area_m2"),
        "id": (f'<node id="{first}">', '<node id="999">', "nodes|region graph|names region"),
        "resolution": ('<data key="d0">0.05</data>', '<data key="d0">0.1</data>', "resolution"),
    }
    for name, (old, new, shown) in cases.items():
        folder = _copy(saved, tmp_path / name)
        try:
            _graph_edit(folder, old, new)
        except AssertionError:
            continue  # the key numbering differs: the digest still refuses below
        with pytest.raises(ExportFormatError, match=shown):
            TopoMap.load(folder)


def test_export_and_view_never_write_over_their_inputs_even_with_force(tmp_path, capsys, saved):
    folder = _copy(saved, tmp_path / "inputs")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    map_yaml = str(folder / "map.yaml")
    for argv in (
        ["export", map_yaml, "--regions", str(folder), "--nav2-route", str(folder / "graph.json")],
        ["export", map_yaml, "--regions", str(folder), "--rosbag", str(folder)],
        ["export", map_yaml, "--regions", str(folder), "--nav2-route", map_yaml],
        ["view", str(folder), "--out", str(folder / "graph.json")],
    ):
        assert main(["-q", *argv, "--force"]) == 2
        assert "would be written over the input" in _error_line(capsys)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert main(["-q", "export", map_yaml, "--rosbag", ""]) == 2
    assert "an output path cannot be empty" in capsys.readouterr().err


def test_plan_and_export_never_write_over_the_map_image_or_regions_even_with_force(
    tmp_path, capsys, saved
):
    folder = _copy(saved, tmp_path / "inputs")
    image = tmp_path / "lab map.png"  # a map beside its PNG image, as map_server's are
    cv2.imwrite(str(image), cv2.imread(str(folder / "map.pgm"), cv2.IMREAD_UNCHANGED))
    map_yaml = tmp_path / "lab.yaml"
    map_yaml.write_text((folder / "map.yaml").read_text().replace("map.pgm", "'lab map.png'"))
    before = {p: p.read_bytes() for p in (image, *folder.iterdir())}
    ends = ["--start", "1", "--goal", "2"]
    regions = ["--regions", str(folder)]
    for argv in (
        ["plan", str(map_yaml), *ends, "--draw", str(image)],
        ["plan", str(map_yaml), *regions, *ends, "--draw", str(folder / "regions.png")],
        ["export", str(map_yaml), "--nav2-route", str(image)],
    ):
        assert main(["-q", *argv, "--force"]) == 2
        assert "would be written over the input" in _error_line(capsys)
    assert {p: p.read_bytes() for p in (image, *folder.iterdir())} == before


@pytest.mark.parametrize("files", [None, {}, "drop graph.json"])
def test_a_folder_whose_digests_are_gone_is_refused(tmp_path, saved, files):
    folder = _copy(saved, tmp_path / "digests")
    about = json.loads((folder / "topomap.json").read_text())
    if files is None:
        del about["files"]
    elif files == {}:
        about["files"] = {}
    else:
        del about["files"]["graph.json"]
    (folder / "topomap.json").write_text(json.dumps(about))
    with pytest.raises(ExportFormatError, match="field 'files' does not list the digests of"):
        TopoMap.load(folder)


def test_a_changed_map_yaml_or_label_image_is_refused(tmp_path, saved):
    folder = _copy(saved, tmp_path / "yaml")
    doc = yaml.safe_load((folder / "map.yaml").read_text())
    doc["origin"][0] += 1.0
    (folder / "map.yaml").write_text(yaml.safe_dump(doc))
    with pytest.raises(ExportFormatError, match="origin"):
        TopoMap.load(folder)
    folder = _copy(saved, tmp_path / "png")
    (folder / "regions.png").write_bytes((saved / "map.pgm").read_bytes())
    with pytest.raises((ExportFormatError, MapFormatError)):
        TopoMap.load(folder)


def test_a_half_written_folder_is_refused(tmp_path, saved):
    folder = _copy(saved, tmp_path / "half")
    (folder / "regions.geojson").write_text("{}")  # another run's file
    with pytest.raises(ExportFormatError, match=r"regions\.geojson: changed"):
        TopoMap.load(folder)
    (folder / "regions.geojson").unlink()
    with pytest.raises(MapFileNotFoundError, match=r"regions\.geojson"):
        TopoMap.load(folder)
    (folder / "topomap.json").unlink()
    with pytest.raises(MapFileNotFoundError, match=r"topomap\.json"):
        TopoMap.load(folder)


def test_a_digit_name_never_shadows_a_region_id(tmp_path, saved):
    topo = TopoMap.load(saved)
    other = sorted(topo.graph.nodes)[-1]
    with pytest.raises(LabelError, match="only digits"):
        topo.rename(other, "1")
    assert topo.region("1") == 1
    folder = _copy(saved, tmp_path / "digits")
    name = topo.graph.nodes[other]["name"]
    text = (folder / "graph.graphml").read_text().replace(f">{name}<", ">1<")
    (folder / "graph.graphml").write_text(text)
    with pytest.raises(ExportFormatError, match="only digits"):
        TopoMap.load(folder)


def _redigest(folder: Path) -> Path:
    """``folder`` with the digest of its changed graph.graphml written into topomap.json as
    TopoMap.save writes it: only the checks of the graph can refuse it."""
    about = json.loads((folder / "topomap.json").read_text())
    about["files"]["graph.graphml"] = saving._digest(folder / "graph.graphml")
    (folder / "topomap.json").write_text(json.dumps(about, indent=2))
    return folder


def _non_neighbours(graph: nx.Graph) -> tuple[int, int]:
    """Two regions whose outlines do not even touch (so their cells do not either)."""
    return next(
        (a, b)
        for a, b in itertools.combinations(sorted(graph.nodes), 2)
        if not graph.nodes[a]["polygon"].intersects(graph.nodes[b]["polygon"])
    )


def _swap_outlines(graph: nx.Graph) -> None:
    one, two = graph.nodes[1], graph.nodes[2]
    one["polygon"], two["polygon"] = two["polygon"], one["polygon"]


def _first_door(graph: nx.Graph, **numbers: object) -> None:
    data = graph.edges[min(graph.edges)]
    data["doors"] = (dataclasses.replace(data["doors"][0], **numbers), *data["doors"][1:])


def _nan_outline() -> shapely.Polygon:
    with np.errstate(invalid="ignore"):  # shapely warns of NaN
        return shapely.Polygon([(0, 0), (math.nan, 1), (1, 1)])


# a damage to the graph (the digests written again) and what the refusal says
_DAMAGES = {
    "another region's outline": (
        _swap_outlines,
        r"region 1 field 'polygon' holds 0% of the region's \d+ cells in regions\.png and \d+ "
        r"cells that are not its own \(most of them region 2's\)",
    ),
    "an outline moved half a metre": (
        lambda g: g.nodes[3].update(polygon=affinity.translate(g.nodes[3]["polygon"], 0.5, 0.5)),
        r"region 3 field 'polygon' holds \d+% of the region's \d+ cells in regions\.png and ",
    ),
    "an outline of NaN": (
        lambda g: g.nodes[1].update(polygon=_nan_outline()),
        "region 1 field 'polygon' has coordinates that are not finite numbers",
    ),
    "an outline of inf": (
        lambda g: g.nodes[1].update(polygon=shapely.box(0, 0, math.inf, 1)),
        "region 1 field 'polygon' has coordinates that are not finite numbers",
    ),
    "an outline off the map": (
        lambda g: g.nodes[1].update(polygon=affinity.translate(g.nodes[1]["polygon"], 1e6)),
        r"region 1 field 'polygon' lies off the map: its bounds are \(100000",
    ),
    "a point for an outline": (
        lambda g: g.nodes[1].update(polygon=shapely.Point(1, 1)),
        r"region 1 field 'polygon' is 'POINT \(1 1\)', not the outline of cells",
    ),
    "a region's point of NaN": (
        lambda g: g.nodes[3].update(y=math.nan),
        "region 3 field 'y' must be a finite number, got nan",
    ),
    "an edge between regions that do not touch": (
        lambda g: g.add_edge(*_non_neighbours(g), **g.edges[min(g.edges)]),
        r"edge \((\d+), (\d+)\): regions \1 and \2 do not touch in regions\.png",
    ),
    "a door of NaN": (
        lambda g: _first_door(g, centre=(math.nan, 1.0)),
        r"edge \(\d+, \d+\) door 1's centre x must be a finite number, got nan",
    ),
    "a door of inf": (
        lambda g: _first_door(g, end=(1.0, -math.inf)),
        r"edge \(\d+, \d+\) door 1's end y must be a finite number, got -inf",
    ),
    "a door of negative width": (
        lambda g: _first_door(g, width=-0.5),
        r"edge \(\d+, \d+\) door 1's width must lie in \[0, inf\], got -0\.5",
    ),
    "an edge's width of inf": (
        lambda g: g.edges[min(g.edges)].update(width=math.inf),
        r"edge \(\d+, \d+\) field 'width' must be a finite number, got inf",
    ),
    "an edge without doors": (
        lambda g: g.edges[min(g.edges)].update(doors=()),
        r"edge \(\d+, \d+\) field 'doors' holds no door",
    ),
    "a name twice": (
        lambda g: g.nodes[2].update(name=g.nodes[1]["name"].upper()),
        r"region 2 field 'name' is '[A-Z0-9 ]+', the name of region 1 too",
    ),
    "a lost name": (
        lambda g: g.nodes[2].pop("name"),
        "region 2 has no field 'name', but the map is labelled",
    ),
    "an empty name": (
        lambda g: g.nodes[2].update(name=" "),
        r"region 2 field 'name' is ' ', not a name \(text, not blank\)",
    ),
}


@pytest.mark.parametrize("damage", _DAMAGES)
def test_a_graph_that_disagrees_with_its_labels_is_refused_even_with_its_digest(
    tmp_path, saved, damage
):
    edit, shown = _DAMAGES[damage]
    folder = _copy(saved, tmp_path)
    graph = read_graphml(folder / "graph.graphml")
    edit(graph)
    write_graphml(graph, folder / "graph.graphml", overwrite=True)
    with pytest.raises(ExportFormatError, match=rf"graph\.graphml: {shown}"):
        TopoMap.load(_redigest(folder))


def test_an_edge_to_a_region_the_file_lacks_is_refused_by_name(tmp_path, saved):
    folder = _copy(saved, tmp_path)
    text = (folder / "graph.graphml").read_text()
    source, target = re.search(r'<edge source="(\d+)" target="(\d+)"', text).groups()
    _graph_edit(folder, f'source="{source}" target="{target}"', f'source="{source}" target="99"')
    shown = rf"graph\.graphml: edge \({source}, 99\) names region 99, which the file does not hold"
    with pytest.raises(ExportFormatError, match=shown):
        TopoMap.load(_redigest(folder))


def test_outlines_simplified_by_a_cell_still_load(tmp_path, saved):
    folder = _copy(saved, tmp_path)
    graph = read_graphml(folder / "graph.graphml")
    outlines = dict(graph.nodes(data="polygon"))
    for _, data in graph.nodes(data=True):
        data["polygon"] = data["polygon"].simplify(graph.graph["resolution"])
    assert any(not graph.nodes[r]["polygon"].equals(outlines[r]) for r in graph)
    write_graphml(graph, folder / "graph.graphml", overwrite=True)
    assert TopoMap.load(_redigest(folder)).regions.ids == sorted(graph.nodes)


def test_a_map_never_labelled_loads_without_names(tmp_path, saved):
    folder = _copy(saved, tmp_path)
    graph = read_graphml(folder / "graph.graphml")
    for _, data in graph.nodes(data=True):
        del data["name"], data["label"]
    graph.nodes[2]["name"] = "kitchen"  # a name given on a map never labelled
    write_graphml(graph, folder / "graph.graphml", overwrite=True)
    topo = TopoMap.load(_redigest(folder))
    assert dict(topo.graph.nodes(data="name")) == {r: "kitchen" if r == 2 else None for r in graph}
    assert topo.region("Kitchen") == 2


@settings(max_examples=60, deadline=None)
@given(
    labels=arrays(
        np.int32, st.tuples(st.integers(2, 9), st.integers(2, 9)), elements=st.integers(0, 3)
    ),
    origin=st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-4, 4)),
)
def test_every_outline_a_region_has_holds_exactly_its_cells(labels, origin):
    # what load checks the outlines with: honest outlines, rotated maps too, are never refused
    regions = Regions(OccupancyGrid(np.zeros(labels.shape, np.int8), 0.05, origin), labels)
    for region, polygon in regions.polygons.items():
        parts = shapely.get_rings(shapely.get_parts(polygon))
        xy, ring = shapely.get_coordinates(parts, return_index=True)
        rows, cols = saving._lattice(regions.grid, xy)
        inside = saving._cells_inside(rows, cols, ring, labels.shape)
        assert np.array_equal(inside, regions.enclosing == region)
        assert saving._outline_problem(polygon, region, regions) is None


# ---------------------------------------------------------------- batch
def test_batch_inputs_differing_by_extension_get_their_own_folders(tmp_path):
    line = "FLASER 3 1 1 1 0 0 0 0 0 0 1 host 1\n"
    (tmp_path / "run.log").write_text(line)
    (tmp_path / "run.clf").write_text(line)
    (tmp_path / "run.gz").write_text(line)
    names = [job.name for job in find_inputs([str(tmp_path)])]
    assert len(set(names)) == 3


def test_a_deeply_nested_yaml_fails_alone_in_batch(tmp_path):
    (tmp_path / "deep.yaml").write_text("[" * 20_000 + "]" * 20_000)
    (jobs,) = find_inputs([str(tmp_path / "deep.yaml")])
    record = process(jobs, str(tmp_path / "out"), BatchOptions())
    assert record["status"] == "failed" and "nested too deeply" in record["error"]
    assert "deep.yaml" in record["error"]


def test_batch_refuses_a_foreign_index_and_a_bad_scheduler(tmp_path, capsys, plan_map):
    out = tmp_path / "out"
    out.mkdir()
    (out / "index.csv").write_text("my,own,table\n")
    assert main(["batch", str(plan_map), "--out", str(out)]) == 2
    assert "index.csv exists" in _error_line(capsys)
    assert (out / "index.csv").read_text() == "my,own,table\n"
    argv = ["batch", str(plan_map), "--out", str(tmp_path / "o2"), "--scheduler", "nonsense"]
    assert main(argv) == 2
    assert "--scheduler 'nonsense'" in _error_line(capsys)
    with pytest.raises(SchedulerError):
        scheduler_address("tcp://host:99999")
    assert scheduler_address("localhost:8786") == "tcp://localhost:8786"


def test_batch_job_errors_are_typed(tmp_path):
    job = Job(str(tmp_path / "missing.yaml"), "map", "missing")
    record = process(job, str(tmp_path / "out"), BatchOptions())
    assert record["status"] == "failed" and "MapFileNotFoundError" in record["error"]


# ---------------------------------------------------------------- messages
def test_ctrl_c_is_one_line(monkeypatch, capsys, tmp_path):
    module = importlib.import_module("topomap.cli.commands.generate")
    monkeypatch.setattr(module, "cmd_generate", _interrupt)
    assert main(["generate", "--out", str(tmp_path)]) == 130
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_yaml_and_empty_log_messages_are_one_located_line(tmp_path, capsys):
    (tmp_path / "map.yaml").write_text("image: a.pgm\nresolution: [0.1\n")
    assert main(["segment", str(tmp_path / "map.yaml"), "--out", str(tmp_path / "o")]) == 2
    assert "map.yaml, line 3" in _error_line(capsys)
    (tmp_path / "empty.log").write_text("")
    assert main(["-q", "map", str(tmp_path / "empty.log"), "--out", str(tmp_path / "o")]) == 2
    assert "empty.log" in _error_line(capsys)


def _bomb(levels: int) -> str:
    """A map YAML whose image is ``9 ** levels`` nested aliases (a few hundred bytes)."""
    names = "abcdefghijklmnopqrstuvwxyz"[: levels + 1]
    lines = [f"{names[0]}: &{names[0]} [x, x, x, x, x, x, x, x, x]"]
    for low, high in itertools.pairwise(names):
        lines.append(f"{high}: &{high} [" + ", ".join([f"*{low}"] * 9) + "]")
    return "\n".join([*lines, f"image: *{names[-1]}", "resolution: 0.1", "origin: [0, 0, 0]"])


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        (_bomb(12), "line 2: not valid YAML: aliases (*name) are not allowed"),
        ("negate: " + "1" * 5000 + "\nimage: a.pgm\n", "not valid YAML: Exceeds the limit"),
    ],
)
def test_a_yaml_bomb_or_a_huge_integer_is_one_line_at_once(tmp_path, capsys, text, shown):
    (tmp_path / "map.yaml").write_text(text)
    for argv in (
        ["segment", "--out", str(tmp_path / "o")],
        ["plan", "--start", "1,1", "--goal", "2,2"],
    ):
        assert main(["-q", argv[0], str(tmp_path / "map.yaml"), *argv[1:]]) == 2
        line = _error_line(capsys)
        assert "map.yaml" in line and shown in line
    assert not (tmp_path / "o").exists()


def test_json_in_topomap_json_is_data_only(tmp_path, saved):
    folder = _copy(saved, tmp_path / "files")
    about = json.loads((folder / "topomap.json").read_text())
    about["files"]["../../etc/passwd"] = "0"
    (folder / "topomap.json").write_text(json.dumps(about))
    with pytest.raises(ExportFormatError, match="not a saved file"):
        TopoMap.load(folder)


@pytest.mark.parametrize(
    ("text", "shown"),
    [
        ("[1, 2]", "a JSON list, not an object"),
        ("{", "not JSON"),
        ('{"format": "topomap", "seconds": [1]}', "a field is not as TopoMap.save writes it"),
    ],
)
def test_a_damaged_topomap_json_says_what_it_is(tmp_path, saved, text, shown):
    folder = _copy(saved, tmp_path / "damaged")
    (folder / "topomap.json").write_text(text)
    with pytest.raises(ExportFormatError, match=f"topomap.json: not a topomap.json file: {shown}"):
        TopoMap.load(folder)


def test_output_exists_error_is_a_file_exists_error():
    assert issubclass(OutputExistsError, FileExistsError)


def test_a_folder_of_a_newer_or_unknown_version_is_refused(tmp_path, saved):
    for version in (4, "3", 0, True):
        folder = _copy(saved, tmp_path / f"v{version}")
        about = json.loads((folder / "topomap.json").read_text())
        assert about["version"] == 3
        about["version"] = version
        (folder / "topomap.json").write_text(json.dumps(about))
        with pytest.raises(ExportFormatError, match=rf"field 'version' is {version!r}; .* 1 to 3"):
            TopoMap.load(folder)


@pytest.mark.parametrize(
    ("robot", "shown"),
    [
        (["--robot", "rectangle", "--turning-radius", "1"], "--turning-radius"),
        (["--robot", "rectangle", "--footprint", "0.9", "-1"], "footprint width"),
        (["--robot", "reeds-shepp", "--footprint", "0.9", "0.6"], "--turning-radius R"),
        (["--robot", "disc:0.3", "--footprint", "0.9", "0.6"], "--footprint"),
    ],
)
def test_footprint_options_that_do_not_fit_the_robot(capsys, plan_map, robot, shown):
    argv = ["plan", str(plan_map), "--start", "1,1,0", "--goal", "2", *robot]
    assert main(argv) == 2
    line = _error_line(capsys)
    assert shown in line and "unrecognized" not in line and line.startswith("topomap: error:")


def test_a_log_given_as_the_map_is_read_as_a_log(tmp_path, capsys):
    # `topomap segment run.log`: the keyframes of the log, as with --scans, not a map YAML
    (tmp_path / "run.log").write_text("FLASER 3 1 2\n")
    assert main(["-q", "segment", str(tmp_path / "run.log"), "--out", str(tmp_path / "o")]) == 2
    assert "run.log, line 1, field 'ranges'" in _error_line(capsys)


@pytest.mark.parametrize("command", ["map", "segment"])
def test_an_input_that_may_not_be_looked_at_is_one_line(tmp_path, capsys, monkeypatch, command):
    from tests.maps.test_bad_input import _denied

    source = tmp_path / "locked" / "run.log"
    monkeypatch.setattr(Path, "is_dir", _denied(Path.is_dir, source))
    assert main(["-q", command, str(source), "--out", str(tmp_path / "out")]) == 2
    assert _error_line(capsys).endswith("run.log: cannot be read (Permission denied)")
    assert not (tmp_path / "out").exists()


def test_sigterm_while_writing_is_one_line_status_143_and_leaves_nothing(
    tmp_path, capsys, monkeypatch
):
    import os
    import signal

    from tests.maps.test_bad_input import _flaser

    def terminated(path, *_args, **_kwargs):  # as `timeout` or a process manager stops it
        Path(path).write_bytes(b"half a picture")
        os.kill(os.getpid(), signal.SIGTERM)

    log = tmp_path / "run.log"
    log.write_text("".join(_flaser(3, [1.0, 2.0, 3.0], (x, 0.0, 0.0)) for x in (0.0, 1.0)))
    monkeypatch.setattr("topomap.cli.drawing.draw_map", terminated)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["-q", "map", str(log), "--out", str(tmp_path / "out")]) == 143
    assert capsys.readouterr().err.strip() == "topomap: terminated; no output was left half-written"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.log"]
    assert signal.getsignal(signal.SIGTERM) is before


def _eval_data(folder: Path, plan_map: Path, rooms: np.ndarray, anchors: str | None) -> Path:
    """An ipa-layout data folder: the plan, its people's rooms, and an anchors.csv."""
    folder.mkdir()
    grid = OccupancyGrid.load(plan_map)
    grid.save(folder / "m.yaml")
    cv2.imwrite(str(folder / "m_gt_labels.png"), rooms.astype(np.uint16))
    if anchors is not None:
        (folder / "anchors.csv").write_text(anchors)
    return folder


@pytest.mark.parametrize(
    "case, shown",
    [
        ("no map column", "line 2, field 'map': missing"),
        ("not a number", "field 'mcc': expected a number in [-100, 100], got 'high'"),
        ("not finite", "field 'mcc': expected a number in [-100, 100], got 'nan'"),
        ("a field too long for csv", "not a CSV table (field larger than field limit"),
        ("rooms the wrong size", "people's rooms are 10 x 10 cells"),
        ("no room", "no room drawn"),
        ("noise", "no room drawn of more than 100 pixels"),
        ("colour noise", "no room drawn of more than 100 pixels"),
    ],
)
def test_eval_segment_refuses_bad_truth_before_scoring(tmp_path, capsys, plan_map, case, shown):
    grid = OccupancyGrid.load(plan_map)
    rooms = np.where(grid.free, 1, 0)
    header = "map,furnished,method,recall_micro,precision_micro,mcc,runtime_s\n"
    anchors = header + "m,0,other,0.9,0.9,0.8,1\n"
    if case == "no map column":
        anchors = "furnished,method\n0,other\n"
    elif case == "not a number":
        anchors = header + "m,0,other,0.9,0.9,high,1\n"
    elif case == "not finite":
        anchors = header + "m,0,other,0.9,0.9,nan,1\n"
    elif case == "a field too long for csv":
        anchors = header + "m,0," + "x" * 200_000 + ",0.9,0.9,0.8,1\n"
    elif case == "rooms the wrong size":
        rooms = np.ones((10, 10))
    elif case == "no room":
        rooms = np.zeros(grid.shape)
    elif case == "noise":  # rooms of a pixel or a few: none the scores count
        rooms = np.random.default_rng(0).integers(0, 65535, grid.shape)
    elif case == "colour noise":
        rooms = np.random.default_rng(0).integers(0, 65535, (*grid.shape, 3))
    data = _eval_data(tmp_path / "data", plan_map, rooms, anchors)
    out = tmp_path / "out"
    assert main(["-q", "eval", "segment", str(data), "--out", str(out)]) == 2
    assert shown in _error_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize(
    "case, shown",
    [
        ("no free space", "no free space"),
        ("map image cut short", "image data is cut short"),
        ("a field of its YAML", "field 'resolution'"),
        ("rooms the wrong size", "people's rooms are 10 x 10 cells"),
    ],
)
def test_eval_segment_names_the_bad_map_of_the_folder(tmp_path, capsys, plan_map, case, shown):
    grid = OccupancyGrid.load(plan_map)
    data = _eval_data(tmp_path / "data", plan_map, np.where(grid.free, 1, 0), None)
    bad = data / "a.yaml"  # read before the good map m.yaml
    rooms = np.where(grid.free, 1, 0)
    if case == "no free space":
        OccupancyGrid(np.full(grid.shape, 100, np.int8), grid.resolution).save(bad)
    else:
        grid.save(bad)
    if case == "map image cut short":
        image = data / "a.pgm"
        image.write_bytes(image.read_bytes()[:-100])
    elif case == "a field of its YAML":
        bad.write_text(bad.read_text().replace("resolution: 0.05", "resolution: fine"))
    elif case == "rooms the wrong size":
        rooms = np.ones((10, 10))
    cv2.imwrite(str(data / "a_gt_labels.png"), rooms.astype(np.uint16))
    out = tmp_path / "out"
    assert main(["-q", "eval", "segment", str(data), "--out", str(out)]) == 2
    line = _error_line(capsys)
    assert str(bad) in line and shown in line and "m.yaml" not in line
    assert not out.exists()


def test_a_folder_that_may_not_be_listed_and_workers_that_cannot_start_are_typed(
    tmp_path, plan_map, monkeypatch
):
    import distributed

    from topomap.cli.batch import dask_client

    folder = tmp_path / "maps"
    folder.mkdir()

    def denied(self):
        raise PermissionError(13, "Permission denied", str(self))

    with monkeypatch.context() as patch:
        patch.setattr(Path, "iterdir", denied)
        with pytest.raises(MapFormatError, match="maps: cannot be read"):
            find_inputs([str(folder)])

    def no_workers(*args, **kwargs):
        raise RuntimeError("Nanny failed to start.")

    monkeypatch.setattr(distributed, "LocalCluster", no_workers)
    with (
        pytest.raises(SchedulerError, match="cannot start a local Dask cluster"),
        dask_client(workers=2),
    ):
        pass


def test_drawn_rooms_that_are_no_json_or_no_polygons_name_the_file_and_the_room(tmp_path, capsys):
    from topomap.cli.drawn import read_drawn
    from topomap.cli.evaluate_logs import drawn_rooms

    bad = tmp_path / "carmen_rooms.json"
    bad.write_text("{intel: ")
    with pytest.raises(MapFormatError, match=r"carmen_rooms\.json: not a drawn rooms JSON"):
        read_drawn(bad, "drawn rooms JSON")
    bad.write_text(json.dumps({"intel": {"rooms": []}}))  # no log named
    with pytest.raises(MapFormatError, match="maps each log's name to its shapes and 'log'"):
        read_drawn(bad, "drawn rooms JSON")
    assert main(["eval", "logs", str(tmp_path), "--hand-labels", str(tmp_path)]) == 2
    assert "carmen_rooms.json" in _error_line(capsys)
    bad.write_text(json.dumps({"intel": {"log": "intel.log.gz"}}))  # no rooms
    command = ["-q", "eval", "logs", str(tmp_path), "--hand-labels", str(tmp_path)]
    assert main([*command, "--out", str(tmp_path / "out")]) == 2
    assert "'intel' has no list of 'rooms' drawn" in _error_line(capsys)
    grid = OccupancyGrid(np.zeros((10, 10), np.int8), 0.5)
    rooms = [{"name": "hall", "polygon": [[0, 0], [1, 1]]}]
    with pytest.raises(MapFormatError, match="room 1 \\('hall'\\): a polygon needs"):
        drawn_rooms(grid, rooms)
    for rooms, shown in (
        (["x"], "room 1 is no {name, polygon} object"),
        ([{"polygon": [[0, 0], [1]]}], "a polygon needs"),
        ([{"polygon": [[0, 0], ["a", 1], [1, 1]]}], "a polygon needs"),
        ([{"name": "far", "polygon": [[100, 100], [101, 100], [101, 101]]}], "lies off the map"),
        ("x", "the rooms are a list"),
    ):
        with pytest.raises(MapFormatError, match=shown):
            drawn_rooms(grid, rooms)
    far = [{"name": "a", "polygon": [[0, 0], [5, 0], [1e12, 1e12], [0, 5]]}]
    assert drawn_rooms(grid, far).sum() > 0  # the part on the map, not the plane
    for text in ('{"intel": {"log": 5}}', '{"intel": ' + "[" * 5000 + "]" * 5000 + "}"):
        bad.write_text(text)
        with pytest.raises(MapFormatError, match=r"carmen_rooms\.json"):
            read_drawn(bad, "drawn rooms JSON")


_LINE = [[0, 5], [20, 5]]


@pytest.mark.parametrize(
    ("shapes", "shown"),
    [
        (
            {"corridors": [{"width": "2", "line": _LINE}]},
            "corridor 1: width must be a number, got '2'",
        ),
        ({"corridors": [{"line": _LINE}]}, "corridor 1: width must be a number, got None"),
        ({"corridors": [{"width": float("nan"), "line": _LINE}]}, "width must be a finite number"),
        ({"corridors": [{"width": float("inf"), "line": _LINE}]}, "width must be a finite number"),
        ({"corridors": [{"width": -2, "line": _LINE}]}, "width must lie in (0, 1000] m, got -2"),
        ({"corridors": [{"width": 10**400, "line": _LINE}]}, "got a 401-digit integer"),
        ({"corridors": [{"width": [[[2]]], "line": _LINE}]}, "width must be a number, got [[[2]]]"),
        ({"corridors": [{"width": 2, "line": [[0, 5], [20]]}]}, "corridor 1: its line needs"),
        ({"corridors": [{"width": 2, "line": [[0, 5], ["a", 5]]}]}, "its line needs at least 2"),
        ({"corridors": [{"width": 2, "line": [[0, 5], [10**400, 5]]}]}, "its line needs"),
        ({"corridors": [{"width": 2, "line": [[0, 5]]}]}, "its line needs at least 2"),
        ({"corridors": [{"width": 2}]}, "corridor 1: its line needs at least 2 [x, y] points"),
        ({"corridors": [{"width": 2, "line": _LINE}, 5]}, "corridor 2 is no {width, line} object"),
        ({"corridors": 5}, "the corridors are a list of {width, line}, got 5"),
        ({"halls": [{"polygon": [[0, 0], [1]]}]}, "hall 1: its polygon needs at least 3"),
        ({"halls": [{}]}, "hall 1: its polygon needs at least 3 [x, y] points in metres, got None"),
    ],
)
def test_drawn_corridors_and_halls_that_are_no_shapes_are_refused(shapes, shown):
    from topomap.cli.label_sources import drawn_truth

    grid = OccupancyGrid(np.zeros((20, 40), np.int8), 0.5)
    with pytest.raises(MapFormatError) as found:
        drawn_truth(grid, shapes)
    assert shown in str(found.value)


def test_a_drawn_corridor_with_a_far_vertex_is_its_part_on_the_map():
    from topomap.cli.label_sources import drawn_truth

    grid = OccupancyGrid(np.zeros((20, 40), np.int8), 0.5)  # 20 x 10 m
    far = drawn_truth(grid, {"corridors": [{"width": 2.0, "line": [[0, 5], [1e12, 5]]}]})
    near = drawn_truth(grid, {"corridors": [{"width": 2.0, "line": _LINE}]})
    assert (far == near).all()


def test_eval_corridors_names_the_file_the_log_and_the_corridor(tmp_path, capsys, data_dir):
    drawn = tmp_path / "carmen.json"
    corridors = [{"width": 2.0, "line": _LINE}, {"width": "wide", "line": _LINE}]
    drawn.write_text(
        json.dumps({"intel": {"log": "intel-corrected.log.gz", "corridors": corridors}})
    )
    out = tmp_path / "out"
    command = ["-q", "eval", "corridors", str(data_dir / "carmen"), "--hand-labels", str(tmp_path)]
    assert main([*command, "--out", str(out)]) == 2
    line = _error_line(capsys)
    assert line.endswith(f"{drawn}: 'intel', corridor 2: width must be a number, got 'wide'")
    assert not out.exists()
    for text in ('{"intel": ' + "[" * 5000 + "]" * 5000 + "}", '{"a": ' + "1" * 5000 + "}"):
        drawn.write_text(text)
        assert main([*command, "--out", str(out)]) == 2
        assert f"{drawn}: not a drawn corridors JSON" in _error_line(capsys)


_QUICK_PLAN = ["plan", "--sizes", "flat", "--queries", "1", "--planners", "hierarchical"]


@pytest.mark.parametrize(
    ("argv", "shown"),
    [
        (["online", "--parts", "latency", "quality", "--logs", "MISSING"], "CARMEN log not found"),
        (["online", "--parts", "growing", "--snapshots", "MISSING"], "data folder not found"),
        (["online", "--parts", "latency", "--keyframes", "5"], "--keyframes must be more than"),
        ([*_QUICK_PLAN, "--maps", "MISSING"], "maps folder not found"),
        ([*_QUICK_PLAN, "--robot", "rect:0.5x0.3", "--maps", "MISSING"], "maps folder not found"),
    ],
)
@pytest.mark.parametrize("given", [False, True])
def test_a_refused_bench_leaves_no_folder_behind(tmp_path, capsys, argv, shown, given):
    # refused before any work: no folder made, and the user's own folder kept as it was
    out = tmp_path / "out"
    if given:
        out.mkdir()
    argv = [str(tmp_path / "missing") if a == "MISSING" else a for a in argv]
    assert main(["-q", "bench", *argv, "--out", str(out)]) == 2
    assert shown in _error_line(capsys)
    assert out.exists() == given and (not given or not any(out.iterdir()))
