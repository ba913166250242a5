"""`topomap export --nav2-route`: a route graph file from a map and its saved regions."""

import json

from maps.floorplan import generate_floor_plan
from planners.nav2_route import read_nav2_route
from topomap.cli.main import main
from topomap.topomap import TopoMap


def test_export_nav2_route_from_saved_regions(tmp_path, capsys):
    plan = generate_floor_plan((16.0, 12.0), random_state=1)
    plan.grid.save(tmp_path / "map.yaml")
    topo = TopoMap.from_grid(plan.grid, random_state=1)
    topo.save(tmp_path / "regions")
    out = tmp_path / "route.geojson"
    arguments = ["export", str(tmp_path / "map.yaml"), "--regions", str(tmp_path / "regions")]
    assert main([*arguments, "--nav2-route", str(out)]) == 0
    assert "door nodes" in capsys.readouterr().out
    graph = read_nav2_route(out)
    kinds = {d["metadata"]["kind"] for _, d in graph.nodes(data=True)}
    assert kinds == {"door", "region"} and graph.number_of_edges() > 0
    names = {d["metadata"].get("name") for _, d in graph.nodes(data=True)}
    assert set(topo.graph.nodes[r]["name"] for r in topo.graph.nodes) <= names
    assert main([*arguments, "--nav2-route", str(out)]) == 2  # never overwritten unasked
    assert json.loads(out.read_text())["type"] == "FeatureCollection"
