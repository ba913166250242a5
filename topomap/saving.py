"""A :class:`~topomap.topomap.TopoMap` as a folder of files, and back.

:func:`save` writes ``map.yaml`` + ``map.pgm`` (map_server), ``regions.png`` (16-bit labels)
and beside it ``regions_colour.png`` (the same regions in colour, for people),
``graph.graphml`` and ``graph.json`` (labels and names included), ``regions.geojson``, the
prepared planner for a disc robot (``door_graph_rR.npz`` per robot radius ``R``:
:mod:`planners.prepared`) and last ``topomap.json``: the format and its :data:`VERSION`,
seconds, what conditioning dropped, the fitted partition and the SHA-256 of every other file
but the door graphs. :func:`load` reads data only (nothing in the files is executed) and
refuses a folder that is not whole, was changed since, or was written by a newer topomap.

A door graph is a cache, checked rather than listed: it holds the digest of the map, labels
and robot it was made for, so :func:`planner` reuses it only for them (another one is
rebuilt, with a warning in the log), and a later run may add one for another radius
(:func:`save_door_graph`).
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import logging
import math
import os
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import networkx as nx
import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import MultiPolygon, Polygon

from maps.errors import MapFileNotFoundError
from maps.files import OutputFolder, check_output_folder, write_text
from maps.grid import OccupancyGrid
from maps.limits import MAX_ROBOT_RADIUS, finite_in
from maps.map_server import check_input_file
from maps.scan import Keyframe
from segmentation.errors import ExportFormatError
from segmentation.export import (
    read_graphml,
    read_label_image,
    write_colour_image,
    write_geojson,
    write_graphml,
    write_label_image,
    write_node_link,
)
from segmentation.names import normalise_name
from segmentation.pipeline import METHODS
from segmentation.regions import Regions, boundary_pairs

if TYPE_CHECKING:
    from planners.hierarchical import HierarchicalPlanner
    from segmentation.transitions import Transition
    from topomap.topomap import TopoMap

log = logging.getLogger(__name__)

#: The files :func:`save` writes besides the map's YAML and image; ``topomap.json`` last.
SAVED = [
    "regions.png",
    "regions_colour.png",
    "graph.graphml",
    "graph.json",
    "regions.geojson",
    "topomap.json",
]
#: The version of the folder :func:`save` writes; :func:`load` reads it and every older one
#: (1: no file digests; 2: doors without their clear width).
VERSION = 3


@dataclass(frozen=True)
class SavedPartition:
    """The fitted spectral partition as :func:`save` keeps it: the attributes of a
    fitted :class:`~segmentation.spectral.SpectralSegmenter` a reader needs."""

    labels_: NDArray[np.int64]
    n_regions_: int
    silhouette_by_k_: dict[int, float]


@dataclass(frozen=True)
class Saved:
    """What :func:`load` read: the fields of a :class:`~topomap.topomap.TopoMap` kept in
    files."""

    grid: OccupancyGrid
    regions: Regions
    graph: nx.Graph
    seconds: dict[str, float]
    method: str
    partition: SavedPartition | None
    next_id: int


def save(
    topo: TopoMap,
    out: str | Path,
    *,
    overwrite: bool = False,
    door_graphs: Iterable[float] = (),
    progress: Callable[[list[int]], Iterable[int]] = iter,
) -> list[Path]:
    """Write ``topo`` into folder ``out`` (see the module docstring); returns the paths.
    ``door_graphs``: the robot radii whose prepared planners are saved too (prepared now if
    they were not, the parts passed through ``progress``).

    Raises
    ------
    OutputExistsError
        A file exists and ``overwrite`` is false; nothing is written then.
    """
    out, door_graphs = check_output_folder(out), _radii(door_graphs)
    if not callable(progress):
        raise ExportFormatError(f"progress must be a function of the parts, got {progress!r:.80}")
    names = [*SAVED, "map.yaml", "map.pgm"]
    caches = [door_graph_name(radius) for radius in door_graphs]
    folder = OutputFolder(out, [*names, *caches], overwrite=overwrite, last="topomap.json")
    with folder as work, ThreadPoolExecutor(1, "save") as beside:
        for radius, name in zip(door_graphs, caches, strict=True):
            _write_door_graph(topo, radius, work / name, progress)
        # the images are encoded beside the graph files (OpenCV lets the other thread run)
        images = [
            beside.submit(write_label_image, topo.regions.labels, work / "regions.png"),
            beside.submit(write_colour_image, topo.regions.labels, work / "regions_colour.png"),
        ]
        topo.grid.save(work / "map.yaml")
        write_graphml(topo.graph, work / "graph.graphml")
        write_node_link(topo.graph, work / "graph.json")
        write_geojson(topo.graph, work / "regions.geojson")
        for image in images:
            image.result()  # raises what writing it raised
        about: dict[str, Any] = {
            "format": "topomap",
            "version": VERSION,
            "regions": len(topo.regions.ids),
            "seconds": {k: round(v, 4) for k, v in topo.seconds.items()},
            "files": {name: _digest(work / name) for name in names if name != "topomap.json"},
            "method": topo.method,
            "next_id": topo.next_id,
        }
        if topo.segmentation is not None:
            about["conditioning"] = topo.conditioned.summary()
        if topo.segmentation is not None or topo.partition is not None:
            fitted = topo.segmenter  # a map read back keeps its saved partition
            about["partition"] = {
                "labels": [int(v) for v in fitted.labels_],
                "clusters": int(fitted.n_regions_),
                "silhouette_by_k": {str(k): v for k, v in fitted.silhouette_by_k_.items()},
            }
        write_text(work / "topomap.json", json.dumps(about, indent=2))
    return [out / name for name in ("map.yaml", "map.pgm", *caches, *SAVED)]


def door_graph_name(robot_radius: float) -> str:
    """The file name of the door graph saved for a disc robot of ``robot_radius`` metres.

    Examples
    --------
    >>> door_graph_name(0.2)
    'door_graph_r0.2.npz'
    """
    return f"door_graph_r{float(robot_radius)!r}.npz"


def planner(topo: TopoMap, robot_radius: float) -> HierarchicalPlanner:
    """The hierarchical planner of ``topo`` for a disc of ``robot_radius`` metres: with the
    door graph saved in the folder ``topo`` was read from (:attr:`TopoMap.source`) when there
    is one for this radius and it was made for this map and these regions; otherwise (none,
    stale, damaged, or of another version: a warning in the log) one to prepare anew. It
    plans on the map's known part (:meth:`~segmentation.regions.Regions.known_part`): every
    path the same, in the time of the building rather than of the canvas round it."""
    from planners.errors import DoorGraphFileError, StaleDoorGraphError
    from planners.hierarchical import HierarchicalPlanner
    from planners.prepared import read_prepared
    from planners.workspace import Workspace

    known = topo.regions.known_part()  # a SLAM canvas round the building: not planned in
    space = Workspace(known.grid, robot_radius)
    labels, graph = known.labels, topo.graph
    path = None if topo.source is None else topo.source / door_graph_name(robot_radius)
    if path is not None and path.is_file():
        try:
            prepared = read_prepared(path, space)
            return HierarchicalPlanner(space, labels, graph, prepared=prepared)
        except (DoorGraphFileError, StaleDoorGraphError) as err:
            where = "" if str(path) in str(err) else f"{path}: "
            log.warning("%s%s; preparing the planner again", where, err)
    return HierarchicalPlanner(space, labels, graph)


def save_door_graph(
    topo: TopoMap, robot_radius: float, progress: Callable[[list[int]], Iterable[int]] = iter
) -> Path:
    """Add (or replace) the door graph for ``robot_radius`` in the folder ``topo`` was read
    from, prepared now if it was not; returns its path.

    Raises
    ------
    ExportFormatError
        ``topo`` was not read from a folder.
    """
    if topo.source is None:
        raise ExportFormatError("this map was not read from a folder: save it with TopoMap.save")
    path = topo.source / door_graph_name(robot_radius)
    return _write_door_graph(topo, robot_radius, path, progress)


def _write_door_graph(
    topo: TopoMap, robot_radius: float, path: Path, progress: Callable[[list[int]], Iterable[int]]
) -> Path:
    from planners.prepared import write_prepared

    return write_prepared(topo.planner(robot_radius).prepared(progress), path, overwrite=True)


def load(folder: str | Path) -> Saved:
    """Read a folder written by :func:`save`.

    Raises
    ------
    MapFileNotFoundError
        A file is missing.
    MapFormatError
        A file that cannot be read (not a regular file, no permission, a name too long).
    ExportFormatError
        Not a topomap folder, one of a newer version, or files that do not belong together
        (label image and map of different sizes, a region graph that is not the label image's:
        :func:`_check_graph`, a file changed since it was saved).
    """
    if not isinstance(folder, str | os.PathLike):
        raise ExportFormatError(f"a saved topomap is a folder's path, got {folder!r}")
    folder = Path(folder)
    info = check_input_file(folder / "topomap.json", "topomap.json (written by TopoMap.save)")
    try:
        about = json.loads(info.read_text())
    except (ValueError, RecursionError) as err:
        raise ExportFormatError(f"{info}: not a topomap.json file: not JSON ({err})") from None
    if not isinstance(about, dict):
        raise ExportFormatError(
            f"{info}: not a topomap.json file: a JSON {type(about).__name__}, not an object"
        )
    try:
        seconds = {str(k): float(v) for k, v in about.get("seconds", {}).items()}
        files = dict(about.get("files", {}))
        method = str(about.get("method", "doors"))  # folders from before kept no method
        partition = _partition(about.get("partition"))
        next_id = int(about.get("next_id", 0))
        version = about.get("version", 1)
    except (ValueError, AttributeError, TypeError, KeyError, RecursionError, OverflowError) as err:
        raise ExportFormatError(
            f"{info}: not a topomap.json file: a field is not as TopoMap.save writes it "
            f"({type(err).__name__}: {err})"
        ) from None
    if method not in METHODS:
        raise ExportFormatError(f"{info}: field 'method' is {method!r}, not one of {METHODS}")
    if about.get("format") != "topomap":
        raise ExportFormatError(f"{info}: field 'format' is {about.get('format')!r}, not 'topomap'")
    if not isinstance(version, int) or isinstance(version, bool) or not 1 <= version <= VERSION:
        raise ExportFormatError(
            f"{info}: field 'version' is {version!r}; this topomap reads versions 1 to {VERSION}"
        )
    unlisted = sorted({"map.yaml", "map.pgm", *SAVED} - {"topomap.json"} - set(files))
    if version >= 2 and unlisted:  # without its digests a changed folder would be read
        raise ExportFormatError(
            f"{info}: field 'files' does not list the digests of {', '.join(unlisted)}, as "
            "TopoMap.save writes them: segment the map again"
        )
    grid = OccupancyGrid.load(folder / "map.yaml")
    labels = read_label_image(folder / "regions.png")
    if labels.shape != grid.shape:
        raise ExportFormatError(
            f"{folder / 'regions.png'}: {labels.shape} labels for a {grid.shape} map"
        )
    # regions cover furniture and clutter too (not free cells): a changed label image is
    # found by its digest and by the areas the graph holds
    graph = read_graphml(folder / "graph.graphml")
    regions = Regions(grid, labels)
    # on the map's known part (a SLAM package's canvas round the building has no region):
    # the same checks in the time and memory of the building (a 8000 x 8000 canvas: 3.6 s
    # and 1.0 GB -> 1.9 s and 0.75 GB to load)
    _check_graph(graph, regions.known_part(), grid, folder / "graph.graphml")
    for name, digest in files.items():  # version 2: the folder is whole and unchanged
        if name not in ("map.yaml", "map.pgm", *SAVED):
            raise ExportFormatError(f"{info}: field 'files' lists {name!r}, not a saved file")
        if not (folder / name).is_file():
            raise MapFileNotFoundError(folder / name, f"{name} (listed in topomap.json)")
        if _digest(folder / name) != digest:
            raise ExportFormatError(
                f"{folder / name}: changed since topomap.json was written (another run's or "
                "an edited file): segment the map again"
            )
    next_id = max(next_id, max(regions.ids, default=0) + 1)
    return Saved(grid, regions, graph, seconds, method, partition, next_id)


def _radii(door_graphs: object) -> list[float]:
    """The robot radii of the door graphs to save: metres each, in ``(0, MAX_ROBOT_RADIUS]``.

    Examples
    --------
    >>> _radii((0.2, 0.3))
    [0.2, 0.3]
    >>> _radii("0.2")
    Traceback (most recent call last):
    ...
    segmentation.errors.ExportFormatError: door_graphs must be robot radii in metres, got '0.2'
    """
    if isinstance(door_graphs, str) or not isinstance(door_graphs, Iterable):
        raise ExportFormatError(f"door_graphs must be robot radii in metres, got {door_graphs!r}")
    radii = list(door_graphs)
    for radius in radii:
        problem = finite_in(radius, "door_graphs radius", 0.0, MAX_ROBOT_RADIUS, low_open=True)
        if problem is not None:
            raise ExportFormatError(problem)
    return radii


def save_keyframes(
    keyframes: Sequence[Keyframe],
    regions: Sequence[int] | NDArray[np.integer],
    path: str | Path,
    *,
    overwrite: bool = False,
) -> Path:
    """Write ``scan_index,x,y,theta,region``, one row per keyframe."""
    stream = io.StringIO()
    writer = csv.writer(stream, lineterminator="\r\n")
    writer.writerow(["scan_index", "x", "y", "theta", "region"])
    for frame, region in zip(keyframes, regions, strict=True):
        writer.writerow([frame.scan_index, *(f"{v:.4f}" for v in frame.pose), region])
    return write_text(path, stream.getvalue(), overwrite=overwrite)


def _digest(path: Path) -> str:
    """The SHA-256 of a file, hex."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _partition(saved: Any) -> SavedPartition | None:
    """The ``partition`` field of ``topomap.json`` (None when absent)."""
    if saved is None:
        return None
    labels = np.asarray(saved["labels"])
    clusters = int(saved["clusters"])
    silhouettes = {int(k): float(v) for k, v in dict(saved["silhouette_by_k"]).items()}
    if (
        labels.ndim != 1
        or (labels.size and (labels.dtype.kind not in "iu" or labels.min() < 0))
        or not 0 <= clusters <= labels.size
        or (labels.size and labels.max() >= clusters)
        or not all(-1 <= v <= 1 for v in silhouettes.values())
    ):
        raise ValueError("partition: labels 0..clusters-1, silhouettes in [-1, 1]")
    return SavedPartition(labels.astype(np.int64), clusters, silhouettes)


