"""ROS map_server maps: a YAML description plus an image (PGM, PNG...).

Follows ROS 1 map_server's ``image_loader`` and map_saver: the image path is relative to the
YAML file, row 0 of the image is the top of the map, ``mode`` is trinary (default), scale or
raw, ``negate`` inverts the grey values, and a pixel is occupied when
``(255 - grey) / 255 > occupied_thresh``, free when it is below ``free_thresh``.
"""

from __future__ import annotations

import errno
import os
import re
import stat
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import yaml
from numpy.typing import NDArray

from maps.errors import FormatError, MapFileNotFoundError, MapFormatError
from maps.files import check_output_file, written
from maps.grid import FREE, OCCUPIED, UNKNOWN, OccupancyGrid
from maps.limits import MAX_COORDINATE, RESOLUTION_RANGE, check_map_size, finite_in

MODES = ("trinary", "scale", "raw")
#: Grey values map_saver writes for free, occupied and unknown cells in trinary mode.
SAVED_FREE, SAVED_OCCUPIED, SAVED_UNKNOWN = 254, 0, 205
SAVED_THRESHOLDS = {"occupied_thresh": 0.65, "free_thresh": 0.196}
#: A saved map's pixel by its cell's byte (-1 is 255) when the map is trinary; the others
#: are given :data:`_NOT_TRINARY`, which no trinary pixel is.
_NOT_TRINARY = 1
_TRINARY_PIXELS = np.full(256, _NOT_TRINARY, np.uint8)
_TRINARY_PIXELS[[UNKNOWN % 256, FREE, OCCUPIED]] = SAVED_UNKNOWN, SAVED_FREE, SAVED_OCCUPIED


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

    Raises
    ------
    MapFormatError
        An unknown mode, thresholds out of order, or an image that is not a uint8 array of
        rows x columns (x 1-4 channels).
    """
    if mode not in MODES:
        raise MapFormatError(f"unknown mode {mode!r}, expected one of {MODES}", field="mode")
    if negate not in (0, 1):  # True and False compare equal to 1 and 0
        raise MapFormatError(f"expected 0 or 1, got {negate!r}", field="negate")
    for name, value in (("occupied_thresh", occupied_thresh), ("free_thresh", free_thresh)):
        problem = finite_in(value, name, 0.0, 1.0)
        if problem is not None:
            raise MapFormatError(problem, field=name)
    problem = _order_problem(mode, occupied_thresh, free_thresh)
    if problem is not None:
        raise MapFormatError(problem, field="free_thresh")
    pixels = np.asarray(image)
    if pixels.ndim not in (2, 3) or (pixels.ndim == 3 and not 1 <= pixels.shape[2] <= 4):
        raise MapFormatError(
            f"an image is rows x columns (x 1-4 channels), got shape {pixels.shape}",
            field="image",
        )
    if pixels.dtype != np.uint8:  # a 16-bit grey would index past the table
        raise MapFormatError(f"an image array must be uint8, got {pixels.dtype}", field="image")
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    channels = pixels.shape[2]
    has_alpha = channels in (2, 4)
    averaged = channels - 1 if has_alpha else channels
    total = pixels[:, :, 0].astype(np.uint16)  # the sum of the colour channels
    for channel in range(1, averaged):
        total += pixels[:, :, channel]
    # every sum's cell, looked up: the arithmetic on the 256 grey values, not on every pixel
    grey = np.arange(255 * averaged + 1) // averaged
    table = _cell_table(grey, mode, negate, occupied_thresh, free_thresh)
    if averaged == 1:  # OpenCV's lookup, 5x numpy's gather
        grey_pixels = np.ascontiguousarray(pixels[:, :, 0])
        cells = cv2.LUT(grey_pixels, table.view(np.uint8)).view(np.int8)
    else:
        cells = table[total]
    if mode == "scale" and has_alpha:  # a fully transparent pixel is unknown
        transparent = pixels[:, :, -1] == 0
        trinary = _cell_table(grey, "trinary", negate, occupied_thresh, free_thresh)
        cells[transparent] = trinary[total[transparent]]
    return cells


def _order_problem(mode: str, occupied_thresh: float, free_thresh: float) -> str | None:
    """What is wrong with the thresholds' order in ``mode``, or None: ``free_thresh`` above
    ``occupied_thresh``, or equal to it in scale mode (a grey on both would be scaled by
    0 / 0, which map_server leaves undefined)."""
    if free_thresh > occupied_thresh:
        return f"free_thresh {free_thresh} is above occupied_thresh {occupied_thresh}"
    if mode == "scale" and free_thresh == occupied_thresh:
        return (
            f"free_thresh {free_thresh} equals occupied_thresh: scale mode has no range to "
            "scale between them"
        )
    return None


def _cell_table(
    grey: NDArray[np.int64], mode: str, negate: bool, occupied_thresh: float, free_thresh: float
) -> NDArray[np.int8]:
    """The occupancy value of each ``grey`` value (an opaque pixel), map_server's rule."""
    if negate:
        grey = 255 - grey
    if mode == "raw":
        return np.where(grey <= OCCUPIED, grey, UNKNOWN).astype(np.int8)
    occ = (255 - grey) / 255.0
    cells = np.full(grey.shape, UNKNOWN, np.int8)
    cells[occ > occupied_thresh] = OCCUPIED
    cells[occ < free_thresh] = FREE
    if mode == "scale":
        between = (occ <= occupied_thresh) & (occ >= free_thresh)
        ratio = (occ[between] - free_thresh) / (occupied_thresh - free_thresh)
        cells[between] = (1 + 98 * ratio).astype(np.int8)
    return cells


PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: How image files begin (PNG, JPEG, TIFF; a PBM/PGM/PPM: ``P1``..``P6`` and a space): a map
#: given as its image alone is named as such, not read as a YAML that is no text.
IMAGE_SIGNATURE = re.compile(
    re.escape(PNG_SIGNATURE) + rb"|\xff\xd8\xff|II\*\x00|MM\x00\*|P[1-6]\s+[#\d]"
)
#: Bytes a map_server YAML may have (a real one has a few hundred).
MAX_YAML_BYTES = 1 << 20
#: Bytes of a PBM/PGM/PPM header (its comments included) read to learn the image's size.
MAX_PNM_HEADER_BYTES = 1 << 20
#: Digits a PBM/PGM/PPM header's width, height or maxval may have: no map is 10^10 cells wide
#: (:data:`maps.limits.MAX_CELLS`), and a longer number is never turned into a huge integer.
MAX_PNM_DIGITS = 10

_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a device"),
    (stat.S_ISBLK, "a device"),
    (stat.S_ISSOCK, "a socket"),
)


def _unreadable(
    path: Path, field: str | None, err: OSError, error: type[FormatError] = MapFormatError
) -> FormatError:
    return error(f"cannot be read ({err.strerror or err})", path=path, field=field)


def check_input_file(
    path: str | Path,
    what: str = "file",
    *,
    field: str | None = None,
    error: type[FormatError] = MapFormatError,
) -> Path:
    """``path`` as a :class:`~pathlib.Path` once it is known to be a regular file this user
    may read (opened and closed: a FIFO or a device is never opened).

    Raises
    ------
    MapFileNotFoundError
        Nothing is at ``path`` (``what`` names it).
    MapFormatError
        A folder, FIFO or device is, or it cannot be opened (no permission, a name too long);
        ``error`` instead, when given (a log's :class:`~maps.errors.LogFormatError`).
    """
    if not isinstance(path, str | os.PathLike):
        raise error(f"{what} must be a path, got {path!r}", field=field)
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        raise MapFileNotFoundError(path, what) from None
    except OSError as err:
        raise _unreadable(path, field, err, error) from None
    except ValueError as err:  # a NUL byte in the name
        raise error(
            f"{what} path cannot be used ({err})", path=repr(str(path)), field=field
        ) from None
    if not stat.S_ISREG(mode):
        kind = next((name for test, name in _KINDS if test(mode)), "not a file")
        raise error(f"{what} is {kind}, not a regular file", path=path, field=field)
    try:
        path.open("rb").close()
    except OSError as err:
        raise _unreadable(path, field, err, error) from None
    return path


