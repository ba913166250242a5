"""``topomap bench online``: latency of the online segmentation along a long run, and its
agreement with the offline partition on the demo run and the CARMEN logs."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.carmen import read_carmen
from maps.errors import MapFileNotFoundError
from maps.files import write_text, written
from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import Keyframe, select_keyframes
from maps.sim.exploration import wander
from maps.sim.floorplan import generate_floor_plan
from maps.sim.laser import simulate_scans
from maps.sim.survey import SURVEY_LASER
from segmentation.incremental import IncrementalSegmenter
from segmentation.metrics import score
from segmentation.online import OnlineSegmenter
from segmentation.pipeline import MapSegmenter
from segmentation.spectral import SpectralSegmenter
from topomap.cli.bench import robot_keyframes
from topomap.cli.evaluate import floor_plans
from topomap.cli.online import (
    ONLINE_METHODS,
    agreement,
    dense_regions,
    latency_ms,
    run_online,
)

Progress = Callable[[Iterable[Any]], Iterable[Any]]

#: The four CARMEN logs of ``../shared/data/carmen``.
LOGS = ("intel", "aces", "csail", "freiburg-079")
#: The snapshots of one exploration (ROSE²'s incremental partial maps).
SNAPSHOTS = "../shared/data/rose2_partial"


def bench_latency(
    *,
    keyframes: int = 10_000,
    seed_keyframes: int = 500,
    building: str = "campus",
    batch: int = 100,
    offline_up_to: int = 2_000,
    theta: float = 0.5,
    seed: int = 0,
    method: str = "windows",
    progress: Progress = iter,
) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Time every ``partial_fit`` (assignment and dense regions; wall clock, and the CPU time
    of the caller's thread, which a busy machine's preemptions do not inflate; the CPU time of
    each re-partition, run beside them, and of the whole process per keyframe, all threads
    included, apart) along the first ``keyframes``
    keyframes of a robot wandering through a generated ``building``, seeded on the first
    ``seed_keyframes``; per batch of ``batch`` keyframes, the latency and, up to
    ``offline_up_to`` keyframes, the time of re-running the offline partition on everything
    seen so far (the offline pipeline on the map of those keyframes). Returns one record per
    batch and a summary."""
    run = robot_keyframes(building, keyframes, seed)
    start = time.perf_counter()
    online: IncrementalSegmenter | OnlineSegmenter
    if method == "windows":
        online = IncrementalSegmenter(random_state=seed)
    else:
        online = OnlineSegmenter(SpectralSegmenter(random_state=seed), theta=theta)
    online.fit(run[:seed_keyframes])
    seed_seconds = time.perf_counter() - start
    records: list[dict[str, Any]] = []
    every: list[float] = []
    every_cpu: list[float] = []
    process, offline_cpu = time.process_time(), 0.0
    for first in progress(range(seed_keyframes, len(run), batch)):
        last = min(first + batch, len(run))
        seconds, cpu = [], []
        for keyframe in run[first:last]:
            clock, thread = time.perf_counter(), time.thread_time()
            online.partial_fit(keyframe)
            seconds.append(time.perf_counter() - clock)
            cpu.append(time.thread_time() - thread)
        every += seconds
        every_cpu += cpu
        offline = None
        if last <= offline_up_to:
            clock, thread = time.perf_counter(), time.thread_time()
            MapSegmenter().segment(grid_from_keyframes(run[:last]), run[:last], random_state=seed)
            offline = round(time.perf_counter() - clock, 3)
            offline_cpu += time.thread_time() - thread
        records.append(
            {
                "first": first,
                "keyframes_seen": last,
                **latency_ms(seconds),
                **latency_ms(cpu, "cpu_"),
                "online_s": round(sum(seconds), 4),
                "offline_rerun_s": offline,
                "regions": online.n_regions_,
            }
        )
    online.flush()
    process = time.process_time() - process - offline_cpu  # every thread of the online run
    rerun = [r for r in records if r["offline_rerun_s"] is not None]
    work: list[float] = []
    if isinstance(online, IncrementalSegmenter):
        work = online.repartition_seconds_[1:].tolist()  # the seed's aside
    summary = {
        "method": method,
        "building": building,
        "keyframes": len(run),
        "seed_keyframes": seed_keyframes,
        "seed_seconds": round(seed_seconds, 3),
        "regions": online.n_regions_,
        **latency_ms(every),
        **latency_ms(every_cpu, "cpu_"),
        **(latency_ms(work, "repartition_cpu_") if work else {}),
        "repartitions": len(work),
        "process_cpu_per_keyframe_ms": round(1000 * process / len(every_cpu), 3),
        "online_total_s": round(sum(every), 3),
        "offline_reruns_up_to": rerun[-1]["keyframes_seen"] if rerun else 0,
        "offline_reruns_total_s": round(sum(r["offline_rerun_s"] for r in rerun), 3),
        "online_total_same_prefix_s": round(sum(r["online_s"] for r in rerun), 3),
    }
    return records, summary


