"""Camera–IMU calibration of a recorded rig against a target (the job behind ``dualpose calibrate camera-imu``).

Reads the IMU file (EuRoC CSV), the camera's target detections (``timestamp [ns], u, v, X, Y, Z, tag_id,
corner_idx``) and the rig's ``sensors.yaml`` (intrinsics, IMU noise, gravity magnitude), puts both clocks on one
origin in exact integer nanoseconds, and runs :func:`dualpose.calibration.camera_imu.calibrate_camera_imu`.
Returns the dictionary printed with ``--json`` (the keys the tracking job reads: ``rotation_xyzw``,
``translation_m``, ``time_offset_s``, …).  Method and results: docs/euroc.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp
from dualpose.calibration.camera_imu import CameraImuCalibration, calibrate_camera_imu
from dualpose.io import read_rig_sensors, read_target_detections
from dualpose.io.recording import read_imu
from dualpose.types.camera import FrameCorrespondences
from dualpose.types.camera_models import RadTanCamera
from dualpose.types.imu import STANDARD_GRAVITY

__all__ = ["EUROC_KALIBR_T_BS", "UnknownCamera", "calibrate_camera_imu_files", "calibration_summary", "pose_matrix"]

#: distortion models the estimator's camera Jacobians support
SUPPORTED = ("radtan",)

#: The reference of docs/euroc.md: EuRoC's published Kalibr camera–IMU extrinsics ``T_BS`` (the camera pose in the
#: IMU/body frame, 4 × 4), Burri et al. 2016, ``mav0/cam0|cam1/sensor.yaml``.
EUROC_KALIBR_T_BS = {
    "cam0": np.array([0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975, 0.999557249008,
                      0.0149672133247, 0.025715529948, -0.064676986768, -0.0257744366974, 0.00375618835797,
                      0.999660727178, 0.00981073058949, 0, 0, 0, 1]).reshape(4, 4),
    "cam1": np.array([0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556, 0.999598781151,
                      0.0130119051815, 0.0251588363115, 0.0453689425024, -0.0253898008918, 0.0179005838253,
                      0.999517347078, 0.00786212447038, 0, 0, 0, 1]).reshape(4, 4),
}  # fmt: skip


def pose_matrix(summary: Mapping[str, Any]) -> np.ndarray:
    """The camera pose in the IMU frame ``T_bc`` (4, 4) of a :func:`calibration_summary` dictionary."""
    T = np.eye(4)
    T[:3, :3] = dp.matrix_from_quat(np.asarray(summary["rotation_xyzw"], dtype=np.float64))
    T[:3, 3] = summary["translation_m"]
    return T


class UnknownCamera(ValueError):
    """The camera name is not in the sensor file (a usage error of the command line)."""


def _floats(x: ArrayLike) -> list[float]:
    return [float(v) for v in np.asarray(x).ravel()]


def calibration_summary(res: CameraImuCalibration, camera: str) -> dict[str, Any]:
    """The JSON-ready dictionary of a :class:`CameraImuCalibration` (all values plain floats, lists, dicts)."""
    o = res.outliers
    e = res.excitation
    axes: dict[str, Any] = {}
    if res.imu_axes:
        axes = {"gyro_axes_matrix": [_floats(r) for r in res.imu_axes[0]],
                "accel_axes_matrix": [_floats(r) for r in res.imu_axes[1]],
                "imu_axes_std": _floats(res.imu_axes_std)}  # fmt: skip
    if len(res.accel_axis_positions):
        axes |= {"accel_axis_positions_m": [_floats(r) for r in res.accel_axis_positions],
                 "accel_axis_positions_std_m": _floats(res.accel_axis_positions_std)}  # fmt: skip
    return {
        "camera": camera,
        "rotation_xyzw": _floats(res.q_bc),
        "translation_m": _floats(res.p_bc),
        "time_offset_s": float(res.time_offset),
        "reprojection_rms_px": float(res.reprojection_rms_px),
        "pixel_sigma_px": float(res.pixel_sigma),
        "blur_time_s": float(res.blur_time_s),
        "gyro_bias": _floats(res.gyro_bias),
        "accel_bias": _floats(res.accel_bias),
        "gravity_target": _floats(res.gravity_target),
        "std": {
            "rotation_deg": _floats(res.std["rotation_deg"]),
            "translation_m": _floats(res.std["translation_m"]),
            "time_offset_s": float(res.std["time_offset_s"]),
            "gyro_bias": _floats(res.std["gyro_bias"]),
            "accel_bias": _floats(res.std["accel_bias"]),
            "gravity_target_deg": float(res.std["gravity_target_deg"]),
        },
        "covariance": [_floats(r) for r in res.covariance],
        "camera_parameters": _floats(res.camera_parameters),
        "camera_parameters_std": _floats(res.camera_parameters_std),
        "imu_chi2_per_dof": float(res.imu_chi2_per_dof),
        "frames_used": int(res.frames_used),
        "outliers": {
            "frames_total": o["frames_total"],
            "frames_no_detections": len(o["no_detections"]),
            "frames_too_few_corners": len(o["too_few_corners"]),
            "frames_outside_imu": len(o["outside_imu"]),
            "frames_pnp_failed": len(o["pnp_failed"]),
            "corners_total": o["corners_total"],
            "corners_rejected": o["corners_rejected"],
            "corners_rejected_fraction": float(o["corners_rejected_fraction"]),
            "reject_threshold_px": float(o["reject_threshold_px"]),
        },
        "excitation": {
            "translation_std_m": _floats(e["translation_std_m"]),
            "translation_directions": [_floats(r) for r in e["translation_directions"]],
            "time_offset_std_s": float(e["time_offset_std_s"]),
        },
        "warnings": list(e["warnings"]),
        "gyro_misalignment": [_floats(r) for r in res.gyro_misalignment],
        "accel_misalignment": [_floats(r) for r in res.accel_misalignment],
        "imu_model": ("scale_misalignment_size_effect" if len(res.accel_axis_positions)
                      else "scale_misalignment" if res.imu_axes else "calibrated"),
        "iterations": int(res.iterations),
        "runtime_s": float(res.runtime_s),
    } | axes


def calibrate_camera_imu_files(
    imu_path: str,
    detections_path: str,
    sensors_path: str,
    camera: str = "cam0",
    bias_model: str = "random_walk",
    min_frames: int = 40,
    frame_window: tuple[float, float] | None = None,
    imu_model: str = "scale_misalignment",
    imu_noise_scale: float = 1.0,
    **options: Any,
) -> dict[str, Any]:
    """Read the three files and calibrate ``camera`` against the IMU; returns :func:`calibration_summary`.

    ``frame_window`` (start, end) in seconds from the first IMU sample keeps only the frames and IMU samples inside
    it (a cut of the recording).  ``imu_model``: as :func:`~dualpose.calibration.camera_imu.calibrate_camera_imu`.
    ``imu_noise_scale`` multiplies every IMU noise density and random walk of the sensor file (a sensitivity
    study: docs/euroc.md).  ``options`` are passed on to
    :func:`~dualpose.calibration.camera_imu.calibrate_camera_imu` (``noise_model``, ``huber``, ``reject_sigmas``, …).

    Raises
    ------
    ValueError
        Unknown camera name (listing the available ones), an unsupported distortion model, no time overlap between
        the IMU and the detections, or fewer than ``min_frames`` usable frames.
    dualpose.io.RecordingError / OSError
        Unreadable or malformed files (file and line named).
    """
    rig = read_rig_sensors(sensors_path)
    if camera not in rig.cameras:
        raise UnknownCamera(f"unknown camera {camera!r}; {sensors_path} has {', '.join(rig.cameras)}")
    cam = rig.camera(camera)
    if not isinstance(cam, RadTanCamera):
        raise ValueError(f"camera {camera!r}: distortion model {getattr(cam, 'model', type(cam).__name__)!r} is not "
                         f"supported by the camera-IMU calibration (supported: {', '.join(SUPPORTED)})")  # fmt: skip
    if rig.imu_noise is None:
        raise ValueError(f"{sensors_path}: no IMU noise densities (imu0) in the sensor file")
    imu = read_imu(imu_path)
    det = read_target_detections(detections_path)
    ns0 = int(imu.stamps_ns[0])
    imu_t = (imu.stamps_ns - ns0).astype(np.float64) * 1e-9
    frame_t = (det.stamps_ns - ns0).astype(np.float64) * 1e-9
    gyro, accel = imu.gyro, imu.accel
    offsets, pixels, points = det.offsets, det.pixels, det.points
    if frame_window is not None:
        a, b = frame_window
        keep_imu = (imu_t >= a - 0.5) & (imu_t <= b + 0.5)
        imu_t, gyro, accel = imu_t[keep_imu], gyro[keep_imu], accel[keep_imu]
        sel = det.select((frame_t >= a) & (frame_t <= b))
        frame_t = (sel.stamps_ns - ns0).astype(np.float64) * 1e-9
        offsets, pixels, points = sel.offsets, sel.pixels, sel.points
    if len(frame_t) == 0 or frame_t[-1] < imu_t[0] or frame_t[0] > imu_t[-1]:
        raise ValueError(f"no time overlap between the IMU ({imu_path}) and the detections ({detections_path})")
    frames = FrameCorrespondences(frame_t, offsets, pixels, points)
    g = rig.gravity_magnitude if math.isfinite(rig.gravity_magnitude) else STANDARD_GRAVITY
    if not imu_noise_scale > 0:
        raise ValueError(f"imu_noise_scale must be > 0; got {imu_noise_scale}")
    noise = rig.imu_noise.scaled(imu_noise_scale)
    res = calibrate_camera_imu(imu_t, gyro, accel, frames, cam, noise, gravity_magnitude=g,
                               bias_model=bias_model, min_frames=min_frames, imu_model=imu_model,
                               **options)  # fmt: skip
    return calibration_summary(res, camera)