def _pnm_header(data: bytes, path: Path) -> tuple[str, int, int, int, int]:
    """``(magic, width, height, maxval, offset of the pixels)`` of a PBM/PGM/PPM header."""
    magic = data[:2].decode("ascii")
    wanted = 2 if magic in ("P1", "P4") else 3
    values: list[int] = []
    at = 2
    while len(values) < wanted:
        while at < len(data) and data[at : at + 1].isspace():
            at += 1
        if data[at : at + 1] == b"#":
            while at < len(data) and data[at : at + 1] not in (b"\n", b"\r"):
                at += 1
            continue
        start = at
        while at < len(data) and data[at : at + 1].isdigit():
            at += 1
        name = ("width", "height", "maxval")[len(values)]
        if start == at and at >= len(data) >= MAX_PNM_HEADER_BYTES:
            raise MapFormatError(
                f"{magic} header runs past {MAX_PNM_HEADER_BYTES} bytes before its {name} "
                "(comments that long are not read)",
                path=path,
                field="image",
            )
        if start == at:
            raise MapFormatError(f"{magic} header has no {name}", path=path, field="image")
        if at - start > MAX_PNM_DIGITS:
            raise MapFormatError(
                f"{magic} header's {name} has {at - start} digits (at most {MAX_PNM_DIGITS})",
                path=path,
                field="image",
            )
        values.append(int(data[start:at]))
    maxval = values[2] if wanted == 3 else 1
    if not 1 <= maxval <= 65535:
        raise MapFormatError(f"maxval must lie in 1..65535, got {maxval}", path=path, field="image")
    return magic, values[0], values[1], maxval, at + 1


def image_size(path: str | Path, *, field: str | None = None) -> tuple[int, int] | None:
    """``(height, width)`` of a PNG or PBM/PGM/PPM image from its header alone (nothing is
    decoded), or None for other formats."""
    path = Path(path)
    try:
        with path.open("rb") as stream:
            head = stream.read(4096)
            if head[:1] == b"P":  # a header's comments may be long
                head += stream.read(MAX_PNM_HEADER_BYTES - len(head))
    except OSError as err:
        raise _unreadable(path, field, err) from None
    if head.startswith(PNG_SIGNATURE) and len(head) >= 24 and head[12:16] == b"IHDR":
        return int.from_bytes(head[20:24], "big"), int.from_bytes(head[16:20], "big")
    if len(head) >= 2 and head[:1] == b"P" and head[1:2] in b"123456":
        _, width, height, _, _ = _pnm_header(head, path)
        return height, width
    return None


