"""A camera-IMU recording: the common input of ``dualpose fuse`` whatever its source.

A :class:`Recording` holds the IMU stream, the frames' 2-D–3-D point correspondences, the sensor set-up the filter
needs and, optionally, ground truth.  It is built from the simulator (:func:`recording_from_simulation`), read
from files (:func:`dualpose.io.recording.read_recording`, the format documented in ``docs/fusion.md``) or made from
a BROAD trial with pseudo-vision (:func:`dualpose.pipelines.broad_pose.recording_from_broad`).

Frames and layouts as in :mod:`dualpose.estimation`: world ``w``, IMU body ``b``, camera ``c``; ``q_wb`` (4,) xyzw
body→world; the extrinsic ``(q_bc, p_bc)`` gives the camera axes and centre in the body frame; the clocks are
related by ``t_imu = t_cam + time_offset`` (Kalibr ``timeshift_cam_imu``).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from dualpose.types import _inputs
from dualpose.types.camera import FrameCorrespondences, PinholeModel
from dualpose.types.imu import STANDARD_GRAVITY, ImuNoise
from dualpose.types.trajectory import Trajectory

__all__ = ["IMU_LIMITS", "NOISE_LIMITS", "FilterStart", "Recording", "RecordingWarning", "SensorRun", "SensorSetup"]

#: largest plausible IMU reading per stream (rad/s, m/s²): far above any MEMS or tactical IMU's range (±35 rad/s,
#: ±160 m/s² are typical full scales); a larger value is a corrupt sample, not a measurement
IMU_LIMITS = {"gyro": _inputs.IMU_LIMITS["gyro"], "accel": _inputs.IMU_LIMITS["accel"]}

#: largest plausible IMU noise parameter (Kalibr units): above these the filter's covariances overflow or mean nothing
NOISE_LIMITS = _inputs.NOISE_LIMITS

#: an IMU gap longer than this many nominal sample periods is reported by :meth:`Recording.check_imu_gaps`
GAP_PERIODS = 5.0


class RecordingWarning(UserWarning):
    """A recording that can be processed but probably not as intended (IMU gaps, a doubtful gravity vector)."""


class SensorRun(Protocol):
    """What the estimators read from a run: :class:`Recording` and :class:`dualpose.sim.SimulatedRun` both are one.

    ``t`` (N,) IMU times (s), ``gyro`` / ``accel`` (N, 3) rad/s and m/s² in the body frame, ``frames`` the camera
    correspondences, ``imu_noise``, and :meth:`sensor_options`: the filter keyword arguments of the sensor set-up.
    """

    # read-only members: a run whose attributes are subtypes (a simulator's frames) is one too
    @property
    def t(self) -> np.ndarray: ...
    @property
    def gyro(self) -> np.ndarray: ...
    @property
    def accel(self) -> np.ndarray: ...
    @property
    def frames(self) -> FrameCorrespondences: ...
    @property
    def imu_noise(self) -> ImuNoise: ...

    def sensor_options(self) -> dict[str, Any]:
        """Keyword arguments for a filter: ``imu_noise``, ``camera``, ``q_bc``, ``p_bc``, ``pixel_sigma``,
        ``camera_time_offset``."""
        ...


@dataclass
class Recording:
    """IMU samples, camera correspondences, sensor set-up and optional ground truth of one run.

    The field names match :class:`~dualpose.sim.SimulatedRun` where they mean the same, so the filters'
    constructors and :func:`dualpose.estimation.initialization.initial_state_from_run` accept either.

    Attributes
    ----------
    t : ndarray, shape (N,)
        IMU sample times, seconds (IMU clock), strictly increasing.
    gyro : ndarray, shape (N, 3)
        Angular rate, body frame, rad/s.
    accel : ndarray, shape (N, 3)
        Specific force, body frame, m/s².
    frames : FrameCorrespondences
        Camera-clock stamps (s) and the correspondences of every frame (pixels, world points in metres).
    camera : PinholeModel
        Intrinsics (``fx``, ``fy``, ``cx``, ``cy`` px, ``width``, ``height``).
    q_bc, p_bc : ndarray, shapes (4,), (3,)
        Camera axes (xyzw) and camera centre (m) in the body frame.
    pixel_sigma : float
        Pixel noise standard deviation, px (> 0).
    imu_noise : ImuNoise
        Kalibr noise densities and random walks, turn-on bias sigmas, ``update_rate`` (Hz).
    time_offset : float
        ``t_imu = t_cam + time_offset``, seconds.
    gravity : ndarray, shape (3,)
        World-frame gravity the filter assumes, m/s².
    rest_seconds : float or None
        Length of the leading rest period used for the static alignment (s); None: detect it
        (:func:`dualpose.estimation.initialization.detect_rest`).
    ground_truth : Trajectory or None
        Body poses (world frame, ``q_wb`` xyzw) to evaluate against; None when the recording has none.
    stamps_ns : ndarray of int64, shape (N,), or None
        The IMU stamps as exact integer nanoseconds when the source had them (used for the output trajectory);
        refused when they are not the times ``t``.
    name : str
        A label (the source path, or "sim").
    info : dict
        Source-specific extras (e.g. the BROAD movement mask); not used by the filters.
    """

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    frames: FrameCorrespondences
    camera: PinholeModel
    q_bc: np.ndarray
    p_bc: np.ndarray
    pixel_sigma: float
    imu_noise: ImuNoise
    time_offset: float = 0.0
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -STANDARD_GRAVITY]))
    rest_seconds: float | None = None
    ground_truth: Trajectory | None = None
    stamps_ns: np.ndarray | None = None
    name: str = ""
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t = _inputs.sample_times(self.t, "t")
        n = self.t.shape[0]
        if self.t.ndim != 1 or n < 2:
            raise ValueError("t must hold at least two finite, strictly increasing IMU times (N,)")
        for name in ("gyro", "accel"):  # the IMU sample checks every path shares (docs/refusals.md)
            a = _inputs.imu_rows(getattr(self, name), name, name, n, lambda k: f"sample {k} (t = {self.t[k]:.6f} s)")
            setattr(self, name, a)
        if self.stamps_ns is not None:  # the same times twice: they must agree (docs/refusals.md)
            ns = np.asarray(self.stamps_ns)
            if ns.dtype.kind not in "iu" or ns.shape != (n,):
                raise ValueError(f"stamps_ns must be an integer array of shape ({n},); got {ns.dtype} {ns.shape}")
            _inputs.check_stamps_agree(self.t, ns, "t")
        _check_setup(self)

    @property
    def duration(self) -> float:
        """``t[-1] − t[0]``, seconds."""
        return float(self.t[-1] - self.t[0])

    def sensor_options(self) -> dict[str, Any]:
        """Keyword arguments configuring a filter for this recording (IMU noise, gravity, camera, extrinsic,
        pixel σ, time offset); the counterpart of :meth:`SimulatedRun.sensor_options
        <dualpose.sim.SimulatedRun.sensor_options>`."""
        return _sensor_options(self)

    def nominal_period(self) -> float:
        """The median IMU sample spacing, seconds."""
        return float(np.median(np.diff(self.t)))

    def imu_gaps(self, periods: float = GAP_PERIODS) -> list[tuple[float, float]]:
        """``(t_before, t_after)`` (s) of every IMU gap longer than ``periods`` nominal sample periods."""
        dt = np.diff(self.t)
        k = np.flatnonzero(dt > periods * self.nominal_period())
        return [(float(self.t[i]), float(self.t[i + 1])) for i in k]

    def check_imu_gaps(self, periods: float = GAP_PERIODS) -> list[tuple[float, float]]:
        """Warn (:class:`RecordingWarning`, one message) about the IMU gaps of :meth:`imu_gaps`; returns them.

        A filter predicts across a gap with no IMU data: its state drifts and the estimate after it can be metres
        off (docs/fusion.md, "Checks on the input")."""
        gaps = self.imu_gaps(periods)
        if gaps:
            shown = ", ".join(f"{a - self.t[0]:.3f}-{b - self.t[0]:.3f} s ({b - a:.3f} s)" for a, b in gaps[:5])
            more = f" and {len(gaps) - 5} more" if len(gaps) > 5 else ""
            warnings.warn(
                f"{self.name or 'recording'}: {len(gaps)} IMU gap(s) longer than {periods:g} sample periods "
                f"({periods * self.nominal_period() * 1e3:.1f} ms) at {shown}{more} (times from the first sample); "
                "the estimate drifts across them",
                RecordingWarning,
                stacklevel=2,
            )
        return gaps

    def check_gravity(self, q_wb: np.ndarray, rest_seconds: float | None = None, max_angle_deg: float = 10.0) -> float:
        """Check ``gravity`` against the accelerometer at rest, given the body attitude ``q_wb`` (4,) xyzw at rest.

        At rest the specific force is ``f_b = −R_wbᵀ g_w`` (docs/fusion.md): its mean over the rest period
        (``rest_seconds``, default the recording's or 0.2 s), rotated to the world, must point opposite to
        ``gravity``.  Returns the angle between ``R_wb f_b`` and ``−g`` (deg).

        Raises
        ------
        ValueError
            The angle exceeds 90°: ``gravity`` points up, against the documented convention (z up, gravity
            ``[0, 0, −9.81]``); the filter would double gravity instead of cancelling it.

        Warns
        -----
        RecordingWarning
            The angle exceeds ``max_angle_deg``, or ``|f_b|`` and ``|gravity|`` differ by more than 5 %.
        """
        from dualpose.algebra.quat import quat_rotate

        rest = self.rest_seconds if rest_seconds is None else rest_seconds
        sel = self.t <= self.t[0] + (0.2 if rest is None else rest)
        f_w = quat_rotate(np.asarray(q_wb, dtype=np.float64), self.accel[sel].mean(axis=0))
        g = self.gravity
        nf, ng = float(np.linalg.norm(f_w)), float(np.linalg.norm(g))
        angle = _inputs.gravity_angle(f_w, g)
        where = self.name or "recording"
        problem = _inputs.gravity_up_problem(f_w, g, where)
        if problem:
            raise ValueError(problem)
        if angle > max_angle_deg:
            warnings.warn(f"{where}: the specific force at rest is {angle:.1f} deg from -gravity {g.tolist()}: check "
                          "the gravity vector and the scene's vertical", RecordingWarning, stacklevel=2)  # fmt: skip
        if abs(nf - ng) > 0.05 * ng:
            warnings.warn(f"{where}: the specific force at rest is {nf:.3f} m/s² but |gravity| is {ng:.3f} m/s²: "
                          "check the accelerometer's unit (m/s², not g)", RecordingWarning, stacklevel=2)  # fmt: skip
        return angle


def _check_setup(s: Recording | SensorSetup) -> None:
    """Check (and convert to float64 arrays) the sensor set-up fields shared by Recording and SensorSetup
    (:mod:`dualpose.types._inputs`, the checks every path shares)."""
    s.q_bc = _inputs.unit_quaternion(s.q_bc, "q_bc")
    s.p_bc = _inputs.finite_vector(s.p_bc, "p_bc", 3, _inputs.MAX_POSITION_M, "m")
    s.pixel_sigma = _inputs.positive(s.pixel_sigma, "pixel_sigma", 1e4, "px")
    s.gravity = _inputs.gravity_vector(s.gravity)
    _inputs.check_imu_noise(s.imu_noise)
    _inputs.check_camera(s.camera)
    s.time_offset = _inputs.time_offset(s.time_offset, "time_offset")


def _sensor_options(s: Recording | SensorSetup) -> dict[str, Any]:
    return {
        "imu_noise": s.imu_noise,
        "gravity": s.gravity,
        "camera": s.camera,
        "q_bc": s.q_bc,
        "p_bc": s.p_bc,
        "pixel_sigma": s.pixel_sigma,
        "camera_time_offset": s.time_offset,
    }


@dataclass(frozen=True)
class FilterStart:
    """Where a camera–IMU filter starts: the error-state filter's nominal state and the sigmas of its diagonal
    covariance (the bias sigmas are the IMU's turn-on bias sigmas).

    Attributes
    ----------
    position, velocity : ndarray, shape (3,)
        ``p_wb`` (m) and ``v_w`` (m/s), world frame.
    quat : ndarray, shape (4,)
        ``q_wb``, xyzw, body → world (unit).
    gyro_bias, accel_bias : ndarray, shape (3,)
        rad/s, m/s².
    position_sigma, velocity_sigma, attitude_sigma : float
        1σ of the start, m, m/s, rad (attitude: the local error ``q = q̂ ⊗ Exp(δθ)``).
    """

    position: np.ndarray
    quat: np.ndarray
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    gyro_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    accel_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    position_sigma: float = 0.01
    velocity_sigma: float = 0.01
    attitude_sigma: float = math.radians(0.5)

    def __post_init__(self) -> None:  # the filter-parameter checks every path shares (docs/refusals.md)
        put = object.__setattr__
        put(self, "position", _inputs.finite_vector(self.position, "position", 3, _inputs.MAX_POSITION_M, "m"))
        put(self, "quat", _inputs.unit_quaternion(self.quat, "quat"))
        put(self, "velocity", _inputs.finite_vector(self.velocity, "velocity", 3, _inputs.MAX_VELOCITY_M_S, "m/s"))
        put(self, "gyro_bias", _inputs.finite_vector(self.gyro_bias, "gyro_bias", 3, _inputs.IMU_LIMITS["gyro"],
                                                     "rad/s"))  # fmt: skip
        put(self, "accel_bias", _inputs.finite_vector(self.accel_bias, "accel_bias", 3, _inputs.IMU_LIMITS["accel"],
                                                      "m/s²"))  # fmt: skip
        put(self, "position_sigma", _inputs.positive(self.position_sigma, "position_sigma", 1e6, "m"))
        put(self, "velocity_sigma", _inputs.positive(self.velocity_sigma, "velocity_sigma", 1e4, "m/s"))
        put(self, "attitude_sigma", _inputs.positive(self.attitude_sigma, "attitude_sigma", math.pi, "rad"))


@dataclass
class SensorSetup:
    """The sensor set-up of a recording without its data, and where the filter starts: what a camera–IMU filter
    needs before the first sample (``dualpose fuse --stream --calibration FILE``, docs/fusion.md "Streaming").

    Attributes as :class:`Recording`'s of the same names (``camera``, ``q_bc``, ``p_bc``, ``pixel_sigma``,
    ``imu_noise`` -- whose ``update_rate`` is the IMU rate --, ``time_offset``, ``gravity``); ``start`` the
    :class:`FilterStart`.
    """

    camera: PinholeModel
    q_bc: np.ndarray
    p_bc: np.ndarray
    pixel_sigma: float
    imu_noise: ImuNoise
    start: FilterStart
    time_offset: float = 0.0
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -STANDARD_GRAVITY]))

    def __post_init__(self) -> None:
        _check_setup(self)

    @classmethod
    def of(cls, recording: Recording, start: FilterStart) -> SensorSetup:
        """The set-up of ``recording`` (its sensors, without the data) with the filter start ``start``."""
        r = recording
        return cls(camera=r.camera, q_bc=r.q_bc, p_bc=r.p_bc, pixel_sigma=r.pixel_sigma, imu_noise=r.imu_noise,
                   start=start, time_offset=r.time_offset, gravity=r.gravity)  # fmt: skip

    def sensor_options(self) -> dict[str, Any]:
        """Keyword arguments configuring a filter for this set-up (as :meth:`Recording.sensor_options`)."""
        return _sensor_options(self)
