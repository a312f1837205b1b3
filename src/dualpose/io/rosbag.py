"""ROS bags in and out: ROS 1 ``.bag``, ROS 2 ``.db3`` / ``.mcap`` files and ROS 2 bag directories.

Reading and writing go through ``rosbags`` (pure Python, Apache-2.0, no ROS installation needed; the optional extra
``dualpose[ros]``).  A topic of a bag is addressed with a *bag source* string (:func:`parse_bag_source`)::

    FILE.bag:/topic                  a topic of a ROS 1 bag (also FILE.db3, FILE.mcap, or a ROS 2 bag directory)
    FILE.bag:/tf:PARENT:CHILD        the pose of frame CHILD in frame PARENT, chained through /tf and /tf_static

Messages read (the ROS 1 and ROS 2 definitions are the same field for field):

============================================  =========================================================================
message type                                  read as
============================================  =========================================================================
``geometry_msgs/PoseStamped``                 :class:`~dualpose.types.Trajectory`: ``pose`` (position, orientation)
``geometry_msgs/PoseWithCovarianceStamped``   the same, ``pose.pose``
``geometry_msgs/TransformStamped``            ``transform`` (translation, rotation): the pose of ``child_frame_id``
                                              in ``header.frame_id``
``nav_msgs/Odometry``                         ``pose.pose``: the pose of ``child_frame_id`` in ``header.frame_id``
``tf2_msgs/TFMessage`` (``/tf``)              a parent -> child chain of its transforms (``/tf_static`` included)
``sensor_msgs/Imu``                           :class:`~dualpose.io.ImuData`: ``angular_velocity`` (rad/s),
                                              ``linear_acceleration`` (m/s², specific force, REP 145)
``sensor_msgs/MagneticField``                 ``magnetic_field`` (tesla), see :func:`read_bag_magnetic_field`
============================================  =========================================================================

Quaternions are ``geometry_msgs/Quaternion`` ``x y z w``: dualpose's xyzw (scalar last), unchanged.  Stamps are
the messages' ``header.stamp`` (``stamps="header"``, default) or the times the bag recorded them
(``stamps="receive"``), as exact int64 nanoseconds (``stamps_ns``) and float seconds.

Speed: the messages are never turned into Python message objects.  ROS 1 bags are read from their chunk index
(connection and chunk-info records, then per chunk the fixed-size index entries ``time, offset`` as NumPy arrays and
the message records at those offsets; ROS bag format 2.0, chunks uncompressed, bz2 or lz4).  ROS 2 bags go through
rosbags' reader, which yields each message's raw bytes; those of a block of messages are joined into one buffer.
Either way the fields are read with NumPy at offsets computed for all messages at once (ROS 1 serialization: packed
little-endian; ROS 2 CDR: little-endian with each primitive aligned to its size from the end of the 4-byte
encapsulation header).  Strings (``frame_id``) make the offsets differ between messages; they are followed for all
messages at once.  The layout is checked: a ROS 1 connection's md5sum must be the standard definition's, and the
first ROS 2 message is also decoded by rosbags' own deserializer and compared, so a message type whose layout differs
from the standard one is refused.

Every problem is a :class:`BagError` (a ValueError) naming the bag and the topic: a missing topic (the message lists
the bag's topics and types), a message type that does not carry what was asked for, header stamps that are not
strictly increasing (the message index and both stamps), an unreadable bag.
"""

from __future__ import annotations

import os
import shutil
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

import dualpose as dp

if TYPE_CHECKING:  # rosbags is optional (the ros extra): imported where a bag is written
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import Writer as Writer2
from dualpose.io._bagfile import (
    IMU,
    MAG,
    ODOMETRY,
    POSE,
    TF,
    TRAJECTORY_TYPES,
    TRANSFORM,
    Bag,
    BagError,
    Fields,
    check_rosbags,
    open_bag,
)
from dualpose.io._output import temporary_sibling_dir
from dualpose.io._text import check_path
from dualpose.io.broad import BroadTrial
from dualpose.io.euroc import ImuData
from dualpose.types.trajectory import Trajectory, interpolate_poses, seconds_from_ns

__all__ = [
    "BAG_SUFFIXES",
    "BagError",
    "BagSource",
    "parse_bag_source",
    "is_bag_source",
    "bag_topics",
    "read_bag_trajectory",
    "read_bag_imu",
    "read_bag_magnetic_field",
    "read_bag_imu_trial",
    "write_trajectory_bag",
]

