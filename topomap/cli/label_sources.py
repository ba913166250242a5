"""Labelled buildings for the label evaluation, one loader per source.

Every source gives :class:`LabelledMap` objects: a segmented map, the features of its
regions and each region's true type, the majority type of its floor in a truth raster (place
type index per cell, -1 where none is known). The floor is where a robot of
:data:`~topomap.features.FLOOR_RADIUS_M` fits (:func:`floor_cells`): laser rays through doors
and windows and the gaps between clutter are free cells nobody stands on, and a corridor
region with a fan of rays into the rooms it passes is a corridor. A region without such floor
(a fan of rays) is typed by all its cells. The sources:

- ``ipa_places``: plans with a place type per pixel (``NAME_places.png``), drawn by ipa;
- ``rose2``: ROSE²'s SLAM maps of one building, the people's rooms (colours of ``gt/``) typed
  by hand in ``rose2_partial.csv``; both the segmented regions and the people's rooms
  themselves as regions (``rose2-rooms``: the classifier alone, without the segmentation);
- ``carmen``: maps built from the four real logs, corridors and halls drawn by hand in
  ``carmen.json`` (corridor centrelines with a width, hall polygons, map-frame metres;
  every other free cell a room);
- ``generated``: generated buildings with furniture (the generator's own types, a flat's
  "hall" a room: :func:`generated_type`), the true
  plans and, with ``scanned``, the map a simulated robot's laser builds (rays, noise).
"""

from __future__ import annotations

import csv
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import networkx as nx
import numpy as np
from numpy.typing import NDArray

from maps.errors import MapFileNotFoundError, MapFormatError
from maps.grid import OccupancyGrid
from maps.limits import MAX_LENGTH, finite_in
from maps.map_server import grid_from_image
from maps.scan import Keyframe
from maps.sim.floorplan import generate_floor_plan
from segmentation.graph import region_graph
from segmentation.regions import Regions
from segmentation.working import grow
from topomap.classifiers import PLACE_TYPES
from topomap.cli.drawn import drawn_cells, drawn_for, drawn_list, drawn_points, read_drawn
from topomap.cli.evaluate import ROSE2_MAP
from topomap.features import FLOOR_RADIUS_M, region_features
from topomap.topomap import TopoMap

#: The widest line of unlabelled cells people draw between two of their rooms at a door, m
#: (ROSE²'s ground truth: one or two cells of 5 cm).
DOOR_LINE_M = 0.1
#: Grey levels of ``*_places.png``: room, corridor, doorway.
PLACE_GREYS = {77: "room", 115: "corridor", 179: "doorway"}
#: Cell size of the ipa_places images, metres.
PLACES_RESOLUTION = 0.05
#: The thickest line OpenCV draws, cells: a wider corridor band is drawn this wide.
CV_MAX_THICKNESS = 32767
#: Progress wrapper of the loaders (``iter``: none).
Progress = Callable[[Any], Iterable[Any]]


@dataclass
class LabelledMap:
    """One labelled map: its source, its building (what leave-one-building-out leaves out),
    its regions and graph, their feature table and each region's true type."""

    source: str
    building: str
    map: str
    regions: Regions
    graph: nx.Graph
    features: dict[str, NDArray[np.float64]]
    truth: list[str]


def labelled_map(
    regions: Regions,
    graph: nx.Graph,
    truth: NDArray[np.int8],
    *,
    source: str,
    building: str,
    name: str,
) -> LabelledMap:
    """The :class:`LabelledMap` of a segmentation and a truth raster of the same shape: every
    region with a known type among its cells, typed by the majority on its floor
    (:func:`floor_cells`), or of all its cells when it has no floor."""
    features = region_features(regions, graph)
    floor = floor_cells(regions.grid)
    types = []
    for region in features["id"].astype(int):
        cells = (regions.labels == region) & (truth >= 0)
        counts = np.bincount(truth[cells & floor], minlength=len(PLACE_TYPES))
        if not counts.sum():  # no floor: a fan of rays, typed by all its cells
            counts = np.bincount(truth[cells], minlength=len(PLACE_TYPES))
        types.append(PLACE_TYPES[int(counts.argmax())] if counts.sum() else None)
    keep = np.array([t is not None for t in types], bool)
    return LabelledMap(
        source,
        building,
        name,
        regions,
        graph,
        {k: v if k == "links" else v[keep] for k, v in features.items()},
        [t for t in types if t is not None],
    )


