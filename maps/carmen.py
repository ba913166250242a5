"""Reader for CARMEN laser logs (FLASER, RLASER, ROBOTLASER1 lines; plain or gzip)."""

from __future__ import annotations

import gzip
import math
import zlib
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from maps.errors import InvalidScanError, LogFormatError
from maps.limits import MAX_COORDINATE, MAX_HEADING, finite_in, no_valid_beam, pose_jump
from maps.map_server import check_input_file
from maps.scan import Keyframe, LaserScan

#: Metres under which a reading is no reading (the logs write 0 for a failed one; their
#: lasers see from about 0.1 m).
MIN_RANGE = 0.01
#: Old-style lines: ``FLASER n r1 .. rn x y theta odom_x odom_y odom_theta ipc_ts host log_ts``.
OLD_STYLE = ("FLASER", "RLASER")
ROBOTLASER = "ROBOTLASER1"
#: Characters a log line may have: a laser line of 100,000 beams at 10 characters each is
#: 1 MB. A longer line is not a laser line (a damaged or hostile file): it is never read whole.
MAX_LINE_CHARS = 1 << 20
#: Lines a log may have: a day of a 75 Hz laser and its odometry is about 13 million. A file
#: of more (a gzip bomb of empty lines) is refused after them, not read for hours.
MAX_LOG_LINES = 50_000_000


def carmen_angle_increment(beams: int) -> float:
    """CARMEN's rule for old-style lines: 1 degree for 180/181 beams, 0.5 for 360/361, else
    ``pi / (beams - 1)`` (a 180 degree field of view)."""
    if beams in (180, 181):
        return math.pi / 180
    if beams in (360, 361):
        return math.pi / 360
    return math.pi / max(beams - 1, 1)


def _lines(path: Path) -> Iterator[tuple[int, str]]:
    try:
        with path.open("rb") as raw:
            gzipped = raw.read(2) == b"\x1f\x8b"
        opener = gzip.open if gzipped else open
        # utf-8-sig: a byte order mark (Windows editors write one) is not part of line 1
        with opener(path, "rt", encoding="utf-8-sig", errors="strict") as text:
            for number in range(1, MAX_LOG_LINES + 2):
                line = text.readline(MAX_LINE_CHARS)
                if not line:
                    return
                if number > MAX_LOG_LINES:
                    raise LogFormatError(f"more than {MAX_LOG_LINES} lines", path=path)
                if len(line) == MAX_LINE_CHARS and not line.endswith("\n"):
                    raise LogFormatError(
                        f"line longer than {MAX_LINE_CHARS} characters", path=path, line=number
                    )
                yield number, line
    except (OSError, EOFError, UnicodeDecodeError, zlib.error) as err:
        raise LogFormatError(f"cannot be read as a text log ({err})", path=path) from err


def _is_number(token: str) -> bool:
    if "_" in token:  # Python and numpy read "1_0" as 10; a log never writes it
        return False
    try:
        float(token)
    except ValueError:
        return False
    return True


class _Line:
    """Tokens of one log line with typed, located access."""

    def __init__(self, tokens: list[str], path: Path, number: int) -> None:
        self.tokens, self.path, self.number = tokens, path, number

    def error(self, message: str, field: str) -> LogFormatError:
        return LogFormatError(message, path=self.path, line=self.number, field=field)

    def need(self, count: int, what: str) -> None:
        if len(self.tokens) < count:
            raise self.error(
                f"line is cut short: {len(self.tokens)} values, {what} needs {count}", what
            )

    def number_at(self, index: int, field: str) -> float:
        self.need(index + 1, field)
        if not _is_number(self.tokens[index]):
            raise self.error(f"expected a number, got {self.tokens[index]!r}", field)
        value = float(self.tokens[index])
        if not math.isfinite(value):
            raise self.error(f"expected a finite number, got {self.tokens[index]!r}", field)
        return value

    def count_at(self, index: int, field: str) -> int:
        value = self.number_at(index, field)
        if value != int(value) or value < 0:
            raise self.error(f"expected a count, got {self.tokens[index]!r}", field)
        if value > MAX_LINE_CHARS // 2:  # each value takes a digit and a space at least
            raise self.error(
                f"a count of {self.tokens[index]} values does not fit in a line of at most "
                f"{MAX_LINE_CHARS} characters",
                field,
            )
        return int(value)

    def ranges(self, start: int, count: int) -> np.ndarray:
        self.need(start + count, "ranges")
        tokens = self.tokens[start : start + count]
        if not any("_" in token for token in tokens):
            try:
                return np.array(tokens, dtype=float)
            except ValueError:
                pass  # found below
        bad = next(i for i, token in enumerate(tokens) if not _is_number(token))
        raise self.error(f"expected a number, got {tokens[bad]!r}", f"range {bad}")

    def pose_at(self, index: int, names: tuple[str, str, str]) -> tuple[float, float, float]:
        x, y, t = (self.number_at(index + i, name) for i, name in enumerate(names))
        for value, name in ((x, names[0]), (y, names[1])):
            if abs(value) > MAX_COORDINATE:
                raise self.error(f"{value:g} m is farther than {MAX_COORDINATE:g} m", name)
        if abs(t) > MAX_HEADING:
            raise self.error(f"{t:g} rad is no heading (at most {MAX_HEADING:g})", names[2])
        return x, y, t

    def check_numbers(self, expected: int, field: str) -> None:
        """The line has exactly the fields of a CARMEN layout: ``expected`` numbers after its
        first two tokens (the last one the IPC stamp), then the host name and the logger's
        stamp, or neither (older logs). Any other count means a count that does not match its
        values, which would read ranges as the pose or the pose from the stamps (a host name
        that is a number is refused too: a line without host name whose count is two short
        would look the same)."""
        rest = self.tokens[2:]
        numbers = next((i for i, token in enumerate(rest) if not _is_number(token)), len(rest))
        if numbers == expected and (
            len(rest) == expected or (len(rest) == expected + 2 and _is_number(rest[-1]))
        ):
            return
        found = (
            f"{numbers} numbers and no host name"
            if numbers == len(rest)
            else f"{numbers} numbers before its host name and {len(rest) - numbers - 1} fields "
            "after it"
        )
        raise self.error(
            f"{self.tokens[0]} has {found}, but its {field} "
            f"{self.tokens[1 if field == 'n' else 8]!r} asks for {expected} numbers (then a host "
            "name and the logger's stamp, or neither): the count does not match the values",
            field,
        )