def _read_pnm(path: Path, field: str | None) -> NDArray[np.uint8] | None:
    """A grey or colour PGM/PPM image scaled by its maxval to 0..255 as ROS map_server does
    (OpenCV reads a binary PGM of maxval 100 unscaled: its white would be occupied); None for
    other files, which OpenCV reads."""
    try:
        data = path.read_bytes()
    except OSError as err:
        raise _unreadable(path, field, err) from None
    if data[:2] not in (b"P2", b"P3", b"P5", b"P6"):
        return None
    magic, width, height, maxval, offset = _pnm_header(data, path)
    channels = 3 if magic in ("P3", "P6") else 1
    count = width * height * channels
    if count == 0:
        raise MapFormatError(f"image of {width} x {height} pixels is empty", path=path, field=field)
    if magic in ("P5", "P6"):
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
        if len(data) - offset < count * dtype.itemsize:
            raise MapFormatError(
                f"image data is cut short: {max(0, len(data) - offset)} bytes, expected "
                f"{count * dtype.itemsize} for {width} x {height} pixels",
                path=path,
                field=field,
            )
        values = np.frombuffer(data, dtype, count, offset).astype(np.int64)
    else:
        body = data[offset - 1 :].splitlines()
        tokens = [token for line in body for token in line.split(b"#")[0].split()]
        if len(tokens) < count or not all(token.isdigit() for token in tokens[:count]):
            raise MapFormatError(
                f"image data is cut short or not numbers: expected {count} values",
                path=path,
                field=field,
            )
        longest = max(tokens[:count], key=lambda token: len(token.lstrip(b"0")))
        if len(longest.lstrip(b"0")) > 5:  # above any maxval, and perhaps any int64
            raise MapFormatError(
                f"pixel value {_short(longest.decode())} is above maxval {maxval}",
                path=path,
                field=field,
            )
        values = np.array(tokens[:count], dtype=np.int64)
    if values.max() > maxval:
        raise MapFormatError(
            f"pixel value {int(values.max())} is above maxval {maxval}", path=path, field=field
        )
    if maxval == 65535:
        values = values >> 8
    elif maxval != 255:
        values = values * 255 // maxval
    shape = (height, width) if channels == 1 else (height, width, channels)
    return values.astype(np.uint8).reshape(shape)


def read_image(path: str | Path, *, field: str | None = None) -> NDArray[np.uint8]:
    """An image file as 8-bit pixels: 16-bit images keep their high byte, PGM and PPM images
    are scaled by their maxval (as ROS map_server does).

    The size in the header is checked before anything is decoded
    (:func:`maps.limits.check_map_size`).

    Raises
    ------
    MapFileNotFoundError
        If the file does not exist.
    MapFormatError
        If it is not a regular file this user may read, not an image OpenCV can decode, or
        is cut short.
    MapTooLargeError
        If its header asks for more pixels than this machine can hold.
    """
    path = check_input_file(path, "image", field=field)
    size = image_size(path, field=field)
    if size is not None:
        check_map_size(*size, what="image", path=path, field=field)
    scaled = _read_pnm(path, field)
    if scaled is not None:
        return scaled
    try:
        pixels = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    except cv2.error as err:  # a header over OpenCV's own limits
        reason = str(err).strip().splitlines()[-1]
        raise MapFormatError(f"OpenCV cannot read it: {reason}", path=path, field=field) from None
    if pixels is None:
        raise MapFormatError("not an image OpenCV can read", path=path, field=field)
    if pixels.dtype == np.uint16:
        pixels = (pixels.astype(np.uint16) >> 8).astype(np.uint8)
    if pixels.dtype != np.uint8:
        raise MapFormatError(f"unsupported pixel type {pixels.dtype}", path=path, field=field)
    if pixels.ndim == 3 and pixels.shape[2] in (3, 4):  # OpenCV gives BGR(A); keep RGB(A)
        swap = cv2.COLOR_BGR2RGB if pixels.shape[2] == 3 else cv2.COLOR_BGRA2RGBA
        pixels = cv2.cvtColor(pixels, swap)
    elif pixels.ndim == 3 and pixels.shape[2] > 4:
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
    pixels = read_image(image) if isinstance(image, str | Path) else image
    cells = cells_from_image(
        pixels, mode=mode, negate=negate, occupied_thresh=occupied_thresh, free_thresh=free_thresh
    )
    return OccupancyGrid(cells, resolution, origin)


def _number(doc: dict[str, Any], key: str, path: Path, lo: float, hi: float) -> float:
    if key not in doc:
        raise MapFormatError("required field is missing", path=path, field=key)
    value = _yaml_number(doc[key])
    if isinstance(value, str):
        raise MapFormatError(f"expected a number, got {_short(repr(value))}", path=path, field=key)
    problem = finite_in(value, key, lo, hi)
    if problem is not None:
        raise MapFormatError(_short(problem), path=path, field=key)
    return float(value)


