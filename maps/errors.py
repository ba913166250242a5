"""Errors raised by the maps package; each names the file, line or field at fault."""

from __future__ import annotations

import errno
from pathlib import Path


def _where(path: str | Path | None, line: int | None, field: str | None) -> str:
    parts = []
    if path is not None:
        parts.append(str(path))
    if line is not None:
        parts.append(f"line {line}")
    if field is not None:
        parts.append(f"field {field!r}")
    return ", ".join(parts)


class TopomapError(Exception):
    """Root of every error the topomap packages raise on bad input.

    Each package has its own branch: :class:`MapError` (:mod:`maps`),
    ``segmentation.errors.SegmentationError``, ``planners.errors.PlanningError`` and
    ``topomap.errors.LabelError``; each error is also the built-in exception that fits
    (``ValueError``, ``FileNotFoundError``...). Anything else that escapes is a bug.

    Examples
    --------
    >>> issubclass(InvalidMapError, TopomapError) and issubclass(InvalidMapError, ValueError)
    True
    """


class _FileError(OSError):
    """An ``OSError`` with ``errno``, ``filename`` and a message of our own as its text
    (``OSError`` would print ``[Errno 2] ...: 'path'``); pickled by its own arguments."""

    def __init__(self, code: int, message: str, path: str | Path, *arguments: str) -> None:
        super().__init__(code, message)
        self.filename = str(path)
        self._arguments = (path, *arguments)

    def __str__(self) -> str:
        return str(self.strerror)

    def __reduce__(self) -> tuple[type, tuple[str | Path, ...]]:
        return type(self), self._arguments


class OutputExistsError(TopomapError, _FileError, FileExistsError):
    """A file that exists and would be overwritten; nothing is replaced without asking.

    Examples
    --------
    >>> error = OutputExistsError("out/map.yaml")
    >>> str(error), error.filename
    ('out/map.yaml exists; pass overwrite=True to replace it', 'out/map.yaml')
    """

    def __init__(self, path: str | Path, how: str = "overwrite=True") -> None:
        super().__init__(errno.EEXIST, f"{path} exists; pass {how} to replace it", path, how)


class OutputPathError(TopomapError, _FileError):
    """An output path that cannot be written as asked: a folder where a file goes, a file
    where a folder goes or on the way to one. Raised before any work, nothing is written.

    Examples
    --------
    >>> str(OutputNotAFolderError("out/map.yaml/x", "out/map.yaml is a file, not a folder"))
    'out/map.yaml is a file, not a folder'
    """

    code = errno.EIO

    def __init__(self, path: str | Path, message: str) -> None:
        super().__init__(self.code, message, path, message)


class OutputNotAFolderError(OutputPathError, NotADirectoryError):
    """An output folder, or a folder on the way to an output, that is a file."""

    code = errno.ENOTDIR


class OutputIsAFolderError(OutputPathError, IsADirectoryError):
    """An output file whose place is taken by a folder."""

    code = errno.EISDIR


class OutputNotWritableError(OutputPathError, PermissionError):
    """An output folder that this user may not write in (or look into)."""

    code = errno.EACCES


class OutputWriteError(OutputPathError):
    """An output the system refused while it was being written (the disk full, a quota, an
    I/O error): nothing half-written is left.

    Examples
    --------
    >>> import errno
    >>> err = OutputWriteError("out/map.pgm", OSError(errno.ENOSPC, "No space left on device"))
    >>> str(err), err.errno == errno.ENOSPC
    ('could not write out/map.pgm: No space left on device', True)
    """

    def __init__(self, path: str | Path, err: OSError) -> None:
        self.code = err.errno or errno.EIO
        reason = err.strerror or str(err)
        super().__init__(path, f"could not write {path}: {reason}")
        self._arguments = (path, OSError(self.code, reason))  # type: ignore[assignment]


class MapError(TopomapError):
    """Base class of every error raised by :mod:`maps`."""


#: The former name of :class:`MapError`.
MapsError = MapError


class MapFileNotFoundError(MapError, _FileError, FileNotFoundError):
    """A map, image, log or bag file that does not exist.

    Examples
    --------
    >>> str(MapFileNotFoundError("maps/lab.yaml", "map YAML"))
    'map YAML not found: maps/lab.yaml'
    """

    def __init__(self, path: str | Path, what: str = "file") -> None:
        super().__init__(errno.ENOENT, f"{what} not found: {path}", path, what)


class FormatError(MapError, ValueError):
    """A file whose content is malformed, located by file, line and field.

    Parameters
    ----------
    message
        What is wrong, e.g. ``"expected a number, got 'abc'"``.
    path, line, field
        Where it is wrong; any may be None.
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | Path | None = None,
        line: int | None = None,
        field: str | None = None,
    ) -> None:
        where = _where(path, line, field)
        super().__init__(f"{where}: {message}" if where else message)
        self.path = None if path is None else str(path)
        self.line = line
        self.field = field


class MapFormatError(FormatError):
    """A map_server YAML or map image that cannot be read as a map."""


class MapTooLargeError(FormatError):
    """A map (an image header, a message's width and height, keyframes spread far apart) with
    more cells than this machine can hold; refused with its size before anything is allocated."""


class LogFormatError(FormatError):
    """A laser log (CARMEN, ROS bag) that cannot be read."""


class InvalidMapError(MapError, ValueError):
    """Map parameters that make no sense (a zero resolution, a wrong array shape...)."""


class RandomStateError(MapError, TypeError):
    """A ``random_state`` that is neither a seed (a whole number >= 0), a numpy Generator nor
    None."""


class InvalidScanError(MapError, ValueError):
    """A laser scan or pose with values that make no sense (NaN pose, negative angle step...)."""


class TransformError(LogFormatError):
    """A transform that a bag's tf tree cannot give: frames not linked, a link that does
    not cover a stamp, or a malformed link (``field``: the tf message it came in). ``source``,
    ``target`` and ``stamp`` (seconds) say which, when known."""

    def __init__(
        self,
        message: str,
        *,
        path: str | Path | None = None,
        field: str = "/tf",
        source: str | None = None,
        target: str | None = None,
        stamp: float | None = None,
    ) -> None:
        super().__init__(message, path=path, field=None if path is None else field)
        self.detail = message
        self.source = source
        self.target = target
        self.stamp = stamp