#: file suffixes of bags (a ROS 2 bag directory, holding ``metadata.yaml``, is a bag too)
BAG_SUFFIXES = (".bag", ".db3", ".mcap")

Stamps = Literal["header", "receive"]

@dataclass(frozen=True)
class BagSource:
    """A topic of a bag, or a /tf frame chain.

    Attributes
    ----------
    path : Path
        The bag: a ROS 1 ``.bag``, a ROS 2 ``.db3`` / ``.mcap`` file or a ROS 2 bag directory.
    topic : str or None
        ``/topic``; None when the source named only the bag.
    parent, child : str or None
        With ``topic`` ``/tf``: the frames of the chain (``parent`` is the reference frame, ``child`` the moving one).
    """

    path: Path
    topic: str | None
    parent: str | None = None
    child: str | None = None

    def __str__(self) -> str:
        text = os.fspath(self.path)
        if self.topic is not None:
            text += f":{self.topic}"
        if self.parent is not None:
            text += f":{self.parent}:{self.child}"
        return text


def _is_bag_path(path: Path) -> bool:
    return path.suffix.lower() in BAG_SUFFIXES or (path.is_dir() and (path / "metadata.yaml").is_file())


def parse_bag_source(source: str | os.PathLike[str] | BagSource) -> BagSource | None:
    """The bag source named by ``source``, or None when it names an ordinary file.

    ``source`` is ``BAG``, ``BAG:/topic`` or ``BAG:/tf:PARENT:CHILD`` where ``BAG`` is a path ending in ``.bag``,
    ``.db3`` or ``.mcap`` (any case) or an existing ROS 2 bag directory.  A path-like object (not a str) is never
    split.  Leading ``/`` of tf frame names are dropped (tf2 names frames without them).

    Raises
    ------
    BagError
        ``/tf`` without both frames, an empty frame name or a topic that does not start with ``/``.
    """
    if isinstance(source, BagSource):
        return source
    if not isinstance(source, str):
        path = Path(os.fspath(source))
        return BagSource(path, None) if _is_bag_path(path) else None
    cut = source.find(":/")
    while cut != -1:
        path = Path(source[:cut])
        if _is_bag_path(path):
            break
        cut = source.find(":/", cut + 1)
    if cut == -1:
        path = Path(source)
        return BagSource(path, None) if _is_bag_path(path) else None
    topic, *frames = source[cut + 1 :].split(":")
    if not frames:
        return BagSource(path, topic)
    if topic not in ("/tf", "/tf_static") or len(frames) != 2:
        raise BagError(f"{source}: a frame chain is written BAG:/tf:PARENT:CHILD (two frame names after /tf)")
    parent, child = (f.lstrip("/") for f in frames)
    if not parent or not child:
        raise BagError(f"{source}: empty frame name in BAG:/tf:PARENT:CHILD")
    return BagSource(path, "/tf", parent, child)


def is_bag_source(source: object) -> bool:
    """Whether ``source`` (a str or path) names a bag or a topic of one (:func:`parse_bag_source`)."""
    if not isinstance(source, (str, os.PathLike, BagSource)):
        return False
    try:
        return parse_bag_source(source) is not None
    except BagError:
        return True


def bag_topics(path: str | os.PathLike[str]) -> dict[str, str]:
    """The topics of a bag and their message types (``"geometry_msgs/msg/PoseStamped"``), sorted by topic."""
    src = parse_bag_source(path) if isinstance(path, str) else None
    with open_bag(src.path if src is not None else Path(os.fspath(path))) as bag:
        return bag.topics()


