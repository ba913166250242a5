"""Occupancy grids, laser scans and keyframes, file readers and writers, and simulation."""

from maps.carmen import read_carmen
from maps.errors import (
    FormatError,
    InvalidMapError,
    InvalidScanError,
    LogFormatError,
    MapFileNotFoundError,
    MapFormatError,
    MapsError,
)
from maps.floorplan import FloorPlan, generate_floor_plan
from maps.grid import OccupancyGrid
from maps.laser_sim import LaserModel, RayCaster, simulate_scans
from maps.mapping import grid_from_keyframes
from maps.rosbag import read_rosbag
from maps.scan import Keyframe, LaserScan, select_keyframes
from maps.wander import Route, wander

__all__ = [
    "FloorPlan",
    "FormatError",
    "InvalidMapError",
    "InvalidScanError",
    "Keyframe",
    "LaserModel",
    "LaserScan",
    "LogFormatError",
    "MapFileNotFoundError",
    "MapFormatError",
    "MapsError",
    "OccupancyGrid",
    "RayCaster",
    "Route",
    "generate_floor_plan",
    "grid_from_keyframes",
    "read_carmen",
    "read_rosbag",
    "select_keyframes",
    "simulate_scans",
    "wander",
]
