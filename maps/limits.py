"""Bounds on every size, count and distance read from a file or given as an option.

Each is checked before anything is allocated, so a hostile header or a typo ends in a typed
error naming the value, never in an ``OverflowError``, a ``MemoryError`` or a hang.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from maps.errors import MapTooLargeError

if TYPE_CHECKING:
    from maps.scan import Keyframe

#: Metres per cell a map may have: a millimetre to a hundred metres.
RESOLUTION_RANGE = (1e-3, 100.0)
#: Metres from the frame's origin a pose, a transform or a map origin may lie (10,000 km).
MAX_COORDINATE = 1e7
#: Radians a logged heading may have: loggers that do not wrap the heading add a turn to it
#: at each turn of the robot (a thousand and more turns fit), while a larger value is no
#: angle (its sine and cosine lose every digit) but a corrupt field.
MAX_HEADING = 1e4
#: Metres a laser may move between two consecutive scans of a log. Lasers log 1 to 75 scans a
#: second and robots move a few metres a second (a car on a motorway: 40 m/s), so a longer
#: jump is a corrupt pose, not motion, even across a gap of half a minute in a log; one such
#: pose would spread the map over square kilometres.
MAX_POSE_JUMP = 100.0
#: Metres a robot's radius may have.
MAX_ROBOT_RADIUS = 10.0
#: Metres any other length option (spacing, clutter size, keyframe distance) may have.
MAX_LENGTH = 1000.0
#: Furniture blocks per 10 m^2 a generated building may have: one per square metre of floor
#: leaves no floor to furnish.
MAX_FURNITURE = 10.0
#: Cells a map may have whatever the memory: 2^28 (16384 x 16384).
MAX_CELLS = 1 << 28
#: Bytes the command line holds per cell of a map at its peak: about 60 drawing ``map.png``
#: (the cell classes, the RGBA image and matplotlib's copies of it; measured on maps of 4 to
#: 100 million cells), more than segmenting holds (masks, distances, labels).
BYTES_PER_CELL = 64


def _memory_bytes() -> int | None:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def max_cells() -> int:
    """The most cells a map may have on this machine: :data:`MAX_CELLS`, or fewer when
    :data:`BYTES_PER_CELL` times them would not fit in its memory."""
    memory = _memory_bytes()
    return MAX_CELLS if memory is None else min(MAX_CELLS, memory // BYTES_PER_CELL)


def check_map_size(
    height: float,
    width: float,
    *,
    what: str = "map",
    path: str | Path | None = None,
    field: str | None = None,
) -> None:
    """Refuse a map of ``height`` x ``width`` cells that this machine cannot hold.

    Raises
    ------
    MapTooLargeError
        Naming the size in cells and what the limit is.

    Examples
    --------
    >>> check_map_size(3000, 3000)
    >>> check_map_size(2e9, 2e9, what="image")
    Traceback (most recent call last):
    ...
    maps.errors.MapTooLargeError: image of 2000000000 x 2000000000 cells (4e+18 cells) is ...
    """
    if not (math.isfinite(height) and math.isfinite(width)) or height < 0 or width < 0:
        raise MapTooLargeError(f"{what} of {width} x {height} cells", path=path, field=field)
    cells = float(height) * float(width)
    limit = max_cells()
    if cells > limit:
        gib = cells * BYTES_PER_CELL / 2**30
        raise MapTooLargeError(
            f"{what} of {int(width)} x {int(height)} cells ({cells:.3g} cells) is larger than "
            f"memory allows (about {gib:.3g} GiB; at most {limit} cells here)",
            path=path,
            field=field,
        )


def pose_jump(before: Sequence[float], after: Sequence[float]) -> str | None:
    """What is wrong with a laser moving from pose ``before`` to ``after`` between consecutive
    scans (farther than :data:`MAX_POSE_JUMP`), or None when it is fine. Callers raise their
    own located error with it.

    Examples
    --------
    >>> pose_jump((0.0, 0.0, 0.0), (0.5, 0.0, 0.1)) is None
    True
    >>> pose_jump((0.0, 0.0, 0.0), (150.0, 0.0, 0.0))
    'the laser jumps 150 m from (0, 0) to (150, 0) between consecutive scans (at most 100 m)'
    """
    distance = math.hypot(after[0] - before[0], after[1] - before[1])
    if distance <= MAX_POSE_JUMP:
        return None
    return (
        f"the laser jumps {distance:.6g} m from ({before[0]:.6g}, {before[1]:.6g}) to "
        f"({after[0]:.6g}, {after[1]:.6g}) between consecutive scans "
        f"(at most {MAX_POSE_JUMP:g} m)"
    )


def no_valid_beam(frames: Sequence[Keyframe]) -> str | None:
    """What is wrong with a log whose scans have not one valid beam (every reading NaN,
    infinite, negative, under the sensor's least range or beyond its greatest: nothing to map),
    or None when a beam is valid. Callers raise their own located error with it.

    Examples
    --------
    >>> from maps.scan import Keyframe, LaserScan
    >>> scan = LaserScan([float("nan"), -1.0], -0.5, 0.5)
    >>> no_valid_beam([Keyframe((0.0, 0.0, 0.0), scan)] * 3)  # doctest: +ELLIPSIS
    "3 scans of 6 beams read, and no beam is valid (each NaN, infinite, negative, under the ...
    """
    if any(frame.scan.valid.any() for frame in frames):
        return None
    beams = sum(len(frame.scan) for frame in frames)
    return (
        f"{len(frames)} scans of {beams} beams read, and no beam is valid (each NaN, infinite, "
        "negative, under the sensor's least range or beyond its greatest): nothing to map"
    )


def finite_in(
    value: object, name: str, lo: float, hi: float, *, unit: str = "", low_open: bool = False
) -> str | None:
    """What is wrong with ``value`` as a number in ``[lo, hi]`` (``(lo, hi]`` with
    ``low_open``), or None when it is fine. Callers raise their own located error with it.

    Examples
    --------
    >>> finite_in(1000.0, "robot_radius", 0, 10, unit="m", low_open=True)
    'robot_radius must lie in (0, 10] m, got 1000.0'
    >>> finite_in(float("nan"), "max_range", 0, 1e3, low_open=True)
    'max_range must be a finite number, got nan'
    >>> import numpy as np
    >>> finite_in(0.5, "p", 0, 1) is None, finite_in(np.float32(0.05), "resolution", 0, 1)
    (True, None)
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):  # numpy's numbers too
        return f"{name} must be a number, got {value!r}"
    try:
        number = float(value)
    except OverflowError:
        return f"{name} must be a finite number, got a {len(str(value))}-digit integer"
    if not math.isfinite(number):
        return f"{name} must be a finite number, got {value!r}"
    if number < lo or number > hi or (low_open and number == lo):
        left = "(" if low_open else "["
        return (
            f"{name} must lie in {left}{lo:g}, {hi:g}]{' ' + unit if unit else ''}, got {value!r}"
        )
    return None
