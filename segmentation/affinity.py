"""The affinity the spectral partition clusters: the paper's similarity, weighed by the doors.

The paper's criteria (:mod:`segmentation.similarity`) say how much two keyframes' scans look
alike. Keyframes on both sides of an open door see the same door frame and walls, so the
similarity alone leaks through doors; keyframes far apart in one long corridor see different
stretches of wall, so it alone cuts corridors. :class:`PassageAffinity` adds what the geometry
of the free space knows:

``W_ij = S_ij * openness(place_i, place_j) ** contrast``

with ``S`` the paper's similarity and ``openness`` that of the narrowest passage on the most
open route between the places the keyframes stand in
(:func:`~segmentation.passages.bottleneck_openness`): 1 inside one room or corridor, small
across a door. The normalised cut then prefers cutting at doors, and the silhouette chooses
among partitions that do.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage, sparse

from maps.grid import OccupancyGrid
from maps.scan import Keyframe, poses_array
from segmentation.errors import ParameterError
from segmentation.passages import bottleneck_openness, boundary_openness
from segmentation.similarity import Criterion, PointsSimilarity, as_criterion

#: A keyframe off every place but this close to one (metres) stands beside it: in a door
#: frame, in a closed wall gap (:mod:`segmentation.walls`), beside furniture.
BESIDE = 0.5


@dataclass
class PassageAffinity:
    """A :class:`~segmentation.similarity.Criterion`: ``base`` similarity weighed by the
    openness of the passages between keyframes (see the module docstring).

    Parameters
    ----------
    grid
        The space the places were found in.
    places
        Label image of the places on ``grid`` (clearance basins).
    base
        The paper's criterion: ``"nn"``, ``"hausdorff"``, ``"features"``, a criterion or a
        callable of two point arrays.
    contrast
        The openness exponent: 0 ignores the geometry (the paper's affinity alone).

    Examples
    --------
    >>> import maps
    >>> from segmentation.refine import basins
    >>> from segmentation.virtual import virtual_keyframes
    >>> plan = maps.generate_floor_plan("flat", random_state=0)
    >>> places = basins(plan.grid)
    >>> keyframes = virtual_keyframes(plan.grid, 2.0, places=places, random_state=0)
    >>> weighed = PassageAffinity(plan.grid, places).affinity(keyframes)
    >>> plain = PassageAffinity(plan.grid, places, contrast=0).affinity(keyframes)
    >>> bool((weighed.toarray() <= plain.toarray()).all()), weighed.nnz == plain.nnz
    (True, True)
    >>> bool(weighed.sum() < plain.sum())  # pairs across doors are weakened
    True
    """

    grid: OccupancyGrid = field(repr=False)
    places: NDArray[np.integer] = field(repr=False)
    base: str | Criterion | PointsSimilarity = "nn"
    contrast: float = 2.0
    route_: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if self.places.shape != self.grid.shape:
            raise ParameterError(
                f"places of shape {self.places.shape} for a grid of shape {self.grid.shape}"
            )
        if not (isinstance(self.contrast, int | float) and 0 <= self.contrast < 64):
            raise ParameterError(f"contrast must lie in [0, 64), got {self.contrast!r}")
        as_criterion(self.base)
        count = int(self.places.max(initial=0)) + 1
        self.route_ = bottleneck_openness(count, *boundary_openness(self.grid, self.places))
        self.route_[0, :] = self.route_[:, 0] = 1.0  # a keyframe on no place: nothing between

    def keyframe_places(self, keyframes: Sequence[Keyframe]) -> NDArray[np.int64]:
        """:func:`standing_places` of ``keyframes`` among these places."""
        return standing_places(self.grid, self.places, poses_array(keyframes))

    def affinity(self, keyframes: Sequence[Keyframe]) -> sparse.csr_matrix:
        """``W`` of all pairs of ``keyframes`` (see the module docstring); keyframes on no
        place keep the base similarity."""
        similarity = as_criterion(self.base).affinity(keyframes).tocoo()
        place = self.keyframe_places(keyframes)
        weight = self.route_[place[similarity.row], place[similarity.col]] ** self.contrast
        return sparse.csr_matrix(
            (similarity.data * weight, (similarity.row, similarity.col)), shape=similarity.shape
        )


def standing_places(
    grid: OccupancyGrid, places: NDArray[np.integer], poses: NDArray[np.float64]
) -> NDArray[np.int64]:
    """The place (of ``places`` on ``grid``) each of ``poses`` (x, y, ...) stands in, or the
    nearest within :data:`BESIDE` metres (a robot in a door frame or a closed wall gap stands
    beside the place it passes through); 0 if none.

    Examples
    --------
    >>> places = np.array([[1] + [0] * 12 + [2]])  # 0.1 m cells
    >>> grid = OccupancyGrid.from_masks(places > 0, 0.1)
    >>> standing_places(grid, places, np.array([[0.25, 0.05], [0.75, 0.05], [1.15, 0.05]]))
    array([1, 0, 2])
    """
    rows, cols = grid.world_to_cell(poses[:, 0], poses[:, 1])
    inside = grid.contains(rows, cols)
    found = np.zeros(len(poses), np.int64)
    found[inside] = places[rows[inside], cols[inside]]
    off = np.flatnonzero(inside & (found == 0))
    if len(off):
        distance, (near_rows, near_cols) = ndimage.distance_transform_edt(
            places == 0, return_indices=True
        )
        r, c = rows[off], cols[off]
        beside = distance[r, c] * grid.resolution <= BESIDE
        found[off[beside]] = places[near_rows[r, c], near_cols[r, c]][beside]
    return found