def _yaml_number(value: Any) -> Any:
    """``value``, a string that is a number read as one: map_server's yaml-cpp reads "1e-3"
    as a number, PyYAML as a string (it wants "1.0e-3"). Anything else as it is.

    Examples
    --------
    >>> _yaml_number("1e3"), _yaml_number("-2.5e-1"), _yaml_number("abc"), _yaml_number([1])
    (1000.0, -0.25, 'abc', [1])
    """
    if isinstance(value, str) and "_" not in value:
        try:
            return float(value)
        except ValueError:
            pass
    return value


def _short(text: str, limit: int = 200) -> str:
    """``text`` on one line, long values cut (a 400-digit number is named, not printed)."""
    line = " ".join(text.split())
    return line if len(line) <= limit else line[: limit - 3] + "..."


class _PlainLoader(yaml.SafeLoader):
    """PyYAML's safe loader without aliases (``*name``): a map YAML never repeats a node,
    and a few lines of nested aliases expand to billions of items once a message prints the
    value (a YAML bomb)."""

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            raise yaml.composer.ComposerError(
                None, None, "aliases (*name) are not allowed", self.peek_event().start_mark
            )
        return super().compose_node(parent, index)

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        """The mapping, a key written twice refused (PyYAML keeps the last value, map_server's
        yaml-cpp the first)."""
        lines: dict[Any, int] = {}
        for key_node, _ in node.value:
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag.endswith(":merge"):
                continue  # a collection as a key is refused as unhashable; << merges
            key = self.construct_object(key_node)
            if key in lines:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping",
                    node.start_mark,
                    f"found key {key!r} twice (first on line {lines[key]})",
                    key_node.start_mark,
                )
            lines[key] = key_node.start_mark.line + 1
        return super().construct_mapping(node, deep)


def parse_yaml(path: str | Path, *, limit: int = MAX_YAML_BYTES) -> Any:
    """The data of a small YAML file (data only, as ``safe_load`` reads it, without
    aliases), every failure a one-line :class:`MapFormatError` naming the file and line.

    Examples
    --------
    >>> import tempfile
    >>> bomb = Path(tempfile.mkdtemp()) / "map.yaml"
    >>> _ = bomb.write_text("a: &a [x, x]" + chr(10) + "b: [*a, *a]" + chr(10))
    >>> parse_yaml(bomb)
    Traceback (most recent call last):
    ...
    maps.errors.MapFormatError: ...map.yaml, line 2: not valid YAML: aliases (*name) are not allowed
    """
    path = check_input_file(path, "YAML")
    size = path.stat().st_size
    if size > limit:
        raise MapFormatError(
            f"{size} bytes is too large for a map YAML (at most {limit})", path=path
        )
    try:
        return yaml.load(path.read_text(encoding="utf-8"), Loader=_PlainLoader)
    except OSError as err:
        raise _unreadable(path, None, err) from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        line = None if mark is None else mark.line + 1
        problem = getattr(err, "problem", None) or str(err)
        context = getattr(err, "context", None)
        start = getattr(err, "context_mark", None)
        if context and start is not None:
            context = f"{context} (from line {start.line + 1})"
        what = f"{context}, {problem}" if context else problem
        raise MapFormatError(f"not valid YAML: {_short(what)}", path=path, line=line) from None
    except RecursionError:
        raise MapFormatError("not valid YAML: nested too deeply", path=path) from None
    except UnicodeDecodeError:
        raise MapFormatError("not a text file", path=path) from None
    except (ValueError, OverflowError) as err:  # an integer of thousands of digits
        what = str(err).split(";")[0]  # not Python's advice on sys.set_int_max_str_digits
        raise MapFormatError(f"not valid YAML: {_short(what)}", path=path) from None


def _parse_yaml(path: Path) -> dict[str, Any]:
    try:
        with path.open("rb") as stream:
            head = stream.read(8)
    except OSError as err:
        raise _unreadable(path, None, err) from None
    if IMAGE_SIGNATURE.match(head):
        raise MapFormatError(
            "an image, not a map YAML: write a map_server YAML that names it with its "
            "resolution and origin",
            path=path,
        )
    doc = parse_yaml(path)
    if not isinstance(doc, dict):
        raise MapFormatError("expected a mapping of map_server fields", path=path)
    return doc


