"""A hierarchical planner's prepared door graph as one file, and back.

Preparing the planner (:mod:`planners.door_graph`: submaps, doors, a visibility graph per
submap) takes seconds on a building, a query milliseconds: the prepared state is saved once
with the regions and read back by every later run. :func:`write_prepared` writes a NumPy
``.npz`` file (arrays only: :func:`read_prepared` loads it without pickles, nothing in it is
executed) holding the format name and its :data:`VERSION`, the :func:`door_graph_key` of the
map, labels and robot it was made for, the layout (filled labels, parts, doors), every
part's visibility graph, all parts' arrays concatenated, and the SHA-256 of all of them
(:func:`checksum`): a file changed after it was written (a copy cut short, an edit, a bit
flipped on disk) is refused as damaged, so the planner is prepared again rather than
routing over arrays nobody made.

A planner given a prepared state checks its key against its own map, labels and radius
(:meth:`Prepared.check`): a door graph of another map is refused, never used.
"""

from __future__ import annotations

import hashlib
import zipfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.files import written
from planners.door_graph import DoorGraph, Layout, door_graph_key, part_space
from planners.doors import Door
from planners.errors import DoorGraphFileError, StaleDoorGraphError
from planners.visibility import VisibilityGraph
from planners.workspace import Workspace
from segmentation.transitions import Transition

#: The ``format`` field of a saved door graph.
FORMAT = "topomap-door-graph"
#: The version :func:`write_prepared` writes; :func:`read_prepared` reads it and no other
#: (2: with the arrays' :func:`checksum`).
VERSION = 2
#: The arrays of one part's visibility graph (:meth:`VisibilityGraph.arrays`).
_GRAPH_ARRAYS = ("corners", "blocked", "sites", "data", "indices", "indptr", "dist", "pred")


@dataclass(frozen=True, eq=False)
class Prepared:
    """A planner's preprocessing and what it was made from.

    Attributes
    ----------
    key
        :func:`~planners.door_graph.door_graph_key` of the map, labels and robot radius.
    robot_radius
        The disc robot's radius, metres.
    layout, door_graph
        The submaps and doors, and the door graph.
    """

    key: str
    robot_radius: float
    layout: Layout
    door_graph: DoorGraph

    def check(self, space: Workspace, labels: NDArray[np.integer]) -> None:
        """Refuse to serve a planner on another map, other labels or another robot.

        Raises
        ------
        StaleDoorGraphError
            Saying which.
        """
        if self.robot_radius != space.robot_radius:
            raise _other_robot(self.robot_radius, space)
        if np.shape(labels) != self.layout.labels.shape or self.key != door_graph_key(
            space, labels
        ):
            raise StaleDoorGraphError(
                "the door graph was prepared for another map or other regions (or by another "
                "version of the planner)"
            )