def floor_cells(grid: OccupancyGrid) -> NDArray[np.bool_]:
    """The free cells of ``grid`` a disc of :data:`~topomap.features.FLOOR_RADIUS_M` fits on
    (centred there); not the narrow free strips of laser rays or the gaps between clutter.

    Examples
    --------
    >>> free = np.zeros((20, 20), bool)
    >>> free[2:18, 2:18] = True  # a 1.6 m square room at 10 cm ...
    >>> free[9:10, 18:] = True  # ... with a ray of one cell out of it
    >>> floor = floor_cells(OccupancyGrid.from_masks(free, 0.1))
    >>> int(floor.sum()), bool(floor[9, 19])
    (144, False)
    """
    return grid.inflate(FLOOR_RADIUS_M).free


def _segmented(grid: OccupancyGrid, truth: NDArray[np.int8], **names: str) -> LabelledMap:
    """:func:`labelled_map` of the default segmentation of ``grid``."""
    topo = TopoMap.from_grid(grid, random_state=0)
    return labelled_map(topo.regions, topo.graph, truth, **names)


def ipa_places(data_dir: str | Path, progress: Progress = iter) -> list[LabelledMap]:
    """Every ``NAME.png`` with ``NAME_places.png`` of ``data_dir``, segmented; each plan is a
    building of its own."""
    folder = Path(data_dir)
    if not folder.is_dir():
        raise MapFileNotFoundError(folder, "data folder")
    pairs = [
        (p.name.removesuffix("_places.png"), p)
        for p in sorted(folder.glob("*_places.png"))
        if (folder / p.name.replace("_places.png", ".png")).exists()
    ]
    if not pairs:
        raise MapFileNotFoundError(folder / "*_places.png", "place-labelled map")
    found = []
    for name, places in progress(pairs):
        grid = OccupancyGrid.from_image(folder / f"{name}.png", PLACES_RESOLUTION)
        truth = read_places(places)
        found.append(_segmented(grid, truth, source="ipa_places", building=name, name=name))
    return found


def read_places(path: Path) -> NDArray[np.int8]:
    """Place type index (into :data:`PLACE_TYPES`) per pixel, -1 for walls and other greys."""
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise MapFileNotFoundError(path, "places image")
    types = np.full(image.shape, -1, np.int8)
    for grey, place in PLACE_GREYS.items():
        types[image == grey] = PLACE_TYPES.index(place)
    return types


def read_room_types(path: Path) -> dict[str, dict[str, str]]:
    """Map -> room colour (hex) -> type, from a CSV with columns ``map,colour,type``.

    Raises
    ------
    MapFormatError
        Naming the file and line of a row with another column set or an unknown type.
    """
    if not path.exists():
        raise MapFileNotFoundError(path, "room types CSV")
    found: dict[str, dict[str, str]] = {}
    with path.open(newline="") as file:
        reader = csv.DictReader(file)
        if reader.fieldnames != ["map", "colour", "type"]:
            raise MapFormatError(f"{path}: columns {reader.fieldnames}, expected map,colour,type")
        for line, row in enumerate(reader, start=2):
            if row["type"] not in PLACE_TYPES:
                raise MapFormatError(f"{path}:{line}: unknown type {row['type']!r}")
            found.setdefault(row["map"], {})[row["colour"].lower()] = row["type"]
    return found


def rose2(
    data_dir: str | Path, types_csv: str | Path, progress: Progress = iter
) -> list[LabelledMap]:
    """ROSE²'s maps with the typed rooms of ``types_csv``: per map the segmented regions
    (source ``rose2``) and the people's rooms as regions (``rose2-rooms``); one building."""
    folder, table = Path(data_dir), read_room_types(Path(types_csv))
    found = []
    for name, colours in progress(sorted(table.items(), key=lambda kv: int(kv[0][3:]))):
        grid = grid_from_image(folder / "maps" / f"{name}.png", **ROSE2_MAP)  # type: ignore[arg-type]
        image = cv2.imread(str(folder / "gt" / f"{name}.png"), cv2.IMREAD_COLOR)
        if image is None:
            raise MapFileNotFoundError(folder / "gt" / f"{name}.png", "ROSE² ground truth")
        rgb = image[..., ::-1].astype(np.int64)
        key = (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]
        truth = np.full(key.shape, -1, np.int8)
        rooms = np.zeros(key.shape, np.int32)
        for number, (colour, place) in enumerate(sorted(colours.items()), start=1):
            cells = key == int(colour, 16)
            truth[cells] = PLACE_TYPES.index(place)
            rooms[cells] = number
        names = {"building": "rose2-cartesium", "name": name}
        found.append(_segmented(grid, truth, source="rose2", **names))
        people = _joined_rooms(_connected_rooms(Regions(grid, rooms)))
        found.append(
            labelled_map(people, region_graph(people), truth, source="rose2-rooms", **names)
        )
    return found