def _pose_fields(f: Fields, msgtype: str) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Header stamps (n,) ns and the 7 pose values ``x y z qx qy qz qw`` (n, 7) of trajectory messages."""
    stamps = f.header()
    if msgtype in (TRANSFORM, ODOMETRY):
        f.string()  # child_frame_id
    return stamps, f.read("<f8", 7)


#: what a message parser returns: header stamps ns (n,) and the values (n, k)
_Parsed = tuple[NDArray[np.int64], NDArray[np.float64]]
#: the tf edges (parent, child) -> their (topic, stamps ns (n,), values x y z qx qy qz qw (n, 7)) series
_Edges = dict[tuple[str, str], list[tuple[str, NDArray[np.int64], NDArray[np.float64]]]]


def _read_records(
    bag: Bag, conns: list[Any], msgtype: str, where: str, parse: Callable[[Fields], _Parsed],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """Receive ns (N,), header ns (N,) and the parsed values (N, k) of all messages of ``conns``.

    The outputs are allocated once from the bag's message counts and filled block by block (peak memory: the
    outputs and one block); a count the bag got wrong only costs a copy."""
    total = sum(max(int(getattr(c, "msgcount", 0) or 0), 0) for c in conns)
    recv = np.empty(total, np.int64)
    head = np.empty(total, np.int64)
    vals: np.ndarray | None = None
    extra: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    first = None
    n = 0
    for times, buf, starts, ends, raw in bag.blocks(conns):
        if n == 0:
            first = raw
        f = Fields(buf, starts, ends, bag.is2, where, msgtype.replace("/msg/", "/"))
        stamps, values = parse(f)
        del buf, f
        if vals is None:
            vals = np.empty((total, values.shape[1]))
        m = min(len(times), max(total - n, 0))
        recv[n : n + m], head[n : n + m], vals[n : n + m] = times[:m], stamps[:m], values[:m]
        if m < len(times):
            extra.append((times[m:], stamps[m:], values[m:]))
        n += len(times)
    if vals is None:
        raise BagError(f"{where}: the topic has no messages")
    if n < total:
        recv, head, vals = recv[:n], head[:n], vals[:n]
    if extra:
        recv = np.concatenate([recv, *(e[0] for e in extra)])
        head = np.concatenate([head, *(e[1] for e in extra)])
        vals = np.concatenate([vals, *(e[2] for e in extra)])
    bag.verify(conns, msgtype, first, np.concatenate([[head[0]], vals[0]]), where)
    if (np.diff(recv) < 0).any():  # chunks out of time order: bag order is receive-time order, as rosbags'
        order = np.argsort(recv, kind="stable")
        recv, head, vals = recv[order], head[order], vals[order]
    return recv, head, vals


def _cat(parts: list[NDArray[Any]]) -> NDArray[Any]:
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


def _stamps(recv: np.ndarray, head: np.ndarray, stamps: str, where: str, strict: bool) -> NDArray[np.int64]:
    if stamps not in ("header", "receive"):
        raise ValueError(f"stamps must be 'header' or 'receive'; got {stamps!r}")
    ns = head if stamps == "header" else recv
    if strict:
        d = np.diff(ns)
        if (d <= 0).any():
            k = int(np.argmax(d <= 0)) + 1
            what = "the same stamp as" if d[k - 1] == 0 else "an earlier stamp than"
            hint = (" (read the bag's receive times instead with stamps='receive', CLI: --bag-time receive)"
                    if stamps == "header" else "")  # fmt: skip
            raise BagError(f"{where}: {stamps} stamps must be strictly increasing; message {k} has {what} message "
                           f"{k - 1} ({ns[k]} ns after {ns[k - 1]} ns){hint}")  # fmt: skip
    return ns


# ------------------------------------------------------------------------------------------------ readers


def _source(source: str | os.PathLike[str] | BagSource) -> BagSource:
    src = parse_bag_source(source)
    if src is None:
        name = str(source) if isinstance(source, BagSource) else os.fspath(source)
        raise BagError(f"{name}: not a bag (expected a .bag, .db3 or .mcap file or a ROS 2 bag "
                       "directory, with :/topic)")  # fmt: skip
    return src


def read_bag_trajectory(
    source: str | os.PathLike[str] | BagSource, *, stamps: Stamps = "header", strict: bool = True
) -> Trajectory:
    """Read the poses of a bag topic, or of a /tf frame chain, as a :class:`~dualpose.types.Trajectory`.

    Parameters
    ----------
    source : str, path-like or BagSource
        ``BAG:/topic`` of ``PoseStamped``, ``PoseWithCovarianceStamped``, ``TransformStamped`` or ``Odometry``
        messages, or ``BAG:/tf:PARENT:CHILD`` (:func:`parse_bag_source`).
    stamps : {"header", "receive"}
        ``header.stamp`` of the messages (default) or the bag's receive times.
    strict : bool
        Require strictly increasing stamps (default); False returns the poses in bag order, duplicates and all
        (for :func:`dualpose.calibration.clean_pose_stream`).

    Returns
    -------
    Trajectory
        ``stamps_ns`` exact int64 ns, ``stamps`` float s, ``positions`` (N, 3) m, ``quats`` (N, 4) xyzw as stored;
        the pose of the message's (child) frame in its header frame.  ``name`` is the source text.

    Raises
    ------
    BagError
        A missing topic (the message lists the topics), a message type without a pose, stamps not strictly
        increasing, a frame chain not in /tf, a zero quaternion.
    FileNotFoundError
        When the bag does not exist.
    ImportError
        When ``rosbags`` is not installed (``pip install 'dualpose[ros]'``).
    """
    src = _source(source)
    if src.parent is not None:
        ns, pos, quat = _tf_chain(src, stamps, strict)
    else:
        with open_bag(src.path) as bag:
            conns = bag.connections(src.topic, TRAJECTORY_TYPES, "poses")
            if len({c.msgtype for c in conns}) != 1:
                raise BagError(f"{src}: the topic mixes message types {sorted({c.msgtype for c in conns})}")
            msgtype = conns[0].msgtype

            def parse(f: Fields) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
                return _pose_fields(f, msgtype)

            recv, head, vals = _read_records(bag, conns, msgtype, str(src), parse)
        ns = _stamps(recv, head, stamps, str(src), strict)
        pos, quat = vals[:, 0:3], vals[:, 3:7]
    try:
        return Trajectory(seconds_from_ns(ns), pos, quat, ns, str(src))
    except ValueError as exc:
        raise BagError(f"{src}: {exc}") from None


def read_bag_imu(source: str | os.PathLike[str] | BagSource, *, stamps: Stamps = "header") -> ImuData:
    """Read the ``sensor_msgs/Imu`` messages of a bag topic.

    Returns
    -------
    ImuData
        ``stamps_ns`` exact int64 ns (strictly increasing), ``gyro`` (N, 3) ``angular_velocity`` rad/s,
        ``accel`` (N, 3) ``linear_acceleration`` m/s² (specific force, REP 145), in the IMU frame
        (``header.frame_id``).  The orientation and the covariances are not read.

    Raises
    ------
    BagError
        As :func:`read_bag_trajectory`; also fewer than two messages or non-finite values.
    """
    src = _source(source)
    with open_bag(src.path) as bag:
        conns = bag.connections(src.topic, (IMU,), "IMU samples")

        def parse(f: Fields) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
            head = f.header()
            f.skip("<f8", 4 + 9)  # orientation, orientation_covariance
            gyro = f.read("<f8", 3)
            f.skip("<f8", 9)
            return head, np.hstack([gyro, f.read("<f8", 3)])

        recv, head, vals = _read_records(bag, conns, IMU, str(src), parse)
    ns = _stamps(recv, head, stamps, str(src), True)
    _finite(vals, src, "angular_velocity / linear_acceleration")
    if ns.shape[0] < 2:
        raise BagError(f"{src}: at least two IMU messages are needed; found {ns.shape[0]}")
    return ImuData(ns, seconds_from_ns(ns), vals[:, 0:3], vals[:, 3:6], str(src))


def read_bag_magnetic_field(
    source: str | os.PathLike[str] | BagSource, *, stamps: Stamps = "header"
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Read the ``sensor_msgs/MagneticField`` messages of a bag topic.

    Returns
    -------
    stamps_ns : ndarray of int64, shape (N,)
        Strictly increasing, ns.
    field : ndarray, shape (N, 3)
        ``magnetic_field`` in the sensor frame, **tesla** (the message's unit; BROAD files and
        :func:`dualpose.io.load_broad` use µT).

    Raises
    ------
    BagError
        As :func:`read_bag_imu`.
    """
    src = _source(source)
    with open_bag(src.path) as bag:
        conns = bag.connections(src.topic, (MAG,), "a magnetic field")

        def parse(f: Fields) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
            return f.header(), f.read("<f8", 3)

        recv, head, vals = _read_records(bag, conns, MAG, str(src), parse)
    ns = _stamps(recv, head, stamps, str(src), True)
    _finite(vals, src, "magnetic_field")
    return ns, vals