def write_prepared(prepared: Prepared, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write ``prepared`` to ``path`` (an ``.npz`` file; under a temporary name, then
    renamed).

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``overwrite`` is false.
    """
    path = Path(path)
    layout, door_graph = prepared.layout, prepared.door_graph
    openings = list(dict.fromkeys(d.opening for d in layout.doors))
    which = {opening: k for k, opening in enumerate(openings)}
    parts = sorted(layout.region_of)
    graphs = [door_graph.part_graphs[p].arrays() for p in parts]
    arrays: dict[str, NDArray] = {
        "format": np.array(FORMAT),
        "version": np.array(VERSION),
        "key": np.array(prepared.key),
        "robot_radius": np.array(prepared.robot_radius),
        "seconds": np.array(door_graph.seconds),
        "labels": layout.labels,
        "parts": layout.parts,
        "region_of": np.array([layout.region_of[p] for p in parts], np.int64),
        "door_parts": np.array([(d.a, d.b) for d in layout.doors], np.int64).reshape(-1, 2),
        "door_geometry": np.array(
            [(*d.point, *d.portal[0], *d.portal[1], d.width) for d in layout.doors], float
        ).reshape(-1, 7),
        "door_opening": np.array([which[d.opening] for d in layout.doors], np.int64),
        "opening_regions": np.array([(t.a, t.b) for t in openings], np.int64).reshape(-1, 2),
        "opening_geometry": np.array(
            [(*t.start, *t.end, *t.centre, t.width, t.clear_width) for t in openings], float
        ).reshape(-1, 8),
        "edges": np.column_stack([door_graph.a, door_graph.b, door_graph.part]).astype(np.int64),
        "costs": door_graph.costs,
        "n_corner_edges": np.array([int(g["n_corner_edges"]) for g in graphs], np.int64),
    }
    for name in _GRAPH_ARRAYS:
        arrays[name] = np.concatenate([g[name].ravel() for g in graphs] or [np.zeros(0)])
        arrays[f"{name}_sizes"] = np.array([g[name].size for g in graphs], np.int64)
    arrays["checksum"] = np.array(checksum(arrays))
    with written(path, overwrite=overwrite) as partial, partial.open("wb") as stream:
        np.savez_compressed(stream, allow_pickle=False, **arrays)
    return path


def read_prepared(path: str | Path, space: Workspace) -> Prepared:
    """Read a door graph written by :func:`write_prepared` for the robot of ``space``
    (its free space: every part's visibility graph is rebuilt on a crop of it).

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    DoorGraphFileError
        Not a door graph file, of another version, or damaged (its arrays do not match
        their checksum).
    StaleDoorGraphError
        Prepared for another robot radius or a map of another size.
    """
    path = Path(path)
    if not zipfile.is_zipfile(path):  # missing: FileNotFoundError; np.load would unpickle
        path.open("rb").close()
        raise DoorGraphFileError(f"{path}: not a door graph file (not an .npz archive)")
    try:
        with np.load(path, allow_pickle=False) as found:
            arrays = {name: found[name] for name in found.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise DoorGraphFileError(f"{path}: not a door graph file: {err}") from None
    about = {name: _scalar(arrays, name) for name in ("format", "version")}
    if about["format"] != FORMAT or about["version"] != VERSION:
        raise DoorGraphFileError(
            f"{path}: format {about['format']!r} version {about['version']!r}; this topomap "
            f"reads {FORMAT!r} version {VERSION}"
        )
    if _scalar(arrays, "checksum") != checksum(arrays):
        raise DoorGraphFileError(
            f"{path}: a damaged door graph file: its arrays do not match their checksum"
        )
    radius = _scalar(arrays, "robot_radius")
    if radius != space.robot_radius:
        raise _other_robot(radius, space, f"{path}: ")
    shape = arrays["labels"].shape if "labels" in arrays else None
    if shape != space.grid.shape:
        raise StaleDoorGraphError(
            f"{path}: the door graph was prepared for another map ({shape} cells, not "
            f"{space.grid.shape})"
        )
    try:
        return _prepared(arrays, space)
    except (KeyError, ValueError, IndexError, TypeError) as err:
        raise DoorGraphFileError(f"{path}: a damaged door graph file: {err!r}") from None


def checksum(arrays: Mapping[str, NDArray]) -> str:
    """The SHA-256 (hex) of ``arrays`` but one named ``checksum``: each array's name, type,
    shape and bytes, in the order of the names.

    Examples
    --------
    >>> one = {"a": np.arange(3), "b": np.array("x")}
    >>> checksum(one) == checksum({**one, "checksum": np.array("anything")})
    True
    >>> checksum(one) == checksum({"a": np.arange(3).reshape(3, 1), "b": np.array("x")})
    False
    """
    digest = hashlib.sha256()
    for name in sorted(arrays):
        if name == "checksum":
            continue
        value = np.ascontiguousarray(arrays[name])
        digest.update(f"{name} {value.dtype.str} {value.shape};".encode())
        digest.update(value.tobytes())
    return digest.hexdigest()


def _other_robot(radius: object, space: Workspace, where: str = "") -> StaleDoorGraphError:
    """The error for a door graph prepared for a robot of ``radius`` metres, not ``space``'s."""
    return StaleDoorGraphError(
        f"{where}the door graph was prepared for a robot radius of {radius!r} m, "
        f"not {space.robot_radius!r} m"
    )


def _scalar(arrays: dict[str, NDArray], name: str) -> object:
    """The one value of array ``name``, None when there is no such array of one value."""
    found = arrays.get(name)
    return found.item() if found is not None and found.size == 1 else None


def _prepared(arrays: dict[str, NDArray], space: Workspace) -> Prepared:
    """The :class:`Prepared` state the arrays of a door graph file describe."""
    labels, parts = arrays["labels"], arrays["parts"]
    if parts.shape != labels.shape:
        raise ValueError(f"labels of shape {labels.shape}, parts of shape {parts.shape}")
    region_of = {k + 1: int(r) for k, r in enumerate(arrays["region_of"])}
    openings = [
        Transition(int(a), int(b), (g[0], g[1]), (g[2], g[3]), (g[4], g[5]), g[6], g[7])
        for (a, b), g in zip(
            arrays["opening_regions"], arrays["opening_geometry"].tolist(), strict=True
        )
    ]
    doors = [
        Door(int(a), int(b), (g[0], g[1]), ((g[2], g[3]), (g[4], g[5])), g[6], openings[k])
        for (a, b), g, k in zip(
            arrays["door_parts"],
            arrays["door_geometry"].tolist(),
            arrays["door_opening"],
            strict=True,
        )
    ]
    layout = Layout(labels, parts, region_of, doors)
    graphs = _SavedGraphs(space, parts, arrays)
    edges = arrays["edges"].reshape(-1, 3).astype(np.intp)
    door_graph = DoorGraph(
        graphs, edges[:, 0], edges[:, 1], arrays["costs"], edges[:, 2], float(arrays["seconds"])
    )
    return Prepared(str(arrays["key"]), space.robot_radius, layout, door_graph)


class _SavedGraphs(Mapping[int, VisibilityGraph]):
    """The parts' visibility graphs of a door graph file, each made from its arrays when it is
    first asked for (a query touches a few parts, not all)."""

    def __init__(self, space: Workspace, parts: NDArray[np.int32], arrays: dict[str, NDArray]):
        self._space, self._parts, self._arrays = space, parts, arrays
        self._boxes = ndimage.find_objects(parts)
        self._pieces = {
            name: np.split(arrays[name], np.cumsum(arrays[f"{name}_sizes"])[:-1])
            for name in _GRAPH_ARRAYS
        }
        sizes = {name: arrays[f"{name}_sizes"] for name in _GRAPH_ARRAYS}
        n, m = sizes["corners"] // 2, sizes["sites"] // 2
        whole = (
            len(n) == len(self._boxes)
            and np.array_equal(sizes["blocked"], 2 * n)
            and np.array_equal(sizes["indptr"], n + m + 1)
            and np.array_equal(sizes["dist"], m * (n + m))
            and np.array_equal(sizes["pred"], m * (n + m))
        )
        if not whole:
            raise ValueError(f"part graphs that do not fit the {len(self._boxes)} parts")
        self._made: dict[int, VisibilityGraph] = {}

    def __getitem__(self, part: int) -> VisibilityGraph:
        if part not in self._made:
            if not 1 <= part <= len(self._boxes):
                raise KeyError(part)
            k = part - 1
            graph = {name: self._pieces[name][k] for name in _GRAPH_ARRAYS}
            n, m = len(graph["corners"]) // 2, len(graph["sites"]) // 2
            for name, shape in (("corners", (n, 2)), ("blocked", (n, 2)), ("sites", (m, 2))):
                graph[name] = graph[name].reshape(shape)
            for name in ("dist", "pred"):
                graph[name] = graph[name].reshape(m, n + m)
            graph["n_corner_edges"] = self._arrays["n_corner_edges"][k]
            sub = part_space(self._space, self._parts, self._boxes, part)
            self._made[part] = VisibilityGraph.from_arrays(sub, graph)
        return self._made[part]

    def __iter__(self) -> Iterator[int]:
        return iter(range(1, len(self._boxes) + 1))

    def __len__(self) -> int:
        return len(self._boxes)