def _connected_rooms(regions: Regions) -> Regions:
    """The largest connected piece of every room (people's rooms have stray pixels)."""
    labels = np.zeros_like(regions.labels)
    for region in regions.ids:
        count, pieces = cv2.connectedComponents((regions.labels == region).astype(np.uint8))
        if count > 1:
            sizes = np.bincount(pieces.ravel())[1:]
            labels[pieces == 1 + int(sizes.argmax())] = region
    return Regions(regions.grid, labels)


def _joined_rooms(regions: Regions) -> Regions:
    """``regions`` grown over the free cells within :data:`DOOR_LINE_M` of them: people
    close each room at its doors with a line of unlabelled cells, so their rooms do not touch
    and their graph would have no doors (a corridor with no neighbour is no corridor).

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((3, 5), np.int8), 0.05)
    >>> labels = np.array([[1, 1, 0, 2, 2]] * 3, np.int32)  # a door line between two rooms
    >>> _joined_rooms(Regions(grid, labels)).labels[0].tolist()
    [1, 1, 2, 2, 2]
    """
    reach = max(1, round(DOOR_LINE_M / regions.grid.resolution))
    near = cv2.dilate((regions.labels > 0).astype(np.uint8), np.ones((2 * reach + 1,) * 2))
    labels = grow(regions.labels.copy(), regions.grid.free & near.astype(bool))
    return Regions(regions.grid, labels)


def carmen(
    log_dir: str | Path, drawn_json: str | Path, progress: Progress = iter
) -> list[LabelledMap]:
    """Maps built from the CARMEN logs of ``log_dir`` (as ``topomap map`` builds them), typed
    by the corridors and halls drawn in ``drawn_json``; each log is a building."""
    found = []
    for name, shapes in progress(sorted(read_drawn(drawn_json).items())):
        _, grid = carmen_map(Path(log_dir) / shapes["log"])
        with drawn_for(drawn_json, name):
            truth = drawn_truth(grid, shapes)
        found.append(_segmented(grid, truth, source="carmen", building=name, name=name))
    return found


def carmen_map(log: Path, resolution: float = 0.05) -> tuple[list[Keyframe], OccupancyGrid]:
    """A CARMEN log's keyframes (0.5 m apart) and the map of ``resolution`` metres per cell
    they build, as ``topomap map`` builds it."""
    from maps.carmen import read_carmen
    from maps.mapping import grid_from_keyframes
    from maps.scan import select_keyframes

    keyframes = select_keyframes(read_carmen(log), distance=0.5)
    return keyframes, grid_from_keyframes(keyframes, resolution, max_range=30.0)


