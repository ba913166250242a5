"""Evaluation of the segmentation against people's rooms: the ipa floor plans (a label image
per plan) and ROSE²'s real SLAM maps (a colour image per map, ROSE²'s own results beside)."""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.errors import MapFileNotFoundError, MapFormatError, TopomapError
from maps.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from maps.map_server import grid_from_image
from segmentation.export import read_image_unchanged
from segmentation.metrics import MIN_PIXELS, colour_labels, rose2_score, score
from topomap.errors import led_by
from topomap.topomap import pipeline_from_options

METRICS = ["recall", "precision", "mcc", "ari", "rose2_precision", "rose2_recall", "rose2_iou"]
#: How ROSE²'s maps are read (its README): 0.05 m per pixel, map_server's trinary thresholds.
ROSE2_MAP = {"resolution": 0.05, "free_thresh": 0.05, "occupied_thresh": 0.65}


@dataclass(frozen=True)
class FloorPlan:
    """One map to evaluate: its occupancy map, its people's rooms, furnished or not, and an
    other system's segmentation of it when the data has one."""

    name: str
    yaml: Path
    truth: Path
    furnished: bool
    released: Path | None = None

    def grid(self) -> OccupancyGrid:
        """The occupancy map (a map_server YAML, or a ROSE² image)."""
        if self.yaml.suffix == ".png":
            return grid_from_image(self.yaml, **ROSE2_MAP)  # type: ignore[arg-type]
        return OccupancyGrid.load(self.yaml)

    def rooms(self) -> NDArray[np.int32]:
        """The people's rooms as labels (0 = no room)."""
        return read_rooms(self.truth)


def read_rooms(path: Path) -> NDArray[np.int32]:
    """People's rooms from a 16-bit label image (ipa) or a colour image (ROSE²: one colour a
    room, black none), told apart by their channels; sized before they are decoded."""
    image = read_image_unchanged(path, "people's rooms image")
    if image.ndim == 3:
        return colour_labels(np.asarray(image[..., :3], np.uint8))
    return image.astype(np.int32)


def floor_plans(data_dir: str | Path) -> list[FloorPlan]:
    """The maps of ``data_dir``: every ``NAME.yaml`` / ``NAME_furnitures.yaml`` with a
    ``NAME_gt_labels.png`` beside it (the ipa layout), or every ``maps/NAME.png`` with a
    colour ``gt/NAME.png`` (ROSE²'s layout; ``rose2_seg/NAME.png`` its released result)."""
    data_dir = Path(data_dir)
    if not data_dir.is_dir():
        raise MapFileNotFoundError(data_dir, "data folder")
    found = []
    for yaml in sorted(data_dir.glob("*.yaml")):
        name = yaml.stem
        base = name.removesuffix("_furnitures")
        truth = data_dir / f"{base}_gt_labels.png"
        if truth.exists():
            found.append(FloorPlan(name, yaml, truth, name != base))
    for image in sorted((data_dir / "maps").glob("*.png"), key=_natural):
        truth = data_dir / "gt" / image.name
        released = data_dir / "rose2_seg" / image.name
        if truth.exists():
            found.append(
                FloorPlan(image.stem, image, truth, False, released if released.exists() else None)
            )
    if not found:
        raise MapFileNotFoundError(
            data_dir / "*.yaml", "map YAML with a *_gt_labels.png, or maps/*.png with gt/*.png"
        )
    return found


def _natural(path: Path) -> tuple[str, int]:
    stem = path.stem.rstrip("0123456789")
    digits = path.stem[len(stem) :]
    return stem, int(digits) if digits else -1


def _scores(labels: NDArray[np.integer], truth: NDArray[np.integer]) -> dict[str, Any]:
    found: dict[str, Any] = {
        **score(labels, truth).as_dict(),
        **rose2_score(labels, truth).as_dict(),
    }
    return {k: round(v, 4) if isinstance(v, float) else v for k, v in found.items()}


