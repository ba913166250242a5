"""Shapes drawn by hand on the maps of the real logs, read and type-checked alike for every
evaluation that takes them: ``carmen.json`` (corridors and halls,
:func:`~topomap.cli.label_sources.drawn_truth`) and ``carmen_rooms.json`` (rooms,
:func:`~topomap.cli.evaluate_logs.drawn_rooms`). A shape that is no shape is refused in one
line naming the file, the log, the shape, its field and value (:func:`drawn_for`)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.errors import MapFileNotFoundError, MapFormatError
from maps.grid import OccupancyGrid


def read_drawn(
    drawn_json: str | Path, what: str = "drawn corridors JSON"
) -> dict[str, dict[str, Any]]:
    """The shapes drawn by hand per log (``carmen.json``: see
    :func:`~topomap.cli.label_sources.drawn_truth`; ``carmen_rooms.json``:
    :func:`~topomap.cli.evaluate_logs.drawn_rooms`), ``what`` naming the file in errors."""
    path = Path(drawn_json)
    if not path.exists():
        raise MapFileNotFoundError(path, what)
    try:
        drawn = json.loads(path.read_text())
    except (UnicodeDecodeError, ValueError, RecursionError) as error:  # 5000-digit numbers too
        raise MapFormatError(f"{path}: not a {what}: {str(error)[:200]}") from None
    if not isinstance(drawn, dict) or not all(
        isinstance(shapes, dict) and isinstance(shapes.get("log"), str) for shapes in drawn.values()
    ):
        raise MapFormatError(f"{path}: a {what} maps each log's name to its shapes and 'log'")
    return drawn


@contextmanager
def drawn_for(path: str | Path, log: str) -> Iterator[None]:
    """Within: a :class:`~maps.errors.MapFormatError` about the shapes drawn for ``log`` in
    the file ``path`` is led by both.

    Examples
    --------
    >>> with drawn_for("carmen.json", "intel"):
    ...     drawn_points([[0, 0]], 2, "corridor 1: its line")
    Traceback (most recent call last):
    ...
    maps.errors.MapFormatError: carmen.json: 'intel', corridor 1: its line needs at least 2 [x, y] points in metres, got [[0, 0]]
    """  # noqa: E501
    try:
        yield
    except MapFormatError as err:
        raise MapFormatError(f"{log!r:.40}, {err}", path=path) from None


def drawn_list(shapes: object, kind: str, fields: str) -> list[dict[str, Any]]:
    """``shapes`` as a list of objects (``kind``: what one is, ``fields``: its keys).

    Raises
    ------
    MapFormatError
        Naming the list or the first of its items that is not an object.

    Examples
    --------
    >>> drawn_list([{"width": 2}, 5], "corridor", "width, line")
    Traceback (most recent call last):
    ...
    maps.errors.MapFormatError: corridor 2 is no {width, line} object, got 5
    """
    if not isinstance(shapes, list):
        raise MapFormatError(f"the {kind}s are a list of {{{fields}}}, got {shapes!r:.80}")
    for number, shape in enumerate(shapes, 1):
        if not isinstance(shape, dict):
            raise MapFormatError(f"{kind} {number} is no {{{fields}}} object, got {shape!r:.80}")
    return shapes


def drawn_points(points: object, least: int, what: str) -> NDArray[np.float64]:
    """``points`` (``[[x, y], ...]`` in metres, at least ``least`` of them, all finite) as an
    array; ``what`` names them in the error.

    Examples
    --------
    >>> drawn_points([[0, 1], [2, 3.5]], 2, "line").tolist()
    [[0.0, 1.0], [2.0, 3.5]]
    >>> drawn_points([[0, 0], ["a", 1]], 2, "room 1: a polygon")
    Traceback (most recent call last):
    ...
    maps.errors.MapFormatError: room 1: a polygon needs at least 2 [x, y] points in metres, got [[0, 0], ['a', 1]]
    """  # noqa: E501
    try:
        xy = np.asarray(points if points is not None else [], float)
    except (TypeError, ValueError, OverflowError, RecursionError):  # ragged, text, 400 digits
        xy = np.zeros(0)
    if xy.ndim != 2 or xy.shape[1] != 2 or len(xy) < least or not np.isfinite(xy).all():
        raise MapFormatError(
            f"{what} needs at least {least} [x, y] points in metres, got {points!r:.80}"
        )
    return xy


def drawn_cells(
    grid: OccupancyGrid, xy: NDArray[np.float64], *, closed: bool = True
) -> list[NDArray[np.int32]]:
    """The polygon ``xy`` (metres; a line unless ``closed``) as OpenCV draws it on ``grid``:
    the ``(col, row)`` cells of its parts on the map (:func:`_on_map`).

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((10, 20), np.int8), 0.5)  # 10 x 5 m
    >>> drawn_cells(grid, np.array([[0.2, 0.2], [1e12, 0.2]]), closed=False)[0].tolist()
    [[0, 9], [22, 9]]
    """
    parts = _on_map(xy, grid.bounds(), closed=closed)
    found = [grid.world_to_cell(part[:, 0], part[:, 1]) for part in parts]
    return [np.column_stack([cols, rows]).astype(np.int32) for rows, cols in found]


def _on_map(
    xy: NDArray[np.float64], box: tuple[float, float, float, float], *, closed: bool = True
) -> list[NDArray[np.float64]]:
    """The polygon ``xy`` (metres; a line unless ``closed``) as it is drawn on a map of
    bounds ``box``: itself when it lies within a metre of them (the shapes people draw, slits
    and all), else its parts within them (a vertex a million kilometres off would be drawn
    across the whole plane, or past the range of the drawing's integer cells).

    Examples
    --------
    >>> square = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    >>> _on_map(square, (0, 0, 10, 10))[0] is square
    True
    >>> far = np.array([[0.0, 0.0], [1e12, 0.0], [0.0, 2.0]])
    >>> float(np.abs(_on_map(far, (0, 0, 10, 10))[0]).max()) <= 11
    True
    >>> _on_map(far[:2], (0, 0, 10, 10), closed=False)[0].tolist()
    [[0.0, 0.0], [11.0, 0.0]]
    """
    x0, y0, x1, y1 = box
    low, high = xy.min(axis=0), xy.max(axis=0)
    if low[0] >= x0 - 1 and low[1] >= y0 - 1 and high[0] <= x1 + 1 and high[1] <= y1 + 1:
        return [xy]
    import shapely

    shape = shapely.Polygon(xy).buffer(0) if closed else shapely.LineString(xy)
    inside = shape.intersection(shapely.box(x0 - 1, y0 - 1, x1 + 1, y1 + 1))
    kind = shapely.Polygon if closed else shapely.LineString
    return [
        np.asarray((part.exterior if closed else part).coords)
        for part in getattr(inside, "geoms", [inside])
        if isinstance(part, kind) and not part.is_empty
    ]