def _image_of(doc: dict[str, Any], path: Path) -> tuple[str, Path]:
    """The ``image`` field of the map YAML at ``path`` and the file it names (relative to the
    YAML, as map_server reads it)."""
    image = doc.get("image")
    if not isinstance(image, str) or not image or not image.isprintable():
        raise MapFormatError(
            f"expected an image file name, got {image!r}", path=path, field="image"
        )
    return image, Path(image) if Path(image).is_absolute() else path.parent / image


def map_files(path: str | Path) -> tuple[Path, Path]:
    """The files a map is read from: the YAML at ``path`` and the image it names (which
    need not exist yet: :func:`load_map` says so).

    Raises
    ------
    MapFileNotFoundError, MapFormatError
        As :func:`load_map` does for the YAML and its ``image`` field.
    """
    path = check_input_file(path, "map YAML")
    return path, _image_of(_parse_yaml(path), path)[1]


def load_map(path: str | Path) -> OccupancyGrid:
    """Read a ROS map_server map: the YAML at ``path`` and the image it names.

    Raises
    ------
    MapFileNotFoundError
        If the YAML or its image does not exist.
    MapFormatError
        If either is not a regular file this user may read, a field is missing or wrong
        (named in the message) or the image is unreadable.
    """
    path = check_input_file(path, "map YAML")
    doc = _parse_yaml(path)
    image, image_path = _image_of(doc, path)
    resolution = _number(doc, "resolution", path, *RESOLUTION_RANGE)
    occupied = _number(doc, "occupied_thresh", path, 0.0, 1.0)
    free = _number(doc, "free_thresh", path, 0.0, 1.0)
    negate = doc.get("negate")
    if negate not in (0, 1):  # True and False compare equal to 1 and 0
        raise MapFormatError(f"expected 0 or 1, got {negate!r}", path=path, field="negate")
    mode = doc.get("mode", "trinary")
    if mode not in MODES:
        raise MapFormatError(f"expected one of {MODES}, got {mode!r}", path=path, field="mode")
    problem = _order_problem(mode, occupied, free)
    if problem is not None:
        raise MapFormatError(problem, path=path, field="free_thresh")
    origin = doc.get("origin")
    if isinstance(origin, list):
        origin = [_yaml_number(v) for v in origin]
    if (
        not isinstance(origin, list)
        or len(origin) != 3
        or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in origin)
        or any(finite_in(v, "origin", -MAX_COORDINATE, MAX_COORDINATE) for v in origin)
    ):
        raise MapFormatError(
            _short(f"expected [x, y, yaw] within {MAX_COORDINATE:g} m, got {origin!r}"),
            path=path,
            field="origin",
        )
    check_input_file(image_path, f"image {image!r} of {path}", field="image")
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
    path = check_output_file(path, overwrite=overwrite)
    image_path = path.with_suffix(".pgm")
    check_output_file(image_path, overwrite=overwrite)
    cells = grid.cells
    pixels = cv2.LUT(cells.view(np.uint8), _TRINARY_PIXELS)  # a table lookup per cell
    if not (pixels == _NOT_TRINARY).any():
        mode, thresholds = "trinary", SAVED_THRESHOLDS
    else:
        pixels = np.where(cells == UNKNOWN, 255, cells).astype(np.uint8)
        mode, thresholds = "raw", SAVED_THRESHOLDS
    doc = {
        "image": image_path.name,
        "mode": mode,
        "resolution": grid.resolution,
        "origin": list(grid.origin),
        "negate": 0,
        **thresholds,
    }
    with written(image_path, overwrite=overwrite) as partial:
        if not cv2.imwrite(str(partial), pixels):
            raise OSError(errno.EIO, "the image encoder wrote nothing")
    with written(path, overwrite=overwrite) as partial:
        partial.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path
