"""What topomap can read, recognised in one place: map_server YAMLs, CARMEN logs and ROS bags,
alone, in folders or by glob (``topomap segment``, ``map`` and ``batch`` all ask
:func:`input_kind`)."""

from __future__ import annotations

import glob
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from maps.errors import FormatError, MapFileNotFoundError, MapFormatError

#: Suffixes of CARMEN logs (``.gz``: compressed).
LOG_SUFFIXES = (".log", ".clf", ".gz")
#: Suffixes of bag files: ROS 1, and the storage files of ROS 2 (rosbags reads them alone).
BAG_SUFFIXES = (".bag", ".mcap", ".db3")


@dataclass(frozen=True)
class Job:
    """One input of a batch: its ``source`` path, ``kind`` (``map``, ``log`` or ``bag``) and
    the ``name`` of its output folder."""

    source: str
    kind: str
    name: str


def is_bag(path: Path) -> bool:
    """A ROS 1 ``.bag``, a ROS 2 bag folder (with ``metadata.yaml``) or one of its storage
    files (``.mcap``, ``.db3``)."""
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.name.lower().endswith(BAG_SUFFIXES)


def input_kind(path: Path) -> str | None:
    """``"map"``, ``"log"`` or ``"bag"`` for a path topomap can segment, else None.

    A bag is what :func:`is_bag` says; a map is a YAML file with an ``image`` field
    (map_server's); a log ends in one of :data:`LOG_SUFFIXES`.

    Examples
    --------
    >>> input_kind(Path("run.bag")), input_kind(Path("run_0.mcap")), input_kind(Path("a.log.gz"))
    ('bag', 'bag', 'log')
    """
    try:
        return _kind(path)
    except OSError:  # a folder on the way that may not be looked into: its reader says so
        return None


def _kind(path: Path) -> str | None:
    """:func:`input_kind`, raising what looking at ``path`` raises."""
    if is_bag(path):
        return "bag"
    if path.is_dir():
        return None
    name = path.name.lower()
    if name.endswith(LOG_SUFFIXES):
        return "log"
    if name.endswith((".yaml", ".yml")) and name != "metadata.yaml":
        from maps.map_server import parse_yaml

        try:
            content = parse_yaml(path)
        except MapFormatError:  # a broken map: its own input fails with the reason, not the run
            return "map"
        except OSError:
            return None
        return "map" if isinstance(content, dict) and "image" in content else None
    return None


def _expand(pattern: str) -> list[Path]:
    """The inputs a command-line argument names: a glob, a file, a bag, or a folder of them."""
    if glob.has_magic(pattern):
        paths = [Path(p) for p in sorted(glob.glob(pattern, recursive=True))]
        if not paths:
            raise MapFileNotFoundError(pattern, "input matching")
    else:
        paths = [Path(pattern)]
        if not paths[0].exists():
            raise MapFileNotFoundError(pattern, "input")
    found = []
    for path in paths:
        if input_kind(path) is not None:
            found.append(path)
        elif path.is_dir():
            found += _walk(path)
        elif not glob.has_magic(pattern):  # named on its own: say what it is not
            raise FormatError(
                "not a map_server YAML (with 'image'), a CARMEN log (.log, .clf, .gz), "
                "a ROS 1 .bag or a ROS 2 bag (a folder, .mcap or .db3)",
                path=path,
            )
    return found


def _walk(folder: Path) -> list[Path]:
    """Inputs in a folder and its subfolders (not inside a bag), in name order."""
    found = []
    try:
        entries = sorted(folder.iterdir())
    except OSError as err:  # no permission to list it
        raise MapFormatError(f"cannot be read ({err.strerror or err})", path=folder) from None
    for entry in entries:
        if input_kind(entry) is not None:
            found.append(entry)
        elif entry.is_dir():
            found += _walk(entry)
    return found


def _stem(path: Path) -> str:
    name = path.name
    for suffix in (".gz", ".log", ".clf", *BAG_SUFFIXES, ".yaml", ".yml"):
        name = name.removesuffix(suffix)
    return name or path.name


def find_inputs(patterns: Sequence[str]) -> list[Job]:
    """The inputs named by files, folders and globs, each once, with unique output names.

    An output folder is named after its input's stem (``lab_ipa`` for ``lab_ipa.yaml``,
    ``intel`` for ``intel.log.gz``); inputs sharing a stem take their parent folders' names
    too (``ipa__lab_ipa``).

    Raises
    ------
    MapFileNotFoundError
        If a named path does not exist, a glob matches nothing, or nothing at all can be
        segmented.
    FormatError
        If a file named on its own is none of these.
    """
    paths: list[Path] = []
    seen: set[Path] = set()
    for pattern in patterns:
        for path in _expand(pattern):
            if path.resolve() not in seen:
                seen.add(path.resolve())
                paths.append(path)
    if not paths:
        raise MapFileNotFoundError(", ".join(patterns), "map YAML, log or bag")
    names = [_stem(p) for p in paths]
    for name in {n for n in names if names.count(n) > 1}:
        clashing = [i for i, n in enumerate(names) if n == name]
        common = Path(os.path.commonpath([paths[i].resolve() for i in clashing]))
        for i in clashing:
            folders = paths[i].resolve().parent.relative_to(common).parts
            names[i] = "__".join([*folders, name])
    for name in {n for n in names if names.count(n) > 1}:  # a.yaml beside a.log
        names = [
            f"{n}.{input_kind(p)}" if n == name else n for n, p in zip(names, paths, strict=True)
        ]
    for name in {n for n in names if names.count(n) > 1}:  # a.log beside a.log.gz
        names = [p.name if n == name else n for n, p in zip(names, paths, strict=True)]
    taken: set[str] = set()
    for i, name in enumerate(names):  # still the same: numbered, never one result lost
        unique, number = name, 1
        while unique in taken:
            number += 1
            unique = f"{name}-{number}"
        names[i] = unique
        taken.add(unique)
    return [Job(str(p), str(input_kind(p)), n) for p, n in zip(paths, names, strict=True)]
