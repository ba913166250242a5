"""Lazy package exports (PEP 562), listed once: a package's public names are the
``from module import name as name`` lines of its ``__init__`` (PEP 484's explicit re-export
form, under ``if TYPE_CHECKING:`` for those loaded lazily). Type checkers read those lines;
at run time this module reads the same lines from the source, and imports a name's module the
first time the name is used, so ``import topomap`` stays fast and does not load OMPL until a
planner is asked for.

A package's ``__init__`` ends with::

    def __getattr__(name: str) -> Any:
        return _exports.load(__name__, name)


    def __dir__() -> list[str]:
        return _exports.names(__name__)

``__all__`` comes from :func:`load` too. ``lazy_loader.attach_stub`` (scikit-image's way)
reads such lines from a ``.pyi`` stub, but only relative ones: ``topomap`` re-exports the
lower packages' names.
"""

from __future__ import annotations

import ast
import functools
import importlib
import sys
from pathlib import Path
from typing import Any


@functools.cache
def exports(package: str) -> dict[str, str]:
    """Name -> module of every name ``package`` re-exports.

    Examples
    --------
    >>> exports("maps")["OccupancyGrid"]
    'maps.grid'
    """
    tree = ast.parse(Path(str(sys.modules[package].__file__)).read_text())
    nodes = list(tree.body)
    for node in tree.body:
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING":
            nodes += node.body
    return {
        alias.name: node.module
        for node in nodes
        if isinstance(node, ast.ImportFrom) and node.module
        for alias in node.names
        if alias.asname == alias.name
    }


def load(package: str, name: str) -> Any:
    """The object ``name`` of ``package`` (``__all__``: the names it exports), imported from
    its module and kept in the package's namespace, so later uses do not come back here.

    Raises
    ------
    AttributeError
        When the package exports no ``name`` (as for any missing module attribute).

    Examples
    --------
    >>> load("maps", "OccupancyGrid").__name__
    'OccupancyGrid'
    """
    table = exports(package)
    if name == "__all__":
        value: Any = sorted(table)
    elif name in table:
        value = getattr(importlib.import_module(table[name]), name)
    else:
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    setattr(sys.modules[package], name, value)
    return value


def names(package: str) -> list[str]:
    """``dir(package)``: what it holds already and everything it exports."""
    return sorted(set(vars(sys.modules[package])) | set(exports(package)))
