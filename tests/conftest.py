"""Shared fixtures: the evaluation data in ../shared/data (never copied into the project)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings

from maps.grid import OCCUPIED, OccupancyGrid

# property tests write files and cast rays; a shared, noisy machine must not turn time into failures
settings.register_profile("topomap", deadline=None)
settings.load_profile("topomap")

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("TOPOMAP_DATA", ROOT.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The shared evaluation data; missing data fails in CI and skips only on a dev machine."""
    if not (DATA / "README.md").is_file():
        message = f"evaluation data not found at {DATA} (set TOPOMAP_DATA)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return DATA


def _two_rooms(door: float = 1.0, resolution: float = 0.05, wall: float = 0.1) -> OccupancyGrid:
    """Two 4 x 4 m rooms side by side, a ``wall`` thick wall with a door of ``door`` metres."""
    outer, inner = round(0.1 / resolution), round(wall / resolution)
    height, width = round(4.2 / resolution), round((8.2 + wall) / resolution)
    cells = np.full((height, width), OCCUPIED, np.int8)
    cells[outer:-outer, outer:-outer] = 0
    middle = width // 2
    cells[:, middle - inner // 2 : middle + inner - inner // 2] = OCCUPIED
    opening = round(door / resolution)
    top = height // 2 - opening // 2
    cells[top : top + opening, middle - inner : middle + inner] = 0
    return OccupancyGrid(cells, resolution)


@pytest.fixture
def two_rooms():
    """``two_rooms(door=1.0, resolution=0.05, wall=0.1)``: two 4 x 4 m rooms and a door."""
    return _two_rooms