def _quality(
    name: str,
    keyframes: list[Keyframe],
    grid: OccupancyGrid,
    seed_fraction: float | None,
    theta: float,
    seed: int,
) -> tuple[list[dict[str, Any]], NDArray[np.int64], dict[str, NDArray[np.int64]]]:
    """Each online engine against the offline pipeline on the same keyframes (on ``grid``,
    their map): ARI of the final regions of the keyframes, latency, and churn (the share of
    keyframes whose region changed once they were 50 keyframes old; windows only). Beside
    it, ``ari_online_resolution``: against the offline pipeline on their map at the windows'
    resolution (what the windows are partitioned on), and ``offline_across_resolutions``: the
    two offline partitions against each other."""
    offline = MapSegmenter().segment(grid, keyframes, random_state=seed).keyframe_regions()
    coarse = IncrementalSegmenter().resolution
    same = offline
    if not np.isclose(coarse, grid.resolution):
        rebuilt = grid_from_keyframes(keyframes, coarse)
        same = MapSegmenter().segment(rebuilt, keyframes, random_state=seed).keyframe_regions()
    both = (offline > 0) & (same > 0)
    seeded = None if seed_fraction is None else max(2, round(seed_fraction * len(keyframes)))
    records, labels = [], {}
    for method in ONLINE_METHODS:
        run = run_online(
            keyframes, seed_keyframes=seeded, method=method, theta=theta, random_state=seed
        )
        online = run.online
        late = online.late_changes_ if isinstance(online, IncrementalSegmenter) else None
        records.append(
            {
                "run": name,
                "method": method,
                "keyframes": len(keyframes),
                "seed_keyframes": online.n_seed_,
                "offline_regions": len(np.unique(offline[offline > 0])),
                "online_regions": online.n_regions_,
                "ari": agreement(online.labels_[offline > 0], offline[offline > 0]),
                "ari_online_resolution": agreement(online.labels_[same > 0], same[same > 0]),
                "offline_across_resolutions": agreement(offline[both], same[both]),
                "churn": "-" if late is None else round(float(np.mean(late > 0)), 4),
                **run.latency_ms(),
            }
        )
        labels[method] = online.labels_
    return records, offline, labels


def bench_quality(
    *,
    logs_dir: str | Path | None = "../shared/data/carmen",
    demo: bool = True,
    seed_fraction: float | None = None,
    theta: float = 0.5,
    seed: int = 0,
    progress: Progress = iter,
) -> list[dict[str, Any]]:
    """Online against offline on the demo's run (the robot in the generated office, also
    scored against the generator's rooms: MCC of each made dense on the run's map) and on
    the CARMEN logs (keyframes every 0.5 m)."""
    logs = carmen_logs(logs_dir) if logs_dir else {}
    records = []
    for name in progress((["demo office"] if demo else []) + list(logs)):
        if name == "demo office":
            plan = generate_floor_plan("office", furniture=0.3, random_state=seed)
            route = wander(plan.grid, plan.labels, random_state=seed)
            scans = simulate_scans(plan.grid, route.poses, SURVEY_LASER, random_state=seed)
            keyframes = select_keyframes(scans)
            grid = grid_from_keyframes(keyframes, plan.grid.resolution)
            found, offline, online = _quality(name, keyframes, grid, seed_fraction, theta, seed)
            truth = plan.rooms_on(grid)
            mcc_offline = _mcc(grid, keyframes, offline, truth)
            for record in found:
                record["mcc_offline"] = mcc_offline
                record["mcc_online"] = _mcc(grid, keyframes, online[record["method"]], truth)
        else:
            keyframes = select_keyframes(read_carmen(logs[name]), distance=0.5)
            grid = grid_from_keyframes(keyframes, 0.05)
            found = _quality(name, keyframes, grid, seed_fraction, theta, seed)[0]
        records += found
    return records


