"""The mapper's blur on the walls: taken off before anything is measured.

A laser mapper marks a cell occupied wherever a beam ended in it, so a wall is a band of cells
round its surface, as wide as the mapper's range noise and occupancy threshold make it. Seen
from one side only (free space in front, unknown behind), the band is that blur alone and the
surface lies in its middle: a band of ``b`` cells stands ``(b - 1) / 2`` cells into the room
in front of the surface's cell. Every door, corridor and room of the map is then narrower by
that much on each side than the same building drawn by a sharper mapper, and the widths the
segmentation compares with physical ones (the narrowest door, the narrowest corridor) move
with the mapper. :func:`sharpened` takes the whole cells of blur off the obstacles' thick
parts when it is more than a laser's own (:data:`LASER_BLUR`), so a map whose walls are
drawn thick is measured like one whose walls are drawn thin; thin walls stay whole (no wall
is opened). On ROSE²'s SLAM maps, the ipa plans and the maps built from the CARMEN logs the
walls' bands are 1-2.2 cells of 0.05 m (median; at most 0.03 m of blur on each side):
nothing is taken off. The same ROSE² maps with every wall a cell thicker on each side
(``topomap eval segment --thicker``) show 3.6-4 cells (0.065-0.075 m), and one comes off.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from scipy import ndimage

from maps.grid import OccupancyGrid
from segmentation.working import disc_cells

#: The blur every laser leaves, metres on each side of a surface: a scanner's range noise is
#: a centimetre or three, and the widths the segmentation compares with doors and corridors
#: allow for it. Only a band blurred further (a noisier mapper, another occupancy threshold)
#: is sharpened.
LASER_BLUR = 0.05
#: The thickest band read as blur, metres: a one-sided wall band thicker than this is a
#: wall's own thickness (a drawn plan's outer walls, 0.3 m) or furniture against it.
BLUR_MAX = 0.25

#: A free cell with at least this many free cells in its 5 x 5 neighbourhood is a room's floor;
#: fewer, a laser ray (a cell or two wide at any resolution), whose end says nothing of a
#: wall's band (the unknown beside the ray is a cell away).
FLOOR_AROUND = 12
_SQUARE = np.ones((3, 3), bool)


def wall_band(grid: OccupancyGrid) -> float:
    """The median thickness, in cells, of the walls ``grid`` shows from one side: at every
    occupied cell beside a room's floor (4-neighbourhood; :data:`FLOOR_AROUND`), the
    distance to the nearest unknown cell, where it is at most :data:`BLUR_MAX`; 0 when no
    wall is seen from one side.

    Examples
    --------
    >>> cells = np.full((10, 10), -1, np.int8)
    >>> cells[:, :5] = 0
    >>> cells[:, 5:8] = 100  # a wall three cells thick, unknown behind it
    >>> wall_band(OccupancyGrid(cells, 0.05))
    3.0
    """
    unknown = grid.unknown
    if not unknown.any():
        return 0.0
    free = grid.free.astype(np.uint8)
    around = cv2.boxFilter(
        free, cv2.CV_16U, (5, 5), normalize=False, borderType=cv2.BORDER_CONSTANT
    )
    floor = free & (around >= FLOOR_AROUND).astype(np.uint8)  # a room's floor, not a ray
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    face = grid.occupied & (cv2.dilate(floor, cross) > 0)
    # no face within BLUR_MAX of an unknown cell (walls with rooms on both sides): no depth
    # counts, no distance transform (the disc a hundredth of a cell wider: OpenCV's
    # distances are off in their last bits)
    near = cv2.dilate(unknown.astype(np.uint8), disc_cells(BLUR_MAX / grid.resolution + 0.01))
    if not (face & (near > 0)).any():
        return 0.0
    seen = (~unknown).astype(np.uint8)  # the distance to the nearest unknown cell
    depth = cv2.distanceTransform(seen, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[face]
    depth = depth[depth <= BLUR_MAX / grid.resolution]
    return float(np.median(depth)) if len(depth) else 0.0


def sharpened(grid: OccupancyGrid) -> tuple[OccupancyGrid, int]:
    """``grid`` with the whole cells of its walls' blur taken off each side of its obstacles'
    thick parts, and how many cells that is on each side: ``floor((band - 1) / 2)`` for the
    :func:`wall_band` ``band``, when that blur is more than a laser's own
    (:data:`LASER_BLUR`). The cells taken off take the state (free or unknown) of the
    nearest cell that was not occupied; parts of obstacles the erosion would remove entirely
    (a wall a cell thick, a chair's leg) stay as they are. ``grid`` itself when nothing
    comes off.

    Examples
    --------
    >>> cells = np.full((30, 16), -1, np.int8)
    >>> cells[1:29, 1:7] = 0  # a room ...
    >>> cells[1:29, 7:11] = 100  # ... its wall four cells thick (0.2 m), unknown behind
    >>> cells[5, 3] = 100  # a chair's leg
    >>> sharp, blur = sharpened(OccupancyGrid(cells, 0.05))
    >>> blur, sharp.cells[5, 6:12].tolist(), int(sharp.cells[5, 3])
    (1, [0, 0, 100, 100, -1, -1], 100)
    >>> sharpened(sharp)[1]  # a wall two cells thick: nothing more comes off
    0
    """
    side = (wall_band(grid) - 1) / 2  # cells of blur on each side of the surface
    if side * grid.resolution <= LASER_BLUR or side < 1:
        return grid, 0
    blur = math.floor(side)
    occupied = grid.occupied
    core = ndimage.binary_erosion(occupied, _SQUARE, iterations=blur, border_value=1)
    thick = ndimage.binary_dilation(core, _SQUARE, iterations=blur)
    off = occupied & thick & ~core
    _, (rows, cols) = ndimage.distance_transform_edt(occupied, return_indices=True)
    cells = np.where(off, grid.cells[rows, cols], grid.cells).astype(np.int8)
    return OccupancyGrid(cells, grid.resolution, grid.origin), blur