#: The cell grid moved against the building by one cell right, down and both (with the map
#: itself): on a 0.05 m map the working grid's four ways of pooling 2 x 2 cells.
SHIFTS = ((0, 0), (1, 0), (0, 1), (1, 1))


#: Turns of the building against the cell grid, degrees: a robot's map is rarely square with
#: its walls (a few degrees off is common), and 17, 30 and 45 put them at unlike slants.
#: Each turn is also scored turned and turned back (``turned_back``): square with the cells
#: again but resampled twice, what the turning's nearest-cell resampling costs alone (on the
#: ROSE² maps more than the slant: MCC 0.70 / 0.67 at 30 / 45 degrees and back, 0.73 / 0.71
#: turned once), so only the difference between the two is the slant's own cost.
ROTATIONS = (0.0, 3.0, 17.0, 30.0, 45.0)


#: Cell sizes against the map's own, each a map of its own: the same building mapped with cells
#: twice as large (a 0.05 m map as a 0.1 m one) and half as large; users' maps are 0.02-0.1 m.
CELL_FACTORS = (1.0, 2.0, 0.5)


#: Walls grown by this many cells, each a map of its own: the same building drawn by a mapper
#: whose beams end a cell further on both sides of every surface (more range noise, another
#: occupancy threshold); the doors and corridors are a cell narrower on each side.
GROWN_WALLS = (0, 1)


def half_cell_over(
    grid: OccupancyGrid, rooms: NDArray[np.int32]
) -> tuple[OccupancyGrid, NDArray[np.int32]]:
    """``grid`` and its people's ``rooms`` as a mapper whose cells fall half a cell over
    (right and down) would draw them: each cell split in four (:func:`resampled`), moved one
    split cell, and merged again as a mapper makes a cell of four. A wall that fell in one
    cell now falls across two: a cell is occupied where one of the two by two cells up and
    left of it was. A ray too, which a real mapper draws a cell wide whatever the offset: on
    fans of rays the test is harsher than such a mapper.

    Examples
    --------
    >>> cells = np.array([[0, 0, 0], [0, 100, 0], [0, 0, -1]], np.int8)
    >>> grid, rooms = half_cell_over(OccupancyGrid(cells, 0.05), np.ones((3, 3), np.int32))
    >>> grid.cells.tolist(), rooms.tolist()
    ([[0, 0, 0], [0, 100, 100], [0, 100, 100]], [[1, 1, 1], [1, 0, 0], [1, 0, 0]])
    """
    split, split_rooms = resampled(grid, rooms, 0.5)
    cells = np.pad(split.cells, ((1, 0), (1, 0)), constant_values=UNKNOWN)[:-1]
    moved = np.pad(split_rooms, ((1, 0), (1, 0)))[:-1]
    return resampled(OccupancyGrid(cells, split.resolution, split.origin), moved, 2.0)


def thickened(
    grid: OccupancyGrid, rooms: NDArray[np.int32], cells: int
) -> tuple[OccupancyGrid, NDArray[np.int32]]:
    """``grid`` with every cell within ``cells`` of an occupied one (8-neighbourhood, free or
    unknown) occupied, and its people's ``rooms`` without those cells (people draw rooms on
    the free space).

    Examples
    --------
    >>> cells = np.array([[0, 0, 0, 0], [0, 100, 0, -1], [0, 0, 0, 0]], np.int8)
    >>> grid, rooms = thickened(OccupancyGrid(cells, 0.05), np.ones((3, 4), np.int32), 1)
    >>> grid.cells.tolist()
    [[100, 100, 100, 0], [100, 100, 100, -1], [100, 100, 100, 0]]
    >>> rooms.tolist()
    [[0, 0, 0, 1], [0, 0, 0, 1], [0, 0, 0, 1]]
    """
    if cells == 0:
        return grid, rooms
    grown = ndimage.binary_dilation(grid.occupied, np.ones((3, 3), bool), iterations=cells)
    walls = np.where(grown, OCCUPIED, grid.cells).astype(np.int8)
    return OccupancyGrid(walls, grid.resolution, grid.origin), np.where(grown, 0, rooms)


