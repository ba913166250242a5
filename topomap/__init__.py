"""topomap: semantic topological maps for robot navigation.

``from topomap import TopoMap`` is the front door; the names a user needs (the map readers,
the planners, the errors) are here too, imported lazily the first time they are used, so
``import topomap`` is quick and OMPL is loaded only when planning starts. The lower packages
do one part each: :mod:`maps` (grids, scans, readers, simulation), :mod:`segmentation`,
:mod:`planners`.

Examples
--------
>>> import topomap
>>> issubclass(topomap.NoPathError, topomap.TopomapError)
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names as type checkers see them (``as``: re-exported)
    from maps.carmen import read_carmen as read_carmen
    from maps.errors import MapError as MapError
    from maps.errors import OutputExistsError as OutputExistsError
    from maps.errors import TopomapError as TopomapError
    from maps.grid import OccupancyGrid as OccupancyGrid
    from maps.mapping import grid_from_keyframes as grid_from_keyframes
    from maps.rosbag import read_rosbag as read_rosbag
    from maps.scan import Keyframe as Keyframe
    from maps.scan import LaserScan as LaserScan
    from maps.scan import select_keyframes as select_keyframes
    from maps.sim.floorplan import generate_floor_plan as generate_floor_plan
    from planners.errors import InvalidQueryError as InvalidQueryError
    from planners.errors import NoPathError as NoPathError
    from planners.errors import PlanningError as PlanningError
    from planners.flat import FlatPlanner as FlatPlanner
    from planners.hierarchical import HierarchicalPlanner as HierarchicalPlanner
    from planners.path import PlannedPath as PlannedPath
    from segmentation.errors import RegionNotFoundError as RegionNotFoundError
    from segmentation.errors import SegmentationError as SegmentationError
    from segmentation.pipeline import MapSegmenter as MapSegmenter
    from segmentation.regions import Regions as Regions
    from segmentation.spectral import SpectralSegmenter as SpectralSegmenter
    from topomap.errors import LabelError as LabelError
    from topomap.topomap import TopoMap as TopoMap

__version__ = "0.1.0"


def __getattr__(name: str) -> Any:
    # the helper is imported here, not above, so that ``import topomap`` imports nothing else
    from maps import _exports

    return _exports.load(__name__, name)


def __dir__() -> list[str]:
    from maps import _exports

    return _exports.names(__name__)
