"""The demo: the whole pipeline on a generated building, writing pictures and a summary.

Each stage is a function of the run's :class:`DemoRun`; it adds its results to the run and
the summary, and its time is recorded (:data:`STAGES`, in order).
"""

from __future__ import annotations

import json
import logging
import re
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.files import check_output_folder, write_text, written
from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import Keyframe, poses_array
from maps.sim.exploration import Route, wander
from maps.sim.floorplan import FloorPlan, generate_floor_plan
from maps.sim.laser import simulate_keyframes
from maps.sim.survey import SURVEY_LASER
from planners.benchmark import far_queries
from planners.flat import FlatPlanner
from planners.path import PlannedPath
from planners.visibility import VisibilityGraph
from planners.workspace import Point, Workspace
from segmentation.metrics import score
from segmentation.pipeline import MapSegmenter
from topomap.cli.drawing import draw_map, draw_paths, draw_regions
from topomap.cli.online import agreement, dense_regions, run_online, write_gif
from topomap.topomap import TopoMap

log = logging.getLogger(__name__)

#: Far-apart queries planned; the disc robot's radius (m).
QUERIES, ROBOT_RADIUS = 10, 0.2
#: The summary's sections in order.
SUMMARY_ORDER: tuple[str, ...] = ("building", "robot", "map", "segment_log", "segment_online")
SUMMARY_ORDER += ("segment_plan", "plan")


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
    plan_topo: TopoMap | None = None
    summary: dict[str, Any] = field(default_factory=dict)
    offline: NDArray[np.int64] | None = None  # region of each keyframe (segment_log)
    truth: NDArray[np.int32] | None = None  # the plan's rooms on the built map, a corridor
    # system one room (:meth:`~maps.sim.floorplan.FloorPlan.corridor_systems`), as the issue asks
    offline_spectral: dict[str, float | int] | None = None  # the offline keyframes' scores
    online: dict[str, Any] | None = None  # what online_run found
    paths: dict[str, list[PlannedPath]] = field(default_factory=dict)
    optimal: list[float] = field(default_factory=list)  # the queries' shortest lengths
    prepare_s: float = 0.0  # the hierarchical planner's preprocessing
    path_labels: NDArray[np.int32] | None = None  # the hierarchical planner's submaps


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
    run.keyframes = simulate_keyframes(
        run.plan.grid, run.route.poses, SURVEY_LASER, random_state=run.seed
    )
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
    """Segment the robot's keyframes on the map built from them; score against the plan's
    rooms, each corridor system one."""
    assert run.plan is not None and run.grid is not None
    topo = TopoMap.from_keyframes(run.keyframes, run.grid, random_state=run.seed)
    doors = MapSegmenter(method="doors").segment(run.grid, run.keyframes, random_state=run.seed)
    run.truth = run.plan.rooms_on(run.grid, run.plan.corridor_systems())
    _segment(run, topo, "segment_log", run.truth, doors.regions.labels)
    run.offline = topo.keyframe_regions()


def offline_scores(run: DemoRun) -> None:
    """:func:`segment_online`'s offline side: the offline partition of the keyframes made
    dense as the online one is, scored (after :func:`segment_log`)."""
    assert run.grid is not None and run.offline is not None and run.truth is not None
    offline_regions = dense_regions(run.grid, run.keyframes, run.offline, named=False)[0]
    run.offline_spectral = _rounded(score(offline_regions.labels, run.truth).as_dict())


def segment_plan(run: DemoRun) -> None:
    """Segment the true plan alone (virtual keyframes), as floor plans are segmented; score
    against its rooms, each corridor system one."""
    assert run.plan is not None
    run.plan_topo = TopoMap.from_grid(run.plan.grid, random_state=run.seed)
    doors = MapSegmenter(method="doors").segment(run.plan.grid, random_state=run.seed)
    truth = run.plan.corridor_systems()
    _segment(run, run.plan_topo, "segment_plan", truth, doors.regions.labels)


def _queries(space: Workspace, run: DemoRun) -> list[tuple[Point, Point]]:
    return list(far_queries(space, QUERIES, random_state=run.seed))