def resampled(
    grid: OccupancyGrid, rooms: NDArray[np.int32], factor: float
) -> tuple[OccupancyGrid, NDArray[np.int32]]:
    """``grid`` and its people's ``rooms`` on cells ``factor`` (2 or 0.5) times as large.

    Twice as large as a mapper would make the cell from the scans it had: occupied when a beam
    ended in one of its four cells, free when one crossed it and none ended there, unknown
    else; a room's cell takes the room most of its four cells are in (cells in no room left
    out: a laser ray people drew in a room is one cell of four), and none where it is
    occupied (people draw rooms on the free space). Half as large: each cell split in four.

    Examples
    --------
    >>> cells = np.array([[0, 0, 100, -1], [0, 0, -1, -1], [0, 100, -1, 0]], np.int8)
    >>> rooms = np.array([[3, 3, 3, 3], [0, 1, 2, 2], [0, 0, 2, 0]])
    >>> grid, rooms = resampled(OccupancyGrid(cells, 0.05), rooms, 2.0)  # the top row goes
    >>> grid.cells.tolist(), grid.resolution, rooms.tolist()  # (the origin is at the bottom)
    ([[100, 0]], 0.1, [[0, 2]])
    >>> resampled(OccupancyGrid(cells, 0.05), np.ones((3, 4), int), 0.5)[0].cells.shape
    (6, 8)
    """
    if factor == 1:
        return grid, rooms
    if factor == 0.5:
        finer = np.repeat(np.repeat(grid.cells, 2, axis=0), 2, axis=1)
        return (
            OccupancyGrid(finer, grid.resolution / 2, grid.origin),
            np.repeat(np.repeat(rooms, 2, axis=0), 2, axis=1),
        )
    if factor != 2:
        raise ValueError(f"cells are resampled 2 or 0.5 times as large, not {factor}")
    top, width = grid.shape[0] % 2, grid.shape[1] // 2 * 2  # the bottom row stays at the origin

    def four(cells: NDArray) -> NDArray:  # each block's four cells along the last axis
        blocks = cells[top:, :width]
        shape = (blocks.shape[0] // 2, 2, width // 2, 2)
        return blocks.reshape(shape).transpose(0, 2, 1, 3).reshape(*shape[::2], 4)

    occupied, free = four(grid.occupied).any(axis=-1), four(grid.free).any(axis=-1)
    cells = np.where(occupied, OCCUPIED, np.where(free, FREE, UNKNOWN)).astype(np.int8)
    labels = four(rooms)
    votes = (labels[..., :, None] == labels[..., None, :]).sum(axis=-1) * (labels > 0)
    most = np.take_along_axis(labels, votes.argmax(axis=-1)[..., None], axis=-1)[..., 0]
    return OccupancyGrid(cells, grid.resolution * 2, grid.origin), np.where(occupied, 0, most)


def rotated(cells: NDArray[np.integer], degrees: float, fill: int) -> NDArray[np.integer]:
    """``cells`` turned ``degrees`` counter-clockwise about their centre, nearest cell, on a
    canvas that holds all of them (``fill`` around).

    Examples
    --------
    >>> rotated(np.array([[1, 2], [3, 4]]), 90.0, 0).tolist()
    [[2, 4], [1, 3]]
    >>> rotated(np.ones((4, 4), int), 45.0, 0).shape
    (6, 6)
    """
    if degrees == 0:
        return cells
    return ndimage.rotate(cells, degrees, order=0, mode="constant", cval=fill, prefilter=False)


def turned(
    cells: NDArray[np.integer], degrees: float, fill: int, *, back: bool = False
) -> NDArray[np.integer]:
    """``cells`` turned ``degrees`` (:func:`rotated`), and turned back if ``back``: square
    with the cells again, but resampled twice to the nearest cell.

    Examples
    --------
    >>> room = np.zeros((40, 60), int)
    >>> room[10:30, 10:50] = 1
    >>> again = turned(room, 30.0, 0, back=True)
    >>> rows, cols = np.nonzero(again)  # square with the cells again, a cell off at most
    >>> int(np.ptp(rows)) + 1, int(np.ptp(cols)) + 1, round(int(again.sum()) / int(room.sum()), 2)
    (20, 41, 0.99)
    """
    once = rotated(cells, degrees, fill)
    return rotated(once, -degrees, fill) if back else once


def evaluate(
    plan: FloorPlan,
    *,
    shifts: tuple[tuple[int, int], ...] = ((0, 0),),
    rotations: tuple[float, ...] = (0.0,),
    cell_factors: tuple[float, ...] = (1.0,),
    grown_walls: tuple[int, ...] = (0,),
    half_cells: tuple[bool, ...] = (False,),
    **options: Any,
) -> list[dict[str, Any]]:
    """Segment one map with each method (the spectral partition, the door-rule baseline) and
    score both, and the released segmentation of another system when there is one.

    With ``rotations`` (degrees), the map and its people's rooms are turned alike
    (:func:`rotated`) and each turn is a record of its own (``rotation``), and another of
    them turned and turned back (``turned_back``: the resampling's own cost); so with
    ``cell_factors``, the map on cells that many times as large (:func:`resampled`,
    ``cell_factor``), with ``grown_walls`` its walls that many cells thicker
    (:func:`thickened`, ``grown_walls``), and with ``half_cells`` as a mapper whose cells fall
    half a cell over would draw it (:func:`half_cell_over`, ``half_cell_over``).

    With several ``shifts`` (cells added left and on top, :meth:`OccupancyGrid.padded`), each
    method segments the map once per shift and its scores are their means, with
    ``mcc_spread`` (largest minus smallest MCC): a map one cell over is the same building.
    ``seconds`` is the mean wall time of one segmentation call (:meth:`MapSegmenter.segment`:
    the region graph and names not included, like the anchors' segmentation-only times),
    ``cpu_seconds`` its processor time.

    Raises
    ------
    MapFormatError
        People's rooms of another size than the map, or none of more than
        :data:`~segmentation.metrics.MIN_PIXELS` pixels (an image of noise, all black): a map
        is never scored, and averaged, against no rooms.
    """
    grid, rooms = plan.grid(), plan.rooms()
    if rooms.shape != grid.shape:
        raise MapFormatError(
            f"people's rooms are {rooms.shape[1]} x {rooms.shape[0]} cells, its map "
            f"{plan.yaml} {grid.shape[1]} x {grid.shape[0]}",
            path=plan.truth,
        )
    sizes = np.bincount(rooms.ravel())[1:]
    if not (sizes > MIN_PIXELS).any():  # none at all, or noise: rooms the scores ignore
        raise MapFormatError(
            f"no room drawn of more than {MIN_PIXELS} pixels, the smallest the scores count "
            f"({np.count_nonzero(sizes)} smaller): nothing to score against",
            path=plan.truth,
        )
    return [
        record
        for factor in cell_factors
        for over in half_cells
        for grown in grown_walls
        for degrees in rotations
        for back in ((False, True) if degrees else (False,))
        for record in _evaluate_turned(
            plan,
            *_drawn(grid, rooms, factor, over, grown),
            degrees,
            back,
            shifts,
            options,
            {"cell_factor": factor, "grown_walls": grown, "half_cell_over": over},
        )
    ]


def _drawn(
    grid: OccupancyGrid, rooms: NDArray[np.int32], factor: float, over: bool, grown: int
) -> tuple[OccupancyGrid, NDArray[np.int32]]:
    """``grid`` and ``rooms`` on cells ``factor`` times as large, half a cell over if
    ``over``, their walls ``grown`` cells thicker."""
    grid, rooms = resampled(grid, rooms, factor)
    if over:
        grid, rooms = half_cell_over(grid, rooms)
    return thickened(grid, rooms, grown)


def _evaluate_turned(
    plan: FloorPlan,
    grid: OccupancyGrid,
    rooms: NDArray[np.int32],
    degrees: float,
    back: bool,
    shifts: tuple[tuple[int, int], ...],
    options: dict[str, Any],
    drawn: dict[str, Any],
) -> list[dict[str, Any]]:
    """Both methods' records of ``grid`` turned ``degrees`` (and turned back if ``back``),
    each with the ``drawn`` fields (how the map was redrawn, :func:`_drawn`); and the released
    segmentation's, scored on the map as given."""
    truth = turned(rooms, degrees, 0, back=back)
    if degrees:
        cells = turned(grid.cells, degrees, UNKNOWN, back=back)
        grid = OccupancyGrid(cells.astype(np.int8), grid.resolution)
    height, width = truth.shape
    records = []
    for method in ("spectral", "doors"):
        pipeline = pipeline_from_options({**options, "method": method})
        runs = []
        for left, top in shifts:
            wall, cpu = time.perf_counter(), time.process_time()
            found = pipeline.segment(grid.padded(left, top), random_state=0)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            labels = found.regions.labels[top : top + height, left : left + width]
            runs.append(
                {
                    "keyframes": len(found.keyframes),
                    "seconds": wall,
                    "cpu_seconds": cpu,
                    **_scores(labels, truth),
                }
            )
        record: dict[str, Any] = {
            "map": plan.name.removesuffix("_furnitures"),
            "furnished": plan.furnished,
            "variant": method,
            "rotation": degrees,
            "turned_back": back,
            **drawn,
        }
        for key, value in runs[0].items():
            mean = float(np.mean([run[key] for run in runs]))
            whole = isinstance(value, int) and len(runs) == 1
            record[key] = value if whole else round(mean, 3 if "seconds" in key else 4)
        if len(runs) > 1:
            mccs = [run["mcc"] for run in runs]
            record["mcc_spread"] = round(max(mccs) - min(mccs), 4)
        records.append(record)
    as_given = drawn == {"cell_factor": 1.0, "grown_walls": 0, "half_cell_over": False}
    if degrees == 0 and as_given and plan.released is not None:  # the other's, as released
        records.append(
            {
                "map": plan.name,
                "furnished": False,
                "variant": "rose2_released",
                "seconds": None,
                **_scores(read_rooms(plan.released), truth),
            }
        )
    return records


def evaluate_all(
    data_dir: str | Path,
    progress: Callable[[Iterator[FloorPlan]], Iterator[FloorPlan]] = iter,
    **options: Any,
) -> list[dict[str, Any]]:
    """:func:`evaluate` on every floor plan of ``data_dir`` (``options``: its ``shifts`` and
    the pipeline's settings).

    Raises
    ------
    TopomapError
        A map that cannot be read, segmented or scored: the error :func:`evaluate` raised, of
        the same type, its message led by the map's path when it does not name it already.
    """
    records = []
    for plan in progress(iter(floor_plans(data_dir))):
        try:
            records += evaluate(plan, **options)
        except TopomapError as err:
            if str(plan.yaml) in str(err):
                raise
            raise led_by(err, f"{plan.yaml}: {err}") from err
    return records


def read_anchors(data_dir: str | Path) -> list[dict[str, Any]]:
    """Rows of ``anchors.csv`` (other systems' scores), numbers parsed; [] if it is absent.

    Raises
    ------
    MapFormatError
        A row without a column the scores need, or a value that is no number (file, line and
        column named), or a file that is not text.
    """
    path = Path(data_dir) / "anchors.csv"
    if not path.exists():
        return []
    rows: list[dict[str, Any]] = []
    try:
        with path.open(encoding="utf-8") as stream:
            for line, row in enumerate(csv.DictReader(stream), start=2):
                rows.append(_anchor(row, path, line))
    except UnicodeDecodeError as err:
        raise MapFormatError(f"not UTF-8 text ({err.reason})", path=path) from None
    except csv.Error as err:  # a field over the csv module's limit, a NUL byte
        raise MapFormatError(f"not a CSV table ({err})", path=path) from None
    return rows


def _anchor(row: dict[str, str], path: Path, line: int) -> dict[str, Any]:
    """One row of ``anchors.csv`` as a record: ROSE²'s published scores (in %) or another
    system's on the ipa plans."""

    def value(column: str) -> str:
        found = row.get(column)
        if found is None:
            raise MapFormatError("missing", path=path, line=line, field=column)
        return found

    def number(column: str, lo: float = -100.0, hi: float = 100.0) -> float:
        text = value(column)
        try:
            found = float(text) if "_" not in text else math.nan  # float() reads 0_9 as 9
        except ValueError:
            found = math.nan
        if not math.isfinite(found) or not lo <= found <= hi:  # a score: %, or MCC in [-1, 1]
            raise MapFormatError(
                f"expected a number in [{lo:g}, {hi:g}], got {text[:40]!r}",
                path=path,
                line=line,
                field=column,
            )
        return found

    if "iou_mean_seg" in row:
        return {
            "map": value("map"),
            "furnished": False,
            "variant": value("method"),
            "rose2_precision": number("prec_micro"),
            "rose2_recall": number("rec_micro"),
            "rose2_iou": number("iou_mean_seg"),
            "seconds": None,
        }
    return {
        "map": value("map"),
        "furnished": value("furnished") == "1",
        "variant": value("method"),
        "recall": number("recall_micro"),
        "precision": number("precision_micro"),
        "mcc": number("mcc"),
        "seconds": number("runtime_s", 0.0, 1e6) if value("runtime_s") else None,
    }


def means(records: list[dict[str, Any]], anchors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean scores per (variant, furnished, rotation, turned back, cell factor, walls grown,
    half a cell over), ours and the anchors', over the maps we ran."""
    ours = {(r["map"], r["furnished"]) for r in records}
    rows = []
    for source in (records, [a for a in anchors if (a["map"], a["furnished"]) in ours]):
        groups: dict[tuple[str, bool, float, bool, float, int, bool], list[dict[str, Any]]] = {}
        for r in source:
            key = (
                r["variant"],
                r["furnished"],
                r.get("rotation", 0.0),
                r.get("turned_back", False),
                r.get("cell_factor", 1.0),
                r.get("grown_walls", 0),
                r.get("half_cell_over", False),
            )
            groups.setdefault(key, []).append(r)
        for (variant, furnished, degrees, back, factor, grown, over), group in groups.items():
            row: dict[str, Any] = {
                "method": variant,
                "furnished": furnished,
                "rotation": degrees,
                "turned_back": back,
                "cell_factor": factor,
                "grown_walls": grown,
                "half_cell_over": over,
                "maps": len(group),
            }
            for metric in METRICS:
                values = [g[metric] for g in group if metric in g]
                row[metric] = round(float(np.mean(values)), 3) if values else "-"
            mccs = [g["mcc"] for g in group if "mcc" in g]
            row["min_mcc"] = round(float(np.min(mccs)), 3) if mccs else "-"
            spreads = [g["mcc_spread"] for g in group if "mcc_spread" in g]
            row["mcc_spread"] = round(float(np.mean(spreads)), 3) if spreads else "-"
            times = [g["seconds"] for g in group if g.get("seconds") is not None]
            row["mean_s"] = round(float(np.mean(times)), 2) if times else "-"
            cpu = [g["cpu_seconds"] for g in group if "cpu_seconds" in g]
            row["mean_cpu_s"] = round(float(np.mean(cpu)), 2) if cpu else "-"
            row["max_cpu_s"] = round(float(np.max(cpu)), 2) if cpu else "-"
            row["max_s"] = round(float(np.max(times)), 2) if times else "-"
            rows.append(row)
    return sorted(
        rows,
        key=lambda r: (
            r["furnished"],
            r["method"],
            r["cell_factor"],
            r["half_cell_over"],
            r["grown_walls"],
            r["rotation"],
            r["turned_back"],
        ),
    )
