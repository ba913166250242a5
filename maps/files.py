"""Writing outputs safely: paths checked before any work, files written under a temporary name
and renamed into place, nothing the user has overwritten without asking.

An interrupted write (an error, Ctrl-C) leaves the final name as it was: the old file or
nothing, never half of a new one. :class:`OutputFolder` does the same for a folder of files.
"""

from __future__ import annotations

import errno
import os
import shutil
import uuid
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from maps.errors import (
    OutputExistsError,
    OutputIsAFolderError,
    OutputNotAFolderError,
    OutputNotWritableError,
    OutputPathError,
    OutputWriteError,
    TopomapError,
)


def _blocking_file(path: Path) -> Path | None:
    """The first existing non-folder among ``path``'s parents, if any."""
    for parent in reversed(path.parents):
        if parent.exists() and not parent.is_dir():
            return parent
    return None


def _dangling_link(path: Path) -> Path | None:
    """The first of ``path`` and its parents that is a symbolic link to nothing, if any."""
    return next((p for p in (path, *path.parents) if p.is_symlink() and not p.exists()), None)


def _not_writable(folder: Path, err: OSError) -> OutputPathError:
    """The typed error of an ``OSError`` met writing ``folder`` (or looking into it)."""
    kind = OutputNotWritableError if isinstance(err, PermissionError) else OutputPathError
    where = f" ({err.filename})" if err.filename is not None else ""
    return kind(folder, f"cannot write {folder}: {err.strerror or err}{where}")


def check_output_folder(folder: str | Path) -> Path:
    """Refuse an output folder that is a file or lies under one, or that this user cannot
    write (it may be missing: it is made, with its parents, when written; then the nearest
    existing parent must be writable).

    Raises
    ------
    OutputNotAFolderError
        ``folder`` or one of its parents is a file, or a symbolic link to nothing.
    OutputNotWritableError
        ``folder``, or the nearest existing parent it would be made in, may not be written,
        or a parent may not be looked into.
    OutputPathError
        ``folder`` is no path (None, a number, a name with a NUL byte).
    """
    folder = _as_path(folder)
    try:
        blocking = folder if folder.exists() and not folder.is_dir() else _blocking_file(folder)
        nearest = next(p for p in (folder, *folder.parents) if p.exists())
        dangling = _dangling_link(folder)
    except OSError as err:  # a parent that may not be looked into
        raise _not_writable(folder, err) from None
    if dangling is not None:
        raise OutputNotAFolderError(
            folder,
            f"{dangling} is a symbolic link to {os.readlink(dangling)}, which does not exist: "
            f"cannot write {folder}",
        )
    if blocking is not None:
        raise OutputNotAFolderError(
            folder, f"{blocking} is a file, not a folder: cannot write {folder}"
        )
    if not os.access(nearest, os.W_OK | os.X_OK):
        raise OutputNotWritableError(
            folder, f"cannot write {folder}: {nearest} is not writable by this user"
        )
    return folder


def check_output_file(path: str | Path, *, overwrite: bool, how: str = "overwrite=True") -> Path:
    """Refuse an output file that exists (unless ``overwrite``), whose place is a folder, or
    whose folder is a file. ``how`` says how to allow overwriting (``"--force"``).

    Raises
    ------
    OutputExistsError
        The file exists and ``overwrite`` is false.
    OutputIsAFolderError
        A folder has the file's name.
    OutputNotAFolderError
        A parent of the file is a file.
    """
    path = _as_path(path)
    check_output_folder(path.parent)
    return _check_file(path, overwrite=overwrite, how=how)


def _check_file(path: Path, *, overwrite: bool, how: str) -> Path:
    """:func:`check_output_file` once its folder is checked."""
    if not isinstance(overwrite, bool):  # "no" is truthy: a user's file lost
        raise OutputPathError(path, f"overwrite must be True or False, got {overwrite!r}")
    try:
        is_dir, exists = path.is_dir(), path.exists()
    except OSError as err:  # a name too long
        raise OutputPathError(path, f"cannot write {path}: {err.strerror or err}") from None
    if is_dir:
        raise OutputIsAFolderError(path, f"{path} is a folder, not a file: cannot write it")
    if exists and not overwrite:
        raise OutputExistsError(path, how)
    return path


def _as_path(path: object) -> Path:
    """``path`` as a :class:`~pathlib.Path`, refusing what no file system takes (not a path,
    a NUL byte in it) with an :class:`~maps.errors.OutputPathError`."""
    if not isinstance(path, str | os.PathLike) or "\x00" in str(path):
        raise OutputPathError(str(path), f"{path!r} is no path to write an output to")
    return Path(path)