def read_bag_imu_trial(
    source: str | os.PathLike[str] | BagSource,
    mag_source: str | os.PathLike[str] | BagSource | None = None,
    *,
    stamps: Stamps = "header",
    rest_seconds: float = 1.0,
) -> BroadTrial:
    """An IMU topic (and a magnetometer topic) of a bag as the :class:`~dualpose.io.broad.BroadTrial` the AHRS
    (``dualpose ahrs``) runs on, without a reference orientation.

    Parameters
    ----------
    source : str, path-like or BagSource
        ``BAG:/topic`` of ``sensor_msgs/Imu`` messages (:func:`read_bag_imu`).
    mag_source : str, path-like, BagSource or None
        ``BAG:/topic`` (or ``/topic`` of the same bag) of ``sensor_msgs/MagneticField`` messages; linearly
        interpolated at the IMU stamps and converted from tesla to µT.  IMU samples outside the magnetometer's time
        span are dropped.  None: a 6D trial (``has_mag`` False, ``mag`` NaN).
    stamps : {"header", "receive"}
        As :func:`read_bag_trajectory`.
    rest_seconds : float
        The leading seconds at rest that initialise the filter: the samples before are the trial's static start
        (``movement`` False), the rest its movement phase.

    Returns
    -------
    BroadTrial
        ``rate`` = 1 / median IMU sample interval (Hz); ``gyr`` rad/s, ``acc`` m/s², ``mag`` µT in IMU axes;
        ``quat`` and ``pos`` NaN (no reference); ``name`` the source text.
    """
    if not (isinstance(rest_seconds, (int, float)) and np.isfinite(rest_seconds) and rest_seconds >= 0):
        raise ValueError(f"rest_seconds must be a finite number >= 0; got {rest_seconds!r}")
    src = _source(source)
    imu = read_bag_imu(src, stamps=stamps)
    ns, gyr, acc = imu.stamps_ns, imu.gyro, imu.accel
    mag = np.full_like(gyr, np.nan)
    if mag_source is not None:
        if isinstance(mag_source, str) and mag_source.startswith("/"):
            mag_source = BagSource(src.path, mag_source)
        msrc = _source(mag_source)
        mns, field = read_bag_magnetic_field(msrc, stamps=stamps)
        keep = (ns >= mns[0]) & (ns <= mns[-1])
        if keep.sum() < 2:
            raise BagError(f"{msrc}: the magnetometer messages do not overlap the IMU messages of {src} in time")
        ns, gyr, acc = ns[keep], gyr[keep], acc[keep]
        t, tm = (ns - ns[0]) * 1e-9, (mns - ns[0]) * 1e-9
        mag = np.stack([np.interp(t, tm, field[:, i]) for i in range(3)], axis=1) * 1e6
    t = (ns - ns[0]) * 1e-9
    rate = 1.0 / float(np.median(np.diff(t)))
    n = ns.shape[0]
    return BroadTrial(
        name=str(src), rate=rate, gyr=gyr, acc=acc, mag=mag, quat=np.full((n, 4), np.nan), pos=np.full((n, 3), np.nan),
        movement=t >= rest_seconds, info=f"IMU from {src}" + (f", magnetometer {mag_source}" if mag_source else ""),
        has_mag=mag_source is not None,
    )  # fmt: skip


