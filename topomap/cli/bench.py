"""Benchmarks that print tables and write JSON (``topomap bench ...``)."""

from __future__ import annotations

import hashlib
import json
import logging
import time
from collections.abc import Callable, Iterator
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.errors import MapFileNotFoundError
from maps.files import write_text
from maps.grid import OccupancyGrid
from maps.scan import Keyframe
from maps.sim.exploration import wander
from maps.sim.floorplan import generate_floor_plan
from maps.sim.laser import LaserModel, RayCaster, simulate_keyframes, simulate_scans
from maps.sim.rooms import ROOM_SIZES, generate_rooms
from planners.benchmark import PLANNER_NAMES, Planner, far_queries, run_queries, summarise
from planners.cspace import HeadingCSpace
from planners.errors import PlannerParameterError
from planners.flat import FlatPlanner
from planners.grid_astar import GridAStar
from planners.grid_mcp import GridMCP
from planners.kinematic import FlatKinematicPlanner
from planners.kinematic_hierarchical import KinematicHierarchicalPlanner
from planners.path import PlannedPath
from planners.robots import Disc, Footprint, parse_robot
from planners.sweep import footprint_collisions
from planners.visibility import VisibilityGraph
from planners.workspace import Point, Workspace
from segmentation.errors import ParameterError
from segmentation.spectral import SpectralSegmenter
from topomap.cli.naive import naive_segment
from topomap.cli.plan_report import plot_footprint_paths, write_report
from topomap.topomap import TopoMap

log = logging.getLogger(__name__)


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
    write_text(out / "results.json", json.dumps(records, indent=2), overwrite=True)
    return records


def robot_keyframes(size: str, count: int, seed: int = 0) -> list[Keyframe]:
    """The first ``count`` keyframes (181 beams, 180 degrees) of a robot wandering through a
    generated building of ``size``."""
    plan = generate_floor_plan(size, furniture=0.3, random_state=seed)
    route = wander(plan.grid, plan.labels, random_state=seed)
    keyframes = simulate_keyframes(
        plan.grid, route.poses, LaserModel(noise=0.01), random_state=seed
    )
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
    write_text(out / "results.json", json.dumps(records, indent=2), overwrite=True)
    return records


#: Generated buildings of the planning benchmark: result name -> generator size.
BUILDINGS = {"generated-flat": "flat", "generated-office": "office", "generated-campus": "campus"}
#: Grid benchmark maps of rooms (:func:`maps.sim.rooms.generate_rooms`, 512 x 512 cells):
#: ``--sizes`` name -> cells from wall to wall.
ROOM_MAPS = {f"rooms{room}": room for room in ROOM_SIZES}


def plan_maps(
    sizes: tuple[str, ...] = ("flat", "office", "campus"),
    maps_dir: str | Path | None = None,
    seed: int = 0,
) -> Iterator[tuple[str, OccupancyGrid]]:
    """The benchmark's maps: generated buildings of ``sizes`` (empty, seed ``seed``), the
    512 x 512 rooms maps of ``sizes`` (:data:`ROOM_MAPS`, seed ``seed``), then every map YAML
    in ``maps_dir``; the sizes and the folder are checked when called, before any map is made.

    Raises
    ------
    PlannerParameterError
        A name in ``sizes`` that is neither a building nor a rooms map.
    MapFileNotFoundError
        A ``maps_dir`` that is no folder, or one without a map YAML.
    """
    unknown = sorted(set(sizes) - set(BUILDINGS.values()) - set(ROOM_MAPS))
    if unknown:
        known = [*BUILDINGS.values(), *ROOM_MAPS]
        raise PlannerParameterError(
            f"unknown map sizes {', '.join(unknown)}; known: {', '.join(known)}"
        )
    yamls: list[Path] = []
    if maps_dir is not None:
        folder = Path(maps_dir)
        if not folder.is_dir():
            raise MapFileNotFoundError(folder, "maps folder")
        yamls = sorted(folder.glob("*.yaml"))
        if not yamls:
            raise MapFileNotFoundError(folder / "*.yaml", "map YAML")
    return _plan_maps(sizes, yamls, seed)


def _plan_maps(
    sizes: tuple[str, ...], yamls: list[Path], seed: int
) -> Iterator[tuple[str, OccupancyGrid]]:
    """The maps of :func:`plan_maps`, each made or read when its turn comes."""
    for name, size in BUILDINGS.items():
        if size in sizes:
            yield name, generate_floor_plan(size, random_state=seed).grid
    for size, room in ROOM_MAPS.items():
        if size in sizes:
            yield f"rooms{room}-512", generate_rooms(512, room, random_state=seed)
    for yaml in yamls:
        yield yaml.stem, OccupancyGrid.load(yaml)


