"""The planning benchmark: planners side by side on the same far-apart queries.

Each query is run by every planner in turn (so machine noise hits them alike) and checked
independently: the path must join start and goal, be collision-free when sampled every tenth
of a cell against the inflated map, and its length is compared with the exact shortest path.
A planner whose queries on a map have used up a time budget skips the rest (counted as
skipped, not failed). The report (tables, plots, OMPL's benchmark logs) is the tools' part:
:mod:`topomap.cli.plan_report`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike

from maps.seeding import RandomState, as_generator
from planners.errors import InvalidQueryError, PlanningError
from planners.path import PlannedPath
from planners.workspace import Point, Workspace

#: Benchmark names of the planners, in table order (``grid_astar`` is the pure-Python
#: reference, run only on request: a correctness check, not a speed baseline).
PLANNER_NAMES = (
    "hierarchical",
    "grid_mcp",
    "flat_rrtconnect",
    "flat_prm",
    "flat_bitstar",
    "grid_astar",
)


class Planner(Protocol):
    """Anything with a ``name`` and ``plan(start, goal) -> PlannedPath``."""

    name: str

    def plan(self, start: ArrayLike, goal: ArrayLike) -> PlannedPath: ...


def far_queries(
    space: Workspace, count: int, *, random_state: RandomState = 0, min_fraction: float = 1 / 3
) -> list[tuple[Point, Point]]:
    """``count`` start/goal pairs of free points in the same piece of free space, at least
    ``min_fraction`` of the map's diagonal apart.

    Raises
    ------
    InvalidQueryError
        When 1000 tries per query find none (a map with no two far-apart free points).
    """
    rng = as_generator(random_state)
    rows, cols = np.nonzero(space.free)
    if len(rows) == 0:
        raise InvalidQueryError("the map has no free cell for the robot")
    xs, ys = space.grid.cell_to_world(rows, cols)
    xmin, ymin, xmax, ymax = space.grid.bounds()
    least = min_fraction * math.hypot(xmax - xmin, ymax - ymin)
    queries: list[tuple[Point, Point]] = []
    for _ in range(1000 * count):
        if len(queries) == count:
            return queries
        i, j = rng.integers(len(rows), size=2)
        if math.hypot(xs[i] - xs[j], ys[i] - ys[j]) < least:
            continue
        if space.components[rows[i], cols[i]] != space.components[rows[j], cols[j]]:
            continue
        queries.append(((float(xs[i]), float(ys[i])), (float(xs[j]), float(ys[j]))))
    raise InvalidQueryError(f"found only {len(queries)} of {count} queries {least:.1f} m apart")


def run_queries(
    map_name: str,
    space: Workspace,
    planners: Sequence[Planner],
    optimal: Sequence[float],
    queries: Sequence[tuple[Point, Point]],
    *,
    budget: float = math.inf,
    progress: Callable[[Any], Any] = iter,
    collisions: Callable[[PlannedPath], int] | None = None,
    paths: list[dict[str, Any]] | None = None,
) -> tuple[list[dict[str, Any]], dict[str, int]]:
    """Run every planner on every query; one record per planner and query run.

    Records hold ``map``, ``planner``, ``query``, ``success``, ``seconds`` (wall time of the
    ``plan`` call), ``length_m``, ``optimal_m`` (``optimal[query]``, the exact shortest
    path, or a reference length), ``collisions`` (samples off the free space, or what
    ``collisions`` counts on the path: e.g. a footprint sweep) and ``error`` (why it failed,
    or None). A planner whose query time on this map passes ``budget`` seconds runs no more
    queries; the second result counts the queries each planner skipped. Found paths are
    appended to ``paths`` when given (``map``, ``query``, ``planner``, ``poses``).
    """
    if collisions is None:
        collisions = lambda path: space.collisions(path.waypoints)  # noqa: E731
    records = []
    spent = dict.fromkeys((p.name for p in planners), 0.0)
    skipped = dict.fromkeys(spent, 0)
    for index, (start, goal) in progress(list(enumerate(queries))):
        for planner in planners:
            if spent[planner.name] > budget:
                skipped[planner.name] += 1
                continue
            clock = time.perf_counter()
            path: PlannedPath | None = None
            error: str | None = None
            try:
                path = planner.plan(start, goal)
            except PlanningError as err:
                error = str(err)
            seconds = time.perf_counter() - clock
            spent[planner.name] += seconds
            records.append(_record(map_name, planner.name, index, seconds, optimal[index], error))
            if path is not None:
                ends = np.asarray([start, goal], float)[:, :2]
                joins = np.allclose(path.waypoints[[0, -1]], ends, atol=1e-9)
                records[-1].update(
                    success=bool(joins),
                    length_m=round(path.length, 4),
                    collisions=collisions(path),
                    error=None if joins else "the path does not join start and goal",
                )
                if paths is not None:
                    poses = np.round(path.poses, 4).tolist()
                    paths.append(
                        {"map": map_name, "query": index, "planner": planner.name, "poses": poses}
                    )
    return records, skipped


def _record(
    map_name: str, planner: str, query: int, seconds: float, optimal: float, error: str | None
) -> dict[str, Any]:
    return {
        "map": map_name,
        "planner": planner,
        "query": query,
        "success": False,
        "seconds": round(seconds, 6),
        "length_m": None,
        "optimal_m": round(optimal, 4),
        "collisions": None,
        "error": error,
    }


def summarise(records: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per map and planner: success rate, median and 90th-percentile query time, path length
    over the optimum (median, max), collisions, the hierarchical planner's speed-up (this
    planner's median time over the hierarchical one's; ``speedup_query``: the median over
    the queries both ran of this planner's time over the hierarchical one's on the same
    query), the map's :func:`best_flat` planner
    and how many times faster than it this planner's median is (``vs_best_flat``)."""
    rows = []
    maps = list(dict.fromkeys(r["map"] for r in records))
    for name in maps:
        here = [r for r in records if r["map"] == name]
        medians = {}
        for planner in dict.fromkeys(r["planner"] for r in here):
            mine = [r for r in here if r["planner"] == planner]
            done = [r for r in mine if r["success"]]
            times = np.array([r["seconds"] for r in mine])
            ratios = np.array([r["length_m"] / r["optimal_m"] for r in done if r["optimal_m"]])
            medians[planner] = float(np.median(times))
            rows.append(
                {
                    "map": name,
                    "planner": planner,
                    "queries": len(mine),
                    "success": round(len(done) / len(mine), 3),
                    "median_s": round(float(np.median(times)), 4),
                    "p90_s": round(float(np.percentile(times, 90)), 4),
                    "length_median": round(float(np.median(ratios)), 4) if len(ratios) else None,
                    "length_max": round(float(ratios.max()), 4) if len(ratios) else None,
                    "collisions": int(sum(r["collisions"] or 0 for r in done)),
                }
            )
        base = medians.get("hierarchical")
        hierarchical = {r["query"]: r["seconds"] for r in here if r["planner"] == "hierarchical"}
        here_rows = rows[-len(medians) :]
        best = best_flat(here_rows)
        for row in here_rows:
            median = medians[row["planner"]]
            row["speedup"] = round(median / base, 1) if base else None
            per_query = [
                r["seconds"] / hierarchical[r["query"]]
                for r in here
                if r["planner"] == row["planner"] and hierarchical.get(r["query"])
            ]
            row["speedup_query"] = round(float(np.median(per_query)), 1) if per_query else None
            row["best_flat"] = best
            row["vs_best_flat"] = round(medians[best] / median, 1) if best and median else None
    return rows


def best_flat(rows: Sequence[dict[str, Any]]) -> str | None:
    """The best flat planner (``flat_*``) among one map's summary rows: the lowest median
    query time (failures count with the time they took), then the highest success rate."""
    flats = [r for r in rows if r["planner"].startswith("flat_")]
    if not flats:
        return None
    return str(min(flats, key=lambda r: (r["median_s"], -r["success"]))["planner"])
