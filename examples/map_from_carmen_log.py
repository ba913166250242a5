"""Build an occupancy map from a real CARMEN log and save it for ROS map_server.

Usage: python examples/map_from_carmen_log.py LOG OUT_DIR
"""

import sys
from pathlib import Path

from maps.carmen import read_carmen
from maps.mapping import grid_from_keyframes
from maps.scan import select_keyframes

log, out = Path(sys.argv[1]), Path(sys.argv[2])
keyframes = select_keyframes(read_carmen(log), distance=0.5)
grid = grid_from_keyframes(keyframes, resolution=0.05)
grid.save(out / "map.yaml", overwrite=True)
print(f"{len(keyframes)} keyframes, {grid.free.sum()} free cells -> {out / 'map.yaml'}")