def carmen_logs(logs_dir: str | Path) -> dict[str, Path]:
    """The files of the CARMEN logs :data:`LOGS` in ``logs_dir``, by name.

    Raises
    ------
    MapFileNotFoundError
        Naming the first log that is not there.
    """
    logs = {name: Path(logs_dir) / f"{name}-corrected.log.gz" for name in LOGS}
    for path in logs.values():
        if not path.is_file():
            raise MapFileNotFoundError(path, "CARMEN log")
    return logs


def _mcc(
    grid: OccupancyGrid,
    keyframes: list[Keyframe],
    labels: NDArray[np.integer],
    truth: NDArray[np.integer],
) -> float:
    """MCC of keyframe labels made dense on ``grid`` against the generator's rooms."""
    return round(score(dense_regions(grid, keyframes, labels, named=False)[0].labels, truth).mcc, 4)


def draw_latency(path: Path, records: list[dict[str, Any]], title: str) -> Path:
    """The latency curve: per batch median / p95 / max against the keyframes seen, with the
    offline re-run time on a second axis."""
    from matplotlib.figure import Figure

    seen = [r["keyframes_seen"] for r in records]
    fig = Figure(figsize=(9, 4.5))
    ax = fig.subplots()
    for key, style in (("median_ms", "-"), ("p95_ms", "--"), ("max_ms", ":")):
        ax.plot(seen, [r[key] for r in records], style, color="tab:blue", label=f"wall {key[:-3]}")
        cpu = [r[f"cpu_{key}"] for r in records]
        ax.plot(seen, cpu, style, color="tab:green", label=f"CPU {key[:-3]}")
    ax.set_xlabel("keyframes seen")
    ax.set_ylabel("online ms per keyframe")
    ax.set_yscale("log")
    rerun = [r for r in records if r["offline_rerun_s"] is not None]
    if rerun:
        other = ax.twinx()
        other.plot(
            [r["keyframes_seen"] for r in rerun],
            [r["offline_rerun_s"] for r in rerun],
            color="tab:red",
            label="offline re-run (s, right)",
        )
        other.set_ylabel("offline re-run on all seen, s")
        other.legend(loc="upper right", fontsize=8)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(title)
    with written(path, overwrite=True) as partial:  # the command refuses it first
        fig.savefig(partial, dpi=120, bbox_inches="tight")
    return path


def bench_online(
    out: str | Path,
    *,
    parts: tuple[str, ...] = ("latency", "quality"),
    progress: Progress = iter,
    **options: Any,
) -> dict[str, Any]:
    """Run the ``parts`` and write ``results.json`` (``latency``: one record per batch and a
    summary; ``quality``: one record per run) and ``latency.png`` into ``out``, once every
    part has run: the logs and snapshots the parts read are checked before any runs, and a
    run refused leaves no ``out`` behind."""
    out = Path(out)
    latency_keys = {"keyframes", "seed_keyframes", "building", "batch", "offline_up_to", "method"}
    results: dict[str, Any] = {}
    common = {k: v for k, v in options.items() if k in ("theta", "seed")}
    options = {k: v for k, v in options.items() if v is not None}
    snapshots = options.get("snapshots_dir", SNAPSHOTS)
    if "quality" in parts and options.get("logs_dir"):
        carmen_logs(options["logs_dir"])
    if "growing" in parts:
        floor_plans(snapshots)
    if "latency" in parts:
        chosen = {k: v for k, v in options.items() if k in latency_keys}
        records, summary = bench_latency(**chosen, **common, progress=progress)
        results["latency"] = {"batches": records, "summary": summary}
    if "quality" in parts:
        chosen = {k: v for k, v in options.items() if k in ("logs_dir", "seed_fraction")}
        results["quality"] = bench_quality(**chosen, **common, progress=progress)
    if "growing" in parts:
        from topomap.cli.bench_growing import bench_growing

        results["growing"] = bench_growing(snapshots, progress)
    if "latency" in results:
        summary = results["latency"]["summary"]
        title = f"online, generated {summary['building']}, seed {summary['seed_keyframes']}"
        draw_latency(out / "latency.png", results["latency"]["batches"], title)
    write_text(out / "results.json", json.dumps(results, indent=2), overwrite=True)
    return results
