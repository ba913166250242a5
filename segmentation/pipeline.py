"""The whole map (or keyframes) -> regions pipeline, one object with its settings.

Stages, each timed in :attr:`Segmentation.seconds`:

1. ``condition``: the map's building space and its clutter (:mod:`segmentation.conditioning`).
2. ``places``: watershed basins of the clearance (:func:`segmentation.refine.basins`) measured
   in the conditioned space, where furniture does not count as wall and the gaps of straight
   walls and the mouths of halls are closed but for a hole (:func:`segmentation.walls.wall_gaps`,
   :func:`segmentation.walls.hall_mouths`); places bounded by unknown space rather than walls
   are dropped
   (:func:`~segmentation.conditioning.drop_outside`).
3. ``keyframes``: for a map alone, virtual 360 degree scans at the most open point of every
   place and on a lattice of ``spacing`` metres, simulated in the conditioned space; a robot's
   keyframes are used as they are.
4. ``spectral``: the paper's spectral partition of the keyframes
   (:class:`~segmentation.spectral.SpectralSegmenter`) on the paper's similarity weighed by
   the openness of the passages between the keyframes' places
   (:class:`~segmentation.affinity.PassageAffinity`), with the guess ``k'`` = the number of
   places, block by block on maps of more than ``block_places`` places.
5. ``regions``: the partition made dense: every place takes the cluster of most of its
   keyframes (of the keyframe nearest to it if it has none); pieces under ``min_area`` join a
   neighbour. With ``method="doors"`` (the baseline) the places are joined wherever the
   opening between them is not a door (:func:`~segmentation.refine.merge_open_boundaries`)
   instead.
6. ``cover``: every building cell gets a region (:func:`~segmentation.coverage.cover`):
   furniture, thin rays, rooms seen only through their doors; regions open to the others only
   through gaps narrower than a door join the space they open onto
   (:func:`~segmentation.pockets.join_pockets`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from maps.errors import TopomapError
from maps.grid import UNKNOWN, OccupancyGrid
from maps.limits import MAX_LENGTH, finite_in
from maps.scan import Keyframe, keyframe_list, poses_array, seeing
from maps.seeding import RandomState
from maps.sim.laser import LaserModel
from segmentation.affinity import BESIDE, PassageAffinity, standing_places
from segmentation.base import Estimator, clone
from segmentation.blocks import BlockSpectralSegmenter, check_n_jobs, keyframe_blocks
from segmentation.conditioning import ConditionedMap, condition, drop_outside
from segmentation.corridors import join_corridor_cuts
from segmentation.coverage import Coverage, cover
from segmentation.errors import ParameterError, SegmentationError
from segmentation.passages import boundary_openness
from segmentation.pockets import join_pockets
from segmentation.refine import PLACE_DEPTH, basins, count_basins, merge_open_boundaries
from segmentation.regions import CANVAS_MARGIN, Regions, consecutive, dense_labels, pieces
from segmentation.spectral import SpectralSegmenter, at_most
from segmentation.virtual import VIRTUAL_LASER, virtual_keyframes
from segmentation.walls import hall_mouths, seen_walls, wall_gaps
from segmentation.working import block_phase, pool, pool_factor, unpool

log = logging.getLogger(__name__)

#: The ways regions are made: the spectral partition (default) and the door-rule baseline.
METHODS = ("spectral", "doors")
#: The keyframe similarity of the building pipeline: the overlap of what two scans saw for
#: scans that see all around (virtual keyframes on a map), the paper's nearest neighbours for
#: narrower ones (:class:`~segmentation.similarity.ByFieldOfView`). On the ROSE² maps the view
#: gave IoU 67.9 % against 64.8 % for ``nn`` (ipa MCC 0.840 against 0.843); on 180 degree
#: CARMEN logs the online engine agreed with the offline partition at ARI 0.44-0.83 with the
#: view and 0.72-0.95 with ``nn``.
MAP_CRITERION = "auto"


@dataclass(frozen=True, eq=False)
class Segmentation:
    """What :meth:`MapSegmenter.segment` found.

    Attributes
    ----------
    conditioned
        The building space, its clutter and what was dropped.
    working
        The grid the segmentation ran on: the building space in cells of about
        ``cell_size`` metres (:func:`~segmentation.working.pool`).
    places
        Label image of the places (clearance basins) on ``working``.
    keyframes
        The keyframes (virtual ones for a map alone); those whose scan hit nothing within the
        laser's range are not clustered.
    segmenter
        The fitted spectral partition (one per block on large maps) of the keyframes that saw a
        wall (all of them, unless some scans hit nothing).
    spectral
        The spectral partition made dense and covering the building.
    regions
        The regions of the pipeline's ``method``: ``spectral`` itself by default, the door
        rule's with ``method="doors"``.
    coverage
        What covering the building added to ``regions``: cells filled, rooms seen through
        doors.
    seconds
        Time per stage.
    method
        How ``regions`` were made (:data:`METHODS`).
    """

    conditioned: ConditionedMap
    working: OccupancyGrid
    places: NDArray[np.int32]
    keyframes: list[Keyframe]
    segmenter: SpectralSegmenter | BlockSpectralSegmenter
    spectral: Regions
    regions: Regions
    coverage: Coverage
    seconds: dict[str, float]
    method: str = "spectral"

    def __repr__(self) -> str:
        return (
            f"Segmentation({len(self.regions.ids)} regions by {self.method!r}, "
            f"{len(self.keyframes)} keyframes, {self.working!r})"
        )

    def keyframe_regions(self) -> NDArray[np.int64]:
        """Region of each keyframe's position (0 if it is not on a labelled cell)."""
        poses = poses_array(self.keyframes)
        return self.regions.at_points(poses[:, 0], poses[:, 1])


