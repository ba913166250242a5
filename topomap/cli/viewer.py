"""``topomap view``: one self-contained HTML page of a map, its regions, doors and routes.

The page needs no network and no server: its script and style are inlined and the map is an
embedded PNG (data URI) of the cells of its known part and a metre round it (the page opens on
it, not on a SLAM package's mostly unknown canvas), regions coloured by place type
(:data:`topomap.graph_layout.LABEL_COLOURS`), at most :data:`MAX_IMAGE_SIDE` pixels a side.
The regions (name, label, area, neighbours, most open point, polygon simplified to half a
cell), the doors, the graph's edges door to door and the region graph's weights ride along
as JSON. Hovering a region shows its name, label, area and doors; clicking two regions draws
the region route (Dijkstra on the region graph, in the page) and the hierarchical planner's
path between their most open points: planned here for every pair while there are at most
``max_paths`` pairs, else for every pair of neighbouring regions, the route's legs then
joined in the page. Wheel and drag zoom and pan; names keep their screen size.
"""

from __future__ import annotations

import argparse
import base64
import itertools
import json
import math
from importlib import resources
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np
import shapely

from maps.files import OutputFolder, check_output_file, write_text
from maps.grid import OccupancyGrid
from planners.errors import PlanningError
from topomap.errors import ExportError
from topomap.graph_layout import edge_segments, label_colour

#: Longest side of the embedded map picture, pixels (a 300 x 200 m campus at 0.05 m: 1/2).
MAX_IMAGE_SIDE = 4096
#: Region pairs whose paths are planned for the page unless told otherwise.
MAX_PATHS = 400
_DIGITS = 3  # coordinates in the page: millimetres


def _png_uri(topo: Any) -> tuple[str, int, OccupancyGrid]:
    """The map's known part and :data:`~topomap.cli.drawing.FRAME` metres round it (a SLAM
    package's canvas is mostly unknown), its regions in their label's colour, as a PNG data
    URI; the number of cells per pixel; the part of the map the picture shows."""
    import cv2

    from topomap.cli.drawing import FRAME, map_image

    rows, cols = topo.grid.known_box(FRAME)
    shown = topo.grid.cropped(rows, cols)
    step = max(1, math.ceil(max(shown.shape) / MAX_IMAGE_SIDE))
    labels = topo.regions.labels[rows, cols][::step, ::step]
    picture = OccupancyGrid(shown.cells[::step, ::step], shown.resolution * step, shown.origin)
    colours = np.zeros((int(topo.regions.labels.max(initial=0)) + 1, 4))
    for region, label in topo.graph.nodes(data="label"):
        colours[region] = (*label_colour(label), 1.0)
    image = map_image(picture, labels, alpha=0.55, colours=colours)
    ok, encoded = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_RGBA2BGRA))
    if not ok:
        raise OSError("could not encode the map picture")
    return "data:image/png;base64," + base64.b64encode(encoded.tobytes()).decode(), step, shown


def _xy(points: Any) -> list[list[float]]:
    return [[round(float(x), _DIGITS), round(float(y), _DIGITS)] for x, y in points]


def _rings(polygon: Any, tolerance: float) -> list[list[list[float]]]:
    """The rings of every piece of ``polygon``, simplified within ``tolerance`` metres."""
    rings = []
    for piece in shapely.get_parts(polygon.simplify(tolerance)):
        rings += [_xy(piece.exterior.coords), *(_xy(r.coords) for r in piece.interiors)]
    return rings


def _paths(topo: Any, planner: Any, points: dict[int, Any], pairs: list) -> dict[str, Any]:
    """Planned paths ``"a-b"`` -> waypoints for every pair whose ends have a point."""
    found = {}
    for a, b in pairs:
        if a in points and b in points:
            try:
                found[f"{a}-{b}"] = _xy(planner.plan(points[a], points[b]).waypoints)
            except PlanningError:
                continue  # no path: the page says so
    return found


