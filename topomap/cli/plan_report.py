"""The planning benchmark's report (:mod:`planners.benchmark` runs it): the records and the
summary as JSON, the summary table (``results.md``), the query times per planner and map
(``times.png``) and OMPL's benchmark log per map, which ``ompl_benchmark_statistics`` turns
into a database for Planner Arena."""

from __future__ import annotations

import json
import math
import platform
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from maps.files import write_text, written
from topomap.cli.tables import markdown_table


def write_report(
    out: str | Path,
    records: Sequence[dict[str, Any]],
    summary: Sequence[dict[str, Any]],
    preprocessing: dict[str, dict[str, Any]],
    time_limit: float = 20.0,
    seed: int = 0,
) -> list[Path]:
    """Write ``results.json`` (the records), ``preprocessing.json``, ``summary.json``,
    ``results.md`` (the table), ``times.png`` (query times per planner and map) and
    ``ompl/MAP.log`` (:func:`write_ompl_log`; ``time_limit`` is the flat planners')."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    # the command refuses existing files first (``topomap bench plan --force``)
    files = [
        write_text(out / "results.json", json.dumps(list(records), indent=1), overwrite=True),
        write_text(out / "preprocessing.json", json.dumps(preprocessing, indent=1), overwrite=True),
        write_text(out / "summary.json", json.dumps(list(summary), indent=1), overwrite=True),
        write_text(out / "results.md", markdown_table(summary, COLUMNS) + "\n", overwrite=True),
        _plot(out / "times.png", records),
    ]
    for name in dict.fromkeys(r["map"] for r in records):
        mine = [r for r in records if r["map"] == name]
        log = write_ompl_log(out / "ompl" / f"{name}.log", name, mine, time_limit, seed=seed)
        files.append(log)
    return files


#: Per-run properties of the OMPL log, with their SQL types.
_OMPL_PROPERTIES = (
    ("time", "REAL"),
    ("solved", "BOOLEAN"),
    ("correct solution", "BOOLEAN"),
    ("solution length", "REAL"),
    ("length ratio", "REAL"),
    ("collisions", "INTEGER"),
    ("query", "INTEGER"),
)


def write_ompl_log(
    path: str | Path,
    experiment: str,
    records: Sequence[dict[str, Any]],
    time_limit: float,
    *,
    seed: int = 0,
) -> Path:
    """Write one map's records as an OMPL benchmark log (the format of
    ``ompl::tools::Benchmark::saveResultsToFile``), readable by ``ompl_benchmark_statistics``
    and Planner Arena. A run is ``solved`` when the planner returned a path joining start
    and goal; ``correct solution`` when that path is also collision-free."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    planners = list(dict.fromkeys(r["planner"] for r in records))
    total = sum(r["seconds"] for r in records)
    lines = [
        "topomap version 0.1.0",
        f"Experiment {experiment}",
        f"Running on {platform.node() or 'localhost'}",
        f"Starting at {time.strftime('%Y-%m-%d %H:%M:%S')}",
        "<<<|",
        f"topomap planning benchmark on {experiment}: far-apart start/goal pairs",
        "|>>>",
        "<<<|",
        f"{platform.processor() or platform.machine()}",
        "|>>>",
        f"{seed} is the random seed",
        f"{time_limit:g} seconds per run",
        "0 MB per run",
        f"{max(sum(r['planner'] == p for r in records) for p in planners)} runs per planner",
        f"{total:.6f} seconds spent to collect the data",
        f"{len(planners)} planners",
    ]
    for planner in planners:
        runs = [r for r in records if r["planner"] == planner]
        lines += [
            planner,
            "0 common properties",
            f"{len(_OMPL_PROPERTIES)} properties for each run",
        ]
        lines += [f"{name} {kind}" for name, kind in _OMPL_PROPERTIES]
        lines.append(f"{len(runs)} runs")
        for r in runs:
            solved = bool(r["success"])
            ratio = r["length_m"] / r["optimal_m"] if solved and r["optimal_m"] else math.nan
            values = [
                r["seconds"],
                int(solved),
                int(solved and r["collisions"] == 0),
                r["length_m"] if solved else math.nan,
                ratio,
                r["collisions"] if solved else math.nan,
                r["query"],
            ]
            lines.append("".join(f"{v}; " for v in values))
        lines.append(".")
    return write_text(path, "\n".join(lines) + "\n", overwrite=True)


