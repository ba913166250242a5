"""Dense regions and the region adjacency graph of a growing map, updated keyframe by keyframe.

Every keyframe *claims* the free cells its beams crossed within ``reach`` metres (its scan's
polygon, filled by OpenCV, without the cells the beams ended in): a cell is owned by the nearest
keyframe that saw it through free space, and a cell's region is its owner's region; a cell a
beam ended in is a wall for good. So when a keyframe arrives only the cells it saw change, and
when two regions merge only the absorbed region's keyframes are relabelled: nothing is rebuilt
from scratch.

The graph has a node per region (``area_m2``, ``keyframes``, ``x``, ``y`` the mean keyframe
position, ``name``) and an edge per pair of regions with 4-adjacent cells (``boundary_m``, the
length of their common boundary in metres). Boundary lengths are counted incrementally from the
cells whose region changed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import networkx as nx
import numpy as np
from numpy.typing import NDArray

from maps.errors import MapTooLargeError
from maps.limits import RESOLUTION_RANGE, check_map_size
from maps.scan import Keyframe
from segmentation.base import check_lengths
from segmentation.errors import ParameterError

#: Sub-pixel bits of the scan polygons given to OpenCV.
_SHIFT = 4
#: Cells of unknown border kept around the claimed area when the arrays grow.
_MARGIN = 64


class OnlineRegions:
    """The dense regions of keyframes assigned one at a time (see the module docstring).

    Parameters
    ----------
    resolution
        Cell size in metres.
    reach
        A keyframe claims free cells up to this many metres from its pose.

    Examples
    --------
    >>> import numpy as np
    >>> from maps.scan import Keyframe, LaserScan
    >>> scan = LaserScan(np.full(90, 2.0), -np.pi, 2 * np.pi / 90)
    >>> regions = OnlineRegions(resolution=0.1, reach=4.0)
    >>> regions.add(0, Keyframe((0.0, 0.0, 0.0), scan), region=1)
    >>> regions.add(1, Keyframe((3.0, 0.0, 0.0), scan), region=2)
    >>> regions.region_at(-1.0, 0.0), regions.region_at(2.5, 0.0), sorted(regions.graph.edges)
    (1, 2, [(1, 2)])
    """

    def __init__(self, resolution: float = 0.1, reach: float = 4.0) -> None:
        self.resolution, self.reach = resolution, reach
        check_lengths(self, "resolution", "reach")
        self.resolution = float(resolution)
        self.reach = float(reach)
        low, high = RESOLUTION_RANGE
        if not low <= self.resolution <= high:
            raise ParameterError(
                f"resolution must lie in [{low:g}, {high:g}] metres per cell, got {resolution!r}"
            )
        side = 2 * self.reach / self.resolution + 3  # the window one keyframe's cells fill
        try:
            check_map_size(side, side, what="a keyframe's window of cells")
        except MapTooLargeError as err:
            raise ParameterError(f"reach {reach!r} m at {resolution!r} m per cell: {err}") from None
        self._low = np.zeros(2, np.int64)  # cell (i, j) of array index [0, 0]
        self._owner = np.full((0, 0), -1, np.int32)
        self._distance = np.full((0, 0), np.inf, np.float32)
        self._region_of = np.zeros(64, np.int64)  # region of each keyframe index
        self._poses = np.zeros((64, 2))  # x, y of each keyframe index
        self._members: dict[int, list[int]] = {}
        self._pose_sum: dict[int, NDArray[np.float64]] = {}
        self._cells: dict[int, int] = {}
        self._boundary: dict[tuple[int, int], int] = {}
        self._neighbours: dict[int, set[int]] = {}  # regions with a boundary entry
        self.graph = nx.Graph(resolution=self.resolution)

    # --------------------------------------------------------------------------- queries
    def region_at(self, x: float, y: float) -> int:
        """Region id at map point ``(x, y)``, 0 if no keyframe claimed it."""
        i, j = (np.floor(np.array([x, y]) / self.resolution).astype(np.int64) - self._low).tolist()
        if not (0 <= i < self._owner.shape[0] and 0 <= j < self._owner.shape[1]):
            return 0
        owner = int(self._owner[i, j])
        return int(self._region_of[owner]) if owner >= 0 else 0

    def label_image(self) -> tuple[NDArray[np.int64], tuple[float, float, float, float]]:
        """Region of every cell as an image (row 0 at the top, 0 = none) and its extent
        ``(xmin, xmax, ymin, ymax)`` in metres."""
        labels = self._labels(self._owner).T[::-1]
        res = self.resolution
        x0, y0 = self._low * res
        return labels, (x0, x0 + self._owner.shape[0] * res, y0, y0 + self._owner.shape[1] * res)

    def boundary_counts(self) -> dict[tuple[int, int], int]:
        """Cell sides shared by regions ``a < b``, as counted incrementally."""
        return {pair: count for pair, count in self._boundary.items() if count > 0}

    def areas(self) -> dict[int, float]:
        """Area of each region in square metres, as counted incrementally."""
        return {r: n * self.resolution**2 for r, n in self._cells.items() if n > 0}

    # --------------------------------------------------------------------------- updates
    def relabel(self, indices: NDArray[np.int64], regions: NDArray[np.int64]) -> None:
        """Keyframes ``indices`` (each already added) now belong to ``regions``; areas,
        boundaries and the graph are recounted only around their poses."""
        indices = np.asarray(indices, np.int64)
        regions = np.asarray(regions, np.int64)
        moved = self._region_of[indices] != regions
        indices, regions = indices[moved], regions[moved]
        if len(indices) == 0:
            return
        poses = self._poses[indices]
        margin = self.reach + 2 * self.resolution
        first = np.floor((poses.min(axis=0) - margin) / self.resolution).astype(np.int64)
        last = np.ceil((poses.max(axis=0) + margin) / self.resolution).astype(np.int64)
        first = np.maximum(first - self._low, 0)
        last = np.minimum(last - self._low + 1, self._owner.shape)
        box = self._owner[first[0] : last[0], first[1] : last[1]]
        before = self._labels(box)
        old = self._region_of[indices].copy()
        self._region_of[indices] = regions
        after = self._labels(box)
        # only the cells whose region changed, and the cell sides they touch, are recounted
        changed = before != after
        touch = (changed[1:] | changed[:-1], changed[:, 1:] | changed[:, :-1])
        for labels, sign in ((before, -1), (after, 1)):
            cells = labels[changed]
            found, counts = np.unique(cells[cells > 0], return_counts=True)
            for region, count in zip(found.tolist(), counts.tolist(), strict=True):
                self._cells[region] = self._cells.get(region, 0) + sign * count
            sides = ((labels[1:], labels[:-1]), (labels[:, 1:], labels[:, :-1]))
            for (a, b), near in zip(sides, touch, strict=True):
                a, b = a[near], b[near]
                keep = (a != b) & (a > 0) & (b > 0)
                low, high = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
                pairs, counts = np.unique((low << 32) + high, return_counts=True)
                for pair, count in zip(pairs.tolist(), counts.tolist(), strict=True):
                    self._count_boundary(pair >> 32, pair & 0xFFFFFFFF, sign * count)
        for index, source, target in zip(
            indices.tolist(), old.tolist(), regions.tolist(), strict=True
        ):
            self._members[source].remove(index)
            self._members.setdefault(target, []).append(index)
            self._pose_sum[source] -= self._poses[index]
            self._pose_sum[target] = self._pose_sum.get(target, np.zeros(2)) + self._poses[index]
        touched = set(old.tolist()) | set(regions.tolist())
        for region in touched:
            if not self._members.get(region):
                self._members.pop(region, None)
                self._pose_sum.pop(region, None)
                self._cells.pop(region, None)
                if region in self.graph:
                    self.graph.remove_node(region)
                continue
            self._update_node(region)
        for region in touched:
            for other in self._neighbours.get(region, set()) | set(self.graph.adj.get(region, ())):
                self._update_edge(region, other)

    def add(self, index: int, keyframe: Keyframe, region: int) -> None:
        """Keyframe number ``index`` of region ``region`` claims the free cells it saw.

        Raises
        ------
        MapTooLargeError
            If the arrays would grow beyond what this machine can hold (checked before they
            grow; nothing is changed), naming the keyframe's scan and pose.
        """
        x, y = keyframe.pose[:2]
        self._fit(*self._grown(self._low, self._owner.shape, keyframe))
        cells, distance, walls = self._seen(keyframe)
        if index >= len(self._region_of):
            grown = np.zeros(max(2 * len(self._region_of), index + 1), np.int64)
            grown[: len(self._region_of)] = self._region_of
            self._region_of = grown
        if index >= len(self._poses):
            grown_poses = np.zeros((max(2 * len(self._poses), index + 1), 2))
            grown_poses[: len(self._poses)] = self._poses
            self._poses = grown_poses
        self._region_of[index] = region
        self._members.setdefault(region, []).append(index)
        self._poses[index] = x, y
        self._pose_sum[region] = self._pose_sum.get(region, np.zeros(2)) + np.array([x, y])
        for found, to, owner in (
            (cells, distance, index),
            (walls, np.full(len(walls), -np.inf), -1),
        ):
            i, j = (found - self._low).T
            closer = to < self._distance[i, j]
            if np.any(closer):
                self._claim(i[closer], j[closer], to[closer], owner)
        self._update_node(region)

    def check(self, keyframes: Sequence[Keyframe]) -> None:
        """Refuse ``keyframes`` if :meth:`add` would refuse one of them, before anything
        changes (the arrays hold each keyframe's window of cells, a function of its pose).

        Raises
        ------
        MapTooLargeError
            :meth:`add`'s, at the first keyframe the arrays cannot hold.
        """
        low, shape = self._low, self._owner.shape
        for keyframe in keyframes:
            low, shape = self._grown(low, shape, keyframe)

    def merge(self, survivor: int, absorbed: int) -> None:
        """Region ``absorbed`` becomes part of ``survivor``."""
        members = self._members.pop(absorbed, [])
        self._region_of[np.asarray(members, np.int64)] = survivor
        self._members.setdefault(survivor, []).extend(members)
        self._pose_sum[survivor] = self._pose_sum.get(survivor, np.zeros(2)) + self._pose_sum.pop(
            absorbed, np.zeros(2)
        )
        self._cells[survivor] = self._cells.get(survivor, 0) + self._cells.pop(absorbed, 0)
        for other in self._neighbours.pop(absorbed, set()):
            count = self._boundary.pop((min(absorbed, other), max(absorbed, other)))
            self._neighbours[other].discard(absorbed)
            if other != survivor:
                self._count_boundary(survivor, other, count)
        if absorbed in self.graph:
            self.graph.remove_node(absorbed)
        self._update_node(survivor)
        for other in self._neighbours.get(survivor, set()) | set(self.graph.adj.get(survivor, ())):
            self._update_edge(survivor, other)

    # --------------------------------------------------------------------------- internals
    def _labels(self, owner: NDArray[np.integer]) -> NDArray[np.int64]:
        return np.where(owner >= 0, self._region_of[np.maximum(owner, 0)], 0)

    def _seen(
        self, keyframe: Keyframe
    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.int64]]:
        """Cells inside the scan's polygon (sensor, then every beam's end, cut at ``reach``)
        but those the beams ended in, their distance to the pose, and the cells the beams
        ended in (walls)."""
        scan = keyframe.scan
        valid, open_ = scan.valid, scan.no_return
        top = min(scan.range_max, self.reach) if math.isfinite(scan.range_max) else self.reach
        length = np.where(valid, np.minimum(scan.ranges, self.reach), np.where(open_, top, 0.0))
        x, y, yaw = keyframe.pose
        angles = scan.angles + yaw
        res = self.resolution
        corner, size = self._window(keyframe)
        ends = np.column_stack([x + length * np.cos(angles), y + length * np.sin(angles)])
        polygon = np.vstack([[x, y], ends]) / res - corner - 0.5  # pixel centres at integers
        seen = np.zeros((size, size), np.uint8)
        pixels = np.round(polygon * (1 << _SHIFT)).astype(np.int32)
        cv2.fillPoly(seen, [pixels], 1, lineType=cv2.LINE_8, shift=_SHIFT)
        hit = np.floor(polygon[1:][valid & (scan.ranges <= self.reach)] + 0.5).astype(np.int64)
        seen[hit[:, 1], hit[:, 0]] = 0  # the cells the beams ended in are walls
        j, i = np.nonzero(seen)
        cells = np.column_stack([i, j]).astype(np.int64) + corner
        centres = (cells + 0.5) * self.resolution
        return cells, np.hypot(centres[:, 0] - x, centres[:, 1] - y), hit + corner

    def _window(self, keyframe: Keyframe) -> tuple[NDArray[np.int64], int]:
        """The first cell and the side of the square of cells the keyframe may claim."""
        corner = np.floor((np.asarray(keyframe.pose[:2]) - self.reach) / self.resolution)
        return corner.astype(np.int64) - 1, int(math.ceil(2 * self.reach / self.resolution)) + 3

    def _grown(
        self, low: NDArray[np.int64], shape: tuple[int, int], keyframe: Keyframe
    ) -> tuple[NDArray[np.int64], tuple[int, int]]:
        """The first cell and the shape of arrays (now ``low`` and ``shape``) grown to hold
        the keyframe's window of cells and a one-cell border around it.

        Raises
        ------
        MapTooLargeError
            If they would be larger than memory allows, naming the keyframe's scan and pose.
        """
        corner, side = self._window(keyframe)
        first, last = corner - 1, corner + side + 1
        size = np.array(shape)
        if size.all() and np.all(first >= low) and np.all(last <= low + size):
            return low, shape
        if not size.all():
            new_low, new_high = first - _MARGIN, last + _MARGIN
        else:
            new_low = np.where(first < low, first - np.maximum(_MARGIN, size // 2), low)
            end = low + size
            new_high = np.where(last > end, last + np.maximum(_MARGIN, size // 2), end)
        height, width = (new_high - new_low).tolist()
        grown = (int(height), int(width))
        try:
            check_map_size(*grown, what=f"online regions at {self.resolution:g} m per cell")
        except MapTooLargeError as err:
            x, y = keyframe.pose[:2]
            raise MapTooLargeError(
                f"{err}: scan {keyframe.scan_index} at ({x:.6g}, {y:.6g}) m is too far from "
                "the others"
            ) from None
        return new_low, grown

    def _fit(self, low: NDArray[np.int64], shape: tuple[int, int]) -> None:
        """The arrays from cell ``low`` in ``shape`` (:meth:`_grown`), what they hold kept."""
        if shape == self._owner.shape:
            return
        owner = np.full(shape, -1, np.int32)
        distance = np.full(shape, np.inf, np.float32)
        if self._owner.size:
            a, b = self._low - low
            height, width = self._owner.shape
            owner[a : a + height, b : b + width] = self._owner
            distance[a : a + height, b : b + width] = self._distance
        self._owner, self._distance, self._low = owner, distance, low

    def _claim(
        self, i: NDArray[np.int64], j: NDArray[np.int64], distance: NDArray[np.float64], index: int
    ) -> None:
        """Give cells ``(i, j)`` to keyframe ``index`` (-1: walls, never claimed again); update
        areas and boundary counts."""
        width = self._owner.shape[1]
        flat, first_seen = np.unique(i * width + j, return_index=True)
        distance = distance[first_seen]
        # every cell side touching a changed cell: (cell, +1 column) and (cell, +1 row)
        sides = np.unique(
            np.concatenate([flat * 2, flat * 2 + 1, (flat - 1) * 2, (flat - width) * 2 + 1])
        )
        first = sides // 2
        second = first + np.where(sides % 2 == 0, 1, width)
        owner = self._owner.ravel()
        before = self._labels(owner[first]), self._labels(owner[second])
        old = self._labels(owner[flat])
        owner[flat] = index
        self._distance.ravel()[flat] = distance
        after = self._labels(owner[first]), self._labels(owner[second])
        for labels, sign in ((old, -1), (self._labels(owner[flat]), 1)):
            regions, counts = np.unique(labels[labels > 0], return_counts=True)
            for region, count in zip(regions.tolist(), counts.tolist(), strict=True):
                self._cells[region] = self._cells.get(region, 0) + sign * count
        touched: set[tuple[int, int]] = set()
        for (a, b), sign in ((before, -1), (after, 1)):
            keep = (a != b) & (a > 0) & (b > 0)
            low, high = np.minimum(a[keep], b[keep]), np.maximum(a[keep], b[keep])
            pairs, counts = np.unique((low << 32) + high, return_counts=True)
            for pair, count in zip(pairs.tolist(), counts.tolist(), strict=True):
                p, q = pair >> 32, pair & 0xFFFFFFFF
                self._count_boundary(p, q, sign * count)
                touched.add((p, q))
        for region in np.unique(old[old > 0]).tolist():
            self._update_node(region)
        for pair in touched:
            self._update_edge(*pair)

    def _count_boundary(self, a: int, b: int, count: int) -> None:
        pair = (min(a, b), max(a, b))
        self._boundary[pair] = self._boundary.get(pair, 0) + count
        self._neighbours.setdefault(a, set()).add(b)
        self._neighbours.setdefault(b, set()).add(a)

    def _update_node(self, region: int) -> None:
        members = self._members.get(region)
        if not members:
            return
        x, y = self._pose_sum[region] / len(members)
        self.graph.add_node(
            region,
            area_m2=self._cells.get(region, 0) * self.resolution**2,
            keyframes=len(members),
            x=float(x),
            y=float(y),
            name=f"region {region}",
        )

    def _update_edge(self, a: int, b: int) -> None:
        count = self._boundary.get((min(a, b), max(a, b)), 0)
        if count > 0:
            self.graph.add_edge(a, b, boundary_m=count * self.resolution)
        elif self.graph.has_edge(a, b):
            self.graph.remove_edge(a, b)