def read_carmen(path: str | Path, *, max_range: float = 50.0) -> list[Keyframe]:
    """Read every laser scan of a CARMEN log, in line order.

    Parameters
    ----------
    path
        A ``.log`` file, or a gzip-compressed one (detected from its content).
    max_range
        Readings at or beyond this many metres are no-returns (the logs mark them with the
        sensor's maximum, about 81.9 m or 50 m) and become ``+inf``, as REP-117 asks.

    Returns
    -------
    list of Keyframe
        One per FLASER, RLASER or ROBOTLASER1 line, ``scan_index`` counting them from 0. The
        pose is the logged (for the corrected logs: SLAM-corrected) laser pose. Old-style lines
        use CARMEN's beam rule (:func:`carmen_angle_increment`) from -pi/2; RLASER lines are
        read like FLASER lines, their logged pose taken as the rear laser's own pose.
        ROBOTLASER1 lines carry their own start angle, resolution and laser pose.

    Raises
    ------
    MapFileNotFoundError
        If ``path`` does not exist.
    LogFormatError
        If it is not a regular file this user may read (a folder, a FIFO, a device). For a
        line that is cut short, has a non-number or more or fewer fields than its count
        asks for (see :meth:`_Line.check_numbers`), a field of view of more than a turn, or
        whose laser pose jumps farther than :data:`~maps.limits.MAX_POSE_JUMP` from the
        previous line's; the message names line and field. For a log without one valid beam
        (readings under :data:`MIN_RANGE` are none), a damaged gzip stream, a line longer
        than :data:`MAX_LINE_CHARS` or more than :data:`MAX_LOG_LINES` lines.
    """
    path = check_input_file(path, "CARMEN log", error=LogFormatError)
    problem = finite_in(max_range, "max_range", 0.0, 1e4, unit="m", low_open=True)
    if problem is not None:
        raise InvalidScanError(problem)
    frames: list[Keyframe] = []
    last_line = 0  # of the last laser line read
    for number, text in _lines(path):
        tokens = text.split()
        if not tokens or tokens[0] not in (*OLD_STYLE, ROBOTLASER):
            continue
        line = _Line(tokens, path, number)
        if tokens[0] == ROBOTLASER:
            start = line.number_at(2, "start_angle")
            increment = line.number_at(4, "angular_resolution")
            beams = line.count_at(8, "num_readings")
            ranges = line.ranges(9, beams)
            remissions = line.count_at(9 + beams, "num_remissions")
            at = 10 + beams + remissions
            names = ("laser_pose_x", "laser_pose_y", "laser_pose_theta")
            pose = line.pose_at(at, names)
            # start_angle ... the counts and values, then 12 numbers before the host name
            line.check_numbers(at - 2 + 12, "num_readings")
            stamp = line.number_at(at + 11, "ipc_timestamp")
        else:
            beams = line.count_at(1, "n")
            ranges = line.ranges(2, beams)
            names = ("x", "y", "theta")
            pose = line.pose_at(2 + beams, names)
            line.check_numbers(beams + 7, "n")  # ranges, two poses, the ipc stamp
            start, increment = -math.pi / 2, carmen_angle_increment(beams)
            stamp = line.number_at(2 + beams + 6, "ipc_timestamp")
        if beams == 0:
            field = "num_readings" if tokens[0] == ROBOTLASER else "n"
            raise line.error("a scan needs at least one beam", field)
        if increment == 0:
            raise line.error("angular resolution must not be 0", "angular_resolution")
        if abs(start) > 2 * math.pi or abs(increment) * (beams - 1) > 2 * math.pi + 1e-6:
            raise line.error(
                f"a scan from {start:g} rad in {beams} steps of {increment:g} rad is not a "
                "laser's field of view (at most a turn, starting within a turn)",
                "start_angle" if abs(start) > 2 * math.pi else "angular_resolution",
            )
        jump = None if not frames else pose_jump(frames[-1].pose, pose)
        if jump is not None:
            raise line.error(f"{jump}; the previous laser line is line {last_line}", names[0])
        last_line = number
        ranges = np.where(ranges >= max_range, np.inf, ranges)
        scan = LaserScan(ranges, start, increment, range_min=MIN_RANGE, range_max=max_range)
        frames.append(Keyframe(pose, scan, scan_index=len(frames), stamp=stamp))
    if not frames:
        raise LogFormatError(
            f"no laser lines ({', '.join((*OLD_STYLE, ROBOTLASER))}): not a CARMEN laser log",
            path=path,
        )
    problem = no_valid_beam(frames)
    if problem is not None:
        raise LogFormatError(problem, path=path)
    return frames
