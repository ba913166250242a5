"""Writing and reading regions and the region graph: label PNG, GeoJSON, GraphML, node-link JSON.

Geometry is in map-frame metres. GraphML holds only scalars, so (as OSMnx does) polygons are
WKT strings and an edge's doors a JSON list of ``[x1, y1, x2, y2, cx, cy, width, clear_width]``
(files before the clear width: seven numbers, read as not measured); node-link JSON uses the
same encoding. Every reader returns an object equal to the one written.
"""

from __future__ import annotations

import errno
import json
import math
from pathlib import Path
from typing import Any

import cv2
import networkx as nx
import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import mapping, shape

from maps.errors import MapFileNotFoundError
from maps.files import write_text, written
from maps.limits import check_map_size
from maps.map_server import image_size
from segmentation.errors import ExportFormatError
from segmentation.transitions import Transition

FRAME_NOTE = "map frame (REP-103), metres"


def _door_list(doors: tuple[Transition, ...]) -> str:
    rows = []
    for t in doors:
        measured = [t.clear_width] if math.isfinite(t.clear_width) else []  # inf: not measured
        rows.append([*t.start, *t.end, *t.centre, t.width, *measured])
    return json.dumps(rows)


def _doors(text: str, a: int, b: int) -> tuple[Transition, ...]:
    found = []
    for x1, y1, x2, y2, cx, cy, *widths in json.loads(text):
        if len(widths) not in (1, 2):
            raise ValueError(f"a door of {6 + len(widths)} numbers, not 7 or 8")
        found.append(Transition(a, b, (x1, y1), (x2, y2), (cx, cy), *widths))
    return tuple(found)


def _encoded(graph: nx.Graph) -> nx.Graph:
    """A copy of ``graph`` with only scalar attributes."""
    out = nx.Graph()
    out.graph.update(
        {
            "resolution": graph.graph["resolution"],
            "origin": json.dumps(list(graph.graph["origin"])),
            "frame": FRAME_NOTE,
        }
    )
    for node, data in graph.nodes(data=True):
        attrs = dict(data)
        attrs["polygon"] = shapely.to_wkt(data["polygon"], rounding_precision=-1)
        out.add_node(int(node), **attrs)
    for a, b, data in graph.edges(data=True):
        attrs = dict(data)
        attrs["doors"] = _door_list(data["doors"])
        out.add_edge(int(a), int(b), **attrs)
    return out


def _decoded(graph: nx.Graph, source: Path) -> nx.Graph:
    """Inverse of :func:`_encoded`; errors name the node or edge."""
    for node, data in graph.nodes(data=True):
        if not data and graph.degree(node):  # networkx adds the nodes an edge names
            a, b = sorted(next(iter(graph.edges(node))))
            raise ExportFormatError(
                f"{source}: edge ({a}, {b}) names region {node}, which the file does not hold"
            )
    out = nx.Graph()
    where = "the graph"
    try:
        out.graph["resolution"] = float(graph.graph["resolution"])
        out.graph["origin"] = tuple(json.loads(graph.graph["origin"]))
        for node, data in graph.nodes(data=True):
            where = f"node {node}"
            attrs = dict(data)
            with np.errstate(invalid="ignore"):  # NaN coordinates: TopoMap.load refuses them
                attrs["polygon"] = shapely.from_wkt(data["polygon"])
            out.add_node(int(node), **attrs)
        for a, b, data in graph.edges(data=True):
            where = f"edge ({a}, {b})"
            lo, hi = sorted((int(a), int(b)))
            attrs = dict(data)
            attrs["doors"] = _doors(data["doors"], lo, hi)
            out.add_edge(lo, hi, **attrs)
    except KeyError as err:
        raise ExportFormatError(
            f"{source}: not a topomap region graph: {where} has no field {err.args[0]!r:.80}"
        ) from None
    except (ValueError, TypeError, RecursionError, shapely.errors.GEOSException) as err:
        raise ExportFormatError(
            f"{source}: not a topomap region graph: {err!r:.200} ({where})"
        ) from None
    return out


