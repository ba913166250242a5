"""Robot runs through generated buildings: the regions of a robot's own keyframes against the
building's rooms.

For each building size and seed: a generated building, furnished as the demo's; a robot that
wanders through every room it can reach with a 180 degree laser, or another field of view
(:func:`~maps.sim.exploration.wander`, keyframes every 0.5 m or 30 degrees); the map built from
its keyframes; and the pipeline on that map with those keyframes, as ``topomap segment --scans``
runs it. Each method (the spectral partition, the door-rule baseline) is scored against the
plan's rooms: MCC of the regions on the built map's cells (:func:`~segmentation.metrics.score`)
and the keyframes' ARI (each keyframe's region against the room it stands in, the measure the
issue sets for real logs). The rooms are the generator's, not people's: the measure of the
log pipeline across buildings, beside ``topomap eval corridors`` on the real logs.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from maps.scan import poses_array
from maps.sim.floorplan import generate_floor_plan
from maps.sim.laser import LaserModel
from maps.sim.survey import SURVEY_LASER, survey
from segmentation.metrics import score
from topomap.cli.label_sources import Progress
from topomap.cli.online import agreement
from topomap.topomap import pipeline_from_options


def evaluate_runs(
    sizes: Sequence[str],
    seeds: Iterable[int],
    progress: Progress = iter,
    laser: LaserModel = SURVEY_LASER,
    **options: Any,
) -> list[dict[str, Any]]:
    """A record per run (size, seed) and method: regions, rooms, MCC, recall, precision and
    the keyframes' ARI; the robot scans with ``laser``; ``options`` are the segmentation's
    (``topomap segment``'s)."""
    runs = [(size, seed) for size in sizes for seed in seeds]
    records = []
    for size, seed in progress(runs):
        plan = generate_floor_plan(size, furniture=0.3, random_state=seed)
        run = survey(plan, seed, laser)
        keyframes, grid = run.keyframes, run.grid
        people = plan.corridor_systems()  # a corridor system no door divides is one room
        rooms = plan.rooms_on(grid, people)
        poses = poses_array(keyframes)
        rows, cols = plan.grid.world_to_cell(poses[:, 0], poses[:, 1])
        standing = people[rows, cols]  # the keyframes' rooms (0: in a wall, a door frame)
        inside = standing > 0
        for method in ("spectral", "doors"):
            pipeline = pipeline_from_options({**options, "method": method})
            found = pipeline.segment(grid, keyframes, random_state=seed)
            scores = score(found.regions.labels, rooms)
            records.append(
                {
                    "size": size,
                    "seed": seed,
                    "method": method,
                    "fov": round(math.degrees(laser.fov)),
                    "keyframes": len(keyframes),
                    "regions": int(found.regions.labels.max()),
                    "rooms": int(len(np.unique(rooms[rooms > 0]))),
                    "mcc": round(scores.mcc, 4),
                    "recall": round(scores.recall, 4),
                    "precision": round(scores.precision, 4),
                    "keyframe_ari": agreement(found.keyframe_regions()[inside], standing[inside]),
                }
            )
    return records


def run_means(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per size and method: the runs, their mean MCC and keyframe ARI, and the lowest MCC.

    Examples
    --------
    >>> rows = [{"size": "flat", "method": "spectral", "mcc": m, "keyframe_ari": 1.0}
    ...         for m in (0.8, 0.9)]
    >>> [(m["runs"], m["mcc"], m["min_mcc"], m["keyframe_ari"]) for m in run_means(rows)]
    [(2, 0.85, 0.8, 1.0)]
    """
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for record in records:
        groups.setdefault((record["size"], record["method"]), []).append(record)
    return [
        {
            "size": size,
            "method": method,
            "runs": len(group),
            "mcc": round(float(np.mean([r["mcc"] for r in group])), 4),
            "min_mcc": min(r["mcc"] for r in group),
            "keyframe_ari": round(float(np.mean([r["keyframe_ari"] for r in group])), 4),
        }
        for (size, method), group in groups.items()
    ]
