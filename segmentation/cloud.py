"""All keyframes' scan end points in one array, quantised to a grid, for vectorised criteria."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from maps.scan import Keyframe
from segmentation.errors import ParameterError, SegmentationError


@dataclass(frozen=True)
class ScanCloud:
    """End points of every keyframe's valid beams in the map frame, one row per point.

    Points of one scan that fall in the same ``resolution`` cell are kept once (at the cell's
    centre), so the criteria see each scan as the set of cells it hit.

    Attributes
    ----------
    cells
        ``(m, 2)`` int64 cell coordinates ``(i, j)`` of the points: ``x = (i + 0.5) * resolution``.
    owner
        ``(m,)`` index of the keyframe each point belongs to; sorted.
    n_keyframes
        Number of keyframes (some may own no point).
    resolution
        Cell size in metres.
    """

    cells: NDArray[np.int64]
    owner: NDArray[np.int64]
    n_keyframes: int
    resolution: float

    @classmethod
    def from_keyframes(cls, keyframes: Sequence[Keyframe], resolution: float) -> ScanCloud:
        """Quantise the keyframes' end points.

        Raises
        ------
        SegmentationError
            No keyframe, or a keyframe whose scan has no valid beam.
        """
        if not resolution > 0:
            raise ParameterError(f"resolution must be > 0 metres, got {resolution!r}")
        if len(keyframes) == 0:
            raise SegmentationError("no keyframes to segment")
        points = [k.points() for k in keyframes]
        for i, p in enumerate(points):
            if len(p) == 0:
                raise SegmentationError(
                    f"keyframe {i} (scan_index {keyframes[i].scan_index}) has no valid beam"
                )
        owner = np.repeat(np.arange(len(points), dtype=np.int64), [len(p) for p in points])
        cells = np.floor(np.concatenate(points) / resolution).astype(np.int64)
        low = cells.min(axis=0)
        span = cells.max(axis=0) - low + 1
        key = (owner * span[0] + (cells[:, 0] - low[0])) * span[1] + (cells[:, 1] - low[1])
        key = np.sort(key)  # then its distinct values: np.unique's hash table is 10x slower
        key = key[np.append(True, key[1:] != key[:-1])]
        cells = np.column_stack([key // span[1] % span[0] + low[0], key % span[1] + low[1]])
        return cls(cells, key // (span[0] * span[1]), len(points), float(resolution))

    @property
    def points(self) -> NDArray[np.float64]:
        """``(m, 2)`` cell centres in metres."""
        return (self.cells + 0.5).astype(np.float64) * self.resolution

    @property
    def counts(self) -> NDArray[np.int64]:
        """Number of points per keyframe."""
        return np.bincount(self.owner, minlength=self.n_keyframes)

    def split(self) -> list[NDArray[np.float64]]:
        """The points of each keyframe, as a list of ``(n_i, 2)`` arrays."""
        bounds = np.cumsum(self.counts)[:-1]
        return np.split(self.points, bounds)
