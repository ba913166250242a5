"""Corridor systems on the real logs: one region per corridor system that no door divides.

The corridors drawn by hand on the maps of the four CARMEN logs (``carmen.json``: centrelines
with a width, see :func:`~topomap.cli.label_sources.drawn_truth`) against the regions of the
robot's own keyframes (as ``topomap segment --scans`` makes them): how much of the drawn
corridors the largest region holds, that region's IoU with them, and how many regions share
them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from segmentation.pipeline import MapSegmenter
from topomap.classifiers import PLACE_TYPES
from topomap.cli.drawn import drawn_for, read_drawn
from topomap.cli.label_sources import Progress, carmen_map, drawn_truth

#: A region holds a piece of the corridors when it has at least this share of their cells.
PIECE_SHARE = 0.05


def corridor_scores(
    regions: NDArray[np.integer], truth: NDArray[np.integer]
) -> dict[str, float | int]:
    """How the ``regions`` (0: none) hold the corridor cells of ``truth`` (place types).

    Examples
    --------
    >>> truth = np.array([[1, 1, 1, 1, 0, 0]])  # four corridor cells, two of a room
    >>> corridor_scores(np.array([[1, 1, 1, 2, 2, 2]]), truth)
    {'largest_share': 0.75, 'best_iou': 0.75, 'pieces': 2}
    """
    corridor = (truth == PLACE_TYPES.index("corridor")) & (regions > 0)
    ids, counts = np.unique(regions[corridor], return_counts=True)
    if len(ids) == 0:
        return {"largest_share": 0.0, "best_iou": 0.0, "pieces": 0}
    best = ids[np.argmax(counts)]
    union = corridor | ((regions == best) & (truth >= 0))
    return {
        "largest_share": round(float(counts.max() / counts.sum()), 3),
        "best_iou": round(float(counts.max() / union.sum()), 3),
        "pieces": int((counts >= PIECE_SHARE * counts.sum()).sum()),
    }


def evaluate_corridors(
    log_dir: str | Path,
    drawn_json: str | Path,
    progress: Progress = iter,
    resolution: float = 0.05,
) -> list[dict[str, Any]]:
    """:func:`corridor_scores` of each log drawn in ``drawn_json`` (logs in ``log_dir``,
    mapped on cells of ``resolution`` metres)."""
    records = []
    for name, shapes in progress(sorted(read_drawn(drawn_json).items())):
        keyframes, grid = carmen_map(Path(log_dir) / shapes["log"], resolution)
        with drawn_for(drawn_json, name):  # refused before the log is segmented
            truth = drawn_truth(grid, shapes)
        found = MapSegmenter().segment(grid, keyframes, random_state=0)
        records.append(
            {
                "log": name,
                "resolution": resolution,
                "regions": int(found.regions.labels.max()),
                **corridor_scores(found.regions.labels, truth),
            }
        )
    return records
