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
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from dualpose.types.camera import FrameCorrespondences, PinholeModel
from dualpose.types.imu import ImuNoise
from dualpose.types.trajectory import Trajectory

__all__ = ["Recording", "SensorRun"]


class SensorRun(Protocol):
    """What the estimators read from a run: :class:`Recording` and :class:`dualpose.sim.SimulatedRun` both are one.

    ``t`` (N,) IMU times (s), ``gyro`` / ``accel`` (N, 3) rad/s and m/s² in the body frame, ``frames`` the camera
    correspondences, ``imu_noise``, and :meth:`sensor_options`: the filter keyword arguments of the sensor set-up.
    """

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    frames: FrameCorrespondences
    imu_noise: ImuNoise

    def sensor_options(self) -> dict:
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
        The IMU stamps as exact integer nanoseconds when the source had them (used for the output trajectory).
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
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    rest_seconds: float | None = None
    ground_truth: Trajectory | None = None
    stamps_ns: np.ndarray | None = None
    name: str = ""
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.t = np.ascontiguousarray(self.t, dtype=np.float64)
        n = self.t.shape[0]
        if self.t.ndim != 1 or n < 2 or not np.isfinite(self.t).all() or np.any(np.diff(self.t) <= 0):
            raise ValueError("t must hold at least two finite, strictly increasing IMU times (N,)")
        for name in ("gyro", "accel"):
            a = np.ascontiguousarray(getattr(self, name), dtype=np.float64)
            if a.shape != (n, 3) or not np.isfinite(a).all():
                raise ValueError(f"{name} must be finite with shape ({n}, 3); got {a.shape}")
            setattr(self, name, a)
        self.q_bc = np.asarray(self.q_bc, dtype=np.float64)
        self.p_bc = np.asarray(self.p_bc, dtype=np.float64)
        if self.q_bc.shape != (4,) or self.p_bc.shape != (3,):
            raise ValueError(f"q_bc must have shape (4,) and p_bc (3,); got {self.q_bc.shape}, {self.p_bc.shape}")
        if not (math.isfinite(self.pixel_sigma) and self.pixel_sigma > 0):
            raise ValueError(f"pixel_sigma must be > 0 px; got {self.pixel_sigma}")
        self.gravity = np.asarray(self.gravity, dtype=np.float64)
        if self.gravity.shape != (3,):
            raise ValueError(f"gravity must have shape (3,); got {self.gravity.shape}")

    @property
    def duration(self) -> float:
        """``t[-1] − t[0]``, seconds."""
        return float(self.t[-1] - self.t[0])

    def sensor_options(self) -> dict:
        """Keyword arguments configuring a filter for this recording (IMU noise, gravity, camera, extrinsic,
        pixel σ, time offset); the counterpart of :meth:`SimulatedRun.sensor_options
        <dualpose.sim.SimulatedRun.sensor_options>`."""
        return {
            "imu_noise": self.imu_noise,
            "gravity": self.gravity,
            "camera": self.camera,
            "q_bc": self.q_bc,
            "p_bc": self.p_bc,
            "pixel_sigma": self.pixel_sigma,
            "camera_time_offset": self.time_offset,
        }
