"""Segment a generated office, name its regions, and plan to "hall 1" two ways."""

import maps
from topomap import FlatPlanner, TopoMap

plan = maps.generate_floor_plan("office", random_state=2)
topo = TopoMap.from_grid(plan.grid, random_state=0)
print(f"{len(topo.keyframes)} virtual keyframes -> {topo.graph.number_of_nodes()} regions")
print("not rooms:", ", ".join(n for _, n in topo.graph.nodes(data="name") if "room" not in n))

start = (5.0, 5.0)
path = topo.plan(start, "hall 1")  # the region's most open point; "aisle 1" = "corridor 1"
names = [topo.graph.nodes[r]["name"] for r in path.regions]
print(f"hierarchical: {path.length:.1f} m through {' -> '.join(names)}")
print("  times:", {k: f"{1000 * v:.1f} ms" for k, v in path.seconds.items()})

flat = FlatPlanner(topo.planner().space, "RRTConnect", time_limit=60).plan(
    start, path.waypoints[-1]
)
print(f"flat RRTConnect: {flat.length:.1f} m in {1000 * flat.total_seconds:.1f} ms")
