"""Bags for the tests, written message by message with rosbags' own serializer and writers (independent of
dualpose.io.rosbag), and read back with rosbags' own deserializer."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rosbags.highlevel import AnyReader
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

FORMATS = (".bag", ".db3", ".mcap")
T0 = 1_700_000_000_123_456_789


class _Msgs:
    """Message constructors of one ROS version's typestore."""

    def __init__(self, ros1: bool) -> None:
        self.ros1 = ros1
        self.store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
        if "tf2_msgs/msg/TFMessage" not in self.store.types:  # the Noetic store has only tf/tfMessage
            from rosbags.typesys import get_types_from_msg

            self.store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                                   "tf2_msgs/msg/TFMessage"))  # fmt: skip
        self.t = self.store.types

    def header(self, ns: int, frame: str, seq: int = 0):
        T = self.t["builtin_interfaces/msg/Time"]
        sec, nsec = divmod(int(ns), 1_000_000_000)
        stamp = T(sec=sec, nanosec=nsec)
        H = self.t["std_msgs/msg/Header"]
        return H(seq=seq, stamp=stamp, frame_id=frame) if self.ros1 else H(stamp=stamp, frame_id=frame)

    def vec(self, v, name="geometry_msgs/msg/Vector3"):
        return self.t[name](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    def quat(self, q):
        return self.t["geometry_msgs/msg/Quaternion"](x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))

    def pose(self, p, q):
        return self.t["geometry_msgs/msg/Pose"](
            position=self.vec(p, "geometry_msgs/msg/Point"), orientation=self.quat(q)
        )

    def transform(self, ns, parent, child, p, q):
        tf = self.t["geometry_msgs/msg/Transform"](translation=self.vec(p), rotation=self.quat(q))
        return self.t["geometry_msgs/msg/TransformStamped"](
            header=self.header(ns, parent), child_frame_id=child, transform=tf
        )

    def make(self, msgtype: str, ns: int, frame: str, values: np.ndarray):
        t = self.t
        h = self.header(ns, frame)
        if msgtype == "geometry_msgs/msg/PoseStamped":
            return t[msgtype](header=h, pose=self.pose(values[0:3], values[3:7]))
        if msgtype == "geometry_msgs/msg/PoseWithCovarianceStamped":
            pc = t["geometry_msgs/msg/PoseWithCovariance"](
                pose=self.pose(values[0:3], values[3:7]), covariance=np.arange(36.0)
            )
            return t[msgtype](header=h, pose=pc)
        if msgtype == "geometry_msgs/msg/TransformStamped":
            return self.transform(ns, frame, "body_frame_x", values[0:3], values[3:7])
        if msgtype == "nav_msgs/msg/Odometry":
            pc = t["geometry_msgs/msg/PoseWithCovariance"](
                pose=self.pose(values[0:3], values[3:7]), covariance=np.full(36, 0.5)
            )
            tw = t["geometry_msgs/msg/TwistWithCovariance"](
                twist=t["geometry_msgs/msg/Twist"](linear=self.vec([1, 2, 3]), angular=self.vec([4, 5, 6])),
                covariance=np.zeros(36),
            )
            return t[msgtype](header=h, child_frame_id="base", pose=pc, twist=tw)
        if msgtype == "sensor_msgs/msg/Imu":
            return t[msgtype](
                header=h, orientation=self.quat([0, 0, 0, 1]), orientation_covariance=np.full(9, -1.0),
                angular_velocity=self.vec(values[0:3]), angular_velocity_covariance=np.full(9, 2.0),
                linear_acceleration=self.vec(values[3:6]), linear_acceleration_covariance=np.full(9, 3.0),
            )  # fmt: skip
        if msgtype == "sensor_msgs/msg/MagneticField":
            return t[msgtype](header=h, magnetic_field=self.vec(values), magnetic_field_covariance=np.zeros(9))
        raise AssertionError(msgtype)

    def serialize(self, msg, msgtype: str) -> bytes:
        if self.ros1:
            return bytes(self.store.serialize_ros1(msg, msgtype))
        return bytes(self.store.serialize_cdr(msg, msgtype))


def write_bag(path: Path, topics: dict) -> None:
    """``topics``: topic -> (msgtype, [(receive ns, message object), ...]), written with rosbags' writers."""
    ros1 = path.suffix == ".bag"
    m = _Msgs(ros1)
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if path.suffix == ".mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path.with_suffix(""), version=9, storage_plugin=plugin)
    with writer:
        for topic, (msgtype, msgs) in topics.items():
            conn = writer.add_connection(topic, msgtype, typestore=m.store)
            for t, msg in msgs:
                writer.write(conn, int(t), m.serialize(msg, msgtype))
    if not ros1:  # a single storage file, as the user names it
        d = path.with_suffix("")
        (d / f"{d.name}{path.suffix}").rename(path.with_name(path.stem + "_file" + path.suffix))
        for f in d.iterdir():
            f.unlink()
        d.rmdir()
        path.with_name(path.stem + "_file" + path.suffix).rename(path)


def deserialized(path: Path, topic: str) -> list:
    """(receive ns, message) of a topic through rosbags' own reader and deserializer."""
    with AnyReader([path]) as r:
        conns = [c for c in r.connections if c.topic == topic]
        return [(t, r.deserialize(raw, c.msgtype)) for c, t, raw in r.messages(connections=conns)]


def write_imu_bag(path: Path, topic: str, stamps_ns: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> None:
    """``sensor_msgs/Imu`` messages (header stamp = bag time) on ``topic`` of a new bag."""
    m = _Msgs(path.suffix == ".bag")
    vals = np.hstack([gyro, accel])
    msgs = [(t, m.make("sensor_msgs/msg/Imu", t, "imu", v)) for t, v in zip(stamps_ns.tolist(), vals, strict=True)]
    write_bag(path, {topic: ("sensor_msgs/msg/Imu", msgs)})
