"""Validation of the sensor streams the batch filters take, and of the saved state the streaming filters restore
(not public API)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from dualpose.types._inputs import Doubt, Where, frame_points, gap_doubt, imu_rows, imu_vector, rate_doubt
from dualpose.types.recording import GAP_PERIODS, RecordingWarning


class GapWatch:
    """The IMU stamps of a stream against its nominal sample ``period`` (s; None: none stated), the one check of the
    streams and the line pipelines (docs/refusals.md):

    * a gap, a step between stamps longer than :data:`~dualpose.types.recording.GAP_PERIODS` periods
      (:func:`~dualpose.types._inputs.gap_doubt`, ``"imu_gap"``): each is counted (``count``), the first
      :data:`MAX_REPORTED` are warned about (:class:`~dualpose.types.recording.RecordingWarning`) and kept in
      ``doubts``;
    * the stated rate against the stamps: once :data:`RATE_SAMPLES` stamps are in, a median spacing more than 10 %
      off ``period`` (:func:`~dualpose.types._inputs.rate_doubt`, ``"imu_rate_mismatch"``), warned about and kept in
      ``doubts``; with no stated period the median spacing becomes the period gaps are measured against.

    The per-sample path is one subtraction and one comparison, ``if t - w.last > w.limit: w.note(t)``, then
    ``w.last = t`` (:meth:`see`; the streams inline it): while the first stamps are collected ``limit`` is −∞, so
    every stamp takes :meth:`note`; after that only a gap does.  The caller checks that the stamps increase.

    ``source`` names the input in the messages: ``"{source} line N"`` when :meth:`see` is given a line number,
    otherwise ``"IMU sample at t = ..."``; ``rate_name`` names the stated rate (``"imu.update_rate"``)."""

    __slots__ = ("count", "doubts", "gap_limit", "last", "limit", "period", "rate_name", "source", "stamps")

    #: gaps warned about one by one; later ones only counted
    MAX_REPORTED = 5
    #: stamps after which the stated rate is compared with the stamps' median spacing
    RATE_SAMPLES = 200

    def __init__(self, period: float | None, last: float = -math.inf, source: str = "", rate_name: str = "rate",
                 watch_rate: bool = True) -> None:  # fmt: skip
        self.period: float | None = None
        self.gap_limit = math.inf
        #: the first stamps, until the rate check (None: done, or not watched)
        self.stamps: list[float] | None = [] if watch_rate else None
        self.limit = math.inf
        self.set_period(period)
        self.last = last  # -inf before the first stamp: no step to compare
        self.count = 0
        self.doubts: list[Doubt] = []
        self.source = source
        self.rate_name = rate_name

    def start_after(self, t: float, stamps: list[float] | None = None) -> None:
        """Continue after the stamp ``t`` (s; not finite: no stamp yet) of a restored stream, with the first
        ``stamps`` collected for the rate check (:meth:`saved_stamps`; None: the check is done or not watched): a
        gap across the save is seen at the next sample."""
        self.last = t if math.isfinite(t) else -math.inf
        self.stamps = None if stamps is None else list(stamps)
        self.set_period(self.period)

    def saved_stamps(self) -> list[float] | None:
        """The stamps collected for the rate check so far (None: it is done or not watched), for a saved state."""
        return None if self.stamps is None else list(self.stamps)

    def set_period(self, period: float | None) -> None:
        """Watch against this nominal sample period, s (None: none stated)."""
        self.period = period
        self.gap_limit = math.inf if period is None else GAP_PERIODS * period
        self.limit = -math.inf if self.stamps is not None else self.gap_limit

    def see(self, t: float, line: int = 0) -> None:
        """Note the stamp ``t`` (s) of the next sample (input line ``line``, 0: not from a line)."""
        if t - self.last > self.limit:
            self.note(t, line)
        self.last = t

    def note(self, t: float, line: int = 0) -> None:
        """The slow path of :meth:`see`: collect ``t`` for the rate check while it is pending, and count (and
        report) a gap before ``t``.  A stamp seen before (the line pipelines show each stamp to the watch first,
        with its line number, then the stream sees it again) is ignored."""
        if not t > self.last:
            return
        stamps = self.stamps
        if stamps is not None:
            stamps.append(t)
            if len(stamps) >= self.RATE_SAMPLES:
                self._check_rate(t, line)
        if t - self.last > self.gap_limit and self.last > -math.inf:
            self._gap(t, line)

    def _where(self, t: float, line: int) -> str:
        return f"{self.source} line {line}" if line else f"IMU sample at t = {float(t)!r} s"

    def _check_rate(self, t: float, line: int) -> None:
        stamps = np.array(self.stamps)
        self.stamps = None
        if self.period is None:  # no stated rate: the stamps' own
            self.set_period(float(np.median(np.diff(stamps))))
            return
        where = f"{self.source} lines up to {line}" if line else f"IMU samples up to t = {float(t)!r} s"
        d = rate_doubt(stamps, 1.0 / self.period, where, rate_name=self.rate_name)
        self.set_period(self.period)
        if d is not None:
            self.doubts.append(d)
            warnings.warn(d.message, RecordingWarning, stacklevel=4)

    def _gap(self, t: float, line: int) -> None:
        dt = t - self.last
        self.count += 1
        if self.count > self.MAX_REPORTED or self.period is None:
            return
        d = gap_doubt(dt, self.period, self._where(t, line))
        if d is not None:
            self.doubts.append(d)
            warnings.warn(d.message, RecordingWarning, stacklevel=4)


def saved_rate_stamps(value: Any, last: float, name: str) -> list[float] | None:
    """The stamps a saved stream had collected for its rate check (:meth:`GapWatch.saved_stamps`), checked: None (the
    check was done, or the state was saved before streams checked the rate), or fewer than
    :data:`GapWatch.RATE_SAMPLES` finite, strictly increasing stamps, none after the stream's last sample ``last``.

    Raises
    ------
    ValueError
        Naming ``name`` otherwise.
    """
    if value is None:
        return None
    stamps = np.asarray(value, dtype=np.float64).reshape(-1)
    if not (len(stamps) < GapWatch.RATE_SAMPLES and np.isfinite(stamps).all() and np.all(np.diff(stamps) > 0)
            and (not len(stamps) or stamps[-1] <= last)):  # fmt: skip
        raise ValueError(f"{name}: not the IMU stamps of a saved stream (fewer than {GapWatch.RATE_SAMPLES}, finite, "
                         "increasing, none after its last sample)")  # fmt: skip
    return [float(v) for v in stamps]


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