def _finite(vals: np.ndarray, src: BagSource, what: str) -> None:
    bad = ~np.isfinite(vals).all(axis=1)
    if bad.any():
        raise BagError(f"{src}: message {int(np.argmax(bad))}: non-finite {what}")


# ------------------------------------------------------------------------------------------------ /tf chains


#: the transforms of /tf connections (see _tf_records)
_TfRecords = tuple[
    NDArray[np.int64], NDArray[np.int64], NDArray[np.intp], NDArray[np.intp], NDArray[np.float64], list[str]
]


def _tf_records(bag: Bag, conns: list[Any], where: str) -> _TfRecords | None:
    """All transforms of ``tf2_msgs/TFMessage`` connections: receive ns and header ns of each transform, parent
    and child frame ids (indices into the returned names), and the 7 values ``x y z qx qy qz qw``."""
    recv: list[NDArray[np.int64]] = []
    head: list[NDArray[np.int64]] = []
    offs: list[NDArray[np.int64]] = []
    vals: list[NDArray[np.float64]] = []
    bufs: list[NDArray[np.uint8]] = []
    for times, buf, starts, ends, _ in bag.blocks(conns):
        f = Fields(buf, starts, ends, bag.is2, where, "tf2_msgs/TFMessage")
        count = f.read("<u4")[:, 0].astype(np.int64)
        for k in range(int(count.max(initial=0))):
            idx = np.flatnonzero(count > k)
            g = f.sub(idx)
            stamp = g.header()
            parent = g.frame_id
            child = g.string()
            v = g.read("<f8", 7)
            f.pos[idx] = g.pos
            base = sum(b.shape[0] for b in bufs)
            recv.append(times[idx])
            head.append(stamp)
            offs.append(np.stack([parent[0] + base, parent[1], child[0] + base, child[1]], axis=1))
            vals.append(v)
        bufs.append(buf)
    if not vals:
        return None
    allbuf = _cat(bufs)
    spans = _cat(offs)
    names, ids = _frame_ids(allbuf, np.concatenate([spans[:, 0:2], spans[:, 2:4]]))
    m = spans.shape[0]
    return _cat(recv), _cat(head), ids[:m], ids[m:], _cat(vals), names


