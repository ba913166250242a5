"""Benchmarks that print tables and write JSON (``topomap bench ...``)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.errors import MapFileNotFoundError
from maps.floorplan import generate_floor_plan
from maps.grid import OccupancyGrid
from maps.laser_sim import LaserModel, RayCaster, simulate_scans
from maps.scan import Keyframe, select_keyframes
from maps.wander import wander
from planners.benchmark import Planner, far_queries, run_queries, summarise, write_report
from planners.flat import FlatPlanner
from planners.grid_astar import GridAStar
from planners.visibility import VisibilityGraph
from segmentation.errors import ParameterError
from segmentation.naive import naive_segment
from segmentation.spectral import SpectralSegmenter
from topomap.topomap import TopoMap


def bench_sim(
    out: str | Path,
    *,
    scans: tuple[int, ...] = (1_000, 10_000),
    beams: tuple[int, ...] = (181, 361),
    seed: int = 0,
    progress: Callable[[Any], Any] = iter,
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
    poses: dict[int, NDArray[np.float64]] = {}
    for n in scans:
        pick = rng.integers(len(rows), size=n)
        x, y = plan.grid.cell_to_world(rows[pick], cols[pick])
        poses[n] = np.column_stack((x, y, rng.uniform(-np.pi, np.pi, n)))
    for n, b in progress([(n, b) for n in scans for b in beams]):
        model = LaserModel(fov=np.pi if b % 2 else 2 * np.pi, beams=b, noise=0.01)
        start = time.perf_counter()
        simulate_scans(plan.grid, poses[n], model, random_state=seed, caster=caster)
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
        raise ParameterError(
            f"the {size} building gives {len(keyframes)} keyframes, not {count}: "
            "ask for fewer (--sizes) or a larger building (--building)"
        )
    return keyframes[:count]


def bench_segment(
    out: str | Path,
    *,
    sizes: tuple[int, ...] = (1_000, 2_000, 5_000, 10_000),
    naive_up_to: int = 2_000,
    building: str = "campus",
    seed: int = 0,
    progress: Callable[[Any], Any] = iter,
) -> list[dict[str, Any]]:
    """Time the spectral partition (similarity + eigenvectors + k search) against the naive one.

    Keyframes come from :func:`robot_keyframes`. Records ``{"method": "topomap" | "naive",
    "keyframes", "seconds", "regions"}`` go to ``out/results.json``; the naive version (all
    pairs, dense matrices, the same criterion) runs for sizes up to ``naive_up_to``.
    """
    keyframes = robot_keyframes(building, max(sizes), seed)
    records: list[dict[str, Any]] = []
    for n in progress(sizes):
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


#: Generated buildings of the planning benchmark: result name -> generator size.
BUILDINGS = {"generated-flat": "flat", "generated-office": "office", "generated-campus": "campus"}


def plan_maps(
    sizes: tuple[str, ...] = ("flat", "office", "campus"),
    maps_dir: str | Path | None = None,
    seed: int = 0,
) -> Iterator[tuple[str, OccupancyGrid]]:
    """The benchmark's maps: generated buildings of ``sizes`` (empty, seed ``seed``), then
    every map YAML in ``maps_dir``."""
    for name, size in BUILDINGS.items():
        if size in sizes:
            yield name, generate_floor_plan(size, random_state=seed).grid
    if maps_dir is not None:
        folder = Path(maps_dir)
        if not folder.is_dir():
            raise MapFileNotFoundError(folder, "maps folder")
        yamls = sorted(folder.glob("*.yaml"))
        if not yamls:
            raise MapFileNotFoundError(folder / "*.yaml", "map YAML")
        for yaml in yamls:
            yield yaml.stem, OccupancyGrid.load(yaml)


def bench_plan(
    out: str | Path,
    *,
    sizes: tuple[str, ...] = ("flat", "office", "campus"),
    maps_dir: str | Path | None = None,
    queries: int = 30,
    robot_radius: float = 0.2,
    time_limit: float = 20.0,
    seed: int = 0,
    progress: Callable[[Any], Any] = iter,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Hierarchical planning against flat OMPL RRTConnect, flat PRM (roadmap kept across
    queries) and grid A*, on the same far-apart queries of every map of :func:`plan_maps`.

    Preprocessing is timed apart per map: segmentation, submaps, door-to-door legs, PRM's
    roadmap (grown for one second per 1000 m^2 of free space, 2 to 30 s) and the exact
    reference (visibility graph). Writes the files of
    :func:`planners.benchmark.write_report` to ``out``; returns the records and the summary.
    """
    records: list[dict[str, Any]] = []
    preprocessing: dict[str, dict[str, float]] = {}
    for name, grid in plan_maps(sizes, maps_dir, seed):
        clock = time.perf_counter()
        topo = TopoMap.from_grid(grid, random_state=seed)
        pre = {"segmentation": time.perf_counter() - clock}
        hierarchical = topo.planner(robot_radius, random_state=seed)
        space = hierarchical.space
        pre["submaps"] = hierarchical.build_seconds
        pre["legs"] = hierarchical.prepare()
        rrt = FlatPlanner(space, "RRTConnect", time_limit=time_limit, random_state=seed)
        prm = FlatPlanner(space, "PRM", time_limit=time_limit, random_state=seed)
        free_area = float(space.free.sum()) * grid.resolution**2
        pre["prm_roadmap"] = min(30.0, max(2.0, free_area / 1000))
        prm.grow_roadmap(pre["prm_roadmap"])
        clock = time.perf_counter()
        astar = GridAStar(space)
        pre["grid_astar"] = time.perf_counter() - clock
        reference = VisibilityGraph(space)
        pre["exact_reference"] = reference.build_seconds
        preprocessing[name] = {k: round(v, 3) for k, v in pre.items()}
        preprocessing[name]["regions"] = topo.graph.number_of_nodes()
        preprocessing[name]["submaps_count"] = len(hierarchical.region_of)
        pairs = far_queries(space, queries, random_state=seed)
        planners: list[Planner] = [hierarchical, rrt, prm, astar]
        records += run_queries(name, space, planners, reference, pairs, progress=progress)
    summary = summarise(records)
    write_report(out, records, summary, preprocessing)
    return records, summary
