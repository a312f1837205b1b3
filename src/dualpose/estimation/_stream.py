"""Validation of the sensor streams the batch filters take, and of the saved state the streaming filters restore
(not public API)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from dualpose.types._inputs import Doubt, Where, frame_points, gap_doubt, imu_rows, imu_vector
from dualpose.types.recording import GAP_PERIODS, RecordingWarning


class GapWatch:
    """The IMU gaps of a stream: a step between stamps longer than :data:`~dualpose.types.recording.GAP_PERIODS`
    nominal sample ``period`` s (None: not watched until :meth:`set_period`).  Each gap is counted (``count``); the
    first :data:`MAX_REPORTED` are warned about (:class:`~dualpose.types.recording.RecordingWarning`) and kept in
    ``doubts`` (:class:`~dualpose.types._inputs.Doubt` ``"imu_gap"``, the check of the batch paths,
    docs/refusals.md).  One subtraction and one comparison per sample; the caller checks that the stamps increase.

    ``source`` names the input in the messages: ``"{source} line N"`` when :meth:`see` is given a line number,
    otherwise ``"IMU sample at t = ..."``."""

    __slots__ = ("count", "doubts", "last", "limit", "period", "source")

    #: gaps warned about one by one; later ones only counted
    MAX_REPORTED = 5

    def __init__(self, period: float | None, last: float = math.nan, source: str = "") -> None:
        self.period: float | None = None
        self.limit = math.inf
        self.set_period(period)
        self.last = last  # NaN before the first stamp: no step to compare
        self.count = 0
        self.doubts: list[Doubt] = []
        self.source = source

    def start_after(self, t: float) -> None:
        """Continue after the stamp ``t`` (s; not finite: no stamp yet) of a restored stream: a gap across the save
        is seen at the next sample."""
        self.last = t if math.isfinite(t) else math.nan

    def set_period(self, period: float | None) -> None:
        """Watch for gaps against this nominal sample period, s (None: not watched)."""
        self.period = period
        self.limit = math.inf if period is None else GAP_PERIODS * period

    def see(self, t: float, line: int = 0) -> None:
        """Note the stamp ``t`` (s) of the next sample (input line ``line``, 0: not from a line).  The streams' per-
        sample path inlines it: ``if t - w.last > w.limit: w.gap(t)``, then ``w.last = t``."""
        if t - self.last > self.limit:
            self.gap(t, line)
        self.last = t

    def gap(self, t: float, line: int = 0) -> None:
        """Count (and report) the gap before the stamp ``t``; :meth:`see` calls it."""
        dt = t - self.last
        self.count += 1
        if self.count > self.MAX_REPORTED or self.period is None:
            return
        where = f"{self.source} line {line}" if line else f"IMU sample at t = {float(t)!r} s"
        d = gap_doubt(dt, self.period, where)
        if d is not None:
            self.doubts.append(d)
            warnings.warn(d.message, RecordingWarning, stacklevel=3)


class Streams(NamedTuple):
    """C-contiguous float64 IMU and camera streams; ``cam_t`` is on the IMU clock."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    cam_t: np.ndarray
    offsets: np.ndarray
    pixels: np.ndarray
    points: np.ndarray