def viewer_data(topo: Any, *, robot_radius: float = 0.2, max_paths: int = MAX_PATHS) -> dict:
    """Everything the page shows, as JSON-ready data (see the module's text)."""
    from planners.route_graph import region_point

    graph, grid = topo.graph, topo.grid
    planner = topo.planner(robot_radius)
    image, step, shown = _png_uri(topo)
    points = {r: p for r in graph.nodes if (p := region_point(planner, r)) is not None}
    regions = []
    for region in sorted(graph.nodes):
        data = graph.nodes[region]
        neighbours = sorted(graph[region])
        regions.append(
            {
                "id": region,
                "name": str(data.get("name", region)),
                "label": str(data.get("label", "")),
                "area": float(data["area_m2"]),
                "x": round(float(data["x"]), _DIGITS),
                "y": round(float(data["y"]), _DIGITS),
                "doors": sum(len(graph.edges[region, n].get("doors") or ()) for n in neighbours),
                "neighbours": [str(graph.nodes[n].get("name", n)) for n in neighbours],
                "rings": _rings(data["polygon"], grid.resolution / 2),  # the graph holds it
            }
        )
    edges = []
    for a, b, doors in graph.edges(data="doors"):
        centre = doors[0].centre if doors else (graph.nodes[b]["x"], graph.nodes[b]["y"])
        ends = [(graph.nodes[n]["x"], graph.nodes[n]["y"]) for n in (a, b)]
        weight = math.dist(ends[0], centre) + math.dist(centre, ends[1])
        edges.append({"a": a, "b": b, "w": round(weight, 3), "door": _xy([centre])[0]})
    pairs = list(itertools.combinations(sorted(points), 2))
    every_pair = len(pairs) <= max_paths
    if not every_pair:
        pairs = sorted((min(a, b), max(a, b)) for a, b in graph.edges)
    xmin, ymin, xmax, ymax = shown.bounds()  # the page opens on the picture
    return {
        "bounds": [xmin, ymin, xmax, ymax],
        "origin": list(shown.origin),
        "resolution": shown.resolution,
        "height": shown.shape[0],
        "image": image,
        "image_step": step,
        "regions": regions,
        "doors": [
            _xy([t.start, t.end]) for _, _, ds in graph.edges(data="doors") for t in ds or ()
        ],
        "segments": [_xy(segment) for _, segment in edge_segments(graph)],
        "edges": edges,
        "points": {str(r): _xy([p])[0] for r, p in points.items()},
        "paths": _paths(topo, planner, points, pairs),
        "every_pair": every_pair,
        "robot_radius": robot_radius,
        "colours": {label: _hex(rgb) for label, rgb in _legend(graph).items()},
    }


def _legend(graph: nx.Graph) -> dict[str, tuple[float, float, float]]:
    """The colour of every label the regions have."""
    labels = sorted({str(label) for _, label in graph.nodes(data="label")})
    return {label: label_colour(label) for label in labels}


def _hex(rgb: tuple[float, float, float]) -> str:
    return "#" + "".join(f"{round(255 * c):02x}" for c in rgb)


#: Characters written as JSON ``\\uXXXX`` escapes in the page's data: with them a name can
#: neither end the data's script (``</script>``), open a comment that swallows the viewer's
#: own script (``<!--``), nor end a JavaScript line (U+2028, U+2029).
_UNSAFE = {ord(c): f"\\u{ord(c):04x}" for c in "<>&\u2028\u2029"}


def page(data: dict[str, Any], title: str) -> str:
    """The HTML page of :func:`viewer_data`: the template with its style, script and data
    inlined (:data:`_UNSAFE` characters in the JSON escaped, so no name can break the page).

    Raises
    ------
    ExportError
        A number in the data that is not finite (a damaged graph's NaN coordinates): JSON
        has no NaN, and the page would be blank.

    Examples
    --------
    >>> text = page({"names": ["<!-- <script>"]}, "t")
    >>> "<!-- <script>" in text, "!-- " + chr(92) + "u003cscript" in text
    (False, True)
    >>> page({"x": float("nan")}, "t")
    Traceback (most recent call last):
    ...
    topomap.errors.ExportError: the viewer's data holds a number that is not finite (...)
    """
    assets = resources.files("topomap.cli") / "viewer"
    html = (assets / "viewer.html").read_text()
    try:
        payload = json.dumps(data, separators=(",", ":"), allow_nan=False).translate(_UNSAFE)
    except ValueError as err:
        raise ExportError(f"the viewer's data holds a number that is not finite ({err})") from None
    return (
        html.replace("{{TITLE}}", _escape(title))
        .replace("{{STYLE}}", (assets / "viewer.css").read_text())
        .replace("{{SCRIPT}}", (assets / "viewer.js").read_text())
        .replace("{{DATA}}", payload)
    )


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def write_viewer(
    topo: Any,
    path: str | Path,
    *,
    title: str = "topomap",
    robot_radius: float = 0.2,
    max_paths: int = MAX_PATHS,
    overwrite: bool = False,
) -> Path:
    """Write the page to ``path`` atomically (never over a file unless ``overwrite``)."""
    check_output_file(path, overwrite=overwrite, how="--force")
    data = viewer_data(topo, robot_radius=robot_radius, max_paths=max_paths)
    return write_text(path, page(data, title), overwrite=overwrite, how="--force")


def run_view(args: argparse.Namespace) -> int:
    """``topomap view DIR --out map.html``.

    The page is written through :class:`~maps.files.OutputFolder`, checked and entered before
    the regions are read: a folder that cannot be made, or that the system refuses to write
    in, stops the command before any work.
    """
    from topomap.cli.commands.common import refuse_inputs_as_outputs
    from topomap.topomap import TopoMap

    out = Path(args.out)
    refuse_inputs_as_outputs([args.out], [args.regions])
    with OutputFolder(out.parent, [out.name], overwrite=args.force, how="--force") as work:
        topo = TopoMap.load(args.regions)
        args.progress.stage(f"planning the paths between the regions of {args.regions}")
        write_viewer(
            topo,
            work / out.name,
            title=Path(args.regions).name,
            robot_radius=args.robot_radius,
            max_paths=args.max_paths,
        )
    size = out.stat().st_size
    print(f"wrote {out} ({size / 1e6:.1f} MB, {topo.graph.number_of_nodes()} regions)")
    return 0