@dataclass
class MapSegmenter(Estimator):
    """The map -> regions pipeline (see the module docstring), configured in metres.

    Parameters
    ----------
    spectral
        Settings of the spectral partition; its ``k``, when set, overrides the place count.
        It is cloned for each run, never fitted itself: the fitted partition is the result's
        :attr:`Segmentation.segmenter`.
    robot_radius, clutter_size, min_area
        Conditioning (:func:`~segmentation.conditioning.condition`).
    place_depth
        A place's clearance peak must rise this many metres above the passages around it.
    spacing
        Lattice step of the virtual keyframes, metres.
    cell_size
        Finer maps are segmented on cells of about this size (metres), then labelled cell by
        cell.
    method
        ``"spectral"``: the regions are the spectral partition (the paper's method, default);
        ``"doors"``: the door rule over the places (the baseline).
    contrast
        How much a narrow passage weakens the affinity of the keyframes on both sides
        (:class:`~segmentation.affinity.PassageAffinity`); 0 is the paper's affinity alone.
    block_places
        Maps with more places are partitioned block by block.
    laser
        The virtual laser.
    on_stage
        Called with each stage's name as it starts (progress for long maps).
    n_jobs
        How many blocks of a large map are partitioned at once, with joblib (see
        :class:`~segmentation.blocks.BlockSpectralSegmenter`): one at a time by default.

    Examples
    --------
    >>> import maps
    >>> plan = maps.generate_floor_plan("flat", random_state=0)
    >>> found = MapSegmenter(spectral=SpectralSegmenter(random_state=0)).segment(plan.grid)
    >>> found.regions.labels.shape == plan.grid.shape
    True
    """

    spectral: SpectralSegmenter = field(
        default_factory=lambda: SpectralSegmenter(criterion=MAP_CRITERION)
    )
    robot_radius: float = 0.2
    clutter_size: float = 2.0
    min_area: float = 1.0
    place_depth: float = PLACE_DEPTH
    spacing: float = 2.0
    cell_size: float = 0.1
    method: str = "spectral"
    contrast: float = 2.0
    block_places: int = 100
    laser: LaserModel = VIRTUAL_LASER
    on_stage: Callable[[str], None] | None = field(default=None, repr=False)
    n_jobs: int | None = None

    def _validate_params(self) -> None:
        for name in ("place_depth", "spacing", "cell_size"):
            value = getattr(self, name)
            if finite_in(value, name, 0.0, MAX_LENGTH, low_open=True) is not None:
                raise ParameterError(f"{name} must be in (0, {MAX_LENGTH:g}] metres, got {value!r}")
        if self.method not in METHODS:
            raise ParameterError(f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        if not (isinstance(self.block_places, int) and self.block_places >= 2):
            raise ParameterError(f"block_places must be an integer >= 2, got {self.block_places!r}")
        check_n_jobs(self.n_jobs)
        for name, kind in (("spectral", SpectralSegmenter), ("laser", LaserModel)):
            if not isinstance(getattr(self, name), kind):
                raise ParameterError(
                    f"{name} must be a {kind.__name__}, got {getattr(self, name)!r}"
                )
        if self.on_stage is not None and not callable(self.on_stage):
            raise ParameterError(
                f"on_stage must be a function of the stage's name or None, got {self.on_stage!r}"
            )
        self.spectral._validate_params()

    def segment(
        self,
        grid: OccupancyGrid,
        keyframes: Sequence[Keyframe] | None = None,
        *,
        random_state: RandomState = None,
    ) -> Segmentation:
        """Segment ``grid``, clustering ``keyframes`` if given (else virtual ones).

        ``random_state`` overrides the spectral settings' seed. A map on a canvas far larger
        than what it knows is segmented on its known part
        (:data:`~segmentation.regions.CANVAS_MARGIN`); the regions are of the whole map.

        Raises
        ------
        ParameterError
            A setting out of its range.
        SegmentationError
            A map with no free space the robot fits in, fewer than two of the given
            keyframes that saw a wall (none of the virtual ones: every place gets one, so
            one is a map of one place, one region), or keyframes none of which stands in or
            beside that space (another frame).
        """
        self._validate_params()
        if not isinstance(grid, OccupancyGrid):
            raise ParameterError(
                "the map must be an OccupancyGrid (OccupancyGrid.load('map.yaml')), got "
                f"{type(grid).__name__}"
            )
        rows, cols = grid.known_box(CANVAS_MARGIN)
        if (rows.stop - rows.start, cols.stop - cols.start) == grid.shape:
            return self._segment(grid, keyframes, random_state)
        found = self._segment(grid.cropped(rows, cols), keyframes, random_state)
        return _embedded(found, grid, rows, cols)

    def _segment(
        self,
        grid: OccupancyGrid,
        keyframes: Sequence[Keyframe] | None,
        random_state: RandomState,
    ) -> Segmentation:
        """:meth:`segment` of ``grid`` as given (the map's known part)."""
        seconds: dict[str, float] = {}
        clock = [time.perf_counter()]

        def stage(name: str) -> None:
            log.info("stage %s", name)
            if self.on_stage is not None:
                try:
                    self.on_stage(name)
                except TopomapError:
                    raise
                except Exception as err:  # the user's callback: named, as a criterion is
                    raise ParameterError(
                        f"on_stage raised {type(err).__name__} at stage {name!r}: {err}"
                    ) from err

        def lap(name: str) -> None:
            now = time.perf_counter()
            seconds[name] = now - clock[0]
            clock[0] = now

        spectral = clone(self.spectral)
        if random_state is not None:
            spectral.random_state = random_state
        stage("condition")
        conditioned = self.condition(grid)
        factor = pool_factor(grid.resolution, self.cell_size)
        phase = block_phase(conditioned.space, factor)
        lap("condition")
        stage("places")
        conditioned, space, places = self._places(conditioned, phase)
        lap("places")
        # every place gets a virtual keyframe: one is a map of one place, one region
        needed = 2 if keyframes is not None else 1
        if keyframes is None:
            stage("keyframes")
            keyframes = virtual_keyframes(
                space,
                self.spacing,
                model=self.laser,
                min_clearance=self.robot_radius,
                places=places,
                random_state=spectral.random_state,
            )
            lap("keyframes")
        keyframes = keyframe_list(keyframes)
        stage("spectral")
        seen = seeing(keyframes)  # a scan that hit nothing: no place
        if len(seen) < needed:
            raise SegmentationError(
                f"{len(seen)} of {len(keyframes)} keyframes saw a wall within their laser's "
                f"range: at least {needed} {'are' if needed > 1 else 'is'} needed to cluster"
            )
        if len(seen) < len(keyframes):
            log.info("%d keyframes saw no wall and are not clustered", len(keyframes) - len(seen))
        poses = poses_array(seen)
        rows, cols = space.world_to_cell(poses[:, 0], poses[:, 1])
        if not space.contains(rows, cols).any():
            x0, y0, x1, y1 = grid.bounds()
            raise SegmentationError(
                f"none of the {len(seen)} keyframes stands on the map (x {x0:.6g}..{x1:.6g}, "
                f"y {y0:.6g}..{y1:.6g} m; the first at ({poses[0, 0]:.6g}, {poses[0, 1]:.6g})): "
                "the keyframes and the map are in different frames"
            )
        standing = standing_places(space, places, poses)
        if not standing.any():
            raise SegmentationError(
                f"none of the {len(seen)} keyframes stands within {BESIDE} m of the space "
                "a robot fits in: the keyframes and the map are in different frames"
            )
        fitted = self.partition(space, places, seen, spectral)
        lap("spectral")
        stage("regions")
        if self.spectral.k is None:  # the places vote: regions are whole places
            voted = to_open_neighbours(space, places, by_place(places, standing, fitted.labels_))
            dense = pieces(space, voted, self.min_area, claim_unlabelled=False)
        else:  # the user's k: the clusters decide, a place split between them if need be
            dense = dense_labels(space, rows, cols, fitted.labels_, min_area=self.min_area)
        if self.method == "doors":
            doors = pieces(space, merge_open_boundaries(space, places, places), self.min_area)
        lap("regions")
        stage("cover")
        covered = self._cover(conditioned, unpool(dense, factor, conditioned.free, phase), grid)
        spectral_regions = regions = Regions(grid, covered.labels)
        if self.method == "doors":
            covered = self._cover(conditioned, unpool(doors, factor, conditioned.free, phase), grid)
            regions = Regions(grid, covered.labels)
        lap("cover")
        conditioned = replace(conditioned, free=conditioned.free & grid.free)
        conditioned = _count_unlabelled(conditioned, regions.labels)
        return Segmentation(
            conditioned,
            space,
            places,
            keyframes,
            fitted,
            spectral_regions,
            regions,
            covered,
            seconds,
            self.method,
        )

    def condition(self, grid: OccupancyGrid) -> ConditionedMap:
        """Stage ``condition``: the building space and its clutter.

        Raises
        ------
        SegmentationError
            No free space the robot fits in (:class:`ParameterError`: a setting out of range).
        """
        self._validate_params()
        conditioned = condition(grid, self.robot_radius, self.clutter_size, self.min_area)
        if not conditioned.free.any():
            counts = ", ".join(
                f"{name.removesuffix('_cells').replace('_', ' ')} {count}"
                for name, count in conditioned.summary().items()
            )
            raise SegmentationError(
                "the map has no free space a robot of radius "
                f"{self.robot_radius} m fits in (cells: {counts})"
            )
        return conditioned

    def places(
        self, conditioned: ConditionedMap
    ) -> tuple[ConditionedMap, OccupancyGrid, NDArray[np.int32]]:
        """Stage ``places``: the clearance basins of the building space, in cells of about
        ``cell_size``, those bounded by unknown space dropped; returns the conditioned map
        without them, the working grid and the places on it.

        The gaps of straight walls (:func:`~segmentation.walls.wall_gaps` of the walls the
        map shows, :func:`~segmentation.walls.seen_walls`) are wall on the working grid:
        places, keyframes and passages end at them like at a wall with a door; so are the
        mouths of halls (:func:`~segmentation.walls.hall_mouths`), which part the place of
        the hall and the corridors that enter it (:meth:`_basins`); when places
        bounded by unknown space are dropped (fans of rays), the walls between what is left
        are found again. The cover gives their cells a region. Basins that meet at a cut
        across a corridor are one place (:func:`~segmentation.corridors.join_corridor_cuts`).
        The working grid's blocks fall where the building's space keeps the most of them whole
        (:func:`~segmentation.working.block_phase`), so a map one cell over gives the same."""
        factor = pool_factor(conditioned.grid.resolution, self.cell_size)
        return self._places(conditioned, block_phase(conditioned.space, factor))

    def _places(
        self, conditioned: ConditionedMap, phase: tuple[int, int]
    ) -> tuple[ConditionedMap, OccupancyGrid, NDArray[np.int32]]:
        """:meth:`places` on working blocks laid with ``phase`` (:func:`pool`)."""
        grid = conditioned.grid
        factor = pool_factor(grid.resolution, self.cell_size)
        walls = seen_walls(grid, conditioned.space, conditioned.clutter)
        closed = _closures(walls, conditioned.space, grid.resolution)  # on the map's cells
        space, places, joined = self._basins(grid, conditioned.space, closed, factor, phase)
        outside = drop_outside(conditioned, unpool(places, factor, conditioned.space, phase))
        if outside is not conditioned:
            conditioned = outside
            kept = seen_walls(grid, conditioned.space, conditioned.clutter)
            if bool((kept != walls).any()):  # strips between fans of rays: no walls
                closed = _closures(kept, conditioned.space, grid.resolution)
                space, places, joined = self._basins(grid, conditioned.space, closed, factor, phase)
            else:
                space = pool(
                    conditioned.space & ~closed[1], grid, factor, fine_clearance=True, phase=phase
                )
                places = consecutive(np.where(space.free, places, 0))
        return conditioned, space, places if joined else join_corridor_cuts(places, space)

    def _basins(
        self,
        grid: OccupancyGrid,
        building: NDArray[np.bool_],
        closed: tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]],
        factor: int,
        phase: tuple[int, int],
    ) -> tuple[OccupancyGrid, NDArray[np.int32], bool]:
        """The working grid of the ``building``'s space (the map ``grid``'s cells) with the
        ``closed`` cells (:func:`_closures`) shut, its places, and whether they are joined
        across corridor cuts already: the clearance basins (not joined); where a hall's mouth
        was found, those of the space with the mouths open, joined across the corridors' cuts
        (:func:`join_corridor_cuts`: the corridors that enter the hall meet there, so a
        corridor that runs past the mouth stays one place) and parted along the mouths' lines
        (:func:`parted`; a cut across a mouth's hole is narrower than a corridor, so joining
        again would change nothing)."""
        gaps, shut, cut = closed
        if not cut.any():
            space = pool(building & ~shut, grid, factor, fine_clearance=True, phase=phase)
            return space, basins(space, self.place_depth), False
        # the space with the mouths shut pooled beside the places of the space with them open
        with ThreadPoolExecutor(1, "pool") as beside:
            shut_space = beside.submit(
                pool, building & ~shut, grid, factor, fine_clearance=True, phase=phase
            )
            opened = pool(building & ~gaps, grid, factor, fine_clearance=True, phase=phase)
            joined = join_corridor_cuts(basins(opened, self.place_depth), opened)
            whole = pool(building & ~gaps & ~cut, grid, factor, phase=phase).free
            space = shut_space.result()
        return space, parted(joined, whole, space.free), True

    def partition(
        self,
        space: OccupancyGrid,
        places: NDArray[np.int32],
        keyframes: list[Keyframe],
        spectral: SpectralSegmenter,
    ) -> SpectralSegmenter | BlockSpectralSegmenter:
        """Stage ``spectral``: the spectral partition of ``keyframes`` (each of which saw a
        wall) on ``spectral``'s similarity weighed by the passages between their places."""
        spectral = clone(
            spectral, criterion=PassageAffinity(space, places, spectral.criterion, self.contrast)
        )
        if spectral.k is not None:  # the user's k: the partition must be able to reach it
            return clone(spectral, connected=True).fit(keyframes)
        count = count_basins(space, places, self.min_area)
        if count > self.block_places:
            blocks, per_block = keyframe_blocks(space, places, keyframes, self.block_places)
            return BlockSpectralSegmenter(spectral, blocks, per_block, self.n_jobs).fit(keyframes)
        return at_most(spectral, min(len(keyframes), count)).fit(keyframes)

    def _cover(
        self, conditioned: ConditionedMap, labels: NDArray[np.int32], grid: OccupancyGrid
    ) -> Coverage:
        """``labels`` over the building (:func:`cover`), pockets joined; the wall cells of
        ``grid``, the map as given, stay without a region where its blur was taken off."""
        covered = cover(conditioned.grid, labels, conditioned.clutter, min_area=self.min_area)
        # the partition's regions, not the rooms the cover saw through doors
        robot_regions = set(np.flatnonzero(np.bincount(covered.labels[labels > 0])).tolist())
        joined, pockets = join_pockets(
            conditioned.grid, covered.labels, robot_regions, robot_radius=self.robot_radius
        )
        if conditioned.blur:
            joined = consecutive(np.where(grid.occupied & ~conditioned.clutter, 0, joined))
        return replace(covered, labels=joined, pockets=pockets)