def check_streams(
    t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, frame_t: np.ndarray, offsets: np.ndarray,
    pixels: np.ndarray, points: np.ndarray, camera_time_offset: float, *, strictly_increasing: bool,
) -> Streams:  # fmt: skip
    """Check the shapes of a recording and return it as contiguous arrays.

    ``t`` (N,) IMU times, s; ``gyro``, ``accel`` (N, 3); ``frame_t`` (F,) camera stamps on the camera clock, moved to
    the IMU clock by ``+ camera_time_offset``; ``offsets`` (F + 1,) int, frame k owns rows ``offsets[k]:offsets[k+1]``
    of ``pixels`` (M, 2) and ``points`` (M, 3).  ``strictly_increasing``: at least two strictly increasing IMU times
    (else: at least one, non-decreasing).

    Raises
    ------
    ValueError
        Naming the offending argument and the expected shape.
    """
    t = np.ascontiguousarray(t, dtype=np.float64)
    n = len(t)
    gyro = np.ascontiguousarray(gyro, dtype=np.float64)
    accel = np.ascontiguousarray(accel, dtype=np.float64)
    if gyro.shape != (n, 3) or accel.shape != (n, 3):
        raise ValueError(f"gyro and accel must have shape ({n}, 3); got {gyro.shape} and {accel.shape}")
    if strictly_increasing and (n < 2 or np.any(np.diff(t) <= 0)):
        raise ValueError("t must hold at least two strictly increasing IMU times")
    if not strictly_increasing and (n < 1 or np.any(np.diff(t) < 0)):
        raise ValueError("t must hold non-decreasing IMU times")
    if not np.isfinite(t).all():
        raise ValueError(f"t must be finite: sample {int(np.argmax(~np.isfinite(t)))} is not")
    gyro, accel = imu_rows(gyro, "gyro", "gyro", n), imu_rows(accel, "accel", "accel", n)  # docs/refusals.md
    cam_t = np.ascontiguousarray(frame_t, dtype=np.float64) + camera_time_offset
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    pixels = np.ascontiguousarray(pixels, dtype=np.float64).reshape(-1, 2)
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    if len(offsets) != len(cam_t) + 1 or offsets[-1] != len(pixels) or len(points) != len(pixels):
        raise ValueError("offsets must have F + 1 entries ending at len(pixels) == len(points)")
    if not np.isfinite(cam_t).all():
        raise ValueError("frame_t must be finite (camera stamps, s)")
    pixels, points = frame_points(pixels, points)
    return Streams(t, gyro, accel, cam_t, offsets, pixels, points)


def saved_buffer(buf: object, check: Callable[[np.ndarray, str], None], name: str) -> np.ndarray:
    """A streaming filter's saved ``numpy.uint8`` state buffer (or its bytes) as a fresh, aligned, writeable 1-D copy,
    checked by the native ``check(buffer, name)`` (header, layout version, size).

    Raises
    ------
    ValueError
        Naming ``name`` when ``buf`` is not a ``numpy.uint8`` array or bytes, or fails ``check``.
    """
    if isinstance(buf, (bytes, bytearray, memoryview)):
        buf = np.frombuffer(buf, dtype=np.uint8)
    if not isinstance(buf, np.ndarray) or buf.dtype != np.uint8:
        raise ValueError(f"{name} must be a numpy.uint8 array; got {type(buf).__name__}")
    out = np.array(buf, dtype=np.uint8, copy=True).reshape(-1)
    check(out, name)
    return out


def vec3(v: Any, name: str, kind: str | None = None) -> np.ndarray:
    """One sample ``v`` as a float64 array of shape (3,); ValueError naming ``name`` otherwise (no broadcasting, no
    NaN or infinity, nothing beyond the plausible range of ``kind`` -- default ``name`` --, "gyro", "accel" or "mag":
    :func:`dualpose.types._inputs.imu_vector`)."""
    return imu_vector(v, name, kind or name)


def sample_block(x: Any, name: str, n: int | None, kind: str | None = None, where: Where | None = None) -> np.ndarray:
    """A block of ``n`` (any number when None) samples ``x`` as a C-contiguous float64 array of shape (n, 3);
    ValueError naming ``name`` on another shape or a value that is not finite or beyond the plausible range of
    ``kind`` (default ``name``; :func:`dualpose.types._inputs.imu_rows`), with the first such row (``where(k)``)."""
    return imu_rows(x, name, kind or name, n, where or _row)


def _row(k: int) -> str:
    return f"row {k}"


def saved_quaternion(q: np.ndarray, name: str) -> None:
    """A restored attitude quaternion must be unit to rounding (a saved filter keeps it normalised)."""
    with np.errstate(over="ignore"):
        nq = float(np.linalg.norm(q))
    if not abs(nq - 1.0) <= 1e-6:
        raise ValueError(f"{name}: the saved attitude quaternion is not unit (norm {nq!r}): a corrupted or altered "
                         "buffer")  # fmt: skip
