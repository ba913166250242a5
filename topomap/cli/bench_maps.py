"""``topomap bench maps``: the whole map -> regions pipeline over map sizes.

Each map is segmented from the map alone (conditioning, places, virtual keyframes, the spectral
partition, regions); the table gives wall-clock and CPU seconds and seconds per million free
cells, so growth with the map's size shows at a glance. With ``--command DATA_DIR`` it times
the command users run instead, ``topomap segment MAP.yaml`` in a new process on every map of a
data folder, split into start-up, segmentation and outputs.
"""

from __future__ import annotations

import json
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from maps.carmen import read_carmen
from maps.files import write_text
from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import select_keyframes
from maps.sim.floorplan import generate_floor_plan
from topomap.topomap import pipeline_from_options


def benchmark_maps(
    sizes: Iterable[str], logs: Path | None, seed: int = 0
) -> Iterator[tuple[str, Callable[[], OccupancyGrid]]]:
    """``(name, make_grid)`` for each generated size (furnished, ``seed``) and each CARMEN
    log (``*.log.gz``) in ``logs``: the map a robot built from its keyframes every 0.5 m."""
    for size in sizes:

        def generated(size: str = size) -> OccupancyGrid:
            return generate_floor_plan(size, furniture=0.3, random_state=seed).grid

        yield f"generated-{size}", generated
    for log in sorted(logs.glob("*.log.gz")) if logs is not None else []:

        def built(log: Path = log) -> OccupancyGrid:
            keyframes = select_keyframes(read_carmen(log), distance=0.5)
            return grid_from_keyframes(keyframes, 0.05)

        yield log.name.removesuffix(".log.gz"), built


def time_segmentation(name: str, grid: OccupancyGrid, seed: int = 0) -> dict[str, Any]:
    """Segment ``grid`` from the map alone, as ``topomap segment`` does (its similarity, a
    large map's blocks on every core); its size, regions and seconds."""
    pipeline = pipeline_from_options({"random_state": seed, "n_jobs": -1})
    wall, cpu = time.perf_counter(), time.process_time()
    found = pipeline.segment(grid)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    free = int(grid.free.sum())
    return {
        "map": name,
        "cells": grid.shape[0] * grid.shape[1],
        "free_cells": free,
        "free_m2": round(free * grid.resolution**2),
        "regions": len(found.regions.ids),
        "keyframes": len(found.keyframes),
        "seconds": round(wall, 3),
        "cpu_seconds": round(cpu, 3),
        "s_per_m_free_cells": round(wall / free * 1e6, 3),
        "stages": {k: round(v, 3) for k, v in found.seconds.items()},
    }


def bench_maps(
    out: str | Path,
    *,
    sizes: Iterable[str] = ("flat", "office", "campus"),
    logs: Path | None = None,
    seed: int = 0,
    progress: Callable[[Any], Any] = iter,
) -> list[dict[str, Any]]:
    """Time the pipeline on every map of :func:`benchmark_maps`; write ``out/results.json``."""
    out = Path(out)
    records = [
        time_segmentation(name, make(), seed)
        for name, make in progress(list(benchmark_maps(sizes, logs, seed)))
    ]
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "results.json", json.dumps(records, indent=2), overwrite=True)
    return records


#: What ``topomap segment`` imports before it reads the map, as the command imports it (the
#: collector paused, then frozen: :func:`topomap.cli.commands.common.loading`): its start-up.
STARTUP = (
    "import gc; gc.disable(); import topomap.cli.main, topomap.topomap, topomap.cli.drawing; "
    "gc.freeze()"
)


def _run(command: list[str]) -> tuple[float, float]:
    """``(wall seconds, CPU seconds)`` of running ``command``: user + system time of the
    process, which a machine busy with other work inflates less than the wall time."""
    start, before = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(command, check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return time.perf_counter() - start, cpu


def time_command(yaml: Path, out: Path, startup: float) -> dict[str, Any]:
    """Run ``topomap segment YAML`` as a user does (a new process, every output written) and
    split its wall time into start-up (``startup``: the imports, timed apart), segmentation
    (the stages in its ``summary.json``, graph and names included) and the rest (reading the
    map, writing the files and the picture); ``cpu_s`` is the command's CPU time."""
    command = [sys.executable, "-m", "topomap", "-q", "segment", str(yaml), "--out", str(out)]
    total, cpu = _run([*command, "--force"])
    stages = json.loads((out / "summary.json").read_text())["seconds"]
    segmentation = sum(stages.values())
    return {
        "map": yaml.stem,
        "seconds": round(total, 3),
        "cpu_s": round(cpu, 3),
        "startup_s": round(startup, 3),
        "segmentation_s": round(segmentation, 3),
        "outputs_s": round(max(0.0, total - startup - segmentation), 3),
    }


def bench_command(
    data_dir: str | Path,
    out: str | Path,
    progress: Callable[[Any], Any] = iter,
    canvas: int | None = None,
) -> list[dict[str, Any]]:
    """:func:`time_command` on every map of ``data_dir`` (the layouts
    :func:`topomap.cli.evaluate.floor_plans` reads; ROSE²'s images are given a map_server YAML
    first); start-up is a run of the imports alone just before each map's command, so that a
    machine busy with other work weighs on the two alike. With ``canvas``, each map is timed
    again in the middle of that many cells square of unknown space (:func:`on_canvas`): the
    record named ``NAME@CELLS``."""
    from topomap.cli.evaluate import floor_plans

    out = Path(out)
    records = []
    with tempfile.TemporaryDirectory() as scratch:
        for plan in progress(floor_plans(data_dir)):
            maps = [(plan.name, plan.yaml)]
            if plan.yaml.suffix != ".yaml":
                maps = [(plan.name, plan.grid().save(Path(scratch) / f"{plan.name}.yaml"))]
            if canvas is not None:
                name = f"{plan.name}@{canvas}"
                maps.append(
                    (name, on_canvas(plan.grid(), canvas).save(Path(scratch) / f"{name}.yaml"))
                )
            for name, yaml in maps:
                startup, _ = _run([sys.executable, "-c", STARTUP])
                records.append({**time_command(yaml, Path(scratch) / name, startup), "map": name})
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "command.json", json.dumps(records, indent=2), overwrite=True)
    return records


def on_canvas(grid: OccupancyGrid, cells: int) -> OccupancyGrid:
    """``grid`` in the middle of ``cells`` x ``cells`` unknown cells (or of its own size where
    that is larger), every cell in its place in the map frame: a map as gmapping saves it
    (4000 x 4000 cells by default) round the building it mapped.

    Examples
    --------
    >>> import numpy as np
    >>> big = on_canvas(OccupancyGrid(np.zeros((10, 30), np.int8), 0.1), 20)
    >>> big.shape, int((big.cells == 0).sum()), big.cell_to_world(5, 0)[0]
    ((20, 30), 300, np.float64(0.05))
    """
    rows, cols = max(cells - grid.shape[0], 0), max(cells - grid.shape[1], 0)
    return grid.padded(cols // 2, rows // 2, cols - cols // 2, rows - rows // 2)
