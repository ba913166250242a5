"""Bags written with rosbags' own writers, as robots record them (tests only).

A robot wandering through a generated flat: odometry on ``/tf`` drifting against the map, the
``map -> odom`` correction, the laser's static mount on ``/tf_static``, scans between
odometry messages; and maps on ``/map``.
"""

import math

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

MOUNT = (0.3, 0.0, 0.4)  # the laser: 0.3 m ahead of base_link, turned 0.4 rad


def compose(a, b):
    """Pose ``b`` given in a frame at pose ``a``, in ``a``'s parent frame (arrays (n, 3))."""
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack(
        (
            a[:, 0] + c * b[:, 0] - s * b[:, 1],
            a[:, 1] + s * b[:, 0] + c * b[:, 1],
            a[:, 2] + b[:, 2],
        )
    )


def inverse(a):
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    return np.column_stack((-c * a[:, 0] - s * a[:, 1], s * a[:, 0] - c * a[:, 1], -a[:, 2]))


def drift(t):
    """map -> odom: the odometry has drifted 0.6 m and 0.25 rad by the end of the run."""
    u = (np.asarray(t) - 10.0) / 40.0
    return np.column_stack((0.5 * u, -0.35 * u, 0.25 * u))


class Robot:
    """A robot wandering through the generated flat: odometry at 20 Hz drifting against the
    map, map -> odom at 10 Hz, the laser's static mount, scans between odometry messages."""

    def __init__(self, with_map_tf=True, with_mount=True, map_tf_until=1.0):
        from maps import LaserModel, generate_floor_plan, simulate_scans, wander

        self.plan = generate_floor_plan("flat", random_state=0)
        route = wander(self.plan.grid, self.plan.labels, random_state=0)
        base = np.array(route.poses[::3], float)[:800]
        base[:, 2] = np.unwrap(base[:, 2])
        self.times = 10.0 + 0.05 * np.arange(len(base))
        self.odom = compose(inverse(drift(self.times)), base)  # base_link in odom
        self.scan_times = self.times[:-1:2] + 0.025
        true_base = np.column_stack(
            [np.interp(self.scan_times, self.times, base[:, k]) for k in range(3)]
        )
        self.laser = compose(true_base, np.tile(MOUNT, (len(true_base), 1)))
        model = LaserModel(fov=2 * math.pi * 359 / 360, beams=360, max_range=12.0)
        frames = simulate_scans(self.plan.grid, self.laser, model, random_state=0)
        self.scans = [frame.scan for frame in frames]
        self.with_map_tf, self.with_mount = with_map_tf, with_mount
        # map -> odom is published over this fraction of the run (SLAM may stop or start late)
        self.map_tf_until = self.times[0] + map_tf_until * (self.times[-1] - self.times[0])

    def write(self, writer, store, ros1, edit=None):
        """Write the run; ``edit(records)`` may damage the ``(stamp, connection, message,
        type)`` records first."""
        t = store.types
        header_fields = t["std_msgs/msg/Header"].__dataclass_fields__
        serialize = store.serialize_ros1 if ros1 else store.serialize_cdr

        def time(seconds):
            sec = math.floor(seconds)
            return t["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((seconds - sec) * 1e9))

        def header(seconds, frame):
            seq = {"seq": 0} if "seq" in header_fields else {}
            return t["std_msgs/msg/Header"](**seq, stamp=time(seconds), frame_id=frame)

        def transform(seconds, parent, child, pose):
            x, y, yaw = (float(v) for v in pose)
            return t["geometry_msgs/msg/TransformStamped"](
                header=header(seconds, parent),
                child_frame_id=child,
                transform=t["geometry_msgs/msg/Transform"](
                    translation=t["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.2),
                    rotation=t["geometry_msgs/msg/Quaternion"](
                        x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
                    ),
                ),
            )

        tf_type, scan_type = "tf2_msgs/msg/TFMessage", "sensor_msgs/msg/LaserScan"
        tf = writer.add_connection("/tf", tf_type, typestore=store)
        scan_c = writer.add_connection("/scan", scan_type, typestore=store)
        records = []
        if self.with_mount:
            static = writer.add_connection("/tf_static", tf_type, typestore=store)
            mount = t[tf_type](transforms=[transform(10.0, "base_link", "laser", MOUNT)])
            records.append((10.0, static, mount, tf_type))
        for i, stamp in enumerate(self.times):
            parts = [transform(stamp, "/odom", "base_link", self.odom[i])]
            if self.with_map_tf and i % 2 == 0 and stamp <= self.map_tf_until:
                parts.append(transform(stamp, "map", "odom", drift(stamp)[0]))
            records.append((stamp, tf, t[tf_type](transforms=parts), tf_type))
        for stamp, scan in zip(self.scan_times, self.scans, strict=True):
            message = t[scan_type](
                header=header(stamp, "laser"),
                angle_min=scan.angle_min,
                angle_max=scan.angle_min + scan.angle_increment * (len(scan) - 1),
                angle_increment=scan.angle_increment,
                time_increment=0.0,
                scan_time=0.1,
                range_min=scan.range_min,
                range_max=scan.range_max,
                ranges=scan.ranges.astype(np.float32),
                intensities=np.zeros(0, np.float32),
            )
            records.append((stamp + 0.001, scan_c, message, scan_type))
        if edit is not None:
            edit(records)
        for stamp, connection, message, kind in sorted(records, key=lambda r: r[0]):
            writer.write(connection, round(stamp * 1e9), serialize(message, kind))


def tf_bag(tmp_path, kind, robot, edit=None):
    """Write ``robot``'s run as a ROS 1 bag, a ROS 2 sqlite3 bag or a ROS 2 MCAP bag
    (``edit``: see :meth:`Robot.write`)."""
    if kind == "ros1":
        store, path = get_typestore(Stores.ROS1_NOETIC), tmp_path / "robot.bag"
        # the Noetic store lacks tf2_msgs; a recorder embeds each type's definition anyway
        text = "geometry_msgs/TransformStamped[] transforms"
        store.register(get_types_from_msg(text, "tf2_msgs/msg/TFMessage"))
        with Writer1(path) as writer:
            robot.write(writer, store, True, edit)
        return path
    store, path = get_typestore(Stores.ROS2_HUMBLE), tmp_path / f"robot-{kind}"
    plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as writer:
        robot.write(writer, store, False, edit)
    return path


def map_bag(tmp_path, ros1, grids):
    """A bag with ``grids`` published on /map at 1, 2, 3... s."""
    kind = "nav_msgs/msg/OccupancyGrid"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    t = store.types
    header_fields = t["std_msgs/msg/Header"].__dataclass_fields__

    def build(fields, name):  # the message type ``name`` filled from a plain dict of fields
        cls = t[name]
        values = {}
        for key in cls.__dataclass_fields__:
            if key == "__msgtype__":
                continue
            value = fields[key]
            if key == "data":
                value = np.asarray(value, np.int8)
            elif isinstance(value, dict):
                value = build(value, _field_type(name, key))
            values[key] = value
        return cls(**values)

    def _field_type(name, key):
        return {
            ("nav_msgs/msg/OccupancyGrid", "header"): "std_msgs/msg/Header",
            ("nav_msgs/msg/OccupancyGrid", "info"): "nav_msgs/msg/MapMetaData",
            ("std_msgs/msg/Header", "stamp"): "builtin_interfaces/msg/Time",
            ("nav_msgs/msg/MapMetaData", "map_load_time"): "builtin_interfaces/msg/Time",
            ("nav_msgs/msg/MapMetaData", "origin"): "geometry_msgs/msg/Pose",
            ("geometry_msgs/msg/Pose", "position"): "geometry_msgs/msg/Point",
            ("geometry_msgs/msg/Pose", "orientation"): "geometry_msgs/msg/Quaternion",
        }[name, key]

    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    path = tmp_path / ("maps.bag" if ros1 else "maps")
    writer = Writer1(path) if ros1 else Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer:
        connection = writer.add_connection("/map", kind, typestore=store)
        for second, grid in enumerate(grids, start=1):
            fields = grid.to_msg_fields(stamp=float(second))
            if "seq" in header_fields:
                fields["header"]["seq"] = second
            writer.write(connection, second * 10**9, serialize(build(fields, kind), kind))
    return path