#: Seconds of query time each planner may spend per map before skipping its other queries.
PLAN_BUDGET = 30.0
#: Fixed time budget of the asymptotically optimal OMPL planner, seconds per query.
OPTIMAL_BUDGET = 1.0
#: Longest PRM roadmap growth, seconds (it matches the hierarchical preprocessing up to this).
PRM_MAX_GROWTH = 60.0


def bench_plan(
    out: str | Path,
    *,
    sizes: tuple[str, ...] = ("flat", "office", "campus"),
    maps_dir: str | Path | None = None,
    queries: int = 30,
    robot_radius: float = 0.2,
    time_limit: float = 20.0,
    budget: float = PLAN_BUDGET,
    python_astar: bool = False,
    cache: str | Path | None = "out/cache/exact",
    robot: str | None = None,
    planners: tuple[str, ...] | None = None,
    seed: int = 0,
    progress: Callable[[Any], Any] = iter,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Hierarchical planning against fair baselines on the same far-apart queries of every
    map of :func:`plan_maps`: the compiled grid search (scikit-image ``MCP_Geometric``),
    flat OMPL RRTConnect, PRM (roadmap kept, grown for as long as the hierarchical
    preprocessing took, at most :data:`PRM_MAX_GROWTH` s) and BIT* with a fixed
    :data:`OPTIMAL_BUDGET` s; the pure-Python grid A* only as a reference when asked.

    Preprocessing is timed apart per map (segmentation, submaps, door graph, PRM's roadmap,
    the grid search's set-up, the exact reference). A planner stops after ``budget``
    seconds of queries per map; ``preprocessing.json`` lists what it skipped. The exact
    shortest paths (visibility graph) are cached per map and query set in ``cache`` (None:
    no cache), so a rerun does not rebuild them. Writes the files of
    :func:`topomap.cli.plan_report.write_report` to ``out``; returns the records and the summary.

    ``planners`` names those that run (:data:`~planners.benchmark.PLANNER_NAMES`; default
    all but ``grid_astar``, which ``python_astar`` adds); the others are not even set up.
    A footprint ``robot`` (a :func:`planners.robots.parse_robot` spec other than a disc) runs
    :func:`bench_plan_robot` instead, with only the ``planners`` named (all by default).

    Raises
    ------
    PlannerParameterError
        ``planners`` naming none or one the robot's benchmark does not have.
    """
    model = None if robot is None else parse_robot(robot)
    if model is not None and not isinstance(model, Disc):
        return bench_plan_robot(
            out, model, sizes=sizes, maps_dir=maps_dir, queries=queries,
            time_limit=time_limit, budget=budget, planners=planners, seed=seed,
            progress=progress,
        )  # fmt: skip
    default = PLANNER_NAMES if python_astar else PLANNER_NAMES[:-1]
    chosen = default if planners is None else (*planners, *("grid_astar",) * python_astar)
    unknown = sorted(set(chosen) - set(PLANNER_NAMES))
    if unknown or not chosen:
        raise PlannerParameterError(
            f"unknown planners {', '.join(unknown) or '(none given)'} for a disc robot; "
            f"known: {', '.join(PLANNER_NAMES)}"
        )
    if isinstance(model, Disc):
        robot_radius = model.radius
    records: list[dict[str, Any]] = []
    preprocessing: dict[str, dict[str, Any]] = {}
    for name, grid in plan_maps(sizes, maps_dir, seed):
        clock = time.perf_counter()
        topo = TopoMap.from_grid(grid, random_state=seed)
        pre: dict[str, Any] = {"segmentation": time.perf_counter() - clock}
        hierarchical = topo.planner(robot_radius)
        space = hierarchical.space
        pre["submaps"] = hierarchical.build_seconds
        pre["door_graph"] = hierarchical.prepare()
        running: list[Planner] = [hierarchical] if "hierarchical" in chosen else []
        if "grid_mcp" in chosen:
            mcp = GridMCP(space)
            pre["grid_mcp"] = mcp.build_seconds
            running.append(mcp)
        if "flat_rrtconnect" in chosen:
            running.append(
                FlatPlanner(space, "RRTConnect", time_limit=time_limit, random_state=seed)
            )
        if "flat_prm" in chosen:
            prm = FlatPlanner(space, "PRM", time_limit=time_limit, random_state=seed)
            pre["prm_roadmap"] = min(PRM_MAX_GROWTH, pre["submaps"] + pre["door_graph"])
            prm.grow_roadmap(pre["prm_roadmap"])
            running.append(prm)
        if "flat_bitstar" in chosen:
            running.append(
                FlatPlanner(space, "BITstar", time_limit=OPTIMAL_BUDGET, random_state=seed)
            )
        if "grid_astar" in chosen:
            running.append(GridAStar(space))
        pairs = far_queries(space, queries, random_state=seed)
        optimal, pre["exact_reference"], pre["exact_cached"] = exact_lengths(space, pairs, cache)
        found, skipped = run_queries(
            name, space, running, optimal, pairs, budget=budget, progress=progress
        )
        records += found
        preprocessing[name] = {
            k: round(v, 3) if isinstance(v, float) else v for k, v in pre.items()
        }
        preprocessing[name]["regions"] = topo.graph.number_of_nodes()
        preprocessing[name]["submaps_count"] = len(hierarchical.region_of)
        preprocessing[name]["doors"] = len(hierarchical.doors)
        preprocessing[name]["skipped_queries"] = {k: v for k, v in skipped.items() if v}
    summary = summarise(records)
    write_report(out, records, summary, preprocessing, time_limit, seed)
    return records, summary


#: Flat OMPL planners of the footprint benchmark (each stops at its first exact solution;
#: PRM keeps its roadmap across the queries of a map). RRT is the one the hierarchical
#: planner runs for a forward-only car (RRTConnect's goal tree grows along reversed motions).
ROBOT_BASELINES = ("RRTConnect", "RRT", "RRTstar", "BITstar", "KPIECE1", "PRM")
#: Benchmark names of the footprint benchmark's planners, in table order.
ROBOT_PLANNERS = (
    "hierarchical",
    "hierarchical_union",
    *(f"flat_{name.lower()}" for name in ROBOT_BASELINES),
)
#: Paths drawn per map in ``paths.png``.
DRAWN_PATHS = 3


def bench_plan_robot(
    out: str | Path,
    robot: Footprint,
    *,
    sizes: tuple[str, ...] = ("office", "campus"),
    maps_dir: str | Path | None = None,
    queries: int = 10,
    time_limit: float = 10.0,
    budget: float = PLAN_BUDGET,
    planners: tuple[str, ...] | None = None,
    seed: int = 0,
    progress: Callable[[Any], Any] = iter,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Hierarchical planning with OMPL inside submaps against flat OMPL on the whole map for a
    footprint robot: the same configuration space (computed once per map and shared, timed
    as preprocessing), state space, validity and motion checks, simplification and
    ``time_limit`` per query (for the hierarchical planner: all its routes and legs); flat
    planners :data:`ROBOT_BASELINES` (PRM's roadmap grown first for as long as the
    hierarchical preprocessing took, at most :data:`PRM_MAX_GROWTH` s, and kept), the
    hierarchical planner per leg (``hierarchical``) and over the union of the route's
    submaps (``hierarchical_union``). Queries are ``queries`` far-apart points where a disc as
    wide as the narrowest door the robot takes and the robot stand, each at the valid heading
    nearest 0.
    Collisions are counted by the independent footprint sweep
    (:func:`planners.sweep.footprint_collisions`); lengths are compared with the disc's
    door-graph path. Writes :func:`topomap.cli.plan_report.write_report`'s files,
    ``paths.json`` (footprint, maps, every path's poses) and ``paths.png`` (a few paths of
    each map with the footprint drawn along them). ``planners`` names those that run
    (:data:`ROBOT_PLANNERS`, all by default); the others are not even set up.

    Raises
    ------
    PlannerParameterError
        A name in ``planners`` that is not one of :data:`ROBOT_PLANNERS`.
    """
    chosen = ROBOT_PLANNERS if planners is None else tuple(planners)
    unknown = sorted(set(chosen) - set(ROBOT_PLANNERS))
    if unknown or not chosen:
        raise PlannerParameterError(
            f"unknown planners {', '.join(unknown) or '(none given)'}; "
            f"known: {', '.join(ROBOT_PLANNERS)}"
        )
    records: list[dict[str, Any]] = []
    preprocessing: dict[str, dict[str, Any]] = {}
    found_paths: list[dict[str, Any]] = []
    maps: dict[str, str] = {}
    made: dict[str, OccupancyGrid] = {}  # the generated maps, saved once all are benchmarked
    for name, grid in plan_maps(sizes, maps_dir, seed):
        clock = time.perf_counter()
        topo = TopoMap.from_grid(grid, random_state=seed)
        pre: dict[str, Any] = {"segmentation": time.perf_counter() - clock}
        clock = time.perf_counter()
        cspace = HeadingCSpace(grid, robot)
        pre["cspace"] = time.perf_counter() - clock
        hierarchical = KinematicHierarchicalPlanner(
            cspace, topo.regions.labels, topo.graph, time_limit=time_limit, random_state=seed
        )
        pre["submaps"] = hierarchical.build_seconds
        pre["door_graph"] = hierarchical.prepare()
        running: list[Planner] = [hierarchical] if hierarchical.name in chosen else []
        if "hierarchical_union" in chosen:
            union = KinematicHierarchicalPlanner(
                cspace, topo.regions.labels, topo.graph, time_limit=time_limit, mode="union",
                random_state=seed,
            )  # fmt: skip
            union.prepare()
            running.append(union)
        for baseline in ROBOT_BASELINES:
            if f"flat_{baseline.lower()}" not in chosen:
                continue
            try:
                flat = FlatKinematicPlanner(
                    cspace, baseline, time_limit=time_limit, random_state=seed
                )
            except PlannerParameterError as err:  # PRM for a forward-only car
                if planners is not None:  # asked for by name
                    raise
                log.warning("flat %s left out: %s", baseline, err)
                continue
            if flat.ompl.keeps_roadmap:
                pre["prm_roadmap"] = min(PRM_MAX_GROWTH, pre["submaps"] + pre["door_graph"])
                flat.ompl.grow_roadmap(pre["prm_roadmap"])
            running.append(flat)
        guide = hierarchical.doors
        # the first ``queries`` where the robot stands at both ends (drawn in the same order
        # whatever the count: a larger count adds queries after the same first ones)
        pairs = [
            (s, g)
            for s, g in far_queries(guide.space, 2 * queries, random_state=seed)
            if len(cspace.free_headings(*s)) and len(cspace.free_headings(*g))
        ][:queries]
        reference = [guide.plan(s, g).length for s, g in pairs]
        found, skipped = run_queries(
            name, guide.space, running, reference, pairs, budget=budget, progress=progress,
            collisions=partial(_sweep, grid, robot), paths=found_paths,
        )  # fmt: skip
        records += found
        preprocessing[name] = {k: round(v, 3) for k, v in pre.items()}
        preprocessing[name]["robot"] = robot.name
        preprocessing[name]["skipped_queries"] = {k: v for k, v in skipped.items() if v}
        if maps_dir is not None and (Path(maps_dir) / f"{name}.yaml").exists():
            maps[name] = str(Path(maps_dir) / f"{name}.yaml")
        else:
            maps[name] = str(Path(out) / "maps" / f"{name}.yaml")
            made[name] = grid
    for name, grid in made.items():
        grid.save(maps[name], overwrite=True)
    summary = summarise(records)
    write_report(out, records, summary, preprocessing, time_limit, seed)
    about = {"footprint": robot.polygon.tolist(), "maps": maps, "paths": found_paths}
    write_text(Path(out) / "paths.json", json.dumps(about), overwrite=True)
    plot_footprint_paths(Path(out) / "paths.png", about, per_map=DRAWN_PATHS)
    return records, summary


def _sweep(grid: OccupancyGrid, robot: Footprint, path: PlannedPath) -> int:
    return footprint_collisions(grid, robot.polygon, path.poses)


def exact_lengths(
    space: Workspace, pairs: list[tuple[Point, Point]], cache: str | Path | None
) -> tuple[list[float], float, bool]:
    """Exact shortest path lengths of ``pairs`` (visibility graph), read from ``cache`` when
    this map, robot radius and query set were solved before; returns the lengths, the
    seconds it took to compute them (when they were computed) and whether they were cached."""
    key = hashlib.sha1(space.free.tobytes())
    key.update(json.dumps([space.free.shape, space.grid.resolution, space.grid.origin]).encode())
    key.update(json.dumps(pairs).encode())
    path = None if cache is None else Path(cache) / f"{key.hexdigest()}.json"
    if path is not None and path.exists():
        stored = json.loads(path.read_text())
        return stored["lengths"], stored["seconds"], True
    clock = time.perf_counter()
    reference = VisibilityGraph(space)
    lengths = [reference.plan(s, g).length for s, g in pairs]
    seconds = time.perf_counter() - clock
    if path is not None:
        write_text(path, json.dumps({"lengths": lengths, "seconds": seconds}), overwrite=True)
    return lengths, seconds, False
