"""Lazy package exports (PEP 562): a package names its public objects and the modules that
define them; a module is imported the first time one of its names is used, so ``import
topomap`` stays fast and does not load OMPL until a planner is asked for."""

from __future__ import annotations

import importlib
import sys
from typing import Any


def load(package: str, exports: dict[str, str], name: str) -> Any:
    """The object ``name`` of ``package``, imported from the module ``exports[name]`` and kept
    in the package's namespace, so later uses do not come back here.

    Raises
    ------
    AttributeError
        When the package exports no ``name`` (as for any missing module attribute).

    Examples
    --------
    >>> load("maps", {"OccupancyGrid": "maps.grid"}, "OccupancyGrid").__name__
    'OccupancyGrid'
    """
    if name not in exports:
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(exports[name]), name)
    setattr(sys.modules[package], name, value)
    return value


def names(package: str, exports: dict[str, str]) -> list[str]:
    """``dir(package)``: what it holds already and everything it exports."""
    return sorted(set(vars(sys.modules[package])) | set(exports))
