"""Shared fixtures: the evaluation data in ../shared/data (never copied into the project)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

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
