"""The demo: the whole pipeline on a generated building, writing pictures and a summary.

Each stage is a function of the run's :class:`DemoRun`; it adds its results to the run and
the summary, and its time is recorded (:data:`STAGES`, in order).
"""

from __future__ import annotations

import json
import logging
import multiprocessing
import re
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import Keyframe, poses_array
from maps.sim.exploration import Route, wander
from maps.sim.floorplan import FloorPlan, generate_floor_plan
from maps.sim.laser import LaserModel, simulate_keyframes
from planners.benchmark import far_queries
from planners.flat import FlatPlanner
from planners.path import PlannedPath
from planners.visibility import VisibilityGraph
from segmentation.metrics import score
from segmentation.pipeline import MapSegmenter
from topomap.cli.drawing import draw_map, draw_paths, draw_regions
from topomap.cli.online import agreement, dense_regions, run_online, write_gif
from topomap.topomap import TopoMap

log = logging.getLogger(__name__)


@dataclass
class DemoRun:
    """What the demo's stages share: options, intermediate results and the summary."""

    out: Path
    size: str = "office"
    seed: int = 0
    plan: FloorPlan | None = None
    route: Route | None = None
    keyframes: list[Keyframe] = field(default_factory=list)
    grid: OccupancyGrid | None = None
    topo: TopoMap | None = None
    plan_topo: TopoMap | None = None
    summary: dict[str, Any] = field(default_factory=dict)


def generate(run: DemoRun) -> None:
    """Generate the building and its ground truth."""
    run.plan = generate_floor_plan(run.size, furniture=0.3, random_state=run.seed)
    xmin, ymin, xmax, ymax = run.plan.grid.bounds()
    width, height = xmax - xmin, ymax - ymin
    run.summary["building"] = {
        "size": run.size,
        "seed": run.seed,
        "extent_m": [round(width, 2), round(height, 2)],
        "cells": list(run.plan.grid.shape),
        "spaces": dict(Counter(run.plan.types)),
        "doors": len(run.plan.doors),
    }


def drive(run: DemoRun) -> None:
    """Wander through every room, keep a keyframe every 0.5 m or 30 degrees; the laser (a scan
    at every pose) is simulated at the keyframes, the only scans used."""
    assert run.plan is not None
    run.route = wander(run.plan.grid, run.plan.labels, random_state=run.seed)
    laser = LaserModel(noise=0.01, dropout=0.01)
    run.keyframes = simulate_keyframes(run.plan.grid, run.route.poses, laser, random_state=run.seed)
    run.summary["robot"] = {
        "route_m": round(run.route.length, 1),
        "rooms_visited": len(run.route.visited),
        "rooms_unreachable": len(run.route.unreachable),
        "scans": len(run.route.poses),
        "keyframes": len(run.keyframes),
    }


def build_map(run: DemoRun) -> None:
    """Build an occupancy grid from the keyframes and compare it with the true plan."""
    assert run.plan is not None
    run.grid = grid_from_keyframes(run.keyframes, run.plan.grid.resolution)
    run.grid.save(run.out / "map.yaml", overwrite=True)
    truth = run.plan.grid
    xs, ys = truth.cell_to_world(*np.nonzero(truth.free))
    found = run.grid.is_free(xs, ys)
    xb, yb = run.grid.cell_to_world(*np.nonzero(run.grid.free))
    wrong = ~truth.is_free(xb, yb)
    run.summary["map"] = {
        "cells": list(run.grid.shape),
        "true_free_cells_found": round(float(found.mean()), 4),
        "free_cells_not_free_in_truth": round(float(wrong.mean()), 4),
    }
    draw_map(
        run.out / "map.png",
        run.grid,
        route=run.route.poses if run.route is not None else None,
        keyframes=poses_array(run.keyframes),
        title=f"map from {len(run.keyframes)} keyframes of a generated {run.size} building",
    )


