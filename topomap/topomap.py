"""The :class:`TopoMap` facade: keyframes or a map in, regions and their graph out."""

from __future__ import annotations

import csv
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import Keyframe
from maps.seeding import RandomState
from segmentation.blocks import BlockSpectralSegmenter
from segmentation.conditioning import ConditionedMap
from segmentation.errors import ParameterError
from segmentation.export import write_geojson, write_graphml, write_label_image, write_node_link
from segmentation.graph import region_graph
from segmentation.pipeline import MapSegmenter, Segmentation
from segmentation.regions import Regions
from segmentation.spectral import SpectralSegmenter
from topomap.labels import (
    Classifier,
    classify,
    find_region,
    name_regions,
    region_features,
    rename,
)

if TYPE_CHECKING:
    from planners.hierarchical import HierarchicalPlanner
    from planners.path import Path as PlannedPath

_PIPELINE = {f.name for f in fields(MapSegmenter) if f.init and f.name != "spectral"}
_SPECTRAL = {f.name for f in fields(SpectralSegmenter) if f.init}


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
    spectral = SpectralSegmenter(**{k: v for k, v in options.items() if k in _SPECTRAL})
    return MapSegmenter(spectral, **{k: v for k, v in options.items() if k in _PIPELINE})


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
    segmentation
        Everything the pipeline found: the conditioned map, places, keyframes, the fitted
        spectral partition, the spectral and refined regions, seconds per stage.
    graph
        Region adjacency graph of :attr:`regions` (see :func:`segmentation.graph.region_graph`).
    seconds
        Time per stage, the graph and labels included.
    """

    grid: OccupancyGrid
    segmentation: Segmentation
    graph: nx.Graph
    seconds: dict[str, float] = field(default_factory=dict)
    _planners: dict[tuple, HierarchicalPlanner] = field(
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
        pipeline = pipeline or pipeline_from_options(options)
        return cls._build(grid, pipeline.segment(grid, random_state=random_state))

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
        pipeline = pipeline or pipeline_from_options(options)
        start = time.perf_counter()
        built = grid is None
        grid = grid_from_keyframes(keyframes, resolution) if grid is None else grid
        mapped = time.perf_counter() - start
        found = pipeline.segment(grid, keyframes, random_state=random_state)
        topo = cls._build(grid, found)
        if built:
            topo.seconds = {"map": mapped, **topo.seconds}
        return topo

    @classmethod
    def _build(cls, grid: OccupancyGrid, found: Segmentation) -> TopoMap:
        seconds = dict(found.seconds)
        start = time.perf_counter()
        graph = region_graph(found.regions, found.keyframe_regions())
        seconds["graph"] = time.perf_counter() - start
        topo = cls(grid, found, graph, seconds)
        start = time.perf_counter()
        topo.label()
        seconds["labels"] = time.perf_counter() - start
        return topo

    @property
    def regions(self) -> Regions:
        """The regions (refined unless the pipeline ran with ``refine=False``)."""
        return self.segmentation.regions

    @property
    def spectral(self) -> Regions:
        """The spectral partition alone, made dense."""
        return self.segmentation.spectral

    @property
    def keyframes(self) -> list[Keyframe]:
        """The keyframes that were clustered (virtual ones for a map alone)."""
        return self.segmentation.keyframes

    @property
    def segmenter(self) -> SpectralSegmenter | BlockSpectralSegmenter:
        """The fitted spectral partition."""
        return self.segmentation.segmenter

    @property
    def conditioned(self) -> ConditionedMap:
        """The building space, clutter and dropped cells (see :mod:`segmentation.conditioning`)."""
        return self.segmentation.conditioned

    def region_at(self, x: float, y: float) -> int:
        """The region id at map point ``(x, y)``, 0 if none."""
        return self.regions.at(x, y)

    def label(self, classifier: Classifier | None = None) -> dict[int, str]:
        """Label every region with a place type and give it a unique name ("corridor 1"),
        stored as the graph nodes' ``label`` and ``name`` (and so in every export).

        Parameters
        ----------
        classifier
            A function of the :func:`~topomap.labels.region_features` table, or a fitted
            estimator with ``predict``; :func:`~topomap.labels.rule_classifier` by default.

        Returns
        -------
        dict
            Region id -> label.
        """
        features = region_features(self.regions, self.graph)
        found = classify(classifier, features)
        labels = dict(zip(features["id"].astype(int).tolist(), found, strict=True))
        names = name_regions(self.graph, labels)
        for region in self.graph.nodes:
            self.graph.nodes[region]["label"] = labels[region]
            self.graph.nodes[region]["name"] = names[region]
        return labels

    def region(self, query: int | str) -> int:
        """Region id of a region id or name ("hall 1", "aisle 2"); the error lists the names."""
        return find_region(self.graph, query)

    def rename(self, region: int | str, name: str) -> None:
        """Rename a region (by id or name); a name already taken is refused, nothing changes."""
        rename(self.graph, region, name)

    def planner(self, robot_radius: float = 0.2, **options: Any) -> HierarchicalPlanner:
        """The hierarchical planner on this map for a disc robot of ``robot_radius`` metres
        (made once per radius and kept, with its leg cache). ``options`` go to
        :class:`~planners.hierarchical.HierarchicalPlanner`."""
        from planners.hierarchical import HierarchicalPlanner
        from planners.workspace import Workspace

        key = (robot_radius, tuple(sorted(options.items())))
        if key not in self._planners:
            space = Workspace(self.grid, robot_radius)
            self._planners[key] = HierarchicalPlanner(
                space, self.regions.labels, self.graph, **options
            )
        return self._planners[key]

    def plan(
        self, start: ArrayLike, goal: ArrayLike | int | str, *, robot_radius: float = 0.2
    ) -> PlannedPath:
        """Plan from ``start`` to ``goal`` (a point, a region id or a region name) with
        :meth:`planner`."""
        target = self.region(goal) if isinstance(goal, int | str) else goal
        return self.planner(robot_radius).plan(start, target)

    def keyframe_regions(self) -> NDArray[np.int64]:
        """Region of each keyframe's position (0 if it is not on a labelled cell)."""
        return self.segmentation.keyframe_regions()

    def save(self, out: str | Path, *, overwrite: bool = False) -> list[Path]:
        """Write ``regions.png``, ``graph.graphml``, ``graph.json`` and ``regions.geojson``."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        return [
            write_label_image(self.regions.labels, out / "regions.png", overwrite=overwrite),
            write_graphml(self.graph, out / "graph.graphml", overwrite=overwrite),
            write_node_link(self.graph, out / "graph.json", overwrite=overwrite),
            write_geojson(self.graph, out / "regions.geojson", overwrite=overwrite),
        ]

    def save_keyframes(self, path: str | Path, *, overwrite: bool = False) -> Path:
        """Write ``scan_index,x,y,theta,region``, one row per keyframe."""
        path = Path(path)
        if path.exists() and not overwrite:
            raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
        with path.open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(["scan_index", "x", "y", "theta", "region"])
            for frame, region in zip(self.keyframes, self.keyframe_regions(), strict=True):
                writer.writerow([frame.scan_index, *(f"{v:.4f}" for v in frame.pose), region])
        return path