def hierarchical_paths(run: DemoRun) -> None:
    """:func:`plan_paths`' hierarchical queries (after :func:`segment_plan`)."""
    assert run.plan_topo is not None
    hierarchical = run.plan_topo.planner(ROBOT_RADIUS)
    run.prepare_s = hierarchical.prepare()
    paths = [hierarchical.plan(*q) for q in _queries(hierarchical.space, run)]
    run.paths = {**run.paths, "hierarchical": paths}
    run.path_labels = hierarchical.labels


def flat_paths(run: DemoRun) -> None:
    """:func:`plan_paths`' flat RRTConnect queries and their shortest lengths (on the plan
    alone: the same robot space as the hierarchical planner's)."""
    assert run.plan is not None
    space = Workspace(run.plan.grid, ROBOT_RADIUS)
    flat = FlatPlanner(space, "RRTConnect", random_state=run.seed)
    reference = VisibilityGraph(space)
    queries = _queries(space, run)
    run.paths = {**run.paths, "flat_rrtconnect": [flat.plan(*q) for q in queries]}
    run.optimal = [reference.plan(*q).length for q in queries]


def plan_paths(run: DemoRun) -> None:
    """Plan far-apart queries on the segmented plan, hierarchically and with flat OMPL
    RRTConnect; draw the first pair of paths, report both planners' times side by side."""
    assert run.plan is not None and run.path_labels is not None
    draw_paths(
        run.out / "paths.png",
        run.plan.grid,
        run.path_labels,
        {name: run.paths[name][0] for name in ("hierarchical", "flat_rrtconnect")},
        title="hierarchical against flat planning (first query)",
    )
    summary: dict[str, Any] = {"queries": QUERIES, "preprocessing_s": round(run.prepare_s, 3)}
    for name in ("hierarchical", "flat_rrtconnect"):
        paths = run.paths[name]
        ratios = [p.length / best for p, best in zip(paths, run.optimal, strict=True)]
        summary[name] = {
            "median_ms": round(1000 * float(np.median([p.total_seconds for p in paths])), 2),
            "length_over_shortest_median": round(float(np.median(ratios)), 4),
        }
    summary["speedup"] = round(
        summary["flat_rrtconnect"]["median_ms"] / summary["hierarchical"]["median_ms"], 1
    )
    run.summary["plan"] = summary


