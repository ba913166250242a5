"""Occupancy grids, laser scans and keyframes, file readers and writers, and simulation.

Names are imported lazily, the first time they are used.

Examples
--------
>>> import maps
>>> import numpy as np
>>> grid = maps.OccupancyGrid(np.zeros((4, 6), np.int8), resolution=0.5)
>>> grid.bounds()
(0.0, 0.0, 3.0, 2.0)
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from maps import _exports

if TYPE_CHECKING:  # the names as type checkers see them (``as``: re-exported)
    from maps.carmen import read_carmen as read_carmen
    from maps.errors import FormatError as FormatError
    from maps.errors import InvalidMapError as InvalidMapError
    from maps.errors import InvalidScanError as InvalidScanError
    from maps.errors import LogFormatError as LogFormatError
    from maps.errors import MapError as MapError
    from maps.errors import MapFileNotFoundError as MapFileNotFoundError
    from maps.errors import MapFormatError as MapFormatError
    from maps.errors import MapsError as MapsError
    from maps.errors import OutputExistsError as OutputExistsError
    from maps.errors import TopomapError as TopomapError
    from maps.errors import TransformError as TransformError
    from maps.grid import OccupancyGrid as OccupancyGrid
    from maps.mapping import grid_from_keyframes as grid_from_keyframes
    from maps.rosbag import BagScans as BagScans
    from maps.rosbag import read_bag_scans as read_bag_scans
    from maps.rosbag import read_rosbag as read_rosbag
    from maps.rosbag import read_rosbag_map as read_rosbag_map
    from maps.scan import Keyframe as Keyframe
    from maps.scan import LaserScan as LaserScan
    from maps.scan import select_keyframes as select_keyframes
    from maps.sim.exploration import Route as Route
    from maps.sim.exploration import wander as wander
    from maps.sim.floorplan import FloorPlan as FloorPlan
    from maps.sim.floorplan import generate_floor_plan as generate_floor_plan
    from maps.sim.laser import LaserModel as LaserModel
    from maps.sim.laser import RayCaster as RayCaster
    from maps.sim.laser import simulate_scans as simulate_scans
    from maps.sim.rooms import generate_rooms as generate_rooms
    from maps.tf import TransformTree as TransformTree


def __getattr__(name: str) -> Any:
    return _exports.load(__name__, name)


def __dir__() -> list[str]:
    return _exports.names(__name__)
