"""ROS map_server maps: a YAML description plus an image (PGM, PNG...).

Follows ROS 1 map_server's ``image_loader`` and map_saver: the image path is relative to the
YAML file, row 0 of the image is the top of the map, ``mode`` is trinary (default), scale or
raw, ``negate`` inverts the grey values, and a pixel is occupied when
``(255 - grey) / 255 > occupied_thresh``, free when it is below ``free_thresh``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml
from numpy.typing import NDArray

from maps.errors import MapFileNotFoundError, MapFormatError, OutputExistsError
from maps.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid

MODES = ("trinary", "scale", "raw")
#: Grey values map_saver writes for free, occupied and unknown cells in trinary mode.
SAVED_FREE, SAVED_OCCUPIED, SAVED_UNKNOWN = 254, 0, 205
SAVED_THRESHOLDS = {"occupied_thresh": 0.65, "free_thresh": 0.196}


def cells_from_image(
    image: NDArray[np.uint8],
    *,
    mode: str = "trinary",
    negate: bool = False,
    occupied_thresh: float = 0.65,
    free_thresh: float = 0.196,
) -> NDArray[np.int8]:
    """Occupancy values (-1..100) of an 8-bit image, exactly as map_server computes them.

    Colour channels are averaged with integer division. A last alpha channel (2 or 4
    channels) is never averaged in (map_server averages it in trinary mode, a legacy quirk that
    turns grey 245 with opaque alpha into free space and breaks the rule "grey >= 250 is free"
    of the room-segmentation benchmark); in scale mode a fully transparent pixel is unknown.
    """
    if mode not in MODES:
        raise MapFormatError(f"unknown mode {mode!r}, expected one of {MODES}", field="mode")
    pixels = np.asarray(image)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    channels = pixels.shape[2]
    has_alpha = channels in (2, 4)
    averaged = channels - 1 if has_alpha else channels
    grey = pixels[:, :, :averaged].astype(np.int32).sum(axis=2) // averaged
    alpha = pixels[:, :, -1] if has_alpha else np.full(grey.shape, 255)
    if negate:
        grey = 255 - grey
    if mode == "raw":
        return np.where(grey <= OCCUPIED, grey, UNKNOWN).astype(np.int8)
    occ = (255 - grey) / 255.0
    cells = np.full(grey.shape, UNKNOWN, np.int8)
    cells[occ > occupied_thresh] = OCCUPIED
    cells[occ < free_thresh] = FREE
    if mode == "scale":
        between = (occ <= occupied_thresh) & (occ >= free_thresh) & (alpha > 0)
        ratio = (occ[between] - free_thresh) / (occupied_thresh - free_thresh)
        cells[between] = (1 + 98 * ratio).astype(np.int8)
    return cells


def read_image(path: str | Path, *, field: str | None = None) -> NDArray[np.uint8]:
    """An image file as 8-bit pixels (16-bit images keep their high byte).

    Raises
    ------
    MapFileNotFoundError
        If the file does not exist.
    MapFormatError
        If it is not an image OpenCV can decode.
    """
    path = Path(path)
    if not path.is_file():
        raise MapFileNotFoundError(path, "image")
    pixels = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if pixels is None:
        raise MapFormatError("not an image OpenCV can read", path=path, field=field)
    if pixels.dtype == np.uint16:
        pixels = (pixels.astype(np.uint16) >> 8).astype(np.uint8)
    if pixels.dtype != np.uint8:
        raise MapFormatError(f"unsupported pixel type {pixels.dtype}", path=path, field=field)
    if pixels.ndim == 3 and pixels.shape[2] >= 3:  # OpenCV gives BGR(A); keep RGB(A) order
        pixels = pixels[:, :, [2, 1, 0, *range(3, pixels.shape[2])]]
    return np.ascontiguousarray(pixels)


def grid_from_image(
    image: str | Path | NDArray[np.uint8],
    resolution: float,
    *,
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
    mode: str = "trinary",
    negate: bool = False,
    occupied_thresh: float = 0.65,
    free_thresh: float = 0.196,
) -> OccupancyGrid:
    """An occupancy grid from an image file or an 8-bit array and a resolution in metres."""
    pixels = read_image(image) if isinstance(image, str | Path) else np.asarray(image)
    if pixels.dtype != np.uint8:
        raise MapFormatError(f"an image array must be uint8, got {pixels.dtype}")
    cells = cells_from_image(
        pixels, mode=mode, negate=negate, occupied_thresh=occupied_thresh, free_thresh=free_thresh
    )
    return OccupancyGrid(cells, resolution, origin)


def _number(doc: dict[str, Any], key: str, path: Path, lo: float, hi: float) -> float:
    if key not in doc:
        raise MapFormatError("required field is missing", path=path, field=key)
    value = doc[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapFormatError(f"expected a number, got {value!r}", path=path, field=key)
    if not lo <= value <= hi:
        raise MapFormatError(f"{value!r} is outside [{lo}, {hi}]", path=path, field=key)
    return float(value)


def _parse_yaml(path: Path) -> dict[str, Any]:
    try:
        doc = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = None if mark is None else mark.line + 1
        raise MapFormatError(f"not valid YAML ({err})", path=path, line=line) from err
    except UnicodeDecodeError as err:
        raise MapFormatError("not a text file", path=path) from err
    if not isinstance(doc, dict):
        raise MapFormatError("expected a mapping of map_server fields", path=path)
    return doc


def load_map(path: str | Path) -> OccupancyGrid:
    """Read a ROS map_server map: the YAML at ``path`` and the image it names.

    Raises
    ------
    MapFileNotFoundError
        If the YAML or its image does not exist.
    MapFormatError
        If a field is missing or wrong (named in the message) or the image is unreadable.
    """
    path = Path(path)
    if not path.is_file():
        raise MapFileNotFoundError(path, "map YAML")
    doc = _parse_yaml(path)
    image = doc.get("image")
    if not isinstance(image, str) or not image:
        raise MapFormatError(
            f"expected an image file name, got {image!r}", path=path, field="image"
        )
    resolution = _number(doc, "resolution", path, 1e-9, math.inf)
    occupied = _number(doc, "occupied_thresh", path, 0.0, 1.0)
    free = _number(doc, "free_thresh", path, 0.0, 1.0)
    if free > occupied:
        raise MapFormatError(
            f"free_thresh {free} is above occupied_thresh {occupied}",
            path=path,
            field="free_thresh",
        )
    negate = doc.get("negate")
    if negate not in (0, 1):  # True and False compare equal to 1 and 0
        raise MapFormatError(f"expected 0 or 1, got {negate!r}", path=path, field="negate")
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise MapFormatError(f"expected one of {MODES}, got {mode!r}", path=path, field="mode")
    origin = doc.get("origin")
    if (
        not isinstance(origin, list)
        or len(origin) != 3
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in origin)
        or not all(math.isfinite(v) for v in origin)
    ):
        raise MapFormatError(f"expected [x, y, yaw], got {origin!r}", path=path, field="origin")
    image_path = Path(image) if Path(image).is_absolute() else path.parent / image
    pixels = read_image(image_path, field="image")
    cells = cells_from_image(
        pixels, mode=mode, negate=bool(negate), occupied_thresh=occupied, free_thresh=free
    )
    return OccupancyGrid(cells, resolution, (float(origin[0]), float(origin[1]), float(origin[2])))


def save_map(grid: OccupancyGrid, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``grid`` as map_server YAML at ``path`` and a PGM image beside it.

    Trinary grids (cells only -1, 0, 100) are written as map_saver does (254 free, 0 occupied,
    205 unknown); grids with other occupancy values in raw mode, so every grid reads back equal.

    Raises
    ------
    OutputExistsError
        If the YAML or image exists and ``overwrite`` is False (a ``FileExistsError``).
    """
    path = Path(path)
    image_path = path.with_suffix(".pgm")
    for target in (path, image_path):
        if target.exists() and not overwrite:
            raise OutputExistsError(target)
    cells = grid.cells
    if np.isin(cells, (UNKNOWN, FREE, OCCUPIED)).all():
        pixels = np.full(cells.shape, SAVED_UNKNOWN, np.uint8)
        pixels[cells == FREE] = SAVED_FREE
        pixels[cells == OCCUPIED] = SAVED_OCCUPIED
        mode, thresholds = "trinary", SAVED_THRESHOLDS
    else:
        pixels = np.where(cells == UNKNOWN, 255, cells).astype(np.uint8)
        mode, thresholds = "raw", SAVED_THRESHOLDS
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(image_path), pixels):
        raise OSError(f"could not write {image_path}")
    doc = {
        "image": image_path.name,
        "mode": mode,
        "resolution": grid.resolution,
        "origin": list(grid.origin),
        "negate": 0,
        **thresholds,
    }
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path