def _check_graph(graph: nx.Graph, regions: Regions, grid: OccupancyGrid, source: Path) -> None:
    """Refuse a region graph that is not the graph of ``regions`` on ``grid``: other node ids,
    another resolution or origin, areas that are not the label image's pixel counts, points
    that are not finite, names a query cannot tell apart (:func:`_check_names`), outlines
    that are not their regions' cells (:func:`_outline_problem`), or edges between regions
    that do not touch or with doors that are not finite (:func:`_check_edges`)."""
    nodes, ids = set(graph.nodes), set(regions.ids)
    if nodes != ids:
        raise ExportFormatError(
            f"{source}: the nodes are not the regions of regions.png (nodes "
            f"{sorted(nodes - ids)[:10]} are no region there, regions {sorted(ids - nodes)[:10]} "
            "have no node)"
        )
    resolution, origin = graph.graph.get("resolution"), tuple(graph.graph.get("origin", ()))
    if resolution != grid.resolution or origin != grid.origin:
        raise ExportFormatError(
            f"{source}: resolution {resolution} and origin {origin} are not the map's "
            f"({grid.resolution}, {grid.origin})"
        )
    for region, data in graph.nodes(data=True):
        area, expected = data.get("area_m2"), regions.area(region)
        if not isinstance(area, float) or not math.isclose(area, expected, rel_tol=1e-6):
            raise ExportFormatError(
                f"{source}: region {region} field 'area_m2' is {area!r}, but regions.png gives "
                f"it {expected:.6g} m^2"
            )
        for field in ("x", "y"):
            problem = finite_in(data.get(field), f"field {field!r}", -math.inf, math.inf)
            if problem is not None:
                raise ExportFormatError(f"{source}: region {region} {problem}")
        problem = _outline_problem(data["polygon"], region, regions)
        if problem is not None:
            raise ExportFormatError(f"{source}: region {region} field 'polygon' {problem}")
    _check_names(graph, source)
    _check_edges(graph, regions, source)


