"""The :class:`TopoMap` facade: keyframes or a map in, regions and their graph out."""

from __future__ import annotations

import csv
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np
from numpy.typing import ArrayLike, NDArray

from maps.grid import OccupancyGrid
from maps.mapping import grid_from_keyframes
from maps.scan import Keyframe, poses_array
from maps.seeding import RandomState
from planners.hierarchical import HierarchicalPlanner
from planners.path import Path as PlannedPath
from planners.workspace import Workspace
from segmentation.blocks import BlockSpectralSegmenter, keyframe_blocks
from segmentation.export import write_geojson, write_graphml, write_label_image, write_node_link
from segmentation.graph import region_graph
from segmentation.refine import basins, count_basins, merge_open_boundaries, snap_to_basins
from segmentation.regions import Regions, dense_labels
from segmentation.spectral import SpectralSegmenter
from segmentation.virtual import virtual_keyframes
from topomap.labels import (
    Classifier,
    classify,
    find_region,
    name_regions,
    region_features,
    rename,
)

#: Maps with more places (clearance basins) than this are segmented block by block.
BLOCK_PLACES = 100


@dataclass
class TopoMap:
    """A map segmented into regions, with the region adjacency graph.

    Build one with :meth:`from_grid` (a map only: virtual keyframes are simulated) or
    :meth:`from_keyframes` (a robot's keyframes).

    Attributes
    ----------
    grid
        The occupancy map.
    keyframes
        The keyframes that were clustered (virtual ones for a map-only input).
    segmenter
        The fitted :class:`~segmentation.spectral.SpectralSegmenter`, or for maps of more
        than :data:`BLOCK_PLACES` places the
        :class:`~segmentation.blocks.BlockSpectralSegmenter` that ran one per block.
    spectral
        The spectral partition alone, made dense (every free cell gets the cluster of its
        geodesically nearest keyframe).
    regions
        The regions after refinement (boundaries at doors, open cuts merged), or the spectral
        partition when built with ``refine=False``.
    graph
        Region adjacency graph of :attr:`regions` (see :func:`segmentation.graph.region_graph`).
    seconds
        Time per stage.
    """

    grid: OccupancyGrid
    keyframes: list[Keyframe]
    segmenter: SpectralSegmenter | BlockSpectralSegmenter
    spectral: Regions
    regions: Regions
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
        spacing: float = 0.8,
        refine: bool = True,
        random_state: RandomState = 0,
        **segmenter: Any,
    ) -> TopoMap:
        """Segment a map: virtual 360 degree keyframes every ``spacing`` metres, then the
        spectral pipeline. ``segmenter`` options go to :class:`SpectralSegmenter`; without
        ``k``, the guess ``k'`` is the number of clearance basins of the map
        (:func:`~segmentation.refine.count_basins`)."""
        spectral = SpectralSegmenter(random_state=random_state, **segmenter)
        start = time.perf_counter()
        keyframes = virtual_keyframes(grid, spacing, random_state=random_state)
        seconds = {"keyframes": time.perf_counter() - start}
        return cls._build(grid, keyframes, spectral, refine, seconds)

    @classmethod
    def from_keyframes(
        cls,
        keyframes: Sequence[Keyframe],
        grid: OccupancyGrid | None = None,
        *,
        resolution: float = 0.05,
        refine: bool = True,
        random_state: RandomState = 0,
        **segmenter: Any,
    ) -> TopoMap:
        """Segment a robot's keyframes; the map is built from them unless ``grid`` is given.
        Options as for :meth:`from_grid`."""
        spectral = SpectralSegmenter(random_state=random_state, **segmenter)
        seconds: dict[str, float] = {}
        if grid is None:
            start = time.perf_counter()
            grid = grid_from_keyframes(keyframes, resolution)
            seconds["map"] = time.perf_counter() - start
        return cls._build(grid, list(keyframes), spectral, refine, seconds)

    @classmethod
    def _build(
        cls,
        grid: OccupancyGrid,
        keyframes: list[Keyframe],
        segmenter: SpectralSegmenter,
        refine: bool,
        seconds: dict[str, float],
    ) -> TopoMap:
        clock = time.perf_counter()

        def lap(stage: str) -> None:
            nonlocal clock
            now = time.perf_counter()
            seconds[stage] = now - clock
            clock = now

        basin = basins(grid) if refine or segmenter.k is None else None
        fitted: SpectralSegmenter | BlockSpectralSegmenter = segmenter
        if segmenter.k is None:
            assert basin is not None
            places = count_basins(grid, basin)
            if places > BLOCK_PLACES:
                blocks, per_block = keyframe_blocks(grid, basin, keyframes, BLOCK_PLACES)
                fitted = BlockSpectralSegmenter(segmenter, blocks, per_block)
            else:
                fitted = replace(segmenter, k=min(len(keyframes), places))
        fitted.fit(keyframes)
        lap("spectral")
        poses = poses_array(keyframes)
        rows, cols = grid.world_to_cell(poses[:, 0], poses[:, 1])
        spectral = Regions(grid, dense_labels(grid, rows, cols, fitted.labels_))
        lap("regions")
        regions = spectral
        if refine:
            snapped = snap_to_basins(grid, spectral.labels, basin)
            regions = Regions(grid, merge_open_boundaries(grid, snapped))
            lap("refine")
        graph = region_graph(regions, _regions_of(regions, rows, cols))
        lap("graph")
        topo = cls(grid, keyframes, fitted, spectral, regions, graph, seconds)
        topo.label()
        lap("labels")
        return topo

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
        """Region of each keyframe's position (0 if it is not on a free cell)."""
        poses = poses_array(self.keyframes)
        rows, cols = self.grid.world_to_cell(poses[:, 0], poses[:, 1])
        return _regions_of(self.regions, rows, cols)

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


def _regions_of(regions: Regions, rows: NDArray, cols: NDArray) -> NDArray[np.int64]:
    inside = regions.grid.contains(rows, cols)
    found = np.zeros(len(rows), np.int64)
    found[inside] = regions.labels[rows[inside], cols[inside]]
    return found
