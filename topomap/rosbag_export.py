"""A topological map as a ROS 2 bag (MCAP or sqlite3) for RViz and Foxglove.

One message per topic, all stamped at ``stamp`` in frame ``map`` and recorded with
transient-local durability, so ``ros2 bag play`` hands them to late subscribers like a latched
topic:

- ``/topomap/map`` (nav_msgs/msg/OccupancyGrid): the map, as map_server publishes it.
- ``/topomap/regions`` (sensor_msgs/msg/Image, ``mono16``): the region id of every cell (0 =
  none), pixel ``(u, v)`` = cell ``(u, v)`` of the OccupancyGrid: same width and height, row 0
  at the map's origin (the bottom of the map image), the map's resolution and origin.
- ``/topomap/markers`` (visualization_msgs/msg/MarkerArray), by namespace, marker id = region
  id: ``region_fill`` (TRIANGLE_LIST, the polygon in its place type's colour),
  ``region_outline`` (LINE_LIST, every ring of the polygon), ``region_name``
  (TEXT_VIEW_FACING at the most open point, the region's name); ``doors`` (LINE_LIST, marker
  id = the edge's index in the graph's sorted edges, one segment per door's portal) and
  ``graph_edges`` (one LINE_LIST, the graph's edges door to door,
  :func:`topomap.graph_layout.edge_segments`).
- ``/topomap/route_graph`` (visualization_msgs/msg/MarkerArray): the building's route graph
  (:func:`planners.route_graph.building_route_graph`): ``route_nodes`` (SPHERE_LIST, marker id
  0 doors, 1 regions, 2 corners, in node id order) and ``route_edges`` (LINE_LIST, one segment
  per edge pair, in sorted order).
- ``/topomap/path_K`` (nav_msgs/msg/Path): the K-th planned path given, its waypoints as poses
  heading along the path.

All coordinates are map-frame metres (REP-103), z = 0.
"""

from __future__ import annotations

import functools
import itertools
import math
import shutil
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import networkx as nx
import numpy as np
import shapely

from maps.errors import OutputWriteError
from maps.files import OutputFolder, check_output_folder
from maps.grid import OccupancyGrid
from maps.limits import finite_in
from maps.tf import quaternion_from_yaw
from topomap.errors import ExportError
from topomap.graph_layout import edge_segments, label_colour

if TYPE_CHECKING:
    from planners.path import PlannedPath
    from topomap.topomap import TopoMap

#: Points all markers together may have (bounds the bag of a huge map; 16 bytes per point).
MAX_MARKER_POINTS = 20_000_000
#: The latest stamp, seconds: a ROS time's seconds are a signed 32-bit integer.
MAX_STAMP = 2**31 - 1
#: The storage plugins and their files' suffix.
STORAGES = {"mcap": "mcap", "sqlite3": "db3"}
FRAME = "map"


def bag_files(path: str | Path, storage: str) -> list[str]:
    """The files a bag folder ``path`` holds once written: ``metadata.yaml`` and the data
    file, ``NAME_0.mcap`` or ``NAME_0.db3`` as ``ros2 bag record`` names them (NAME the
    folder's name without a ``.mcap`` or ``.db3`` suffix).

    Examples
    --------
    >>> bag_files("out/lab.mcap", "mcap"), bag_files("out/lab", "sqlite3")
    (['metadata.yaml', 'lab_0.mcap'], ['metadata.yaml', 'lab_0.db3'])
    """
    if storage not in STORAGES:
        raise ExportError(f"storage {storage!r} is not one of {sorted(STORAGES)}")
    name = Path(path).name
    stem = name.rsplit(".", 1)[0] if name.endswith((".mcap", ".db3")) else name
    return ["metadata.yaml", f"{stem}_0.{STORAGES[storage]}"]