def _check_names(graph: nx.Graph, source: Path) -> None:
    """Refuse a name that is not text, empty, only digits (it would read as a region id) or
    another region's as queries compare names (:func:`~segmentation.names.normalise_name`),
    and a region without a name in a labelled map (one whose regions have a ``label``:
    labelling names them all; a map never labelled has no names but those given)."""
    labelled = any("label" in data for _, data in graph.nodes(data=True))
    named: dict[str, int] = {}
    for region, name in graph.nodes(data="name"):
        if name is None:
            if labelled:
                raise ExportFormatError(
                    f"{source}: region {region} has no field 'name', but the map is labelled "
                    "(every region of a labelled map has a name)"
                )
            continue
        wanted = normalise_name(name) if isinstance(name, str) else ""
        if not wanted:
            raise ExportFormatError(
                f"{source}: region {region} field 'name' is {name!r}, not a name (text, not blank)"
            )
        if wanted.isdigit():
            raise ExportFormatError(
                f"{source}: region {region} field 'name' is {name!r}, only digits: it would "
                "read as a region id"
            )
        if wanted in named:
            raise ExportFormatError(
                f"{source}: region {region} field 'name' is {name!r}, the name of region "
                f"{named[wanted]} too (names are compared ignoring case, spaces and synonyms)"
            )
        named[wanted] = region


