"""The real logs against rooms drawn on their maps: the regions of a robot's own keyframes.

The rooms drawn on the maps of the CARMEN logs (``carmen_rooms.json``: a polygon per room in
metres, see :func:`drawn_rooms`) against the regions, for both methods, of the robot's own
keyframes (``input="keyframes"``, as ``topomap segment LOG`` makes them) and of the map alone
(``input="map"``, as ``topomap segment map.yaml`` makes them from the map ``topomap map``
writes: a real SLAM map of another building than ROSE²'s): the keyframes' ARI (each
keyframe's region against the room it stands in, the measure the issue sets for real logs),
MCC and ROSE²'s IoU on the map's cells. The rooms were drawn from the maps alone, not from any
segmentation.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from maps.errors import MapFormatError
from maps.grid import OccupancyGrid
from maps.scan import poses_array
from segmentation.metrics import rose2_score, score
from topomap.cli.drawn import drawn_cells, drawn_for, drawn_list, drawn_points, read_drawn
from topomap.cli.label_sources import Progress, carmen_map
from topomap.cli.online import agreement
from topomap.topomap import pipeline_from_options


def drawn_rooms(grid: OccupancyGrid, rooms: list[dict[str, Any]]) -> NDArray[np.int32]:
    """Room (1..N, in the order given) of each free cell of ``grid`` inside one of the drawn
    ``rooms`` (``{"name": ..., "polygon": [[x, y], ...]}`` in metres), 0 elsewhere.

    Raises
    ------
    MapFormatError
        Rooms that are not a list of objects, a room without a polygon of at least three
        finite points, or one that lies wholly off the map (rooms drawn on another map or
        frame); a far vertex is drawn as the polygon's part on the map.

    Examples
    --------
    >>> grid = OccupancyGrid(np.zeros((10, 20), np.int8), 0.5)  # 10 x 5 m, all free
    >>> rooms = [{"name": "a", "polygon": [[0, 0], [5, 0], [5, 5], [0, 5]]},
    ...          {"name": "b", "polygon": [[5, 0], [10, 0], [10, 5], [5, 5]]}]
    >>> labels = drawn_rooms(grid, rooms)
    >>> labels[5, 2], labels[5, 17], sorted(np.unique(labels).tolist())
    (np.int32(1), np.int32(2), [1, 2])
    """
    labels = np.zeros(grid.shape, np.int32)
    x0, y0, x1, y1 = grid.bounds()
    for number, room in enumerate(drawn_list(rooms, "room", "name, polygon"), 1):
        name = room.get("name", "?")
        xy = drawn_points(room.get("polygon"), 3, f"room {number} ({name!r:.40}): a polygon")
        if xy[:, 0].max() < x0 or xy[:, 0].min() > x1 or xy[:, 1].max() < y0 or xy[:, 1].min() > y1:
            raise MapFormatError(
                f"room {number} ({name!r:.40}) lies off the map (x {x0:g}..{x1:g}, "
                f"y {y0:g}..{y1:g} m): the rooms are of another map or frame"
            )
        cv2.fillPoly(labels, drawn_cells(grid, xy), number)
    return np.where(grid.free, labels, 0)


def evaluate_logs(
    log_dir: str | Path,
    rooms_json: str | Path,
    progress: Progress = iter,
    resolution: float = 0.05,
) -> list[dict[str, Any]]:
    """A record per log drawn in ``rooms_json`` (logs in ``log_dir``, mapped on cells of
    ``resolution`` metres), method and input (the robot's keyframes, the map alone): regions,
    rooms, the keyframes' ARI against the rooms they stand in (None when they all stand in
    one), the cells' MCC and ROSE²'s IoU."""
    records = []
    for name, drawn in progress(sorted(read_drawn(rooms_json, "drawn rooms JSON").items())):
        if not (isinstance(drawn.get("rooms"), list) and drawn["rooms"]):
            raise MapFormatError(f"{rooms_json}: {name!r} has no list of 'rooms' drawn")
        keyframes, grid = carmen_map(Path(log_dir) / drawn["log"], resolution)
        with drawn_for(rooms_json, name):
            rooms = drawn_rooms(grid, drawn["rooms"])
        poses = poses_array(keyframes)
        rows, cols = grid.world_to_cell(poses[:, 0], poses[:, 1])
        standing = np.zeros(len(poses), np.int32)
        on_map = grid.contains(rows, cols)
        standing[on_map] = rooms[rows[on_map], cols[on_map]]
        inside = standing > 0  # not in a wall or a door frame
        rooms_stood = len(np.unique(standing[inside]))
        for method, source in itertools.product(("spectral", "doors"), ("keyframes", "map")):
            found = pipeline_from_options({"method": method}).segment(
                grid, keyframes if source == "keyframes" else None, random_state=0
            )
            regions = found.regions.labels
            at = np.zeros(len(poses), np.int64)
            at[on_map] = regions[rows[on_map], cols[on_map]]
            records.append(
                {
                    "log": name,
                    "method": method,
                    "input": source,
                    "resolution": resolution,
                    "keyframes": len(keyframes),
                    "in_rooms": round(float(inside.mean()), 3),
                    "regions": int(regions.max()),
                    "rooms": len(drawn["rooms"]),
                    # keyframes all in one room (a robot that kept to the corridors): no ARI
                    "keyframe_ari": agreement(at[inside], standing[inside])
                    if rooms_stood > 1
                    else None,
                    "mcc": round(score(regions, rooms).mcc, 4),
                    "rose2_iou": round(rose2_score(regions, rooms).iou, 1),
                }
            )
    return records