def drawn_truth(grid: OccupancyGrid, shapes: dict[str, Any]) -> NDArray[np.int8]:
    """Type per cell of ``grid`` from drawn shapes: ``corridors`` (``{"width": m, "line":
    [[x, y], ...]}``: the cells within half the width of the centreline), ``halls``
    (``{"polygon": [[x, y], ...]}``), every other free cell a room, others -1. The band is
    drawn by OpenCV and may be a cell wider than the width; a far vertex is drawn as the
    shape's part on the map.

    Raises
    ------
    MapFormatError
        Corridors or halls that are not a list of objects, a width that is no number in
        (0, :data:`~maps.limits.MAX_LENGTH`] m, a centreline of fewer than two finite
        ``[x, y]`` points, a hall of fewer than three (the corridor or hall named).

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((20, 40), np.int8), 0.5)  # 20 x 10 m, all free
    >>> shapes = {"corridors": [{"width": 2.0, "line": [[0, 5], [20, 5]]}], "halls": []}
    >>> truth = drawn_truth(grid, shapes)
    >>> int((truth == 1).sum()), int((truth == 0).sum())  # a 2 m band: 5 rows of 0.5 m cells
    (200, 600)
    """
    truth = np.where(grid.free, PLACE_TYPES.index("room"), -1).astype(np.int8)
    corridor = np.zeros(grid.shape, np.uint8)
    corridors = drawn_list(shapes.get("corridors", []), "corridor", "width, line")
    for number, line in enumerate(corridors, 1):
        name = f"corridor {number}"
        problem = finite_in(
            line.get("width"), f"{name}: width", 0, MAX_LENGTH, unit="m", low_open=True
        )
        if problem is not None:
            raise MapFormatError(problem)
        xy = drawn_points(line.get("line"), 2, f"{name}: its line")
        thickness = min(max(1, round(float(line["width"]) / grid.resolution)), CV_MAX_THICKNESS)
        cv2.polylines(corridor, drawn_cells(grid, xy, closed=False), False, 1, thickness)
    hall = np.zeros(grid.shape, np.uint8)
    halls = drawn_list(shapes.get("halls", []), "hall", "polygon")
    for number, polygon in enumerate(halls, 1):
        xy = drawn_points(polygon.get("polygon"), 3, f"hall {number}: its polygon")
        cv2.fillPoly(hall, drawn_cells(grid, xy), 1)
    truth[grid.free & (corridor > 0)] = PLACE_TYPES.index("corridor")
    truth[grid.free & (hall > 0)] = PLACE_TYPES.index("hall")
    return truth


def generated(
    sizes: tuple[str, ...] = ("flat", "office"),
    seeds: tuple[int, ...] = (0, 1, 2),
    *,
    scanned: tuple[int, ...] = (),
    progress: Progress = iter,
) -> list[LabelledMap]:
    """Generated buildings with furniture (0.3 blocks per 10 m^2), typed by the generator:
    the true plans (source ``generated``) and, for the flats of the ``scanned`` seeds, the map
    a simulated robot builds (``generated-scanned``); each plan is a building."""
    from maps.sim.survey import survey

    jobs = [(size, seed, False) for size in sizes for seed in seeds]
    jobs += [("flat", seed, True) for seed in scanned]
    found = []
    for size, seed, scan in progress(jobs):
        plan = generate_floor_plan(size, furniture=0.3, random_state=seed)
        truth = np.full(plan.labels.shape, -1, np.int8)
        for index, place in enumerate(plan.types, start=1):
            truth[plan.labels == index] = PLACE_TYPES.index(generated_type(size, place))
        grid = plan.grid
        if scan:
            grid = survey(plan, seed).grid
            truth = _resampled(truth, plan.grid, grid)
        source = "generated-scanned" if scan else "generated"
        names = {"building": f"{size}-{seed}", "name": f"{source}-{size}-{seed}"}
        found.append(_segmented(grid, truth, source=source, **names))
    return found


def generated_type(size: str, place: str) -> str:
    """The true type of a generated space: the generator's, but a flat's "hall" is a room.

    A flat (about 20 x 15 m) gets its "hall" as a wider stretch of one row of rooms: 6-9 m by
    the row's depth (30-45 m^2), one door onto the corridor. The halls people name apart
    from rooms (issue 21) are large open spaces, warehouse floors and atria; an office's
    halls (two rows deep, 12-20 m long, doors onto two corridors) are, a flat's is a room.

    Examples
    --------
    >>> generated_type("flat", "hall"), generated_type("office", "hall")
    ('room', 'hall')
    """
    return "room" if size == "flat" and place == "hall" else place


def _resampled(
    truth: NDArray[np.int8], truth_grid: OccupancyGrid, grid: OccupancyGrid
) -> NDArray[np.int8]:
    """``truth`` (on ``truth_grid``) at the cells of ``grid``, -1 outside it."""
    rows, cols = np.indices(grid.shape)
    xs, ys = grid.cell_to_world(rows.ravel(), cols.ravel())
    r, c = truth_grid.world_to_cell(xs, ys)
    inside = truth_grid.contains(r, c)
    out = np.full(rows.size, -1, np.int8)
    out[inside] = truth[r[inside], c[inside]]
    return out.reshape(grid.shape)
