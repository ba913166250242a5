"""Evaluation of the segmentation on floor plans with human ground truth (the ipa benchmark)."""

from __future__ import annotations

import csv
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from maps.errors import MapFileNotFoundError
from maps.grid import OccupancyGrid
from segmentation.export import read_label_image
from segmentation.metrics import score
from topomap.topomap import pipeline_from_options

METRICS = ["recall", "precision", "mcc", "ari"]


@dataclass(frozen=True)
class FloorPlan:
    """One map of the benchmark: its YAML, its ground-truth label image, furnished or not."""

    name: str
    yaml: Path
    truth: Path
    furnished: bool


def floor_plans(data_dir: str | Path) -> list[FloorPlan]:
    """Every ``NAME.yaml`` / ``NAME_furnitures.yaml`` with a ``NAME_gt_labels.png`` beside it."""
    data_dir = Path(data_dir)
    if not data_dir.is_dir():
        raise MapFileNotFoundError(data_dir, "data folder")
    found = []
    for yaml in sorted(data_dir.glob("*.yaml")):
        name = yaml.stem
        base = name.removesuffix("_furnitures")
        truth = data_dir / f"{base}_gt_labels.png"
        if truth.exists():
            found.append(FloorPlan(name, yaml, truth, name != base))
    if not found:
        raise MapFileNotFoundError(data_dir / "*.yaml", "map YAML with a *_gt_labels.png")
    return found


def evaluate(plan: FloorPlan, **options: Any) -> list[dict[str, Any]]:
    """Segment one floor plan; score the spectral partition alone and the refined regions.

    Both come from one segmentation call (:meth:`MapSegmenter.segment`, the region graph and
    names not included, like the anchors' segmentation-only times): ``seconds`` is its wall
    time, ``cpu_seconds`` its processor time (the same on an idle machine; on a busy one the
    wall time also counts waiting for the processor).
    """
    grid = OccupancyGrid.load(plan.yaml)
    truth = read_label_image(plan.truth)
    pipeline = pipeline_from_options(options)
    wall, cpu = time.perf_counter(), time.process_time()
    found = pipeline.segment(grid, random_state=0)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    records = []
    for variant, regions in (("spectral", found.spectral), ("refined", found.regions)):
        scores = score(regions.labels, truth).as_dict()
        records.append(
            {
                "map": plan.name.removesuffix("_furnitures"),
                "furnished": plan.furnished,
                "variant": variant,
                "keyframes": len(found.keyframes),
                "seconds": round(wall, 3),
                "cpu_seconds": round(cpu, 3),
                "dropped_cells": sum(found.conditioned.dropped.values()),
                **{k: round(v, 4) if isinstance(v, float) else v for k, v in scores.items()},
            }
        )
    return records


def evaluate_all(
    data_dir: str | Path,
    progress: Callable[[Iterator[FloorPlan]], Iterator[FloorPlan]] = iter,
    **options: Any,
) -> list[dict[str, Any]]:
    """:func:`evaluate` on every floor plan of ``data_dir``."""
    return [r for plan in progress(iter(floor_plans(data_dir))) for r in evaluate(plan, **options)]


def read_anchors(data_dir: str | Path) -> list[dict[str, Any]]:
    """Rows of ``anchors.csv`` (other systems' scores), numbers parsed; [] if it is absent."""
    path = Path(data_dir) / "anchors.csv"
    if not path.exists():
        return []
    rows = []
    with path.open() as stream:
        for row in csv.DictReader(stream):
            rows.append(
                {
                    "map": row["map"],
                    "furnished": row["furnished"] == "1",
                    "variant": row["method"],
                    "recall": float(row["recall_micro"]),
                    "precision": float(row["precision_micro"]),
                    "mcc": float(row["mcc"]),
                    "seconds": float(row["runtime_s"]) if row["runtime_s"] else None,
                }
            )
    return rows


def means(records: list[dict[str, Any]], anchors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Mean scores per (variant, furnished), ours and the anchors', over the maps we ran."""
    ours = {(r["map"], r["furnished"]) for r in records}
    rows = []
    for source in (records, [a for a in anchors if (a["map"], a["furnished"]) in ours]):
        groups: dict[tuple[str, bool], list[dict[str, Any]]] = {}
        for r in source:
            groups.setdefault((r["variant"], r["furnished"]), []).append(r)
        for (variant, furnished), group in groups.items():
            row: dict[str, Any] = {
                "method": variant,
                "furnished": furnished,
                "maps": len(group),
            }
            for metric in ("recall", "precision", "mcc", "ari"):
                values = [g[metric] for g in group if metric in g]
                row[metric] = round(float(np.mean(values)), 3) if values else "-"
            times = [g["seconds"] for g in group if g["seconds"] is not None]
            row["mean_s"] = round(float(np.mean(times)), 2) if times else "-"
            cpu = [g["cpu_seconds"] for g in group if "cpu_seconds" in g]
            row["mean_cpu_s"] = round(float(np.mean(cpu)), 2) if cpu else "-"
            row["max_cpu_s"] = round(float(np.max(cpu)), 2) if cpu else "-"
            row["max_s"] = round(float(np.max(times)), 2) if times else "-"
            rows.append(row)
    return sorted(rows, key=lambda r: (r["furnished"], r["method"]))
