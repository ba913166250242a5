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
from numpy.typing import NDArray

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
from segmentation.pipeline import METHODS
from segmentation.regions import Regions

if TYPE_CHECKING:
    from planners.hierarchical import HierarchicalPlanner
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
    stale, damaged, or of another version: a warning in the log) one to prepare anew."""
    from planners.errors import DoorGraphFileError, StaleDoorGraphError
    from planners.hierarchical import HierarchicalPlanner
    from planners.prepared import read_prepared
    from planners.workspace import Workspace

    space = Workspace(topo.grid, robot_radius)
    labels, graph = topo.regions.labels, topo.graph
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
        (label image and map of different sizes, graph nodes that are not the regions, a file
        changed since it was saved).
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
    _check_graph(graph, regions, grid, folder / "graph.graphml")
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
    areas that are not the label image's pixel counts, another resolution or origin, or a
    name that is only digits (it would read as a region id)."""
    if sorted(graph.nodes) != regions.ids:
        raise ExportFormatError(
            f"{source}: nodes {sorted(graph.nodes)[:10]}... are not the "
            f"regions of regions.png {regions.ids[:10]}..."
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
        name = data.get("name")
        if name is not None and str(name).strip().isdigit():
            raise ExportFormatError(
                f"{source}: region {region} field 'name' is {name!r}, only digits: it would "
                "read as a region id"
            )