@functools.cache
def typestore() -> Any:
    """The message definitions of the bag: ROS 2 Humble's (rosbags' typestore)."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


class _Messages:
    """Builds the messages with :func:`typestore`'s classes."""

    def __init__(self, stamp: float) -> None:
        self.types = typestore().types
        sec = math.floor(stamp)
        self.time = self.types["builtin_interfaces/msg/Time"](
            sec=int(sec), nanosec=min(round((stamp - sec) * 1e9), 999_999_999)
        )
        self.points = 0

    def header(self) -> Any:
        return self.types["std_msgs/msg/Header"](stamp=self.time, frame_id=FRAME)

    def pose(self, x: float, y: float, yaw: float = 0.0) -> Any:
        qx, qy, qz, qw = quaternion_from_yaw(yaw)
        t = self.types
        return t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=qx, y=qy, z=qz, w=qw),
        )

    def occupancy_grid(self, grid: OccupancyGrid) -> Any:
        t = self.types
        height, width = grid.shape
        info = t["nav_msgs/msg/MapMetaData"](
            map_load_time=self.time,
            resolution=float(grid.resolution),
            width=width,
            height=height,
            origin=self.pose(*grid.origin),
        )
        data = np.ascontiguousarray(grid.cells[::-1].ravel(), np.int8)
        return t["nav_msgs/msg/OccupancyGrid"](header=self.header(), info=info, data=data)

    def label_image(self, labels: np.ndarray) -> Any:
        height, width = labels.shape
        rows = np.ascontiguousarray(labels[::-1], "<u2")
        return self.types["sensor_msgs/msg/Image"](
            header=self.header(),
            height=height,
            width=width,
            encoding="mono16",
            is_bigendian=0,
            step=2 * width,
            data=rows.view(np.uint8).ravel(),
        )

    def marker(
        self,
        ns: str,
        marker_id: int,
        kind: str,
        points: Sequence[tuple[float, float]] = (),
        *,
        colour: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0),
        scale: float = 0.05,
        text: str = "",
        at: tuple[float, float] = (0.0, 0.0),
    ) -> Any:
        t = self.types
        marker_type = t["visualization_msgs/msg/Marker"]
        self.points += len(points)
        if self.points > MAX_MARKER_POINTS:
            raise ExportError(
                f"the markers need more than {MAX_MARKER_POINTS} points: the map is too large "
                "to export as markers"
            )
        point = t["geometry_msgs/msg/Point"]
        line = kind in ("LINE_LIST", "LINE_STRIP")
        size = (scale, 0.0, 0.0) if line else (scale, scale, scale)
        return marker_type(
            header=self.header(),
            ns=ns,
            id=marker_id,
            type=getattr(marker_type, kind),
            action=marker_type.ADD,
            pose=self.pose(*at),
            scale=t["geometry_msgs/msg/Vector3"](x=size[0], y=size[1], z=size[2]),
            color=t["std_msgs/msg/ColorRGBA"](*colour),
            lifetime=t["builtin_interfaces/msg/Duration"](sec=0, nanosec=0),
            frame_locked=False,
            points=[point(x=float(x), y=float(y), z=0.0) for x, y in points],
            colors=[],
            texture_resource="",
            texture=t["sensor_msgs/msg/CompressedImage"](
                header=self.header(), format="", data=np.zeros(0, np.uint8)
            ),
            uv_coordinates=[],
            text=text,
            mesh_resource="",
            mesh_file=t["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
            mesh_use_embedded_materials=False,
        )

    def marker_array(self, markers: list[Any]) -> Any:
        return self.types["visualization_msgs/msg/MarkerArray"](markers=markers)

    def path(self, waypoints: np.ndarray) -> Any:
        t = self.types
        heading = np.arctan2(*np.diff(waypoints[:, :2], axis=0).T[::-1]).tolist()
        heading.append(heading[-1] if heading else 0.0)
        poses = [
            t["geometry_msgs/msg/PoseStamped"](header=self.header(), pose=self.pose(x, y, yaw))
            for (x, y), yaw in zip(waypoints[:, :2].tolist(), heading, strict=True)
        ]
        return t["nav_msgs/msg/Path"](header=self.header(), poses=poses)


def _region_markers(build: _Messages, topo: TopoMap) -> list[Any]:
    graph = topo.graph
    text = max(0.3, 0.012 * max(topo.grid.shape) * topo.grid.resolution)
    markers = []
    for region in sorted(graph.nodes):
        data = graph.nodes[region]
        pieces = shapely.get_parts(data["polygon"])  # the graph holds it
        rgb = label_colour(data.get("label"))
        triangles = shapely.get_parts(shapely.constrained_delaunay_triangles(pieces))
        corners = [xy for t in triangles for xy in t.exterior.coords[:3]]
        markers.append(
            build.marker(
                "region_fill", region, "TRIANGLE_LIST", corners, colour=(*rgb, 0.45), scale=1.0
            )
        )
        rings = [ring for piece in pieces for ring in (piece.exterior, *piece.interiors)]
        pairs = [xy for ring in rings for a, b in itertools.pairwise(ring.coords) for xy in (a, b)]
        markers.append(
            build.marker(
                "region_outline",
                region,
                "LINE_LIST",
                pairs,
                colour=(*rgb, 1.0),
                scale=topo.grid.resolution,
            )
        )
        markers.append(
            build.marker(
                "region_name",
                region,
                "TEXT_VIEW_FACING",
                colour=(0.0, 0.0, 0.0, 1.0),
                scale=text,
                text=str(data.get("name", region)),
                at=(data["x"], data["y"]),
            )
        )
    for k, (_, _, doors) in enumerate(sorted(graph.edges(data="doors"))):
        ends = [end for door in doors or () for end in (door.start, door.end)]
        markers.append(
            build.marker(
                "doors",
                k,
                "LINE_LIST",
                ends,
                colour=(0.85, 0.1, 0.1, 1.0),
                scale=2 * topo.grid.resolution,
            )
        )
    segments = [end for _, segment in edge_segments(graph) for end in segment]
    markers.append(
        build.marker("graph_edges", 0, "LINE_LIST", segments, scale=topo.grid.resolution)
    )
    return markers


def _route_markers(build: _Messages, route: nx.DiGraph, resolution: float) -> list[Any]:
    markers = []
    kinds = {
        "door": (0.85, 0.1, 0.1, 1.0),
        "region": (0.1, 0.1, 0.8, 1.0),
        "corner": (0.4, 0.4, 0.4, 1.0),
    }
    for k, (kind, colour) in enumerate(kinds.items()):
        points = [
            (d["x"], d["y"])
            for _, d in sorted(route.nodes(data=True))
            if d["metadata"]["kind"] == kind
        ]
        markers.append(
            build.marker(
                "route_nodes", k, "SPHERE_LIST", points, colour=colour, scale=6 * resolution
            )
        )
    pairs = sorted((a, b) for a, b in route.edges if a < b)
    ends = [(route.nodes[n]["x"], route.nodes[n]["y"]) for pair in pairs for n in pair]
    markers.append(
        build.marker(
            "route_edges", 0, "LINE_LIST", ends, colour=(0.1, 0.5, 0.1, 1.0), scale=2 * resolution
        )
    )
    return markers


def topomap_messages(
    topo: TopoMap,
    *,
    paths: Sequence[PlannedPath] = (),
    robot_radius: float = 0.2,
    stamp: float = 0.0,
) -> dict[str, Any]:
    """The bag's messages, topic -> message (rosbags message objects; see the module's text).

    Raises
    ------
    ExportError
        The markers would exceed :data:`MAX_MARKER_POINTS` points.
    """
    from planners.path import PlannedPath
    from planners.route_graph import building_route_graph

    if finite_in(stamp, "stamp", 0.0, MAX_STAMP) is not None:
        raise ExportError(f"stamp must be seconds in [0, {MAX_STAMP:g}], got {stamp!r}")
    for path in paths:
        if not isinstance(path, PlannedPath):
            raise ExportError(f"paths must be planned paths (TopoMap.plan), got {path!r:.80}")
    build = _Messages(stamp)
    messages = {
        "/topomap/map": build.occupancy_grid(topo.grid),
        "/topomap/regions": build.label_image(topo.regions.labels),
        "/topomap/markers": build.marker_array(_region_markers(build, topo)),
        "/topomap/route_graph": build.marker_array(
            _route_markers(
                build, building_route_graph(topo.planner(robot_radius)), topo.grid.resolution
            )
        ),
    }
    for k, planned in enumerate(paths):
        messages[f"/topomap/path_{k}"] = build.path(np.asarray(planned.waypoints, float))
    return messages


def write_rosbag(
    topo: TopoMap,
    path: str | Path,
    *,
    storage: str = "mcap",
    paths: Sequence[PlannedPath] = (),
    robot_radius: float = 0.2,
    stamp: float | None = None,
    overwrite: bool = False,
) -> Path:
    """Write :func:`topomap_messages` as a ROS 2 bag: folder ``path`` with ``metadata.yaml``
    and one ``mcap`` or ``sqlite3`` file (:func:`bag_files`), written under a temporary name
    and renamed into place. ``stamp`` (seconds) defaults to now.

    Raises
    ------
    OutputExistsError
        A file of the bag exists and ``overwrite`` is false; nothing is written then.
    ExportError
        An unknown ``storage``, too many marker points, or a write that rosbags refuses.
    OutputWriteError
        The system refused the write (the disk full); nothing half-written is left.
    """
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )
    from rosbags.rosbag2 import StoragePlugin, Writer, WriterError

    path = check_output_folder(path)
    names = bag_files(path, storage)
    when = time.time() if stamp is None else stamp
    with OutputFolder(path, names, overwrite=overwrite) as work:
        messages = topomap_messages(topo, paths=paths, robot_radius=robot_radius, stamp=when)
        never = QosTime(sec=0, nsec=0)
        latched = Qos(
            QosHistory.KEEP_LAST,
            1,
            QosReliability.RELIABLE,
            QosDurability.TRANSIENT_LOCAL,
            never,
            never,
            QosLiveliness.AUTOMATIC,
            never,
            False,
        )
        bag = work / Path(names[1]).stem  # rosbags names the data file after its folder
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        store = typestore()
        try:
            with Writer(bag, version=9, storage_plugin=plugin) as writer:
                for topic, message in messages.items():
                    connection = writer.add_connection(
                        topic, message.__msgtype__, typestore=store, offered_qos_profiles=[latched]
                    )
                    data = store.serialize_cdr(message, message.__msgtype__)
                    writer.write(connection, round(when * 1e9), data)
            for name in names:  # the bag's files, up from its folder into the staging folder
                shutil.move(bag / name, work / name)
            bag.rmdir()
        except WriterError as err:
            raise ExportError(f"{path}: rosbags could not write the bag: {err}") from err
        except OSError as err:  # the disk full, a quota, an I/O error
            raise OutputWriteError(path, err) from err
    return path
