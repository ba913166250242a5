"""Generate a flat, drive a simulated robot through every room, keep keyframes like a real run.

Usage: python examples/simulate_robot_run.py [SEED]
"""

import sys

from maps.scan import select_keyframes
from maps.sim.exploration import wander
from maps.sim.floorplan import generate_floor_plan
from maps.sim.laser import LaserModel, simulate_scans

seed = int(sys.argv[1]) if len(sys.argv) > 1 else 0
plan = generate_floor_plan("flat", furniture=0.3, random_state=seed)
route = wander(plan.grid, plan.labels, random_state=seed)
scans = simulate_scans(plan.grid, route.poses, LaserModel(noise=0.01), random_state=seed)
keyframes = select_keyframes(scans, distance=0.5)
print(
    f"{plan.n_rooms} spaces, route {route.length:.1f} m, {len(scans)} scans, "
    f"{len(keyframes)} keyframes"
)
