"""``topomap bench online --parts growing``: the snapshots of one exploration segmented one
after the other with :meth:`TopoMap.update`, scored as the offline maps are, and how many
regions keep their id where the room did not change."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from maps.registration import Placement
from segmentation.growing import align
from segmentation.metrics import rose2_score
from topomap.cli.evaluate import floor_plans, read_rooms
from topomap.topomap import TopoMap

Progress = Callable[[Iterable[Any]], Iterable[Any]]

#: A room of the ground truth "did not change" between snapshots when it covers the same
#: pixels up to this intersection over union.
SAME_ROOM = 0.9


def _most(labels: NDArray[np.integer], mask: NDArray[np.bool_]) -> int:
    found = labels[mask]
    found = found[found > 0]
    return int(np.bincount(found).argmax()) if len(found) else 0


def survival(
    before: NDArray[np.integer],
    rooms_before: NDArray[np.integer],
    after: NDArray[np.integer],
    rooms_after: NDArray[np.integer],
) -> tuple[int, int]:
    """Rooms of the ground truth that did not change (:data:`SAME_ROOM`, ROSE²'s rooms of 200
    pixels or fewer left out) and of those, the ones whose region (the region holding most of
    the room) has the same id before and after. ``before`` and ``rooms_before`` are laid on
    the later map's cells."""
    unchanged = kept = 0
    for room in np.unique(rooms_before[rooms_before > 0]).tolist():
        mask = rooms_before == room
        later = _most(rooms_after, mask)
        if mask.sum() <= 200 or later == 0:
            continue
        mask_after = rooms_after == later
        if (mask & mask_after).sum() < SAME_ROOM * (mask | mask_after).sum():
            continue
        unchanged += 1
        region = _most(before, mask)
        kept += int(region != 0 and region == _most(after, mask_after))
    return unchanged, kept


def bench_growing(data_dir: str | Path, progress: Progress = iter) -> list[dict[str, Any]]:
    """Segment the snapshots of ``data_dir`` (ROSE²'s layout, in the order of the exploration)
    each with :meth:`TopoMap.update` of the one before; per snapshot the ROSE² scores, the
    same scores of ROSE²'s released segmentation, the events and the id survival."""
    records: list[dict[str, Any]] = []
    topo: TopoMap | None = None
    rooms_before = np.zeros((0, 0), np.int32)
    for plan in progress(floor_plans(data_dir)):
        grid, rooms = plan.grid(), plan.rooms()
        record: dict[str, Any] = {"map": plan.name}
        if topo is None:
            topo = TopoMap.from_grid(grid)
        else:  # the images carry no origin: update lays each snapshot where it fits the next
            previous, topo = topo, topo.update(grid)
            laid_grid = (topo.placement or Placement()).moved(previous.grid)
            before = align(laid_grid, previous.regions.labels, grid)
            laid = align(laid_grid, rooms_before, grid)
            unchanged, kept = survival(before, laid, topo.regions.labels, rooms)
            events = [e["event"] for e in topo.changes]
            record |= {e: events.count(e) for e in ("kept", "merged", "split", "created")}
            record |= {"removed": events.count("removed"), "rooms_unchanged": unchanged}
            record["ids_kept"] = kept
        scores = rose2_score(topo.regions.labels, rooms)
        record |= {"regions": len(topo.regions.ids), "rose2_iou": round(scores.iou, 2)}
        if plan.released is not None:
            record["released_iou"] = round(rose2_score(read_rooms(plan.released), rooms).iou, 2)
        records.append(record)
        rooms_before = rooms
    return records
