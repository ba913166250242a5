"""``topomap bench batch``: maps per minute of ``topomap batch`` with 1 and 2 local workers, and
the speed-up of the block-wise campus segmentation run on 2 workers."""

from __future__ import annotations

import json
import logging
import os
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from maps.files import write_text
from topomap.cli.batch import dask_client, run_batch

log = logging.getLogger(__name__)


def generated_maps(folder: Path, count: int, size: str = "flat") -> list[str]:
    """Write ``count`` generated buildings (seeds 0, 1, ...) as map YAMLs in ``folder``."""
    from maps.sim.floorplan import generate_floor_plan

    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for seed in range(count):
        path = folder / f"{size}-{seed}.yaml"
        if not path.exists():
            generate_floor_plan(size, random_state=seed).grid.save(path)
        paths.append(str(path))
    return paths


def bench_batch_maps(
    out: Path,
    *,
    maps: int = 24,
    workers: Sequence[int] = (1, 2),
    size: str = "flat",
    rounds: int = 2,
) -> list[dict[str, Any]]:
    """Run ``topomap batch`` on ``maps`` generated buildings with each worker count.

    The worker counts take turns for ``rounds`` rounds (a busy machine slows them alike) and
    the fastest round of each counts. The cluster's start is timed apart (``startup_s``);
    ``seconds`` runs from the first submission to the last result, every input redone.
    """
    inputs = generated_maps(out / "maps", maps, size)
    runs: dict[int, list[tuple[float, float, list[dict[str, Any]]]]] = {w: [] for w in workers}
    for _ in range(rounds):
        for count in workers:
            start = time.perf_counter()
            with dask_client(count) as client:
                ready = time.perf_counter()
                results = run_batch(inputs, out / f"run-{count}", client=client, force=True)
                runs[count].append((time.perf_counter() - ready, ready - start, results))
    records: list[dict[str, Any]] = []
    for count in workers:
        seconds, startup, results = min(runs[count], key=lambda run: run[0])
        records.append(
            {
                "workers": count,
                "maps": maps,
                "building": size,
                "failed": sum(r["status"] != "ok" for r in results),
                "startup_s": round(startup, 2),
                "seconds": round(seconds, 2),
                "rounds_s": [round(run[0], 2) for run in runs[count]],
                "maps_per_min": round(60 * maps / seconds, 1),
            }
        )
    for record in records:
        record["speedup"] = round(records[0]["seconds"] / record["seconds"], 2)
    return records


def bench_campus_blocks(
    workers: Sequence[int] = (1, 2), *, random_state: int = 0
) -> list[dict[str, Any]]:
    """The whole segmentation of the campus (``MapSegmenter``) with its spectral blocks on a
    local cluster of each worker count (the same single-threaded workers, so only their
    number differs): seconds of the whole call and of its spectral stage, the speed-up over
    the first count, and whether the regions equal the first's."""
    from joblib import parallel_config

    from maps.sim.floorplan import generate_floor_plan
    from segmentation.pipeline import MapSegmenter
    from segmentation.spectral import SpectralSegmenter

    grid = generate_floor_plan("campus", furniture=0.3, random_state=random_state).grid
    records: list[dict[str, Any]] = []
    first = None
    for count in workers:
        with dask_client(count), parallel_config(backend="dask"):
            pipeline = MapSegmenter(SpectralSegmenter(random_state=random_state), n_jobs=-1)
            start = time.perf_counter()
            found = pipeline.segment(grid)
            seconds = time.perf_counter() - start
        labels = found.regions.labels
        first = labels if first is None else first
        records.append(
            {
                "workers": count,
                "keyframes": len(found.keyframes),
                "regions": len(found.regions.ids),
                "seconds": round(seconds, 1),
                "spectral_s": round(found.seconds["spectral"], 1),
                "same_labels": bool(np.array_equal(labels, first)),
            }
        )
    for record in records:
        record["speedup"] = round(records[0]["seconds"] / record["seconds"], 2)
        record["spectral_speedup"] = round(records[0]["spectral_s"] / record["spectral_s"], 2)
    return records


def bench_batch(
    out: str | Path,
    *,
    maps: int = 24,
    workers: Sequence[int] = (1, 2),
    size: str = "flat",
    rounds: int = 2,
    campus: bool = False,
) -> dict[str, Any]:
    """Both benchmarks; writes ``out/results.json`` and returns what it holds."""
    out = Path(out)
    results: dict[str, Any] = {
        "batch": bench_batch_maps(out, maps=maps, workers=workers, size=size, rounds=rounds)
    }
    # the machine's load (other work slows the cluster) when the runs ended
    results["load_average"] = [round(v, 2) for v in os.getloadavg()]
    if campus:
        results["campus_blocks"] = bench_campus_blocks(workers)
    write_text(out / "results.json", json.dumps(results, indent=2), overwrite=True)
    return results
