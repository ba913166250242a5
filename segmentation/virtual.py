"""Virtual keyframes for map-only input: poses spread over the free space, simulated scans."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.grid import OccupancyGrid
from maps.scan import Keyframe
from maps.seeding import RandomState
from maps.sim.laser import LaserModel, simulate_scans
from segmentation.distinct import label_counts, nonzero_cells
from segmentation.errors import ParameterError, SegmentationError

#: The default virtual laser: a full circle of 180 beams reaching 15 m, no noise.
VIRTUAL_LASER = LaserModel(fov=2 * math.pi, beams=180, max_range=15.0)
#: Virtual keyframes a map may get. The benchmark segments 10,000 keyframes in under 5 s;
#: twice that is still a minute's work and a few GB, while a fine lattice over a large map
#: (office_a at 0.2 m: 35,000) takes many minutes and exhausts memory in the keyframes'
#: views. A finer lattice than this is a typo or a map that needs a larger spacing.
MAX_VIRTUAL_KEYFRAMES = 20_000


def virtual_poses(
    grid: OccupancyGrid,
    spacing: float = 0.6,
    min_clearance: float = 0.2,
    places: NDArray[np.integer] | None = None,
) -> NDArray[np.float64]:
    """``(n, 3)`` poses on a square lattice of ``spacing`` metres over the free space.

    Only cells at least ``min_clearance`` metres from any non-free cell are used. Every
    place (a label of ``places``, e.g. the clearance basins) gets a pose at its most open cell;
    without ``places``, every connected piece of the usable space the lattice misses does, so
    no room is left without a keyframe.

    Raises
    ------
    SegmentationError
        The grid has no cell with that clearance.
    ParameterError
        The lattice would hold more than :data:`MAX_VIRTUAL_KEYFRAMES` poses.
    """
    if not spacing > 0 or not min_clearance >= 0:
        raise ParameterError(
            f"need spacing > 0 and min_clearance >= 0 metres, got {spacing!r}, {min_clearance!r}"
        )
    clearance = grid.clearance()
    open_space = clearance >= max(min_clearance, grid.resolution)
    if not open_space.any():
        raise SegmentationError(
            f"the map has no free cell {min_clearance} m away from walls and unknown space"
        )
    step = max(1, round(spacing / grid.resolution))
    lattice = np.zeros_like(open_space)
    lattice[step // 2 :: step, step // 2 :: step] = True
    chosen = open_space & lattice
    if places is None:
        pieces, count = ndimage.label(open_space, structure=np.ones((3, 3)))
        covered = np.zeros(count + 1, bool)
        covered[pieces[chosen]] = True
        wanted = np.flatnonzero(~covered[1:]) + 1
    else:
        pieces = np.where(open_space, places, 0)
        wanted = np.flatnonzero(label_counts(pieces))  # the labels present, ascending
        wanted = wanted[wanted > 0]
    if len(wanted):
        rows, cols = most_open_cells(clearance, pieces, wanted)
        chosen[rows, cols] = True
    count = int(np.count_nonzero(chosen))
    if count > MAX_VIRTUAL_KEYFRAMES:
        area = np.count_nonzero(open_space) * grid.resolution**2
        raise ParameterError(
            f"spacing {spacing:g} m would put {count} virtual keyframes on the map's "
            f"{area:.0f} m^2 of free space, more than the {MAX_VIRTUAL_KEYFRAMES} allowed: "
            "give a larger spacing (--spacing)"
        )
    rows, cols = nonzero_cells(chosen)
    x, y = grid.cell_to_world(rows, cols)
    return np.column_stack([x, y, np.zeros(len(rows))])


def most_open_cells(
    clearance: NDArray[np.floating], labels: NDArray[np.integer], wanted: NDArray[np.integer]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """``(rows, cols)`` of the cell of largest ``clearance`` of each label in ``wanted``, the
    first in row-major order on ties, from the runs of equal labels along the rows (one pass
    over the image; SciPy's ``ndimage.maximum_position`` takes four times as long, and a
    cell-by-cell ``np.maximum.at`` five times as long on office_g's 4.7 M cells). The peaks
    are kept in ``clearance``'s own type, or single precision if that is narrower.

    Examples
    --------
    >>> labels = np.array([[1, 1, 2], [1, 2, 2]])
    >>> clearance = np.array([[0.1, 0.3, 0.2], [0.3, 0.5, 0.1]])
    >>> [v.tolist() for v in most_open_cells(clearance, labels, np.array([1, 2]))]
    [[0, 1], [1, 1]]
    """
    flat_labels, flat = labels.ravel(), clearance.ravel()
    starts = np.flatnonzero(np.r_[True, flat_labels[1:] != flat_labels[:-1]])
    ends = np.r_[starts[1:], len(flat)]
    highest = np.maximum.reduceat(flat, starts)  # along each run
    labelled = flat_labels[starts] > 0
    starts, ends, highest = starts[labelled], ends[labelled], highest[labelled]
    owner = flat_labels[starts]
    peak = np.full(
        int(labels.max(initial=0)) + 1, -np.inf, np.promote_types(clearance.dtype, np.float32)
    )
    np.maximum.at(peak, owner, highest)
    at_peak = np.flatnonzero(highest == peak[owner])
    owners, first = np.unique(owner[at_peak], return_index=True)  # each label's first such run
    runs = at_peak[first[np.isin(owners, wanted)]]
    chosen = [
        start + int(np.argmax(flat[start:end] == peak[label]))
        for start, end, label in zip(starts[runs], ends[runs], owner[runs], strict=True)
    ]
    rows, cols = np.divmod(np.array(chosen, np.intp), labels.shape[1])
    return rows, cols


def virtual_keyframes(
    grid: OccupancyGrid,
    spacing: float = 0.6,
    *,
    model: LaserModel = VIRTUAL_LASER,
    min_clearance: float = 0.2,
    places: NDArray[np.integer] | None = None,
    random_state: RandomState = None,
) -> list[Keyframe]:
    """Keyframes a robot with laser ``model`` would record at :func:`virtual_poses`."""
    poses = virtual_poses(grid, spacing, min_clearance, places)
    return simulate_scans(grid, poses, model, random_state=random_state)