#: Cells an outline may leave out of its region, and cells of others it may hold, per cell
#: of its length. An outline written by :func:`save` runs along the cells' edges and holds
#: exactly the region's cells (and the furniture they enclose); one drawn otherwise, e.g.
#: simplified by a cell or two, strays by up to about half a cell per cell of its length (an
#: outline moved three cells strays by 1.5).
OUTLINE_MARGIN = 1.0


def _outline_problem(polygon: object, region: int, regions: Regions) -> str | None:
    """What is wrong with ``polygon`` as the outline of ``region`` (None: nothing): not a
    polygon, coordinates that are not finite or off the map, or cells that are not the
    region's: half its cells or more outside it, as many cells inside it not the region's
    (:attr:`~segmentation.regions.Regions.enclosing`) as the region's, or either more than
    :data:`OUTLINE_MARGIN` times its length in cells (a cell is inside when its centre is)."""
    if not isinstance(polygon, Polygon | MultiPolygon) or polygon.is_empty:
        return f"is {str(polygon)[:60]!r}, not the outline of cells"
    xy, ring = shapely.get_coordinates(
        shapely.get_rings(shapely.get_parts(polygon)), return_index=True
    )
    if not np.isfinite(xy).all():
        return "has coordinates that are not finite numbers"
    rows, cols = _lattice(regions.grid, xy)
    height, width = regions.grid.shape
    if rows.min() < -1 or cols.min() < -1 or rows.max() > height + 1 or cols.max() > width + 1:
        return f"lies off the map: its bounds are {tuple(round(v, 3) for v in polygon.bounds)}"
    top, left = max(0, math.floor(rows.min())), max(0, math.floor(cols.min()))
    box = np.s_[top : min(height, math.ceil(rows.max())), left : min(width, math.ceil(cols.max()))]
    inside = _cells_inside(rows - top, cols - left, ring, regions.labels[box].shape)
    if inside is None:
        return "crosses rows of cells more often than an outline of cells can"
    cells, around = int(regions.cell_counts[region]), regions.enclosing[box][inside]
    own = int(np.count_nonzero(regions.labels[box][inside] == region))
    foreign = around[around != region]
    margin = OUTLINE_MARGIN * polygon.length / regions.grid.resolution
    if 2 * own > cells and len(foreign) < own and max(cells - own, len(foreign)) <= margin:
        return None
    found = f"holds {own / cells:.0%} of the region's {cells} cells in regions.png"
    if len(foreign):
        most = int(np.bincount(foreign).argmax())
        whose = "no region's" if most == 0 else f"region {most}'s"
        found += f" and {len(foreign)} cells that are not its own (most of them {whose})"
    return found