def _frame_ids(buf: np.ndarray, spans: np.ndarray) -> tuple[list[str], NDArray[np.intp]]:
    """Frame names (leading '/' dropped) and the index of each span's name: spans (m, 2) offset, length."""
    off, length = spans[:, 0].copy(), spans[:, 1].copy()
    slash = (length > 0) & (buf[np.minimum(off, buf.shape[0] - 1)] == ord("/"))
    off[slash] += 1
    length[slash] -= 1
    width = int(length.max(initial=0))
    cols = np.arange(max(width, 1))
    mask = cols < length[:, None]
    text = np.where(mask, buf[np.minimum(off[:, None] + cols, buf.shape[0] - 1)], 0).astype(np.uint8)
    rows = np.ascontiguousarray(text).view(f"V{text.shape[1]}")[:, 0]
    uniq, ids = np.unique(rows, return_inverse=True)
    names = [bytes(u).rstrip(b"\0").decode("utf-8", "replace") for u in uniq]
    return names, ids.ravel()


def _compose(
    q1: np.ndarray, t1: np.ndarray, q2: np.ndarray, t2: np.ndarray,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(q1, t1) ∘ (q2, t2)``: the pose of frame 2 in frame 0 from frame 1 in 0 and frame 2 in 1."""
    return dp.quat_mul(q1, q2), t1 + dp.quat_rotate(q1, t2)


def _tf_chain(
    src: BagSource, stamps: str, strict: bool,
) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Stamps (ns), positions and xyzw quaternions of ``src.child`` in ``src.parent`` through /tf and /tf_static.

    Every tf edge on the frame path is a time series (``/tf``) or a constant (only in ``/tf_static``: its last
    value).  The chain is evaluated at the stamps of the moving edge with the most transforms, inside the time
    span of every moving edge; the other moving edges are interpolated there (linear position, slerp).
    """
    if stamps not in ("header", "receive"):
        raise ValueError(f"stamps must be 'header' or 'receive'; got {stamps!r}")
    where = str(src)
    with open_bag(src.path) as bag:
        types = bag.topics()
        conns = [c for c in bag.all_connections() if c.topic in ("/tf", "/tf_static")]
        if not conns:
            raise BagError(f"{src.path}: no /tf or /tf_static topic; {bag.listing()}")
        bad = sorted({c.msgtype for c in conns} - set(TF))
        if bad:
            raise BagError(f"{where}: /tf message type {bad[0]} (expected tf2_msgs/TFMessage)")
        parts = {}
        for topic in ("/tf", "/tf_static"):
            cs = [c for c in conns if c.topic == topic]
            if cs:
                parts[topic] = _tf_records(bag, cs, f"{src.path}:{topic}")
    del types
    names: list[str] = []
    for rec in parts.values():
        if rec is not None:
            names = sorted(set(names) | set(rec[5]))
    edges: _Edges = {}
    for topic, rec in parts.items():
        if rec is None:
            continue
        recv, head, pid, cid, vals, local = rec
        ns = head if stamps == "header" else recv
        pairs = np.stack([pid, cid], axis=1)
        for a, b in np.unique(pairs, axis=0).tolist():
            sel = (pid == a) & (cid == b)
            edges.setdefault((local[a], local[b]), []).append((topic, ns[sel], vals[sel]))
    if src.parent is None or src.child is None:  # parse_bag_source sets both for /tf:parent:child
        raise BagError(f"{where}: a /tf chain needs its parent and child frames (FILE:/tf:parent:child)")
    path = _frame_path(edges, src.parent, src.child)
    if path is None:
        known = ", ".join(f"{a}->{b}" for a, b in sorted(edges)) or "none"
        raise BagError(f"{where}: no chain of transforms from frame {src.parent!r} to {src.child!r} in /tf and "
                       f"/tf_static; transforms in the bag (parent->child): {known}")  # fmt: skip
    series = []  # (ns or None, quats, positions, inverted)
    for a, b, inverted in path:
        dynamic = [(ns, v) for topic, ns, v in edges[(a, b)] if topic == "/tf"]
        if dynamic:
            ns = _cat([d[0] for d in dynamic])
            v = _cat([d[1] for d in dynamic])
            order = np.argsort(ns, kind="stable")
            ns, v = ns[order], v[order]
            keep = np.concatenate([[True], np.diff(ns) > 0])  # tf republishes a stamp: keep its first transform
            series.append((ns[keep], v[keep], inverted, f"{a}->{b}"))
        else:
            v = edges[(a, b)][-1][2][-1:]
            series.append((None, v, inverted, f"{a}->{b}"))
    moving = [s for s in series if s[0] is not None]
    if not moving:
        raise BagError(f"{where}: every transform from {src.parent!r} to {src.child!r} is static (/tf_static): "
                       "no trajectory")  # fmt: skip
    base = max(moving, key=lambda s: s[0].shape[0])[0]
    lo = max(s[0][0] for s in moving)
    hi = min(s[0][-1] for s in moving)
    t_ns = base[(base >= lo) & (base <= hi)]
    if t_ns.shape[0] == 0:
        raise BagError(f"{where}: the moving transforms of the chain do not overlap in time")
    q = np.tile([0.0, 0.0, 0.0, 1.0], (t_ns.shape[0], 1))
    p = np.zeros((t_ns.shape[0], 3))
    for ns, v, inverted, _ in series:
        if ns is None:
            pe, qe = np.broadcast_to(v[:, 0:3], p.shape), np.broadcast_to(v[:, 3:7], q.shape)
        elif ns is base:
            sel = (base >= lo) & (base <= hi)
            pe, qe = v[sel, 0:3], v[sel, 3:7]
        elif ns.shape[0] == 1:
            pe, qe = np.broadcast_to(v[:, 0:3], p.shape), np.broadcast_to(v[:, 3:7], q.shape)
        else:
            rel = (ns - t_ns[0]) * 1e-9
            pe, qe = interpolate_poses(rel, v[:, 0:3], v[:, 3:7], (t_ns - t_ns[0]) * 1e-9)
        qe = dp.quat_normalize(qe)
        if inverted:
            qe = dp.quat_conj(qe)
            pe = -dp.quat_rotate(qe, pe)
        q, p = _compose(q, p, qe, pe)
    if strict:
        _stamps(t_ns, t_ns, stamps, where, True)
    return t_ns, p, q


def _frame_path(edges: _Edges, start: str, goal: str) -> list[tuple[str, str, bool]] | None:
    """Edges (parent, child, inverted) from ``start`` to ``goal``, breadth first over the tf edges both ways."""
    links: dict[str, list[tuple[str, tuple[str, str, bool]]]] = {}
    for a, b in edges:
        links.setdefault(a, []).append((b, (a, b, False)))
        links.setdefault(b, []).append((a, (a, b, True)))
    prev: dict[str, tuple[str, tuple[str, str, bool]] | None] = {start: None}
    todo = deque([start])
    while todo:
        node = todo.popleft()
        if node == goal:
            out = []
            step = prev[node]
            while step is not None:
                node, edge = step
                out.append(edge)
                step = prev[node]
            return out[::-1]
        for nxt, edge in links.get(node, []):
            if nxt not in prev:
                prev[nxt] = (node, edge)
                todo.append(nxt)
    return None


# ------------------------------------------------------------------------------------------------ writer


def _pose_stamped_bytes(trajectory: Trajectory, ns: np.ndarray, frame_id: bytes, cdr: bool) -> NDArray[np.uint8]:
    """The serialized ``geometry_msgs/PoseStamped`` messages, uint8 (N, size)."""
    n, flen = len(trajectory), len(frame_id)
    if cdr:  # encapsulation, sec int32, nanosec uint32, frame_id (uint32 length with NUL), pad to 8, 7 float64
        pose_at = 4 + -(-(12 + flen + 1) // 8) * 8
        names = ["enc", "sec", "nsec", "len", "frame", "pose"]
        formats = ["<u4", "<i4", "<u4", "<u4", ("u1", (flen,)), ("<f8", (7,))]
        offsets = [0, 4, 8, 12, 16, pose_at]
    else:  # seq, secs, nsecs, frame_id (uint32 length), 7 float64
        pose_at = 16 + flen
        names = ["seq", "sec", "nsec", "len", "frame", "pose"]
        formats = ["<u4", "<u4", "<u4", "<u4", ("u1", (flen,)), ("<f8", (7,))]
        offsets = [0, 4, 8, 12, 16, pose_at]
    dt = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": pose_at + 56})
    out = np.zeros(n, dt)
    sec, nsec = np.divmod(ns, 1_000_000_000)
    if cdr:
        out["enc"] = 0x0100  # bytes 00 01 00 00: CDR, little-endian
        out["len"] = flen + 1
    else:
        out["seq"] = np.arange(n, dtype=np.uint32)
        out["len"] = flen
    out["sec"] = sec
    out["nsec"] = nsec
    if flen:
        out["frame"] = np.frombuffer(frame_id, np.uint8)
    out["pose"][:, 0:3] = trajectory.positions
    out["pose"][:, 3:7] = trajectory.quats
    return out.view(np.uint8).reshape(n, dt.itemsize)


def write_trajectory_bag(
    path: str | os.PathLike[str],
    trajectory: Trajectory,
    topic: str = "/pose",
    frame_id: str = "world",
    *,
    ros_version: int | None = None,
    overwrite: bool = False,
) -> Path:
    """Write ``trajectory`` as ``geometry_msgs/PoseStamped`` messages on ``topic`` of a new bag.

    Parameters
    ----------
    path : path-like
        ``.bag`` (ROS 1), ``.db3`` (ROS 2, SQLite) or ``.mcap`` (ROS 2, MCAP): a single file that
        :func:`read_bag_trajectory` and ``ros2 bag`` read.
    trajectory : Trajectory
        Stamps: ``stamps_ns`` when present, else ``stamps`` rounded to ns; they are the header stamp and the bag
        time of each message.  Quaternions written as stored (xyzw).
    topic : str
        Topic name, starting with ``/``.
    frame_id : str
        ``header.frame_id``: the frame the poses are expressed in.
    ros_version : {1, 2} or None
        Checked against the suffix when given.
    overwrite : bool
        Replace an existing file; by default an existing file raises ``FileExistsError``.

    Returns
    -------
    Path
        The bag written.
    """
    if not isinstance(trajectory, Trajectory):
        raise TypeError(f"trajectory must be a dualpose.io.Trajectory; got {type(trajectory).__name__}")
    out = Path(check_path(path))
    suffix = out.suffix.lower()
    if suffix not in BAG_SUFFIXES:
        raise ValueError(f"path must end in .bag (ROS 1), .db3 or .mcap (ROS 2); got {os.fspath(path)!r}")
    version = 1 if suffix == ".bag" else 2
    if ros_version is not None and ros_version != version:
        raise ValueError(f"ros_version={ros_version!r} does not match {out.name} (a ROS {version} bag)")
    if not isinstance(topic, str) or not topic.startswith("/"):
        raise ValueError(f"topic must be a str starting with '/'; got {topic!r}")
    if not isinstance(frame_id, str):
        raise TypeError(f"frame_id must be a str; got {type(frame_id).__name__}")
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out}: file exists; pass overwrite=True (CLI: --force) to replace it")
    if len(trajectory) == 0:
        raise ValueError("trajectory has no poses")
    ns = trajectory.stamps_ns
    if ns is None:
        ns = np.round(trajectory.stamps * 1e9).astype(np.int64)
    if (ns < 0).any():
        raise ValueError("trajectory stamps must be >= 0 (ROS times are unsigned)")
    check_rosbags()
    from rosbags.typesys import Stores, get_typestore

    rows = _pose_stamped_bytes(trajectory, ns, frame_id.encode(), cdr=version == 2)
    tmp = temporary_sibling_dir(out)  # removed below; one a killed writer left is removed by the next writer
    try:
        if version == 1:
            from rosbags.rosbag1 import Writer as Writer1

            made = tmp / "out.bag"
            writer: Writer1 | Writer2 = Writer1(made)
            store = get_typestore(Stores.ROS1_NOETIC)
        else:
            from rosbags.rosbag2 import StoragePlugin
            from rosbags.rosbag2 import Writer as Writer2

            plugin = StoragePlugin.MCAP if suffix == ".mcap" else StoragePlugin.SQLITE3
            writer = Writer2(tmp / "out", version=9, storage_plugin=plugin)
            made = tmp / "out" / f"out{suffix}"
            store = get_typestore(Stores.LATEST)
        with writer:
            conn = writer.add_connection(topic, POSE, typestore=store)
            write = writer.write
            for t, row in zip(ns.tolist(), rows, strict=True):
                write(conn, t, row.tobytes())
        os.replace(made, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return out