def online_run(run: DemoRun) -> None:
    """:func:`segment_online`'s pass over the keyframes, drawing the regions growing (GIF)."""
    folder = run.out / "segment_online"
    found = run_online(
        run.keyframes,
        random_state=run.seed,
        frames_every=max(1, len(run.keyframes) // 12),
        frames_dir=folder / "frames",
    )
    with written(folder / "regions.gif", overwrite=True) as partial:
        write_gif(found.frames, partial)
    run.online = {
        "labels": found.online.labels_,
        "seed_keyframes": found.online.n_seed_,
        "regions": found.online.n_regions_,
        "latency": found.latency_ms(),
    }


def segment_online(run: DemoRun) -> None:
    """Segment the run online (the offline engine on the robot's neighbourhood, after the
    default seed); score it against the plan beside the offline result; draw the regions
    growing (GIF)."""
    assert run.grid is not None and run.truth is not None and run.offline is not None
    assert run.online is not None  # online_run, segment_log and offline_scores ran
    online, offline = run.online["labels"], run.offline
    # both partitions of the keyframes made dense the same way: the scores compare like for like
    regions = dense_regions(run.grid, run.keyframes, online, named=False)[0]
    run.summary["segment_online"] = {
        "method": "windows",
        "seed_keyframes": run.online["seed_keyframes"],
        "regions": run.online["regions"],
        "offline_regions": len(np.unique(offline[offline > 0])),
        "ari_online_vs_offline": agreement(online, offline),
        "spectral": _rounded(score(regions.labels, run.truth).as_dict()),
        "offline_spectral": run.offline_spectral,
        "latency": run.online["latency"],
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
#: After ``generate`` and ``drive``, these lists of stages and parts of stages need nothing
#: from each other: they run side by side in worker processes, the longest first; then
#: :data:`LAST` combines their results in this process.
PARALLEL: list[list[Callable[[DemoRun], None]]] = [
    [online_run],
    [flat_paths],
    [build_map, segment_log, offline_scores],
    [segment_plan, hierarchical_paths],
]
LAST: list[Callable[[DemoRun], None]] = [segment_online, plan_paths]
#: The stage whose seconds a part's count towards.
PART_OF = {"online_run": "segment_online", "offline_scores": "segment_online"}
PART_OF["flat_paths"] = "plan_paths"
PART_OF["hierarchical_paths"] = "plan_paths"
#: What a list of :data:`PARALLEL` gives back of the run it changed (beside the summary).
RESULTS: tuple[str, ...] = (
    "grid",
    "truth",
    "offline",
    "offline_spectral",
    "online",
    "paths",
    "optimal",
)
RESULTS += ("prepare_s", "path_labels")


def _run_stages(run: DemoRun, stages: list[Callable[[DemoRun], None]]) -> dict[str, Any]:
    """Run ``stages`` in order; return what they added to the summary (``"summary"``), their
    seconds by stage (``"seconds"``) and the :data:`RESULTS` they set."""
    known = set(run.summary)
    before = {name: getattr(run, name) for name in RESULTS}
    seconds: dict[str, float] = {}
    for stage in stages:
        start = time.perf_counter()
        stage(run)
        name = PART_OF.get(stage.__name__, stage.__name__)
        seconds[name] = seconds.get(name, 0.0) + time.perf_counter() - start
        log.info("%s: %.2f s", stage.__name__, time.perf_counter() - start)
    results = {
        name: getattr(run, name) for name in RESULTS if getattr(run, name) is not before[name]
    }
    added = {k: v for k, v in run.summary.items() if k not in known}
    return {"summary": added, "seconds": seconds, **results}


def run_demo(
    out: str | Path,
    *,
    size: str = "office",
    seed: int = 0,
    jobs: int = 2,
    on_stage: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run every stage, write ``summary.json`` and the pictures into ``out``; return the summary.

    ``generate`` and ``drive`` run in order, then the :data:`PARALLEL` lists in ``jobs``
    worker processes with joblib (in this process, one after the other, when ``jobs`` is 1;
    the results are the same), then :data:`LAST`.
    ``on_stage`` is called as each stage starts, with its number, name and what it does.
    ``summary["seconds"]`` holds each stage's seconds (its parts' added up),
    ``summary["wall_seconds"]`` the whole run's.
    """
    from joblib import Parallel, delayed

    clock = time.perf_counter()
    run = DemoRun(check_output_folder(out), size=size, seed=seed)
    run.out.mkdir(parents=True, exist_ok=True)

    def announce(stage: Callable[[DemoRun], None]) -> None:
        if on_stage is not None:
            doc = " ".join(re.split(r"[.;]\s", stage.__doc__ or "")[0].split()).rstrip(".")
            on_stage(f"[{STAGES.index(stage) + 1}/{len(STAGES)}] {stage.__name__}: {doc}")

    seconds: dict[str, float] = {}
    first: list[Callable[[DemoRun], None]] = [generate, drive]
    for stage in first:
        announce(stage)
        seconds.update(_run_stages(run, [stage])["seconds"])
    for stage in STAGES[2:]:
        announce(stage)
    tasks = (delayed(_run_stages)(run, stages) for stages in PARALLEL)
    for done in Parallel(n_jobs=min(jobs, len(PARALLEL)))(tasks):
        run.summary.update(done.pop("summary"))
        for name, value in done.pop("seconds").items():
            seconds[name] = seconds.get(name, 0.0) + value
        run.paths.update(done.pop("paths", {}))
        for name, value in done.items():
            setattr(run, name, value)
    for stage in LAST:
        start = time.perf_counter()
        stage(run)
        seconds[stage.__name__] = seconds.get(stage.__name__, 0.0) + time.perf_counter() - start
    run.summary = {**{k: run.summary[k] for k in SUMMARY_ORDER}, **run.summary}
    run.summary["seconds"] = {stage.__name__: round(seconds[stage.__name__], 3) for stage in STAGES}
    run.summary["wall_seconds"] = round(time.perf_counter() - clock, 3)
    write_text(run.out / "summary.json", json.dumps(run.summary, indent=2), overwrite=True)
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
