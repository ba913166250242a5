"""Segment a generated flat from its map alone and print its regions and doors."""

import sys
from pathlib import Path

import maps
from segmentation.metrics import score
from topomap import TopoMap

plan = maps.generate_floor_plan("flat", random_state=1)
topo = TopoMap.from_grid(plan.grid, random_state=0)
print(
    f"{len(topo.keyframes)} virtual keyframes -> {topo.graph.number_of_nodes()} regions "
    f"for {plan.n_rooms} rooms; "
    f"MCC {score(topo.regions.labels, plan.labels).mcc:.2f}"
)
for a, b, doors in topo.graph.edges(data="doors"):
    x, y = doors[0].centre
    print(f"region {a} - region {b}: door {doors[0].width:.2f} m wide at ({x:.2f}, {y:.2f})")
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out/example-segment")
topo.save(out, overwrite=True)
print(f"wrote {out}/regions.png, graph.graphml, graph.json, regions.geojson")
