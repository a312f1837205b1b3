"""What the streaming camera–IMU filters share (not public API: the classes are
:class:`dualpose.estimation.eskf.EskfStream` and :class:`dualpose.estimation.hol22.Hol22Stream`, the result types
:class:`FrameUpdate` and :class:`BlockResult` are exported by :mod:`dualpose.estimation.eskf`).

The camera–IMU filters one IMU sample / camera frame at a time, with a savable state: ``EskfStream`` and
``Hol22Stream`` run the compiled steps that the batch filters'
:meth:`ErrorStateEKF.run <dualpose.estimation.eskf.ErrorStateEKF.run>` and
:meth:`Hol22EKF.run <dualpose.estimation.hol22.Hol22EKF.run>` loop over (``src/native/estimation/eskf_run.cpp``,
``hol22_run.cpp``), configured by such a filter (its state, covariance, noise, camera and extrinsic), so a stream fed
sample by sample, a stream fed in blocks and the batch ``run`` give the same states to the last bit.

**Camera frames.** :meth:`update_camera` queues a frame; it is filtered at the first IMU sample stamped at or after
it, before that sample's own update -- where the batch filter processes it: the error-state filter predicts to the
frame time with the IMU input interpolated between the samples around it, so it needs the next sample; Hol22 gives
the same result either way.  The returned :class:`FrameUpdate` is filled in then (``status`` ``"done"``, per-point
NIS and acceptance).  As in the batch filters, frames before the first IMU sample are skipped (``"skipped"``) and
a frame at its time is filtered before it.  A frame stamped at or before the last IMU sample filtered is refused:
the stream cannot go back.

**State.** The filter -- state, covariance, constants and the interval reached between IMU samples -- lives in one
``numpy.uint8`` buffer with a header (magic number, layout version, size; :attr:`LAYOUT_VERSION`).
:meth:`state_dict` copies it together with the queued frames; :meth:`from_state` continues exactly where the saved
stream stopped, and refuses a buffer of another kind, layout version or size with a ValueError.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

from dualpose import _native
from dualpose.estimation._stream import GapWatch, sample_block, saved_buffer, saved_quaternion, saved_rate_stamps, vec3
from dualpose.estimation.state import StateLayout
from dualpose.types import ImuNoise, _inputs

__all__ = ["BlockResult", "FrameUpdate", "FusionStream"]


@dataclass
class FrameUpdate:
    """One camera frame given to a stream, and its update once filtered.

    Attributes
    ----------
    t : float
        Frame time on the IMU clock, s (the camera stamp plus the filter's ``camera_time_offset``).
    pixels : ndarray, shape (M, 2)
        Undistorted pixels (u right, v down), px.
    points : ndarray, shape (M, 3)
        Landmarks in the world frame, m.
    nis : ndarray, shape (M,)
        NIS (2 dof) of each correspondence at its turn (inf: behind the camera; NaN until filtered or when skipped).
    accepted_flags : ndarray of int64, shape (M,)
        1 where the χ² gate accepted the correspondence.
    status : {"pending", "done", "skipped"}
        Queued (waiting for an IMU sample at or after ``t``), filtered, or skipped (before the first IMU sample).
    """

    t: float
    pixels: np.ndarray
    points: np.ndarray
    nis: np.ndarray = field(repr=False)
    accepted_flags: np.ndarray = field(repr=False)
    status: str = "pending"

    @property
    def accepted(self) -> np.ndarray:
        """Accepted correspondences, bool (M,)."""
        return self.accepted_flags.astype(bool)

    @classmethod
    def new(cls, t: float, pixels: np.ndarray, points: np.ndarray) -> FrameUpdate:
        m = len(pixels)
        return cls(t, pixels, points, np.full(m, np.nan), np.zeros(m, np.int64))


@dataclass
class BlockResult:
    """Output of :meth:`update_batch`: ``states`` (N, dim) after each IMU sample (the stream's ``state_layout``),
    ``covariance`` (N, d, d) or None, and ``frames``: a :class:`FrameUpdate` per frame of the block (the ones after
    the block's last sample still pending)."""

    states: np.ndarray
    covariance: np.ndarray | None
    frames: list[FrameUpdate]


_correspondences = _inputs.frame_points  # the camera-frame checks every path shares (docs/refusals.md)


class _KernelFilter(Protocol):
    """A batch filter a stream continues (:class:`~dualpose.estimation.eskf.ErrorStateEKF`,
    :class:`~dualpose.estimation.hol22.Hol22EKF`): its state ``x``, covariance ``P``, camera time offset and the
    constants of its compiled kernel."""

    @property
    def x(self) -> np.ndarray: ...
    @property
    def P(self) -> np.ndarray: ...
    @property
    def camera_time_offset(self) -> float: ...
    @property
    def imu_noise(self) -> ImuNoise: ...
    def kernel_config(self) -> tuple[object, ...]: ...


#: the native ``*_stream_imu`` (buffer, t, gyro, accel) -> state
_StreamImu = Callable[[np.ndarray, float, Any, Any], NDArray[np.float64]]
#: the native ``*_stream_get`` (buffer) -> (state, covariance flattened, first and last IMU time, samples)
_StreamGet = Callable[[np.ndarray], tuple[NDArray[np.float64], NDArray[np.float64], float, float, int]]


class FusionStream(abc.ABC):
    """What both streaming filters share: the queue of frames, blocks, saving and restoring (module docstring).

    A subclass sets ``_kind`` (the prefix of its native ``*_stream_*`` functions), ``_filter_type`` (the batch filter
    it continues), ``state_layout``, ``covariance_dim`` and ``LAYOUT_VERSION``, and implements ``_frame_between`` and
    ``_first_sample``.
    """

    _kind: ClassVar[str]  # "eskf" or "hol22": the prefix of the native functions
    _filter_type: ClassVar[type]  # ErrorStateEKF or Hol22EKF
    state_layout: ClassVar[StateLayout]
    covariance_dim: ClassVar[int]
    LAYOUT_VERSION: ClassVar[int]

    def __init__(self, filter: _KernelFilter) -> None:
        name = self._filter_type.__name__
        if not isinstance(filter, self._filter_type):
            article = "an" if name[0] in "AEIOU" else "a"
            raise TypeError(f"filter must be {article} {name}; got {type(filter).__name__}")
        x = np.ascontiguousarray(filter.x, dtype=np.float64)
        P = np.ascontiguousarray(filter.P, dtype=np.float64)
        new = _native.__dict__[f"{self._kind}_stream_new"]
        period = 1.0 / filter.imu_noise.update_rate if filter.imu_noise.update_rate > 0 else None
        self._attach(new(x, P, *filter.kernel_config()), filter.camera_time_offset, period)

    def _attach(self, buffer: np.ndarray, camera_time_offset: float, imu_period: float | None) -> None:
        """Run on the native state ``buffer`` (a new filter's, or a restored one) with no frame queued; IMU gaps are
        watched against the nominal ``imu_period`` (s; None: not watched)."""
        self._buf = buffer
        #: the IMU gaps :meth:`update_imu` saw (longer than five nominal sample periods, ``1 /
        #: imu_noise.update_rate``): warned about (:class:`~dualpose.types.recording.RecordingWarning`) and counted;
        #: see :attr:`doubts`
        self.gap_watch = GapWatch(imu_period, rate_name="imu_noise.update_rate")
        self.camera_time_offset = float(camera_time_offset)
        self._pending: list[FrameUpdate] = []
        ns = _native.__dict__
        self._imu: _StreamImu = ns[f"{self._kind}_stream_imu"]
        self._run: Callable[..., int] = ns[f"{self._kind}_stream_run"]
        self._get: _StreamGet = ns[f"{self._kind}_stream_get"]

    # ---- updates ------------------------------------------------------------------------------------------------

    def update_imu(self, t: float, gyro: Any, accel: Any) -> np.ndarray:
        """Filter the IMU sample taken at ``t`` (after the queued frames up to ``t``) and return the state after it.

        Parameters
        ----------
        t : float
            Time stamp, s (IMU clock), strictly after the previous sample.
        gyro : array_like, shape (3,)
            Angular rate, body frame, rad/s.
        accel : array_like, shape (3,)
            Specific force, body frame, m/s².

        Returns
        -------
        ndarray, shape (state_layout.dim,)
            The state after this sample, laid out by :attr:`state_layout`.

        Raises
        ------
        ValueError
            A time that is not finite or does not increase, or a sample that is not 3 numbers.
        """
        g, a = vec3(gyro, "gyro"), vec3(accel, "accel")  # finite and within the IMU limits (docs/refusals.md)
        x: np.ndarray = self._imu(self._buf, t, g, a) if not self._pending else self._imu_after_frames(float(t), g, a)
        w = self.gap_watch  # GapWatch.see, inlined: a gap longer than five sample periods is reported
        if t - w.last > w.limit:
            w.note(t)
        w.last = t
        return x

    def update_camera(self, t: float, pixels: Any, points: Any) -> FrameUpdate:
        """Queue the point correspondences of the frame stamped ``t`` (camera clock); see the module docstring.

        Parameters
        ----------
        t : float
            Camera time stamp, s (``t + camera_time_offset`` on the IMU clock).
        pixels : array_like, shape (M, 2)
            Undistorted pixels, px.
        points : array_like, shape (M, 3)
            Landmarks, world frame, m.

        Returns
        -------
        FrameUpdate
            Filled in (``status`` "done" or "skipped") when the frame is filtered: at the first IMU sample at or
            after it.

        Raises
        ------
        ValueError
            Shapes that do not match, a time that is not finite, at or before the last IMU sample filtered, or
            before a frame already queued.
        """
        pix, pts = _correspondences(pixels, points)
        tj = float(t) + self.camera_time_offset
        last = self._last_imu_time()
        if not math.isfinite(tj) or tj <= last or (self._pending and tj < self._pending[-1].t):
            before = self._pending[-1].t if self._pending else last
            raise ValueError(f"frame at IMU time {tj!r} is not after the last IMU sample ({last!r}) and the frames "
                             f"queued ({before!r}): the stream takes its inputs in time order")  # fmt: skip
        frame = FrameUpdate.new(tj, pix, pts)
        self._pending.append(frame)
        return frame

    def update_batch(
        self, t: Any, gyro: Any, accel: Any, frame_t: Any = (), offsets: Any = (0,), pixels: Any = (), points: Any = (),
        *, covariance: bool = False,
    ) -> BlockResult:  # fmt: skip
        """Filter a block of IMU samples and frames (the same compiled steps as :meth:`update_imu` and
        :meth:`update_camera`, without a Python call per sample).

        Parameters
        ----------
        t : array_like, shape (N,)
            IMU times, s, strictly increasing and after the last sample filtered.
        gyro, accel : array_like, shape (N, 3)
            As in :meth:`update_imu`.
        frame_t : array_like, shape (F,)
            Camera stamps (camera clock), non-decreasing and not before the frames already queued.
        offsets : array_like of int, shape (F + 1,)
            Frame k owns rows ``offsets[k]:offsets[k + 1]`` of ``pixels`` (M, 2) and ``points`` (M, 3).
        covariance : bool
            Also return the covariance after each sample.

        Returns
        -------
        BlockResult
        """
        t = np.ascontiguousarray(t, dtype=np.float64).reshape(-1)
        n = len(t)
        gyro = sample_block(np.reshape(gyro, (-1, 3)) if n else np.zeros((0, 3)), "gyro", n)
        accel = sample_block(np.reshape(accel, (-1, 3)) if n else np.zeros((0, 3)), "accel", n)
        last = self._last_imu_time()
        if n and (not np.isfinite(t).all() or not t[0] > last or np.any(np.diff(t) <= 0)):
            _inputs.sample_times(t, "t", last)  # names the first bad time
        new = self._block_frames(frame_t, offsets, pixels, points)
        frames = self._pending + new
        cam_t = np.array([f.t for f in frames], dtype=np.float64)
        offs = np.zeros(len(frames) + 1, np.int64)
        np.cumsum([len(f.pixels) for f in frames], out=offs[1:])
        pix = np.concatenate([f.pixels for f in frames]) if frames else np.zeros((0, 2))
        pts = np.concatenate([f.points for f in frames]) if frames else np.zeros((0, 3))
        nis = np.full(len(pix), np.nan)
        acc = np.zeros(len(pix), np.int64)
        d = self.covariance_dim
        X = np.empty((n, self.state_layout.dim))
        Ps = np.empty((n, d, d)) if covariance else None
        started = self._started()
        used = self._run(self._buf, t, gyro, accel, cam_t, offs, pix, pts, X, Ps, nis, acc)
        for k, f in enumerate(frames[:used]):
            f.nis[:] = nis[offs[k] : offs[k + 1]]
            f.accepted_flags[:] = acc[offs[k] : offs[k + 1]]
            f.status = "skipped" if not started and f.t < t[0] else "done"
        self._pending = frames[used:]
        return BlockResult(X, Ps, new)

    def _block_frames(self, frame_t: Any, offsets: Any, pixels: Any, points: Any) -> list[FrameUpdate]:
        ft = np.asarray(frame_t, dtype=np.float64).reshape(-1)
        offs = np.asarray(offsets, dtype=np.int64).reshape(-1)
        pix, pts = _correspondences(pixels, points)
        if len(offs) != len(ft) + 1 or offs[0] != 0 or offs[-1] != len(pix) or np.any(np.diff(offs) < 0):
            raise ValueError("offsets must have F + 1 nondecreasing entries from 0 to len(pixels)")
        t_imu = (ft + self.camera_time_offset).tolist()  # as the batch run's check_streams: array + offset
        out = [FrameUpdate.new(t_imu[k], pix[offs[k] : offs[k + 1]].copy(), pts[offs[k] : offs[k + 1]].copy())
               for k in range(len(ft))]  # fmt: skip
        times = np.array([f.t for f in self._pending + out])
        if not np.isfinite(times).all() or np.any(np.diff(times) < 0) or (out and out[0].t <= self._last_imu_time()):
            raise ValueError("frame times must be finite, non-decreasing, after the last IMU sample filtered and "
                             "not before the frames already queued")  # fmt: skip
        return out

    # ---- the queue ----------------------------------------------------------------------------------------------

    def _imu_after_frames(self, t: float, gyro: Any, accel: Any) -> np.ndarray:
        g, a = vec3(gyro, "gyro"), vec3(accel, "accel")
        last = self._last_imu_time()
        if not (math.isfinite(t) and t > last):
            raise ValueError(f"t must be finite and increase strictly: got {t!r} after {last!r}")
        due = [f for f in self._pending if f.t <= t]
        self._pending = self._pending[len(due) :]
        if self._started():
            for f in due:
                self._frame_between(f, t, g, a)
            return self._imu(self._buf, t, g, a)
        for f in due:
            if f.t < t:
                f.status = "skipped"
        return self._first_sample(t, g, a, [f for f in due if f.t == t])

    # ---- state --------------------------------------------------------------------------------------------------

    @property
    def pending_frames(self) -> list[FrameUpdate]:
        """The frames queued and not filtered yet (oldest first)."""
        return list(self._pending)

    @property
    def state(self) -> np.ndarray:
        """The current state (:attr:`state_layout`), a copy."""
        return self._get(self._buf)[0]

    @property
    def covariance(self) -> np.ndarray:
        """The current covariance, a copy (square, :attr:`covariance_dim`)."""
        d = self.covariance_dim
        return self._get(self._buf)[1].reshape(d, d)

    @property
    def samples(self) -> int:
        """IMU samples filtered so far."""
        return int(self._get(self._buf)[-1])

    def state_dict(self) -> dict[str, Any]:
        """Everything needed to continue this stream elsewhere (:meth:`from_state`), as copies.

        Returns
        -------
        dict
            ``kind`` ("eskf" / "hol22"), ``version`` (:attr:`LAYOUT_VERSION`), ``state`` (the filter's
            ``numpy.uint8`` buffer), ``camera_time_offset`` and ``pending`` (the queued frames: ``t`` on the IMU
            clock, ``pixels`` (M, 2), ``points`` (M, 3)), ``imu_period`` (the nominal IMU sample period gaps are
            measured against, s, or None) and ``imu_rate_stamps`` (the first IMU stamps, kept until the stated rate
            is compared with them; None after).
        """
        return _inputs.seal({
            "imu_period": self.gap_watch.period,
            "imu_rate_stamps": self.gap_watch.saved_stamps(),
            "kind": self._kind,
            "version": self.LAYOUT_VERSION,
            "state": self._buf.copy(),
            "camera_time_offset": self.camera_time_offset,
            "pending": [{"t": f.t, "pixels": f.pixels.copy(), "points": f.points.copy()} for f in self._pending],
        })  # fmt: skip

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> FusionStream:
        """A stream that continues exactly where the one that wrote ``state`` (:meth:`state_dict`) stopped.

        Raises
        ------
        ValueError
            Naming ``state`` when it is not a saved stream of this kind, has another layout version, or its buffer
            has the wrong size or header.
        """
        try:
            kind, version, buf = state["kind"], int(state["version"]), state["state"]
            offset, pending = float(state["camera_time_offset"]), list(state["pending"])
        except (TypeError, KeyError, ValueError) as exc:
            raise ValueError(f"state is not a saved {cls.__name__} (state_dict()): {exc!r}") from None
        if kind != cls._kind:
            raise ValueError(f"state is a saved {kind!r} stream; {cls.__name__} reads {cls._kind!r}")
        if version != cls.LAYOUT_VERSION:
            raise ValueError(f"state has {cls.__name__} layout version {version}; this build reads "
                             f"{cls.LAYOUT_VERSION}")  # fmt: skip
        buf = saved_buffer(buf, _native.__dict__[f"{cls._kind}_stream_check"], "state['state']")
        _inputs.check_seal(state)
        offset = _inputs.time_offset(offset, "state['camera_time_offset']")
        period = state.get("imu_period")  # absent in a state saved before gaps were watched: not watched
        if period is not None:
            period = _inputs.positive(period, "state['imu_period']", upper=100.0, unit="s")  # rates >= 0.01 Hz
        out = cls.__new__(cls)
        out._attach(buf, offset, period)
        out._check_values()
        last = out._last_imu_time()
        out.gap_watch.start_after(last, saved_rate_stamps(state.get("imu_rate_stamps"), last,
                                                           "state['imu_rate_stamps']"))  # fmt: skip
        try:
            times = [float(p["t"]) for p in pending]
            for p, tj in zip(pending, times, strict=True):
                pix, pts = _correspondences(p["pixels"], p["points"])
                out._pending.append(FrameUpdate.new(tj, pix, pts))
        except (TypeError, KeyError) as exc:
            raise ValueError(f"state['pending'] is not a list of saved frames: {exc!r}") from None
        last = out._last_imu_time()
        if times and (not np.isfinite(times).all() or np.any(np.diff(times) < 0) or times[0] <= last):
            raise ValueError("state['pending']: the queued frame times must be finite, non-decreasing and after the "
                             "last IMU sample filtered")  # fmt: skip
        return out

    def _check_values(self) -> None:
        """The restored filter's values (docs/refusals.md): a finite state with a unit quaternion, a finite symmetric
        positive semi-definite covariance, a finite time and a sample count >= 0."""
        x, P, t0, tc, samples = self._get(self._buf)
        d = self.covariance_dim
        L = self.state_layout
        name = "state['state']"
        if not (np.isfinite(x).all() and samples >= 0 and (samples == 0 or (math.isfinite(t0) and math.isfinite(tc)))):
            raise ValueError(f"{name}: the saved filter state is not finite (a corrupted or altered buffer)")
        saved_quaternion(L.get(x, "quat_be" if "quat_be" in L.names else "quat"), name)
        _inputs.covariance_matrix(np.reshape(P, (d, d)), f"{name} covariance", d)

    # ---- per filter ---------------------------------------------------------------------------------------------

    def _last_imu_time(self) -> float:
        _, _, t_imu, _, samples = self._get(self._buf)
        return t_imu if samples else -math.inf

    @property
    def doubts(self) -> list[_inputs.Doubt]:
        """What :meth:`update_imu` doubted about its input, each also warned: the first IMU gaps (``"imu_gap"``;
        ``gap_watch.count`` counts them all) and, after the first 200 samples, a stated rate the stamps contradict
        (``"imu_rate_mismatch"``; ``GapWatch`` of ``dualpose.estimation._stream``).  Not part of the saved state."""
        return list(self.gap_watch.doubts)

    @property
    def time(self) -> float | None:
        """Time of the last IMU sample filtered, s (None before the first)."""
        t = self._last_imu_time()
        return None if t == -math.inf else t

    def _started(self) -> bool:
        return self.samples > 0

    @abc.abstractmethod
    def _frame_between(self, f: FrameUpdate, t1: float, g1: np.ndarray, a1: np.ndarray) -> None:
        """Filter the queued frame ``f`` (IMU time ``f.t``) before the IMU sample ``(t1, g1, a1)`` that follows it,
        fill in its NIS and acceptance and mark it ``"done"`` (the filter has started)."""

    @abc.abstractmethod
    def _first_sample(self, t: float, g: np.ndarray, a: np.ndarray, at_t: list[FrameUpdate]) -> np.ndarray:
        """Filter the first IMU sample ``(t, g, a)`` together with the frames ``at_t`` stamped at its time (as the
        batch filter orders them) and return the state after it."""