#: Columns of the summary table (lengths are ratios to the exact shortest path; ``speedup``
#: is the planner's median time over the hierarchical planner's, ``speedup_query`` the
#: median of its time over the hierarchical planner's on the same query, ``vs_best_flat``
#: the best flat planner's median time over this planner's).
COLUMNS = [
    "map",
    "planner",
    "success",
    "median_s",
    "p90_s",
    "speedup",
    "speedup_query",
    "vs_best_flat",
    "length_median",
    "length_max",
    "collisions",
]


def _plot(path: Path, records: Sequence[dict[str, Any]]) -> Path:
    from matplotlib.figure import Figure

    maps = list(dict.fromkeys(r["map"] for r in records))
    planners = list(dict.fromkeys(r["planner"] for r in records))
    fig = Figure(figsize=(max(6, 1.6 * len(maps) * len(planners) / 2), 4.5))
    ax = fig.subplots()
    width = 0.8 / len(planners)
    for k, planner in enumerate(planners):
        data = [
            [r["seconds"] for r in records if r["map"] == m and r["planner"] == planner]
            for m in maps
        ]
        spots = np.arange(len(maps)) + (k - (len(planners) - 1) / 2) * width
        box = ax.boxplot(data, positions=spots, widths=width * 0.9, patch_artist=True)
        for patch in box["boxes"]:
            patch.set_facecolor(f"C{k}")
        ax.plot([], [], color=f"C{k}", linewidth=6, label=planner)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(maps)), maps, rotation=30, ha="right")
    ax.set_ylabel("query time (s)")
    ax.legend(fontsize=8)
    ax.set_title("planning query times")
    fig.tight_layout()
    with written(path, overwrite=True) as partial:
        fig.savefig(partial, dpi=120)
    return path


#: Metres between two footprints drawn along a path in :func:`plot_footprint_paths`.
FOOTPRINT_EVERY = 1.5


def plot_footprint_paths(path: Path, about: dict[str, Any], *, per_map: int = 3) -> Path:
    """Draw ``per_map`` hierarchical paths of each map of ``about`` (the contents of the
    footprint benchmark's ``paths.json``) over the map, the footprint drawn every
    :data:`FOOTPRINT_EVERY` metres along them, with the flat planners' paths of the same
    queries as thin lines; one panel per map, written to ``path``."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon as Patch
    from matplotlib.transforms import Affine2D

    from maps.grid import OccupancyGrid

    footprint = np.asarray(about["footprint"], float)
    names = list(about["maps"])
    fig = Figure(figsize=(8, 5.5 * max(1, len(names))))
    for k, name in enumerate(names):
        ax = fig.add_subplot(len(names), 1, k + 1)
        grid = OccupancyGrid.load(about["maps"][name])
        (h, w), r = grid.shape, grid.resolution
        ox, oy, yaw = grid.origin
        image = ax.imshow(
            np.where(grid.free, 1.0, 0.25), cmap="gray", vmin=0, vmax=1, extent=(0, w * r, 0, h * r)
        )
        image.set_transform(Affine2D().rotate(yaw).translate(ox, oy) + ax.transData)
        mine = [p for p in about["paths"] if p["map"] == name]
        queries = list(dict.fromkeys(p["query"] for p in mine if p["planner"] == "hierarchical"))
        for colour, query in enumerate(queries[:per_map]):
            for found in (p for p in mine if p["query"] == query):
                poses = np.asarray(found["poses"], float)
                if found["planner"] != "hierarchical":
                    ax.plot(*poses[:, :2].T, color=f"C{colour}", lw=0.6, ls="--")
                    continue
                ax.plot(*poses[:, :2].T, color=f"C{colour}", lw=1.2, label=f"query {query}")
                steps = np.hypot(*np.diff(poses[:, :2], axis=0).T)
                along = np.concatenate([[0.0], np.cumsum(steps)])
                marks = np.searchsorted(along, np.arange(0, along[-1], FOOTPRINT_EVERY))
                for x, y, a in poses[np.append(marks, len(poses) - 1)]:
                    c, s = np.cos(a), np.sin(a)
                    corners = footprint @ np.array([[c, s], [-s, c]]) + (x, y)
                    ax.add_patch(Patch(corners, closed=True, fill=False, lw=0.5, ec=f"C{colour}"))
        ax.set_title(f"{name}: hierarchical paths (footprints), flat paths dashed", fontsize=9)
        ax.set_aspect("equal")
        xmin, ymin, xmax, ymax = grid.bounds()
        ax.set_xlim(xmin, xmax)
        ax.set_ylim(ymin, ymax)
        ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    with written(path, overwrite=True) as partial:
        fig.savefig(partial, dpi=150)
    return path