def _lattice(grid: OccupancyGrid, xy: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
    """Map-frame points as ``(row, col)`` in cell edges: cell ``(r, c)`` spans rows
    ``[r, r + 1)`` and columns ``[c, c + 1)``."""
    ox, oy, yaw = grid.origin
    c, s = math.cos(yaw), math.sin(yaw)
    dx, dy = xy[:, 0] - ox, xy[:, 1] - oy
    with np.errstate(over="ignore"):  # points far off the map: refused as such
        return grid.shape[0] - (-s * dx + c * dy) / grid.resolution, (
            c * dx + s * dy
        ) / grid.resolution


def _cells_inside(
    rows: NDArray[np.float64],
    cols: NDArray[np.float64],
    ring: NDArray[np.intp],
    shape: tuple[int, int],
) -> NDArray[np.bool_] | None:
    """The cells of a grid of ``shape`` whose centres lie inside the rings of vertices
    ``(rows, cols)`` (cell edges; ``ring`` numbers each vertex's ring, closed), by the
    even-odd rule: a cell toggles at each edge crossing its row's centre line left of its
    centre. None when the edges cross more often than an outline of the grid's cells can.

    Examples
    --------
    >>> rows, cols = np.array([0.0, 0, 2, 2, 0]), np.array([1.0, 3, 3, 1, 1])  # a square
    >>> _cells_inside(rows, cols, np.zeros(5, np.intp), (3, 4)).astype(int)
    array([[0, 1, 1, 0],
           [0, 1, 1, 0],
           [0, 0, 0, 0]])
    """
    height, width = shape
    edge = ring[1:] == ring[:-1]
    r0, r1, c0, c1 = rows[:-1][edge], rows[1:][edge], cols[:-1][edge], cols[1:][edge]
    # each edge crosses the centre lines (row + 0.5) of rows [first, stop): half open
    first = np.clip(np.ceil(np.minimum(r0, r1) - 0.5), 0, height).astype(np.int64)
    stop = np.clip(np.ceil(np.maximum(r0, r1) - 0.5), 0, height).astype(np.int64)
    count = stop - first
    if count.sum() > height * (width + 1):
        return None
    which = np.repeat(np.arange(len(count)), count)
    row = first[which] + np.arange(len(which)) - np.repeat(np.cumsum(count) - count, count)
    r0, r1, c0, c1 = r0[which], r1[which], c0[which], c1[which]
    col = c0 + (row + 0.5 - r0) * (c1 - c0) / (r1 - r0)
    at = np.clip(np.ceil(col - 0.5), 0, width).astype(np.int64)  # the first cell right of it
    toggles = np.zeros((height, width + 1), bool)
    np.logical_xor.at(toggles, (row, at), True)
    return np.logical_xor.accumulate(toggles[:, :width], axis=1)


def _check_edges(graph: nx.Graph, regions: Regions, source: Path) -> None:
    """Refuse an edge between regions that do not touch in the label image (no 4-neighbour
    cells), with no door, a ``width`` or door numbers that are not finite (a door's clear
    width may be ``inf``: not measured), or negative widths."""
    ra, ca, rb, cb = boundary_pairs(regions.labels)
    step = int(regions.labels.max(initial=0)) + 1
    touching = set(np.unique(regions.labels[ra, ca] * step + regions.labels[rb, cb]).tolist())
    for a, b, data in graph.edges(data=True):
        edge = f"{source}: edge ({a}, {b})"
        if min(a, b) * step + max(a, b) not in touching:
            raise ExportFormatError(f"{edge}: regions {a} and {b} do not touch in regions.png")
        doors = data["doors"]
        if not doors:
            raise ExportFormatError(f"{edge} field 'doors' holds no door")
        problem = finite_in(data.get("width"), "field 'width'", 0, math.inf)
        for number, door in enumerate(doors, 1):
            problem = problem or _door_problem(door, f"door {number}'s")
        if problem is not None:
            raise ExportFormatError(f"{edge} {problem}")


def _door_problem(door: Transition, name: str) -> str | None:
    """What is wrong with the numbers of ``door`` (None: nothing): a coordinate that is not
    finite, a width that is not a finite number >= 0 (the clear width may be ``inf``: not
    measured). Problems start with ``name``."""
    points = {"start": door.start, "end": door.end, "centre": door.centre}
    problems = [
        *(
            finite_in(value, f"{name} {point} {axis}", -math.inf, math.inf)
            for point, xy in points.items()
            for axis, value in zip("xy", xy, strict=True)
        ),
        finite_in(door.width, f"{name} width", 0, math.inf),
        None
        if door.clear_width == math.inf
        else finite_in(door.clear_width, f"{name} clear width", 0, math.inf),
    ]
    return next((problem for problem in problems if problem is not None), None)