def write_graphml(graph: nx.Graph, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write the region graph as GraphML."""
    path = Path(path)
    with written(path, overwrite=overwrite) as partial:
        nx.write_graphml(_encoded(graph), partial)
    return path


def read_graphml(path: str | Path) -> nx.Graph:
    """Read a region graph written by :func:`write_graphml`."""
    path = Path(path)
    try:
        raw = nx.read_graphml(path, node_type=int)
    except FileNotFoundError:
        raise MapFileNotFoundError(path, "region graph") from None
    except Exception as err:  # networkx raises bare ElementTree / KeyError errors
        raise ExportFormatError(f"{path}: not valid GraphML: {err}") from err
    return _decoded(raw, path)


def write_node_link(graph: nx.Graph, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write the region graph as networkx node-link JSON (key ``edges``)."""
    text = json.dumps(nx.node_link_data(_encoded(graph), edges="edges"), indent=1)
    return write_text(path, text, overwrite=overwrite)


def read_node_link(path: str | Path) -> nx.Graph:
    """Read a region graph written by :func:`write_node_link`."""
    path = Path(path)
    try:
        raw = nx.node_link_graph(json.loads(path.read_text()), edges="edges")
    except FileNotFoundError:
        raise MapFileNotFoundError(path, "region graph") from None
    except (ValueError, KeyError, TypeError, RecursionError) as err:
        raise ExportFormatError(f"{path}: not node-link JSON: {err!r}") from err
    return _decoded(raw, path)


def write_geojson(graph: nx.Graph, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write one GeoJSON Feature per region: its polygon and its scalar attributes.

    Each Feature's properties hold ``id`` (the region's value in the label image), ``area_m2``
    and the node's other scalar attributes. Coordinates are map-frame metres, not WGS84.
    """
    features = []
    for node, data in sorted(graph.nodes(data=True)):
        properties: dict[str, Any] = {"id": int(node)}
        properties.update({k: v for k, v in data.items() if k != "polygon"})
        features.append(
            {"type": "Feature", "geometry": mapping(data["polygon"]), "properties": properties}
        )
    collection = {
        "type": "FeatureCollection",
        "properties": {
            "frame": FRAME_NOTE,
            "resolution": graph.graph["resolution"],
            "origin": list(graph.graph["origin"]),
        },
        "features": features,
    }
    return write_text(path, json.dumps(collection), overwrite=overwrite)


def read_geojson(path: str | Path) -> nx.Graph:
    """The regions of a file written by :func:`write_geojson`, as a graph without edges."""
    path = Path(path)
    index = -1
    try:
        collection = json.loads(path.read_text())
        graph = nx.Graph(
            resolution=float(collection["properties"]["resolution"]),
            origin=tuple(collection["properties"]["origin"]),
        )
        for index, feature in enumerate(collection["features"]):  # noqa: B007 (named in errors)
            properties = dict(feature["properties"])
            node = int(properties.pop("id"))
            graph.add_node(node, polygon=shape(feature["geometry"]), **properties)
    except FileNotFoundError:
        raise MapFileNotFoundError(path, "regions GeoJSON") from None
    except (ValueError, KeyError, TypeError, AttributeError, RecursionError) as err:
        where = f" feature {index}" if index >= 0 else ""
        raise ExportFormatError(f"{path}{where}: not topomap regions GeoJSON: {err!r}") from err
    return graph


def write_label_image(labels: NDArray[np.integer], path: str | Path, *, overwrite: bool = False):
    """Write region ids as a 16-bit PNG, row 0 at the top like the map image."""
    path = Path(path)
    if labels.max(initial=0) > np.iinfo(np.uint16).max:
        raise ExportFormatError(f"{path}: {labels.max()} regions do not fit a 16-bit PNG")
    with written(path, overwrite=overwrite) as partial:
        if not cv2.imwrite(str(partial), labels.astype(np.uint16)):
            raise OSError(errno.EIO, "the image encoder wrote nothing")
    return path


def label_colours(labels: NDArray[np.integer]) -> NDArray[np.uint8]:
    """An RGB picture of a label image: each region a colour of its own (hues a golden angle
    apart, so neighbouring ids differ), no region light grey.

    Examples
    --------
    >>> picture = label_colours(np.array([[0, 1, 2]]))
    >>> picture.shape, picture[0, 0].tolist(), bool((picture[0, 1] != picture[0, 2]).any())
    ((1, 3, 3), [235, 235, 235], True)
    """
    count = int(labels.max(initial=0)) + 1
    hues = (np.arange(count) * 0.381966 * 180) % 180  # OpenCV hues are 0..179
    hsv = np.stack([hues, np.full(count, 150), np.full(count, 230)], axis=1).astype(np.uint8)
    palette = np.zeros((count, 4), np.uint8)  # RGB and a fourth byte: one 32-bit word each
    palette[:, :3] = cv2.cvtColor(hsv[None], cv2.COLOR_HSV2RGB)[0]
    palette[0, :3] = 235
    # words are gathered twice as fast as rows of three bytes (and four times palette[labels])
    words = np.take(palette.view(np.uint32).ravel(), np.maximum(labels, 0))
    return cv2.cvtColor(words.view(np.uint8).reshape(*labels.shape, 4), cv2.COLOR_RGBA2RGB)


def write_colour_image(labels: NDArray[np.integer], path: str | Path, *, overwrite: bool = False):
    """Write :func:`label_colours` of ``labels`` as an 8-bit colour PNG, for people: the
    16-bit label image (:func:`write_label_image`) looks black in an image viewer."""
    path = Path(path)
    with written(path, overwrite=overwrite) as partial:
        bgr = cv2.cvtColor(label_colours(labels), cv2.COLOR_RGB2BGR)
        if not cv2.imwrite(str(partial), bgr):
            raise OSError(errno.EIO, "the image encoder wrote nothing")
    return path


def read_label_image(path: str | Path) -> NDArray[np.int32]:
    """Read a 16-bit label PNG (0 = no region); its size is checked before it is decoded."""
    image = read_image_unchanged(path, "label image")
    if image.ndim != 2:
        raise ExportFormatError(f"{path}: a label image has one channel, found {image.shape[2]}")
    return image.astype(np.int32)


def read_image_unchanged(path: str | Path, what: str = "image") -> NDArray[Any]:
    """An image as stored (its channels and bit depth kept), its size checked from its header
    before it is decoded; errors name ``path`` (``what`` says what it is)."""
    if not Path(path).is_file():
        raise MapFileNotFoundError(path, what)
    size = image_size(path)
    if size is not None:
        check_map_size(*size, what=what, path=path)
    try:
        image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    except cv2.error as err:
        reason = str(err).strip().splitlines()[-1]
        raise ExportFormatError(f"{path}: OpenCV cannot read it: {reason}") from None
    if image is None:
        raise ExportFormatError(f"{path}: not an image OpenCV can read")
    return np.asarray(image)
