"""The reading machinery of :mod:`dualpose.io.rosbag`: opening a bag, ROS 1 bags read from their chunk index, and
the message fields read with NumPy for all messages at once (:class:`Fields`).  The module docstring of
:mod:`dualpose.io.rosbag` describes the layouts; errors are :class:`BagError` naming the bag and the topic."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from itertools import islice
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:  # rosbags is optional (the ros extra): imported where a bag is opened
    from rosbags.highlevel import AnyReader, AnyReaderError

__all__ = [
    "Bag", "BagError", "Fields", "check_rosbags", "open_bag",
    "POSE", "POSE_COV", "TRANSFORM", "ODOMETRY", "TF", "IMU", "MAG", "TRAJECTORY_TYPES", "BLOCK",
]  # fmt: skip

#: message types (rosbags' names; ROS 1 ``pkg/Type`` is read as ``pkg/msg/Type``)

POSE = "geometry_msgs/msg/PoseStamped"
POSE_COV = "geometry_msgs/msg/PoseWithCovarianceStamped"
TRANSFORM = "geometry_msgs/msg/TransformStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
TF = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")  # the same layout
IMU = "sensor_msgs/msg/Imu"
MAG = "sensor_msgs/msg/MagneticField"
TRAJECTORY_TYPES = (POSE, POSE_COV, TRANSFORM, ODOMETRY)

#: messages parsed per block (bounds the temporary memory next to the output arrays)
BLOCK = 1 << 14
#: a block of messages: receive ns (n,) int64, the buffer (uint8) holding them, the start and end byte of each
#: message in it (n,) int64, and the first message's raw bytes (rosbags' reader) or None (ROS 1 bags)
Block = tuple[NDArray[np.int64], NDArray[np.uint8], NDArray[np.int64], NDArray[np.int64], bytes | None]


class BagError(ValueError):
    """A bag or topic that cannot be read as asked; the message names the bag and the topic."""


# ------------------------------------------------------------------------------------------------ opening


def check_rosbags() -> tuple[type[AnyReader], type[AnyReaderError]]:
    """The ``rosbags`` modules, or a clear ImportError."""
    try:
        from rosbags.highlevel import AnyReader, AnyReaderError
    except ImportError:
        raise ImportError(
            "reading and writing ROS bags needs the rosbags package: pip install 'dualpose[ros]'"
        ) from None
    return AnyReader, AnyReaderError


class Bag:
    """An open ROS 2 bag (rosbags' AnyReader) with the error messages of this module."""

    def __init__(self, path: Path) -> None:
        AnyReader, AnyReaderError = check_rosbags()
        self.path = path
        if not path.exists():
            raise FileNotFoundError(f"{path}: no such bag")
        try:
            self.reader = AnyReader([path])
            self.reader.open()
        except (AnyReaderError, OSError, KeyError, ValueError) as exc:
            raise BagError(f"{path}: cannot read the bag ({exc})") from None
        self.is2 = self.reader.is2

    def __enter__(self) -> Bag:
        return self

    def __exit__(self, *exc: object) -> None:
        self.reader.close()

    def topics(self) -> dict[str, str]:
        return {name: str(info.msgtype) for name, info in sorted(self.reader.topics.items())}

    def listing(self) -> str:
        topics = self.topics()
        if not topics:
            return "the bag has no topics"
        return "topics in the bag: " + ", ".join(f"{t} ({m.replace('/msg/', '/')})" for t, m in topics.items())

    def connections(self, topic: str | None, types: tuple[str, ...], what: str) -> list[Any]:
        """The connections of ``topic``; BagError listing the topics when it is absent, or its type not in
        ``types``."""
        if topic is None:
            raise BagError(f"{self.path}: name the topic of the {what}: {self.path}:/TOPIC; {self.listing()}")
        conns = [c for c in self.all_connections() if c.topic == topic]
        if not conns:
            raise BagError(f"{self.path}: no topic {topic}; {self.listing()}")
        bad = sorted({c.msgtype for c in conns} - set(types))
        if bad:
            want = ", ".join(t.replace("/msg/", "/") for t in types)
            raise BagError(
                f"{self.path}:{topic}: message type {bad[0].replace('/msg/', '/')} does not hold {what} "
                f"(expected {want})"
            )
        return conns

    def all_connections(self) -> list[Any]:
        """The bag's connections: rosbags' ``Connection`` objects (here) or ``_Conn1`` records (ROS 1 bags)."""
        return list(self.reader.connections)

    def blocks(self, conns: list[Any]) -> Iterator[Block]:
        """(receive ns, buffer, starts, ends, first raw message) of ``conns`` in bag order, in blocks of at most
        ``BLOCK`` messages: message k of a block is ``buffer[starts[k]:ends[k]]``."""
        gen = self.reader.messages(connections=conns)
        while True:
            batch = list(islice(gen, BLOCK))
            if not batch:
                return
            _, times, raws = zip(*batch, strict=True)
            del batch
            sizes = np.fromiter(map(len, raws), np.int64, len(raws))
            ends = np.cumsum(sizes)
            buf = np.frombuffer(b"".join(raws), np.uint8)
            yield np.fromiter(times, np.int64, len(times)), buf, ends - sizes, ends, raws[0]

    def verify(self, conns: list[Any], msgtype: str, first: bytes | None, values: np.ndarray, where: str) -> None:
        """Compare the values parsed from the first message with rosbags' own deserializer."""
        if first is None:  # blocks() of this reader always hands the first raw message
            raise BagError(f"{where}: no raw message to verify the layout with")
        _check_first(self.reader.deserialize(first, msgtype), msgtype, values, where)


@dataclass(frozen=True)
class _Conn1:
    """A connection of a ROS 1 bag (its connection record)."""

    id: int
    topic: str
    msgtype: str
    md5sum: str
    msgcount: int


_INDEX_ENTRY = np.dtype([("sec", "<u4"), ("nsec", "<u4"), ("offset", "<u4")])


class _Ros1Bag(Bag):
    """An open ROS 1 bag (format 2.0) read with NumPy: the connection and chunk-info records at the index position,
    then per chunk its index-data records (fixed-size ``time, offset`` entries: NumPy arrays) and the chunk's
    message records at those offsets.  No per-message Python object; compression none, bz2 or lz4 (rosbags'
    dependencies).  Record layout: the ROS bag format 2.0 (wiki.ros.org/Bags/Format/2.0)."""

    def __init__(self, path: Path) -> None:
        check_rosbags()
        self.path = path
        self.is2 = False
        try:
            self.file = open(path, "rb")
        except OSError as exc:
            raise BagError(f"{path}: cannot read the bag ({exc.strerror or exc})") from None
        try:
            self._read_index()
        except BagError:
            self.file.close()
            raise
        except (OSError, ValueError, KeyError, IndexError) as exc:
            self.file.close()
            raise BagError(f"{path}: cannot read the bag ({exc})") from None

    def __exit__(self, *exc: object) -> None:
        self.file.close()

    def _record(self) -> tuple[dict[str, bytes], int, int]:
        """The header fields of the record at the file position, its data position and length (data not read)."""
        head = self.file.read(4)
        if len(head) < 4:
            raise BagError(f"{self.path}: truncated bag (a record expected at byte {self.file.tell() - len(head)})")
        fields = _header_fields(self.file.read(int.from_bytes(head, "little")))
        size = int.from_bytes(self.file.read(4), "little")
        return fields, self.file.tell(), size

    def _data(self, pos: int, size: int) -> bytes:
        self.file.seek(pos)
        data = self.file.read(size)
        if len(data) != size:
            raise BagError(f"{self.path}: truncated bag (record data at byte {pos})")
        return data

    def _read_index(self) -> None:
        if self.file.read(13) != b"#ROSBAG V2.0\n":
            raise BagError(f"{self.path}: not a ROS 1 bag of format 2.0 (no '#ROSBAG V2.0' line)")
        head, _, _ = self._record()
        if head.get("op") != b"\x03":
            raise BagError(f"{self.path}: no bag header record")
        index_pos = int.from_bytes(head["index_pos"], "little")
        n_conns = int.from_bytes(head["conn_count"], "little")
        n_chunks = int.from_bytes(head["chunk_count"], "little")
        if index_pos == 0:
            raise BagError(f"{self.path}: the bag has no index (not closed properly): run 'rosbag reindex' on it")
        self.file.seek(index_pos)
        conns: dict[int, tuple[str, str, str]] = {}
        self.chunks: list[tuple[int, dict[int, int]]] = []
        for _ in range(n_conns + n_chunks):
            head, pos, size = self._record()
            data = self._data(pos, size)
            if head.get("op") == b"\x07":
                info = _header_fields(data)
                msgtype = info["type"].decode()
                if "/msg/" not in msgtype:
                    msgtype = msgtype.replace("/", "/msg/", 1)
                cid = int.from_bytes(head["conn"], "little")
                conns[cid] = (head["topic"].decode(), msgtype, info["md5sum"].decode())
            elif head.get("op") == b"\x06":
                counts = np.frombuffer(data, "<u4").reshape(-1, 2)
                self.chunks.append((int.from_bytes(head["chunk_pos"], "little"), dict(counts.tolist())))
            else:
                self.file.seek(pos + size)
        totals: dict[int, int] = {}
        for _, chunk_counts in self.chunks:
            for cid, n in chunk_counts.items():
                totals[cid] = totals.get(cid, 0) + n
        self.conns = [_Conn1(cid, t, m, h, totals.get(cid, 0)) for cid, (t, m, h) in sorted(conns.items())]

    def all_connections(self) -> list[Any]:
        return list(self.conns)

    def topics(self) -> dict[str, str]:
        return dict(sorted({c.topic: c.msgtype for c in self.conns}.items()))

    def blocks(self, conns: list[Any]) -> Iterator[Block]:
        """(receive ns, chunk buffer, starts, ends, None) of the messages of ``conns`` chunk by chunk."""
        ids = {c.id for c in conns}
        for chunk_pos, counts in self.chunks:
            if not ids & counts.keys():
                continue
            self.file.seek(chunk_pos)
            head, pos, size = self._record()
            if head.get("op") != b"\x05":
                raise BagError(f"{self.path}: no chunk record at byte {chunk_pos}")
            compression = head.get("compression", b"none").decode()
            entries = []
            self.file.seek(pos + size)
            for _ in range(len(counts)):
                ihead, ipos, isize = self._record()
                if ihead.get("op") != b"\x04":
                    raise BagError(f"{self.path}: no index-data record after the chunk at byte {chunk_pos}")
                cid = int.from_bytes(ihead["conn"], "little")
                if cid in ids:
                    entries.append(np.frombuffer(self._data(ipos, isize), _INDEX_ENTRY))
                    self.file.seek(ipos + isize)
                else:
                    self.file.seek(ipos + isize)
            data = self._data(pos, size)
            if compression == "bz2":
                import bz2

                data = bz2.decompress(data)
            elif compression == "lz4":
                from lz4.frame import decompress

                data = decompress(data)
            elif compression != "none":
                raise BagError(f"{self.path}: chunk compression {compression!r} (known: none, bz2, lz4)")
            index = np.concatenate(entries) if len(entries) > 1 else entries[0]
            recv = index["sec"].astype(np.int64) * 1_000_000_000 + index["nsec"]
            if len(entries) > 1:
                order = np.argsort(recv, kind="stable")
                index, recv = index[order], recv[order]
            buf = np.frombuffer(data, np.uint8)
            off = index["offset"].astype(np.int64)
            header_len = _u32_at(buf, off, self.path)
            data_at = off + 4 + header_len
            size_msg = _u32_at(buf, data_at, self.path)
            starts = data_at + 4
            ends = starts + size_msg
            if ends.max(initial=0) > buf.shape[0]:
                raise BagError(f"{self.path}: a message record runs past its chunk (byte {chunk_pos}): corrupt bag")
            yield recv, buf, starts, ends, None

    def verify(self, conns: list[Any], msgtype: str, first: bytes | None, values: np.ndarray, where: str) -> None:
        """The connections' md5 sums (of the message definitions) must be the standard type's."""
        want = _ros1_md5(msgtype)
        bad = [c for c in conns if c.md5sum != want]
        if bad:
            raise BagError(f"{where}: the {msgtype.replace('/msg/', '/')} messages do not have the standard layout "
                           f"(md5sum {bad[0].md5sum}, the standard definition's is {want}); not read")  # fmt: skip


def open_bag(path: Path) -> Bag:
    """The bag at ``path``: a ROS 1 ``.bag`` file read from its chunk index, anything else through rosbags."""
    if path.suffix.lower() == ".bag" and path.is_file():
        return _Ros1Bag(path)
    return Bag(path)


def _header_fields(raw: bytes) -> dict[str, bytes]:
    """The ``name=value`` fields of a ROS 1 record header (each a uint32 length, then the bytes)."""
    fields, i = {}, 0
    while i + 4 <= len(raw):
        n = int.from_bytes(raw[i : i + 4], "little")
        key, _, value = raw[i + 4 : i + 4 + n].partition(b"=")
        fields[key.decode("ascii", "replace")] = value
        i += 4 + n
    return fields


def _u32_at(buf: np.ndarray, pos: np.ndarray, path: Path) -> NDArray[np.int64]:
    """The little-endian uint32 at byte ``pos[i]`` of ``buf``, int64 (n,)."""
    if pos.shape[0] and (pos.min() < 0 or pos.max() + 4 > buf.shape[0]):
        raise BagError(f"{path}: an index entry points outside its chunk: corrupt bag")
    return np.ascontiguousarray(buf[pos[:, None] + np.arange(4)]).view("<u4")[:, 0].astype(np.int64)


def _ros1_md5(msgtype: str) -> str:
    """md5sum of the standard ROS 1 definition of ``msgtype`` (rosbags' Noetic type store)."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    if msgtype not in store.types and msgtype in TF:
        from rosbags.typesys import get_types_from_msg

        store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", msgtype))
    return store.generate_msgdef(msgtype)[1]


# ------------------------------------------------------------------------------------------------ parsing


class Fields:
    """Field offsets of n serialized messages of one type held in one byte buffer, advanced field by field.

    ``pos`` is the offset of the next field in every message.  ROS 1: packed, no alignment.  CDR: every primitive
    is aligned to its size counted from the end of the 4-byte encapsulation header; strings are a uint32 length
    that includes the terminating NUL, then the bytes.  Both little-endian (a big-endian CDR message is refused).
    """

    def __init__(self, buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, cdr: bool, where: str, kind: str):
        self.buf, self.starts, self.ends, self.cdr, self.where, self.kind = buf, starts, ends, cdr, where, kind
        self.origin = starts + 4 if cdr else starts
        self.pos = self.origin.copy()
        n = starts.shape[0]
        self.uniform = n > 1 and bool((np.diff(starts) == starts[1] - starts[0]).all())
        if cdr and n:
            self._check(self.origin)
            little = self.take(starts + 1, 1)[:, 0] & 1
            if not little.all():
                k = int(np.argmin(little))
                raise BagError(f"{where}: message {k} is big-endian CDR; only little-endian CDR is read")

    def sub(self, index: np.ndarray) -> Fields:
        """The same buffer, messages ``index`` only, at their current offsets."""
        out = object.__new__(Fields)
        out.buf, out.cdr, out.where, out.kind, out.uniform = self.buf, self.cdr, self.where, self.kind, False
        out.starts, out.ends, out.origin = self.starts[index], self.ends[index], self.origin[index]
        out.pos = self.pos[index].copy()
        return out

    def _check(self, stop: np.ndarray) -> None:
        short = stop > self.ends
        if short.any():
            k = int(np.argmax(short))
            size = int(self.ends[k] - self.starts[k])
            raise BagError(f"{self.where}: message {k} is shorter than a {self.kind} ({size} bytes): not the "
                           "standard message layout")  # fmt: skip

    def align(self, size: int) -> None:
        if self.cdr and size > 1:
            self.pos = self.origin + (self.pos - self.origin + size - 1) // size * size

    def take(self, pos: np.ndarray, nbytes: int) -> NDArray[np.uint8]:
        """Bytes ``pos[i]:pos[i] + nbytes`` of every message, uint8 (n, nbytes): a strided view of the buffer when
        the offsets are evenly spaced (messages of one layout, back to back or in equal records), else gathered."""
        n = pos.shape[0]
        if self.uniform and n > 1:
            step = int(pos[1] - pos[0])
            if step > 0 and bool((np.diff(pos) == step).all()):
                view = self.buf[int(pos[0]) : int(pos[-1]) + nbytes]
                return np.lib.stride_tricks.as_strided(view, (n, nbytes), (step, 1), writeable=False)
        return self.buf[pos[:, None] + np.arange(nbytes)]

    def read(self, dtype: str, count: int = 1) -> NDArray[Any]:
        """``count`` values of ``dtype`` ('<u4', '<i4', '<f8') per message, shape (n, count); advances."""
        size = np.dtype(dtype).itemsize
        self.align(size)
        stop = self.pos + size * count
        self._check(stop)
        out = np.ascontiguousarray(self.take(self.pos, size * count)).view(dtype)
        self.pos = stop
        return out

    def skip(self, dtype: str, count: int) -> None:
        size = np.dtype(dtype).itemsize
        self.align(size)
        self.pos = self.pos + size * count

    def string(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Offsets and lengths (without a NUL) of a string field of every message; advances."""
        length = self.read("<u4")[:, 0].astype(np.int64)
        text = self.pos
        self.pos = self.pos + length
        self._check(self.pos)
        return text, length - 1 if self.cdr else length

    def header(self) -> NDArray[np.int64]:
        """``std_msgs/Header``: the stamp, int64 ns (n,); the frame id's offsets and lengths go to ``frame_id``."""
        if not self.cdr:
            self.skip("<u4", 1)  # seq
        sec = self.read("<u4" if not self.cdr else "<i4")[:, 0].astype(np.int64)
        nsec = self.read("<u4")[:, 0].astype(np.int64)
        self.frame_id = self.string()
        return sec * 1_000_000_000 + nsec


def _check_first(msg: Any, msgtype: str, values: np.ndarray, where: str) -> None:
    """Compare the values parsed from the first message (stamp ns, then the fields) with rosbags' message."""
    if msgtype == IMU:
        ref = [*_xyz(msg.angular_velocity), *_xyz(msg.linear_acceleration)]
    elif msgtype == MAG:
        ref = _xyz(msg.magnetic_field)
    else:
        pose = msg.transform if msgtype == TRANSFORM else msg.pose
        pose = pose.pose if msgtype in (ODOMETRY, POSE_COV) else pose
        if msgtype == TRANSFORM:
            p, q = pose.translation, pose.rotation
        else:
            p, q = pose.position, pose.orientation
        ref = [*_xyz(p), q.x, q.y, q.z, q.w]
    stamp = msg.header.stamp
    ref_ns = int(stamp.sec) * 1_000_000_000 + int(getattr(stamp, "nanosec", getattr(stamp, "nsec", 0)))
    if not (np.array_equal(np.asarray(ref, dtype=np.float64), values[1:], equal_nan=True) and ref_ns == values[0]):
        raise BagError(f"{where}: the {msgtype} messages do not have the standard layout (the first message "
                       "decodes differently); not read")  # fmt: skip


def _xyz(v: Any) -> list[float]:
    return [v.x, v.y, v.z]