def check_outputs(
    folder: str | Path, names: Iterable[str], *, overwrite: bool, how: str = "overwrite=True"
) -> Path:
    """:func:`check_output_folder` and :func:`check_output_file` for every name in it, each
    folder checked once."""
    folder = check_output_folder(folder)
    checked = {folder}
    for name in names:
        path = folder / name
        if path.parent not in checked:
            checked.add(check_output_folder(path.parent))
        _check_file(path, overwrite=overwrite, how=how)
    return folder


def _temporary(path: Path) -> Path:
    """A hidden name beside ``path`` that keeps its suffix (OpenCV and matplotlib pick the
    format from it)."""
    return path.with_name(f".{path.stem}.{uuid.uuid4().hex[:8]}.partial{path.suffix}")


@contextmanager
def written(
    path: str | Path, *, overwrite: bool = False, how: str = "overwrite=True"
) -> Iterator[Path]:
    """Write a file atomically: yields a temporary path beside ``path`` to write to; on
    success it is renamed to ``path``, on any error or interruption removed. An ``OSError``
    while writing (the disk full) is an :class:`~maps.errors.OutputWriteError` naming ``path``.

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "a.txt"
    >>> with written(out) as partial:
    ...     _ = partial.write_text("done")
    >>> out.read_text()
    'done'
    """
    path = check_output_file(path, overwrite=overwrite, how=how)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:  # a folder the checks allowed but the system refuses (/proc)
        raise _not_writable(path.parent, err) from None
    partial = _temporary(path)
    try:
        yield partial
        if not partial.exists():
            raise OSError(errno.EIO, "nothing was written")
        os.replace(partial, path)
    except BaseException as err:
        partial.unlink(missing_ok=True)
        if isinstance(err, OSError) and not isinstance(err, TopomapError):
            raise OutputWriteError(path, err) from err  # the disk full, a device gone
        raise


def write_text(
    path: str | Path, text: str, *, overwrite: bool = False, how: str = "overwrite=True"
) -> Path:
    """Write ``text`` to ``path`` atomically (see :func:`written`)."""
    path = _as_path(path)
    with written(path, overwrite=overwrite, how=how) as partial:
        partial.write_text(text)
    return path


class OutputFolder:
    """Write a folder of files all at once: a context manager yielding a hidden staging folder
    beside ``folder``; on success its files move into ``folder``, on any error or interruption
    it is removed and ``folder`` is as it was.

    A new folder appears whole (one rename). Into an existing folder (``overwrite``) the files
    move one by one, ``last`` (the file that marks the folder complete, e.g. ``topomap.json``)
    removed first and moved in last, so a reader never takes a half-moved folder for whole.

    Parameters
    ----------
    folder
        The output folder.
    names
        The files that will be written (checked before any work).
    overwrite, how
        As for :func:`check_output_file`.
    last
        The name written last and removed first, if any.
    """

    def __init__(
        self,
        folder: str | Path,
        names: Iterable[str],
        *,
        overwrite: bool = False,
        how: str = "overwrite=True",
        last: str | None = None,
    ) -> None:
        self.folder = Path(folder)
        self.names = list(names)
        self.overwrite, self.how, self.last = overwrite, how, last
        check_outputs(self.folder, self.names, overwrite=overwrite, how=how)
        # beside a new folder (renamed into its place), inside an existing one (same disk)
        resolved = self.folder.resolve()
        hidden = f".{resolved.name or 'out'}.{uuid.uuid4().hex[:8]}.partial"
        self.staging = resolved / hidden if resolved.is_dir() else resolved.parent / hidden

    def __enter__(self) -> Path:
        try:
            self.folder.parent.mkdir(parents=True, exist_ok=True)
            self.staging.mkdir()
        except OSError as err:  # a read-only disk, or rights changed since the check
            raise _not_writable(self.folder, err) from None
        return self.staging

    def __exit__(self, kind: type[BaseException] | None, *_: object) -> None:
        try:
            if kind is None:
                self._commit()
        finally:
            shutil.rmtree(self.staging, ignore_errors=True)

    def _commit(self) -> None:
        # checked again: another process may have written there meanwhile
        check_outputs(self.folder, self.names, overwrite=self.overwrite, how=self.how)
        if not self.folder.exists():
            os.rename(self.staging, self.folder)
            return
        files = sorted(p.name for p in self.staging.iterdir())
        if self.last in files:
            (self.folder / self.last).unlink(missing_ok=True)
            files = [name for name in files if name != self.last] + [self.last]
        for name in files:
            if (self.staging / name).is_dir():  # a folder of outputs replaces the old one whole
                shutil.rmtree(self.folder / name, ignore_errors=True)
            os.replace(self.staging / name, self.folder / name)
