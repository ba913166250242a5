"""Benchmarks that print tables and write JSON (``topomap bench ...``)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import numpy as np

from maps.floorplan import generate_floor_plan
from maps.laser_sim import LaserModel, RayCaster, simulate_scans
from maps.scan import Keyframe, select_keyframes
from maps.wander import wander
from segmentation.naive import naive_segment
from segmentation.spectral import SpectralSegmenter


def bench_sim(
    out: str | Path,
    *,
    scans: tuple[int, ...] = (1_000, 10_000),
    beams: tuple[int, ...] = (181, 361),
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Time the laser simulator on a generated office floor (100 x 60 m, 5 cm cells).

    Poses are drawn uniformly over the free cells; each record is one (scans, beams) run:
    ``{"scans", "beams", "seconds", "scans_per_s", "rays_per_s"}``, written to
    ``out/results.json``. The ray caster's set-up (a distance transform) is timed apart.
    """
    plan = generate_floor_plan("office", furniture=0.3, random_state=seed)
    rng = np.random.default_rng(seed)
    start = time.perf_counter()
    caster = RayCaster(plan.grid)
    setup = time.perf_counter() - start
    rows, cols = np.nonzero(plan.grid.free)
    records: list[dict[str, Any]] = []
    for n in scans:
        pick = rng.integers(len(rows), size=n)
        x, y = plan.grid.cell_to_world(rows[pick], cols[pick])
        poses = np.column_stack((x, y, rng.uniform(-np.pi, np.pi, n)))
        for b in beams:
            model = LaserModel(fov=np.pi if b % 2 else 2 * np.pi, beams=b, noise=0.01)
            start = time.perf_counter()
            simulate_scans(plan.grid, poses, model, random_state=seed, caster=caster)
            seconds = time.perf_counter() - start
            records.append(
                {
                    "scans": n,
                    "beams": b,
                    "seconds": round(seconds, 4),
                    "scans_per_s": round(n / seconds),
                    "rays_per_s": round(n * b / seconds),
                    "map_cells": list(plan.grid.shape),
                    "setup_seconds": round(setup, 4),
                }
            )
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(records, indent=2))
    return records


def robot_keyframes(size: str, count: int, seed: int = 0) -> list[Keyframe]:
    """The first ``count`` keyframes (181 beams, 180 degrees) of a robot wandering through a
    generated building of ``size``."""
    plan = generate_floor_plan(size, furniture=0.3, random_state=seed)
    route = wander(plan.grid, plan.labels, random_state=seed)
    scans = simulate_scans(plan.grid, route.poses, LaserModel(noise=0.01), random_state=seed)
    keyframes = select_keyframes(scans)
    if len(keyframes) < count:
        raise ValueError(f"the {size} building gives {len(keyframes)} keyframes, not {count}")
    return keyframes[:count]


def bench_segment(
    out: str | Path,
    *,
    sizes: tuple[int, ...] = (1_000, 2_000, 5_000, 10_000),
    naive_up_to: int = 2_000,
    building: str = "campus",
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Time the spectral partition (similarity + eigenvectors + k search) against the naive one.

    Keyframes come from :func:`robot_keyframes`. Records ``{"method": "topomap" | "naive",
    "keyframes", "seconds", "regions"}`` go to ``out/results.json``; the naive version (all
    pairs, dense matrices, the same criterion) runs for sizes up to ``naive_up_to``.
    """
    keyframes = robot_keyframes(building, max(sizes), seed)
    records: list[dict[str, Any]] = []
    for n in sizes:
        runs = [("topomap", lambda k: SpectralSegmenter(random_state=seed).fit(k).labels_)]
        if n <= naive_up_to:
            runs.append(("naive", lambda k: naive_segment(k, random_state=seed)))
        for method, run in runs:
            start = time.perf_counter()
            labels = run(keyframes[:n])
            seconds = time.perf_counter() - start
            records.append(
                {
                    "method": method,
                    "keyframes": n,
                    "seconds": round(seconds, 3),
                    "regions": int(labels.max()) + 1,
                }
            )
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(records, indent=2))
    return records