def _closures(
    walls: NDArray[np.bool_], space: NDArray[np.bool_], resolution: float
) -> tuple[NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
    """The cells of the robot's ``space`` that close the gaps of straight walls
    (:func:`wall_gaps`); those and the ones that close the mouths of halls but for a hole
    (:func:`hall_mouths`, found with the gaps closed); the mouths' whole lines."""
    gaps = wall_gaps(walls, space, resolution)
    mouths, lines = hall_mouths(walls, space & ~gaps, resolution)
    return gaps, gaps | mouths, lines


def _embedded(found: Segmentation, grid: OccupancyGrid, rows: slice, cols: slice) -> Segmentation:
    """``found``, the segmentation of ``grid``'s cells ``rows`` x ``cols``, on the whole of
    ``grid``: its map-sized arrays put back in place, nothing (unknown space) round them; the
    working grid and the places keep their own frame."""

    def whole(part: NDArray[Any], fill: Any = 0) -> NDArray[Any]:
        out = np.full(grid.shape, fill, part.dtype)
        out[rows, cols] = part
        return out

    conditioned = found.conditioned
    sharp = grid
    if conditioned.blur:  # the walls' blur was taken off: the whole map with it off
        sharp = OccupancyGrid(whole(conditioned.grid.cells, UNKNOWN), grid.resolution, grid.origin)
    conditioned = replace(
        conditioned,
        grid=sharp,
        space=whole(conditioned.space),
        free=whole(conditioned.free),
        clutter=whole(conditioned.clutter),
    )
    spectral = Regions(grid, whole(found.spectral.labels))
    regions = (
        spectral if found.regions is found.spectral else Regions(grid, whole(found.regions.labels))
    )
    coverage = replace(found.coverage, labels=whole(found.coverage.labels))
    return replace(
        found, conditioned=conditioned, spectral=spectral, regions=regions, coverage=coverage
    )


def parted(
    places: NDArray[np.int32], whole: NDArray[np.bool_], free: NDArray[np.bool_]
) -> NDArray[np.int32]:
    """``places`` parted into their pieces (4-connected) on the ``whole`` cells, on the
    ``free`` cells; the free cells off ``whole`` take the nearest piece's label. Only the
    places that reach off ``whole`` are looked at, in the box round them (a campus's few
    mouths, not its whole map).

    Examples
    --------
    >>> places = np.ones((3, 7), np.int32)
    >>> whole = np.ones((3, 7), bool)
    >>> whole[:, 3] = False  # a line across the place
    >>> parted(places, whole, np.ones((3, 7), bool)).tolist()[0]
    [1, 1, 1, 1, 2, 2, 2]
    """
    crossed = np.unique(places[(places > 0) & ~whole])
    if len(crossed) == 0:
        return consecutive(np.where(free, places, 0))
    rows, columns = np.nonzero(np.isin(places, crossed))
    reach = 8  # cells round them: the nearest piece of a cell on the line lies within
    box = (
        slice(max(int(rows.min()) - reach, 0), int(rows.max()) + reach + 1),
        slice(max(int(columns.min()) - reach, 0), int(columns.max()) + reach + 1),
    )
    inside = places[box]
    mine = np.isin(inside, crossed)
    parts, count = ndimage.label(whole[box] & mine)
    keyed = places.astype(np.int64) * (count + 1)  # pieces in the order of their places
    keyed[box] = np.where(mine, np.where(parts > 0, inside * (count + 1) + parts, 0), keyed[box])
    labels = consecutive(keyed)
    near = labels[box]
    missing = free[box] & (near == 0)
    if missing.any() and near.any():
        _, (at_row, at_column) = ndimage.distance_transform_edt(near == 0, return_indices=True)
        labels[box] = np.where(missing, near[at_row, at_column], near)
    return consecutive(np.where(free, labels, 0))


def by_place(
    places: NDArray[np.integer],
    keyframe_places: NDArray[np.integer],
    keyframe_labels: NDArray[np.integer],
) -> NDArray[np.int32]:
    """Each of ``places`` labelled with the cluster (``+ 1``) of most of the keyframes that
    stand in it (``keyframe_places``, 0: none, :func:`~segmentation.affinity.standing_places`);
    0 for a place no keyframe stands in, which the partition says nothing about (in a robot's
    log: part of a room behind its furniture, a room seen through its door;
    :func:`to_open_neighbours` gives it a region).

    Examples
    --------
    >>> places = np.array([[1, 1, 2, 2, 3]])
    >>> by_place(places, np.array([1, 1, 2, 0]), np.array([4, 4, 7, 9])).tolist()
    [[5, 5, 8, 8, 0]]
    """
    count = int(places.max(initial=0)) + 1
    on = keyframe_places > 0
    winner = np.zeros(count, np.int64)
    if on.any():
        pair, votes = np.unique(
            np.stack([keyframe_places[on], keyframe_labels[on] + 1]), axis=1, return_counts=True
        )
        order = np.lexsort((votes, pair[0]))  # per place, the most votes last
        winner[pair[0, order]] = pair[1, order]
    return winner[places].astype(np.int32)


def to_open_neighbours(
    grid: OccupancyGrid, places: NDArray[np.integer], voted: NDArray[np.int32]
) -> NDArray[np.int32]:
    """``voted`` (the places' clusters, :func:`by_place`) with every place no keyframe stands
    in (0) given whole to the voted place it opens onto most widely (the most open boundary,
    :func:`~segmentation.passages.boundary_openness`), through other such places if need be:
    part of a room behind its furniture joins the room, a room the robot only looked into the
    space it was seen from. Places that reach no voted place stay 0.

    Examples
    --------
    >>> free = np.ones((4, 12), bool)
    >>> free[:, 4] = free[:, 8] = False
    >>> free[1:3, 4] = True  # places 1 | 2 | 3, a narrow door between 1 and 2, a wide one ...
    >>> free[:, 8] = True  # ... between 2 and 3
    >>> places = np.array([[1] * 4 + [1] + [2] * 3 + [3] * 4] * 4) * free
    >>> voted = np.where(places == 2, 0, places * 10)
    >>> to_open_neighbours(OccupancyGrid.from_masks(free, 0.1), places, voted)[0].tolist()
    [10, 10, 10, 10, 0, 30, 30, 30, 30, 30, 30, 30]
    """
    count = int(places.max(initial=0)) + 1
    winner = np.zeros(count, np.int64)
    winner[places[places > 0]] = voted[places > 0]
    if winner[1:].all() or not winner.any():
        return voted
    a, b, openness = boundary_openness(grid, places)
    order = np.argsort(-openness, kind="stable")
    a, b = a[order], b[order]
    while True:
        reach = (winner[a] > 0) != (winner[b] > 0)
        if not reach.any():
            break
        first = int(np.argmax(reach))  # the most open boundary between voted and not
        target, source = (b[first], a[first]) if winner[a[first]] else (a[first], b[first])
        winner[target] = winner[source]
    return np.where(places > 0, winner[places], 0).astype(np.int32)


def _count_unlabelled(conditioned: ConditionedMap, labels: NDArray[np.integer]) -> ConditionedMap:
    """``conditioned`` with the kept cells that got no region (a piece too small once pooled,
    which no region reaches without crossing a wall) counted as dropped islands."""
    left = conditioned.free & (labels == 0)
    if not left.any():
        return conditioned
    dropped = {**conditioned.dropped, "islands": conditioned.dropped["islands"] + int(left.sum())}
    return replace(conditioned, free=conditioned.free & ~left, dropped=dropped)