def _truth_on(grid: OccupancyGrid, plan: FloorPlan) -> NDArray[np.int32]:
    """The plan's room labels looked up at the centres of ``grid``'s cells (0 outside)."""
    rows, cols = np.indices(grid.shape)
    x, y = grid.cell_to_world(rows.ravel(), cols.ravel())
    prow, pcol = plan.grid.world_to_cell(x, y)
    inside = plan.grid.contains(prow, pcol)
    truth = np.zeros(rows.size, np.int32)
    truth[inside] = plan.labels[prow[inside], pcol[inside]]
    return truth.reshape(grid.shape)


def _segment(
    run: DemoRun, topo: TopoMap, name: str, truth: NDArray[np.int32], doors: NDArray[np.int32]
) -> None:
    """Save and draw ``topo``; score its regions (the spectral partition) and the door-rule
    baseline's ``doors`` labels against ``truth``."""
    folder = run.out / name
    topo.save(folder, overwrite=True)
    draw_regions(
        folder / "segmentation.png",
        topo.grid,
        topo.regions.labels,
        topo.graph,
        title=f"{name}: {topo.graph.number_of_nodes()} regions",
    )
    run.summary[name] = {
        "keyframes": len(topo.keyframes),
        "regions": topo.graph.number_of_nodes(),
        "doors": sum(len(d) for _, _, d in topo.graph.edges(data="doors")),
        "labels": dict(Counter(label for _, label in topo.graph.nodes(data="label"))),
        "names": {int(r): name for r, name in sorted(topo.graph.nodes(data="name"))},
        "spectral": _rounded(score(topo.regions.labels, truth).as_dict()),
        "doors_baseline": _rounded(score(doors, truth).as_dict()),
        "seconds": {k: round(v, 3) for k, v in topo.seconds.items()},
    }


def _rounded(scores: dict[str, float | int]) -> dict[str, float | int]:
    return {k: round(v, 4) if isinstance(v, float) else v for k, v in scores.items()}


def segment_log(run: DemoRun) -> None:
    """Segment the robot's keyframes on the map built from them; score against the plan."""
    assert run.plan is not None and run.grid is not None
    run.topo = TopoMap.from_keyframes(run.keyframes, run.grid, random_state=run.seed)
    doors = MapSegmenter(method="doors").segment(run.grid, run.keyframes, random_state=run.seed)
    _segment(run, run.topo, "segment_log", _truth_on(run.grid, run.plan), doors.regions.labels)


def segment_plan(run: DemoRun) -> None:
    """Segment the true plan alone (virtual keyframes), as floor plans are segmented."""
    assert run.plan is not None
    run.plan_topo = TopoMap.from_grid(run.plan.grid, random_state=run.seed)
    doors = MapSegmenter(method="doors").segment(run.plan.grid, random_state=run.seed)
    _segment(run, run.plan_topo, "segment_plan", run.plan.labels, doors.regions.labels)


def plan_paths(run: DemoRun, queries: int = 10) -> None:
    """Plan far-apart queries on the segmented plan, hierarchically and with flat OMPL
    RRTConnect; draw the first pair of paths, report both planners' times side by side."""
    assert run.plan_topo is not None
    hierarchical = run.plan_topo.planner()
    prepare = hierarchical.prepare()
    flat = FlatPlanner(hierarchical.space, "RRTConnect", random_state=run.seed)
    reference = VisibilityGraph(hierarchical.space)
    results: dict[str, list[PlannedPath]] = {"hierarchical": [], "flat_rrtconnect": []}
    optimal = []
    for start, goal in far_queries(hierarchical.space, queries, random_state=run.seed):
        results["hierarchical"].append(hierarchical.plan(start, goal))
        results["flat_rrtconnect"].append(flat.plan(start, goal))
        optimal.append(reference.plan(start, goal).length)
    draw_paths(
        run.out / "paths.png",
        run.plan.grid if run.plan is not None else run.plan_topo.grid,
        hierarchical.labels,
        {name: paths[0] for name, paths in results.items()},
        title="hierarchical against flat planning (first query)",
    )
    summary: dict[str, Any] = {"queries": queries, "preprocessing_s": round(prepare, 3)}
    for name, paths in results.items():
        ratios = [p.length / best for p, best in zip(paths, optimal, strict=True)]
        summary[name] = {
            "median_ms": round(1000 * float(np.median([p.total_seconds for p in paths])), 2),
            "length_over_shortest_median": round(float(np.median(ratios)), 4),
        }
    summary["speedup"] = round(
        summary["flat_rrtconnect"]["median_ms"] / summary["hierarchical"]["median_ms"], 1
    )
    run.summary["plan"] = summary


