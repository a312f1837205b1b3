"""A camera–IMU calibration: what ``dualpose calibrate camera-imu ... --json`` states and ``dualpose fuse --data DIR
--calibration CALIB.json`` reads (docs/fusion.md, "Tracking on EuRoC imu_april").

Frames: IMU body ``b`` (the rig's body frame), camera ``c`` (z optical axis, x right, y down), calibration target
``t`` (the corners' frame).  ``x_b = R(rotation_xyzw) x_c + translation_m`` (camera axes and centre in the body
frame: the filters' ``q_bc``, ``p_bc``); clocks ``t_imu = t_cam + time_offset_s`` (Kalibr ``timeshift_cam_imu``,
the filters' ``camera_time_offset``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose.types import _inputs

__all__ = ["CameraImuCalibration"]


def _vector(value: object, name: str, n: int) -> NDArray[np.float64]:
    a = np.asarray(value, dtype=np.float64)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be {n} finite numbers; got {value!r}")
    return a


@dataclass(frozen=True)
class CameraImuCalibration:
    """The extrinsic, clock offset and IMU biases of one camera of a rig.

    Attributes
    ----------
    camera : str
        Name of the calibrated camera in the rig's sensor file (``"cam0"``).
    rotation_xyzw : ndarray, shape (4,)
        ``q_bc``: camera axes in the IMU frame, xyzw, unit (normalised on construction; refused if far from unit).
    translation_m : ndarray, shape (3,)
        ``p_bc``: camera centre in the IMU frame, metres.
    time_offset_s : float
        ``t_imu = t_cam + time_offset_s``, seconds.
    reprojection_rms_px : float
        RMS reprojection error of the calibration, pixels of the measured (distorted) image (> 0).
    gyro_bias, accel_bias : ndarray, shape (3,), or None
        IMU biases over the calibration recording, rad/s and m/s² (body frame); None when not stated.
    gravity_target : ndarray, shape (3,), or None
        Gravity in the target frame, m/s²; None when not stated.
    std : dict
        Standard deviations the calibration states (name -> number or list), kept as read; one under the name of a
        field (``translation_m``, ``gyro_bias``, ``accel_bias``, ``time_offset_s``) must have that field's shape and
        be >= 0, and the field must be stated.
    gyro_axes_matrix, accel_axes_matrix : ndarray, shape (3, 3), or None
        The IMU axis models of the calibration (``dualpose calibrate camera-imu --imu-model scale_misalignment``,
        docs/euroc.md): the measured rate and specific force are ``ω̃ = M_g (ω + b_g)``, ``f̃ = M_a (f + b_a)``
        (scale factors on the diagonal, axis misalignment off it); None when not stated (``M = I``).
        :meth:`corrected_imu` applies them.
    """

    camera: str
    rotation_xyzw: np.ndarray
    translation_m: np.ndarray
    time_offset_s: float
    reprojection_rms_px: float
    gyro_bias: np.ndarray | None = None
    accel_bias: np.ndarray | None = None
    gravity_target: np.ndarray | None = None
    std: dict[str, Any] = field(default_factory=dict)
    gyro_axes_matrix: np.ndarray | None = None
    accel_axes_matrix: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.camera, str) or not self.camera:
            raise ValueError(f"camera must be a camera name such as 'cam0'; got {self.camera!r}")
        q = _vector(self.rotation_xyzw, "rotation_xyzw", 4)
        nq = float(np.linalg.norm(q))
        if abs(nq - 1.0) > 1e-6:
            raise ValueError(f"rotation_xyzw must be a unit quaternion (xyzw); its norm is {nq:.9g}")
        object.__setattr__(self, "rotation_xyzw", q / nq)
        object.__setattr__(self, "translation_m", _vector(self.translation_m, "translation_m", 3))
        for name in ("time_offset_s", "reprojection_rms_px"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"{name} must be a finite number; got {v!r}")
            object.__setattr__(self, name, float(v))
        if not self.reprojection_rms_px > 0:
            raise ValueError(f"reprojection_rms_px must be > 0 px; got {self.reprojection_rms_px!r}")
        if abs(self.time_offset_s) > 1.0:
            raise ValueError(f"time_offset_s must be within ±1 s; got {self.time_offset_s!r}")
        for name in ("gyro_bias", "accel_bias", "gravity_target"):
            v = getattr(self, name)
            if v is not None:
                object.__setattr__(self, name, _vector(v, name, 3))
        for name in ("gyro_axes_matrix", "accel_axes_matrix"):
            v = getattr(self, name)
            if v is not None:
                m = np.asarray(v, dtype=np.float64)
                if m.shape != (3, 3) or not np.isfinite(m).all():
                    raise ValueError(f"{name} must be a 3 x 3 matrix of finite numbers (rows); got {v!r}")
                dev = float(np.abs(m - np.eye(3)).max())
                if dev > 0.2:
                    raise ValueError(f"{name} must be close to the identity (an IMU axis model: scale factors and "
                                     f"misalignment of a few per cent); its largest deviation is {dev:.3g}")
                object.__setattr__(self, name, m)
        if not isinstance(self.std, dict):
            raise ValueError(f"std must be a mapping of names to standard deviations; got {type(self.std).__name__}")
        self._check_std_agrees()

    def _check_std_agrees(self) -> None:
        """A standard deviation in ``std`` under a field's name (``translation_m``, ``gyro_bias``, ``accel_bias``,
        ``time_offset_s``) repeats that field's shape and must be there only with it: one finite number >= 0 per
        component."""
        for name in ("translation_m", "gyro_bias", "accel_bias", "time_offset_s"):
            if name not in self.std or self.std[name] is None:
                continue
            value = getattr(self, name)
            if value is None:
                raise _inputs.disagreement(f"std.{name}", name, "one estimated value", "the calibration states a "
                                           f"standard deviation of {name} but not {name} itself")  # fmt: skip
            try:
                sd = np.asarray(self.std[name], dtype=np.float64)
            except (TypeError, ValueError):
                raise ValueError(f"std.{name} must be numbers; got {self.std[name]!r}") from None
            if sd.shape != np.shape(value):
                raise _inputs.disagreement(f"std.{name}", name, "one estimated value", f"{name} has shape "
                                           f"{np.shape(value)} but its standard deviation {sd.shape}")  # fmt: skip
            if not (np.isfinite(sd) & (sd >= 0)).all():
                raise ValueError(f"std.{name} must be finite standard deviations >= 0; got {sd.tolist()}")

    def as_dict(self) -> dict[str, Any]:
        """The JSON-ready mapping of the calibration file (keys as the attributes; None for absent biases)."""
        def arr(v: Iterable[float] | None) -> list[float] | None:
            return None if v is None else [float(x) for x in v]

        return {
            "camera": self.camera,
            "rotation_xyzw": arr(self.rotation_xyzw),
            "translation_m": arr(self.translation_m),
            "time_offset_s": self.time_offset_s,
            "reprojection_rms_px": self.reprojection_rms_px,
            "gyro_bias": arr(self.gyro_bias),
            "accel_bias": arr(self.accel_bias),
            "gravity_target": arr(self.gravity_target),
            "std": dict(self.std),
            "gyro_axes_matrix": None if self.gyro_axes_matrix is None else [arr(r) for r in self.gyro_axes_matrix],
            "accel_axes_matrix": None if self.accel_axes_matrix is None else [arr(r) for r in self.accel_axes_matrix],
        }

    def corrected_imu(self, gyro: ArrayLike, accel: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The IMU samples with the axis models removed: ``(M_g⁻¹ ω̃, M_a⁻¹ f̃)`` (each (..., 3), rad/s and m/s²,
        body axes; the biases stay in, in the corrected axes, as the filters model them).  Unchanged copies (as
        float64) when the calibration states no axis model.  Elementwise arithmetic in a fixed order, so one sample
        gives bit for bit the row of a whole array (the stream and the batch agree)."""
        return _apply_inverse(self.gyro_axes_matrix, gyro), _apply_inverse(self.accel_axes_matrix, accel)


def _apply_inverse(M: np.ndarray | None, samples: ArrayLike) -> NDArray[np.float64]:
    x = np.array(samples, dtype=np.float64)
    if M is None:
        return x
    if x.shape[-1:] != (3,):
        raise ValueError(f"IMU samples must have 3 components on the last axis; got shape {x.shape}")
    W = np.linalg.inv(np.asarray(M, dtype=np.float64))
    return x[..., 0:1] * W[:, 0] + x[..., 1:2] * W[:, 1] + x[..., 2:3] * W[:, 2]
