"""The :class:`TopoMap` facade: keyframes or a map in, regions and their graph out."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.grid import OccupancyGrid
from maps.limits import MAX_ROBOT_RADIUS, finite_in
from maps.mapping import grid_from_keyframes
from maps.scan import Keyframe, keyframe_list
from maps.seeding import RandomState
from segmentation.blocks import BlockSpectralSegmenter
from segmentation.conditioning import ConditionedMap
from segmentation.errors import ParameterError, SegmentationError
from segmentation.graph import region_graph
from segmentation.pipeline import MAP_CRITERION, MapSegmenter, Segmentation
from segmentation.regions import Regions
from segmentation.spectral import SpectralSegmenter
from topomap import saving
from topomap.features import region_features
from topomap.labels import Classifier, carry_names, find_region, label_graph, rename
from topomap.saving import SavedPartition

if TYPE_CHECKING:
    from maps.registration import Placement
    from planners.hierarchical import HierarchicalPlanner
    from planners.kinematic_hierarchical import KinematicHierarchicalPlanner
    from planners.path import PlannedPath
    from planners.region_route import RegionRoute
    from planners.robots import Footprint, Robot

#: The disc robot's radius, metres, when none is given: the one whose planner is saved.
DEFAULT_RADIUS = 0.2
_PIPELINE = set(MapSegmenter().get_params(deep=False)) - {"spectral"}
_SPECTRAL = set(SpectralSegmenter().get_params(deep=False))


def pipeline_from_options(options: dict[str, Any]) -> MapSegmenter:
    """A :class:`~segmentation.pipeline.MapSegmenter` from flat keyword options: those of the
    pipeline (``robot_radius``, ``spacing``, ``refine`` ...) and of its
    :class:`~segmentation.spectral.SpectralSegmenter` (``criterion``, ``k``, ``p`` ...).

    Examples
    --------
    >>> pipeline_from_options({"robot_radius": 0.3, "k": 4}).spectral.k
    4
    """
    unknown = set(options) - _PIPELINE - _SPECTRAL
    if unknown:
        raise ParameterError(
            f"unknown segmentation option(s) {sorted(unknown)}; known: "
            f"{sorted(_PIPELINE | _SPECTRAL)}"
        )
    spectral_options = {k: v for k, v in options.items() if k in _SPECTRAL}
    if spectral_options.get("criterion") is None:
        spectral_options["criterion"] = MAP_CRITERION
    spectral = SpectralSegmenter(**spectral_options)
    return MapSegmenter(spectral, **{k: v for k, v in options.items() if k in _PIPELINE})


def _pipeline(pipeline: MapSegmenter | None, options: dict[str, Any]) -> MapSegmenter:
    if pipeline is not None and options:
        raise ParameterError(
            f"give a pipeline or segmentation options, not both (got {sorted(options)})"
        )
    if pipeline is not None and not isinstance(pipeline, MapSegmenter):
        raise ParameterError(f"pipeline must be a MapSegmenter, got {pipeline!r:.80}")
    return pipeline or pipeline_from_options(options)


@dataclass
class TopoMap:
    """A map segmented into regions, with the region adjacency graph.

    Build one with :meth:`from_grid` (a map only: virtual keyframes are simulated) or
    :meth:`from_keyframes` (a robot's keyframes); both run a
    :class:`~segmentation.pipeline.MapSegmenter`.

    Attributes
    ----------
    grid
        The occupancy map.
    regions
        The regions: the spectral partition covering the building (the door-rule baseline's
        with ``method="doors"``).
    segmentation
        Everything the pipeline found: the conditioned map, places, keyframes, the fitted
        spectral partition, the regions, what covering added, seconds per stage; None for a
        map read back with :meth:`load` (the regions, the graph and the partition's labels
        are saved, not the keyframes' scans).
    graph
        Region adjacency graph of :attr:`regions` (see :func:`segmentation.graph.region_graph`).
    seconds
        Time per stage, the graph and labels included.
    method
        How the regions were made: ``"spectral"`` or ``"doors"``.
    partition
        For a map read back with :meth:`load`: the saved partition (:attr:`segmenter`).
    next_id
        The lowest id no region of this map had, nor of the maps :meth:`update` made it from.
    changes
        For a map made by :meth:`update`: what happened to each region (the events of
        :func:`segmentation.growing.carry_ids`).
    placement
        For a map made by :meth:`update`: where the previous map lay on this one
        (:class:`maps.registration.Placement`).
    source
        For a map read back with :meth:`load`: the folder, where :meth:`planner` finds the
        prepared door graphs saved with it.
    """

    grid: OccupancyGrid
    regions: Regions
    graph: nx.Graph
    segmentation: Segmentation | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    method: str = "spectral"
    partition: SavedPartition | None = None
    next_id: int = 0
    changes: list[dict[str, Any]] = field(default_factory=list)
    placement: Placement | None = None
    source: Path | None = field(default=None, compare=False)
    _planners: dict[float, HierarchicalPlanner] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _kinematic: dict[tuple, KinematicHierarchicalPlanner] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    @classmethod
    def from_grid(
        cls,
        grid: OccupancyGrid,
        *,
        random_state: RandomState = 0,
        pipeline: MapSegmenter | None = None,
        **options: Any,
    ) -> TopoMap:
        """Segment a map alone: virtual keyframes are simulated in it.

        ``options`` are those of :func:`pipeline_from_options` (or give ``pipeline``).
        """
        pipeline = _pipeline(pipeline, options)
        found = pipeline.segment(grid, random_state=random_state)
        return cls._build(grid, found, pipeline)

    @classmethod
    def from_keyframes(
        cls,
        keyframes: Sequence[Keyframe],
        grid: OccupancyGrid | None = None,
        *,
        resolution: float = 0.05,
        random_state: RandomState = 0,
        pipeline: MapSegmenter | None = None,
        **options: Any,
    ) -> TopoMap:
        """Segment a robot's keyframes; the map is built from them unless ``grid`` is given.
        Options as for :meth:`from_grid`."""
        pipeline = _pipeline(pipeline, options)
        keyframes = keyframe_list(keyframes)
        start = time.perf_counter()
        built = grid is None
        grid = grid_from_keyframes(keyframes, resolution) if grid is None else grid
        mapped = time.perf_counter() - start
        found = pipeline.segment(grid, keyframes, random_state=random_state)
        topo = cls._build(grid, found, pipeline)
        if built:
            topo.seconds = {"map": mapped, **topo.seconds}
        return topo

    def update(
        self,
        grid: OccupancyGrid,
        keyframes: Sequence[Keyframe] | None = None,
        *,
        aligned: bool = False,
        random_state: RandomState = 0,
        pipeline: MapSegmenter | None = None,
        **options: Any,
    ) -> TopoMap:
        """Segment a later, larger map of the same building; regions that continue one of
        this map's keep its id, and its name when their label is the same
        (:mod:`segmentation.growing`). This map is laid where its walls fit the new map's
        best (a shift and a turn within 10 degrees, :attr:`placement` of the result), unless
        ``aligned`` says the two share their frame. Options as for :meth:`from_grid`.

        Raises
        ------
        MapMismatchError
            ``grid`` is not a map of this building (:func:`segmentation.growing.lay`: even
            laid where it fits best, less than half of this map's free cells free in it, or
            more than half of its walls in its free space).
        """
        if not isinstance(grid, OccupancyGrid):
            raise ParameterError(
                f"update takes the new map as an OccupancyGrid, got a {type(grid).__name__}"
            )
        if not isinstance(aligned, bool):  # "no" is truthy: the search skipped
            raise ParameterError(f"aligned must be True or False, got {aligned!r:.80}")
        # imported here: only an update lays one map on another (the registration's FFT)
        from segmentation.growing import align, carry_ids, lay

        placement = lay(self.grid, grid, aligned=aligned)
        previous = align(placement.moved(self.grid), self.regions.labels, grid)
        pipeline = _pipeline(pipeline, options)
        found = pipeline.segment(grid, keyframes, random_state=random_state)
        carried = carry_ids(previous, found.regions.labels, self.next_id or None)
        regions = Regions(grid, carried.labels)
        same = found.spectral is found.regions
        found = replace(found, regions=regions, spectral=regions if same else found.spectral)
        topo = self._build(grid, found, pipeline)
        topo.next_id, topo.changes, topo.placement = carried.next_id, carried.events, placement
        carry_names(topo.graph, self.graph)
        return topo

    @classmethod
    def _build(cls, grid: OccupancyGrid, found: Segmentation, pipeline: MapSegmenter) -> TopoMap:
        seconds = dict(found.seconds)
        stage = pipeline.on_stage or (lambda name: None)
        stage("graph")
        start = time.perf_counter()
        # doors are where the robot the map is segmented for crosses (its planner's free space)
        width = 2 * pipeline.robot_radius
        graph = region_graph(found.regions, found.keyframe_regions(), min_width=width)
        seconds["graph"] = time.perf_counter() - start
        next_id = max(found.regions.ids, default=0) + 1
        topo = cls(grid, found.regions, graph, found, seconds, found.method, next_id=next_id)
        stage("labels")
        start = time.perf_counter()
        topo.label()
        seconds["labels"] = time.perf_counter() - start
        return topo

    def __repr__(self) -> str:
        """One line: the regions, the doors and the map.

        Examples
        --------
        >>> import maps
        >>> TopoMap.from_grid(maps.generate_floor_plan("flat", random_state=0).grid)
        ... # doctest: +ELLIPSIS
        TopoMap(... regions, ... doors by 'spectral' on OccupancyGrid(420 x 320 cells of 0.05 m...))
        """
        doors = sum(len(d) for _, _, d in self.graph.edges(data="doors"))
        return (
            f"TopoMap({self.graph.number_of_nodes()} regions, {doors} doors by "
            f"{self.method!r} on {self.grid!r})"
        )

    @property
    def found(self) -> Segmentation:
        """:attr:`segmentation`, or a clear error for a map read back with :meth:`load`."""
        if self.segmentation is None:
            raise SegmentationError(
                "this map was read back from files, which keep the regions and the graph, not "
                "the keyframes or the spectral partition: segment the map again for those"
            )
        return self.segmentation

    @property
    def spectral(self) -> Regions:
        """The spectral partition made dense (the regions themselves unless they were made by
        the door-rule baseline, ``method="doors"``)."""
        if self.segmentation is None and self.method == "spectral":
            return self.regions
        return self.found.spectral

    @property
    def keyframes(self) -> list[Keyframe]:
        """The keyframes that were clustered (virtual ones for a map alone)."""
        return self.found.keyframes

    @property
    def segmenter(self) -> SpectralSegmenter | BlockSpectralSegmenter | SavedPartition:
        """The fitted spectral partition (for a map read back with :meth:`load`, its labels,
        cluster count and silhouette by k)."""
        if self.segmentation is None and self.partition is not None:
            return self.partition
        return self.found.segmenter

    @property
    def conditioned(self) -> ConditionedMap:
        """The building space, clutter and dropped cells (see :mod:`segmentation.conditioning`)."""
        return self.found.conditioned

    def region_at(self, x: float, y: float) -> int:
        """The region id at map point ``(x, y)``, 0 if none."""
        return self.regions.at(x, y)

    def label(self, classifier: Classifier | None = None) -> dict[int, str]:
        """Label every region with a place type and give it a unique name ("corridor 1"),
        stored as the graph nodes' ``label`` and ``name`` (and so in every export).

        Parameters
        ----------
        classifier
            A function of the :meth:`feature_table`, or a fitted estimator with ``predict``
            (given :func:`~topomap.features.feature_matrix` of it);
            :data:`~topomap.classifiers.rule_classifier` by default. Names given with
            :meth:`rename` stay.

        Returns
        -------
        dict
            Region id -> label.
        """
        return label_graph(self.regions, self.graph, classifier)

    def feature_table(self) -> dict[str, NDArray[np.float64]]:
        """The table a classifier receives: ``"id"`` and the columns of
        :data:`~topomap.features.FEATURES` (units in :data:`~topomap.features.FEATURE_UNITS`),
        one value per region in ascending id order, and ``"links"`` (not a feature: a row
        ``(region a, region b, widest opening m)`` per edge of the region graph)."""
        return region_features(self.regions, self.graph)

    def region(self, query: int | str) -> int:
        """Region id of a region id or name ("hall 1", "aisle 2"), as every query takes them
        (:func:`segmentation.names.find_region`); the error lists the names."""
        return find_region(self.graph, query)

    def rename(self, region: int | str, name: str) -> None:
        """Rename a region (by id or name); a name already taken is refused, nothing changes."""
        rename(self.graph, region, name)

    def planner(self, robot_radius: float = DEFAULT_RADIUS) -> HierarchicalPlanner:
        """The hierarchical planner (:class:`~planners.hierarchical.HierarchicalPlanner`) on
        this map for a disc robot of ``robot_radius`` metres, made once per radius and kept;
        for a map read back with :meth:`load`, with the door graph saved with it when there
        is one for this map, these regions and this radius (:func:`topomap.saving.planner`)."""
        problem = finite_in(robot_radius, "robot_radius", 0.0, MAX_ROBOT_RADIUS, low_open=True)
        if problem is not None:  # before it is a key: a list is no radius
            raise ParameterError(problem)
        if robot_radius not in self._planners:
            self._planners[robot_radius] = saving.planner(self, robot_radius)
        return self._planners[robot_radius]

    def kinematic_planner(
        self, robot: str | Footprint, **options: Any
    ) -> KinematicHierarchicalPlanner:
        """The hierarchical planner with OMPL inside submaps for a footprint robot: a spec
        (``"rect:0.9x0.6"``, ``"dubins:radius=1,footprint=0.9x0.6"``,
        ``"reeds-shepp:radius=1,footprint=0.9x0.6"``) or a :mod:`planners.robots` model;
        made once per spec and kept. ``options`` go to
        :class:`~planners.kinematic_hierarchical.KinematicHierarchicalPlanner`.

        Raises
        ------
        RobotSpecError
            A spec that cannot be read, or a disc (:meth:`planner` plans for discs).
        PlannerParameterError, RandomStateError
            An option it does not take or that makes no sense
            (:func:`~planners.kinematic_hierarchical.check_options`).
        """
        from planners.cspace import HeadingCSpace
        from planners.kinematic_hierarchical import KinematicHierarchicalPlanner, check_options
        from planners.robots import Footprint, RobotSpecError, parse_robot

        model = parse_robot(robot)
        if not isinstance(model, Footprint):
            raise RobotSpecError(f"robot {robot!r} is a disc: use planner(robot_radius)")
        check_options(**options)  # before they are a key: a list is no option
        key = (robot if isinstance(robot, str) else id(robot), tuple(sorted(options.items())))
        if key not in self._kinematic:
            known = self.regions.known_part()  # as :meth:`planner`
            self._kinematic[key] = KinematicHierarchicalPlanner(
                HeadingCSpace(known.grid, model), known.labels, self.graph, **options
            )
        return self._kinematic[key]

    def route(
        self,
        source: int | str,
        target: int | str,
        *,
        robot_radius: float = DEFAULT_RADIUS,
        closed: Iterable[tuple[int, int]] = (),
    ) -> RegionRoute:
        """The regions and doors from ``source`` to ``target`` (region ids or names) for a
        disc of ``robot_radius`` metres (through doors wider than it), not through the doors
        between the ``closed`` region pairs: a topological route, no geometry
        (:func:`planners.region_route.region_route`)."""
        from planners.region_route import region_route

        return region_route(self.graph, source, target, closed=closed, min_width=2 * robot_radius)

    def to_nav2_route(self, robot_radius: float = 0.2) -> dict[str, Any]:
        """The building's route graph for a disc of ``robot_radius`` metres as a nav2_route
        GeoJSON dict (:func:`planners.route_graph.building_route_graph`; ``topomap export
        --nav2-route`` writes it to a file)."""
        from planners.nav2_route import route_geojson
        from planners.route_graph import building_route_graph

        return route_geojson(building_route_graph(self.planner(robot_radius)))

    def to_rosbag(self, path: str | Path, **options: Any) -> Path:
        """Write the map, regions, markers, route graph and ``paths`` as a ROS 2 bag folder
        for RViz and Foxglove (:func:`topomap.rosbag_export.write_rosbag`, its options:
        ``storage="mcap"`` or ``"sqlite3"``, ``paths``, ``robot_radius``, ``stamp``,
        ``overwrite``)."""
        from topomap.rosbag_export import write_rosbag

        return write_rosbag(self, path, **options)

    def plan(
        self,
        start: ArrayLike | int | str,
        goal: ArrayLike | int | str,
        *,
        robot_radius: float = 0.2,
        robot: str | Robot | None = None,
    ) -> PlannedPath:
        """Plan from ``start`` to ``goal``, each a point, a pose ``(x, y, yaw)`` for a
        footprint robot, or a region (an id or a name, as :meth:`region` and :meth:`route`
        take them: its most open point): with :meth:`planner` for a disc of ``robot_radius``
        (``robot`` None, a :class:`~planners.robots.Disc` or ``"disc:R"``), with
        :meth:`kinematic_planner` for a footprint robot."""
        from planners.robots import Disc, parse_robot

        model = None if robot is None else parse_robot(robot)
        if model is None or isinstance(model, Disc):
            radius = robot_radius if model is None else model.radius
            return self.planner(radius).plan(start, goal)
        return self.kinematic_planner(robot if isinstance(robot, str) else model).plan(start, goal)

    def keyframe_regions(self) -> NDArray[np.int64]:
        """Region of each keyframe's position (0 if it is not on a labelled cell)."""
        return self.found.keyframe_regions()

    def save(
        self,
        out: str | Path,
        *,
        overwrite: bool = False,
        door_graphs: Iterable[float] | None = None,
        progress: Callable[[list[int]], Iterable[int]] = iter,
    ) -> list[Path]:
        """Write everything needed to go on with this map into folder ``out``
        (:func:`topomap.saving.save`); read it back with :meth:`load`. The prepared planners
        for the robot radii ``door_graphs`` are saved too (by default those of the
        :meth:`planner` made so far), prepared now if they were not (the parts passed
        through ``progress``; :func:`topomap.saving.save_door_graph` adds one later)."""
        radii = list(self._planners) if door_graphs is None else door_graphs
        return saving.save(self, out, overwrite=overwrite, door_graphs=radii, progress=progress)

    @classmethod
    def load(cls, folder: str | Path) -> TopoMap:
        """Read a folder written by :meth:`save` (:func:`topomap.saving.load`)."""
        return cls(**vars(saving.load(folder)), source=Path(folder))

    def save_keyframes(self, path: str | Path, *, overwrite: bool = False) -> Path:
        """Write ``scan_index,x,y,theta,region``, one row per keyframe."""
        return saving.save_keyframes(
            self.keyframes, self.keyframe_regions(), path, overwrite=overwrite
        )