def segment_online(run: DemoRun) -> None:
    """Segment the run online (the offline engine on the robot's neighbourhood, after the
    default seed); score it against the plan beside the offline result; draw the regions
    growing (GIF)."""
    assert run.plan is not None and run.grid is not None
    keyframes = run.keyframes
    folder = run.out / "segment_online"
    online = run_online(
        keyframes,
        random_state=run.seed,
        frames_every=max(1, len(keyframes) // 12),
        frames_dir=folder / "frames",
    )
    write_gif(online.frames, folder / "regions.gif")
    assert run.topo is not None  # segment_log ran first: its regions are the offline result
    offline = run.topo.keyframe_regions()
    truth = _truth_on(run.grid, run.plan)
    # both partitions of the keyframes made dense the same way: the scores compare like for like
    regions = dense_regions(run.grid, keyframes, online.online.labels_, named=False)[0]
    offline_regions = dense_regions(run.grid, keyframes, offline, named=False)[0]
    run.summary["segment_online"] = {
        "method": "windows",
        "seed_keyframes": online.online.n_seed_,
        "regions": online.online.n_regions_,
        "offline_regions": len(np.unique(offline[offline > 0])),
        "ari_online_vs_offline": agreement(online.online.labels_, offline),
        "spectral": _rounded(score(regions.labels, truth).as_dict()),
        "offline_spectral": _rounded(score(offline_regions.labels, truth).as_dict()),
        "latency": online.latency_ms(),
    }


STAGES: list[Callable[[DemoRun], None]] = [
    generate,
    drive,
    build_map,
    segment_log,
    segment_online,
    segment_plan,
    plan_paths,
]
#: After ``generate``, ``drive`` and ``build_map``, these chains need nothing from each other:
#: they run side by side in worker processes, the longest first.
CHAINS: list[list[Callable[[DemoRun], None]]] = [
    [segment_log, segment_online],
    [segment_plan, plan_paths],
]


def _run_chain(
    run: DemoRun, chain: list[Callable[[DemoRun], None]]
) -> tuple[dict[str, Any], dict[str, float]]:
    """Run ``chain``'s stages in order; return what they added to the summary, and their
    seconds."""
    known = set(run.summary)
    seconds: dict[str, float] = {}
    for stage in chain:
        start = time.perf_counter()
        stage(run)
        seconds[stage.__name__] = round(time.perf_counter() - start, 3)
        log.info("%s: %.2f s", stage.__name__, seconds[stage.__name__])
    return {k: v for k, v in run.summary.items() if k not in known}, seconds


def run_demo(
    out: str | Path,
    *,
    size: str = "office",
    seed: int = 0,
    jobs: int = 2,
    on_stage: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run every stage, write ``summary.json`` and the pictures into ``out``; return the summary.

    The first three stages run in order, then the :data:`CHAINS` in ``jobs`` worker processes
    (in this process, one after the other, when ``jobs`` is 1); the results are the same.
    ``on_stage`` is called as each stage starts, with its number, name and what it does.
    ``summary["seconds"]`` holds each stage's seconds, ``summary["wall_seconds"]`` the whole
    run's.
    """
    clock = time.perf_counter()
    run = DemoRun(Path(out), size=size, seed=seed)
    run.out.mkdir(parents=True, exist_ok=True)

    def announce(stage: Callable[[DemoRun], None]) -> None:
        if on_stage is not None:
            doc = " ".join(re.split(r"[.;]\s", stage.__doc__ or "")[0].split()).rstrip(".")
            on_stage(f"[{STAGES.index(stage) + 1}/{len(STAGES)}] {stage.__name__}: {doc}")

    first = [stage for stage in STAGES if not any(stage in chain for chain in CHAINS)]
    seconds: dict[str, float] = {}
    for stage in first:
        announce(stage)
        seconds.update(_run_chain(run, [stage])[1])
    if jobs > 1:
        context = multiprocessing.get_context("spawn")  # no fork of a process with threads
        with ProcessPoolExecutor(min(jobs, len(CHAINS)), mp_context=context) as pool:
            futures = [pool.submit(_run_chain, run, chain) for chain in CHAINS]
            for chain in CHAINS:
                for stage in chain:
                    announce(stage)
            done = [future.result() for future in futures]
    else:
        done = []
        for chain in CHAINS:
            for stage in chain:
                announce(stage)
            done.append(_run_chain(run, chain))
    for added, chain_seconds in done:
        run.summary.update(added)
        seconds.update(chain_seconds)
    run.summary["seconds"] = {stage.__name__: seconds[stage.__name__] for stage in STAGES}
    run.summary["wall_seconds"] = round(time.perf_counter() - clock, 3)
    (run.out / "summary.json").write_text(json.dumps(run.summary, indent=2))
    return run.summary


def summary_rows(summary: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per stage of a :func:`run_demo` summary: ``stage``, ``seconds`` and a short
    ``result`` (the numbers a reader checks first; ``summary.json`` holds them all)."""
    building, robot, built = summary["building"], summary["robot"], summary["map"]
    width, height = building["extent_m"]
    spaces = sum(building["spaces"].values())
    results = {
        "generate": f"{building['size']} {width:g} x {height:g} m, {spaces} spaces, "
        f"{building['doors']} doors",
        "drive": f"{robot['route_m']:g} m, {robot['rooms_visited']} rooms visited, "
        f"{robot['scans']} scans, {robot['keyframes']} keyframes",
        "build_map": f"{100 * built['true_free_cells_found']:.1f}% of the free cells found, "
        f"{100 * built['free_cells_not_free_in_truth']:.1f}% wrongly free",
    }
    for name in ("segment_log", "segment_plan"):
        found, ours, doors = (
            summary[name],
            summary[name]["spectral"],
            summary[name]["doors_baseline"],
        )
        results[name] = (
            f"{found['regions']} regions ({ours['rooms']} true): MCC {ours['mcc']:.2f}, "
            f"recall {ours['recall']:.2f}, precision {ours['precision']:.2f} "
            f"(door-rule baseline MCC {doors['mcc']:.2f})"
        )
    online = summary["segment_online"]
    offline = online["offline_spectral"]
    results["segment_online"] = (
        f"{online['regions']} regions, ARI {online['ari_online_vs_offline']:.2f} vs offline, "
        f"MCC {online['spectral']['mcc']:.2f} (offline spectral {offline['mcc']:.2f}), "
        f"p95 {online['latency']['p95_ms']:g} ms per keyframe"
    )
    plan = summary["plan"]
    results["plan_paths"] = (
        f"{plan['queries']} queries, median hierarchical {plan['hierarchical']['median_ms']:g} "
        f"ms, flat RRTConnect {plan['flat_rrtconnect']['median_ms']:g} ms "
        f"({plan['speedup']:g}x)"
    )
    rows = [
        {"stage": stage, "seconds": f"{seconds:.1f}", "result": results.get(stage, "")}
        for stage, seconds in summary["seconds"].items()
    ]
    total = sum(summary["seconds"].values())
    wall = summary.get("wall_seconds", total)
    together = f"stages side by side: {wall:.1f} s of wall-clock time" if wall < total else ""
    return [*rows, {"stage": "total", "seconds": f"{total:.1f}", "result": together}]
