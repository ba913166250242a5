"""Segment the map a robot built from a real laser log, save it, read it back and plan on it.

Usage: python examples/segment_a_slam_map.py LOG OUT_DIR
(LOG: a CARMEN log such as ../shared/data/carmen/intel-corrected.log.gz)
"""

import sys
from pathlib import Path

import maps
from topomap import TopoMap

log, out = Path(sys.argv[1]), Path(sys.argv[2])
keyframes = maps.select_keyframes(maps.read_carmen(log), distance=0.5)
topo = TopoMap.from_keyframes(keyframes, resolution=0.05, robot_radius=0.25)
print(f"{len(keyframes)} keyframes -> {len(topo.regions.ids)} regions")
print("conditioning:", topo.conditioned.summary())  # clutter kept, rays and islands dropped
topo.save(out, overwrite=True)

again = TopoMap.load(out)  # the map, regions, graph, labels and names
# regions the robot drove through (rooms seen only through their doors are regions too)
visited = sorted(again.graph.nodes[r]["name"] for r, k in again.graph.nodes(data="keyframes") if k)
start, goal = visited[0], visited[-1]  # e.g. "corridor 1" and "room 9"
node = again.graph.nodes[again.region(start)]
path = again.plan((node["x"], node["y"]), goal, robot_radius=0.25)
crossed = " -> ".join(again.graph.nodes[r]["name"] for r in path.regions)
print(f"{start} to {goal}: {path.length:.1f} m through {crossed}")
