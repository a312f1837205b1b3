"""Calibration from recorded data: the sensors' relative poses, clock offsets and magnetometer errors.

* Camera–IMU (Hol 2008 §"Sensor pose calibration"): :func:`camera_imu_rotation` (camera→body rotation from static
  poses, first-order covariance), :func:`scene_gravity` (the scene's gravity direction from periods at rest),
  :func:`estimate_time_offset` / :func:`refine_time_offset_in_filter` (``t_imu = t_cam + offset`` from gyro vs
  vision rotation rates, refined by the error-state filter's NIS).  docs/fusion.md, "Calibration".
* Camera–IMU against a target, all at once (extrinsic, time offset, biases, target gravity, IMU axis models):
  :func:`calibrate_camera_imu`, a batch over preintegrated IMU factors and reprojections through the distorted
  camera (Forster et al. 2017).  docs/euroc.md.
* Hand–eye with time offset on unsynchronised pose streams (Daniilidis 1999; Furrer et al. 2017):
  :func:`calibrate_hand_eye_streams`.  docs/hand-eye.md.
* IMU-internal: the magnetometer–gyroscope time offset (:mod:`~dualpose.calibration.sensor_time_offset`) and
  magnetometer hard/soft-iron calibration (:mod:`~dualpose.calibration.magnetometer`).  docs/broad.md.

Import explicitly (``from dualpose import calibration``); ``import dualpose`` does not load it.
"""

from dualpose.calibration.camera_imu import CameraImuCalibration, calibrate_camera_imu
from dualpose.calibration.extrinsic import ExtrinsicRotation, camera_imu_rotation, unobservability_check
from dualpose.calibration.gravity import SceneGravity, scene_gravity
from dualpose.calibration.hand_eye_joint import HandEyeStreamResult, calibrate_hand_eye_streams
from dualpose.calibration.hand_eye_residual import (
    LoopResidual,
    fit_hand_eye,
    loop_residual,
    pair_motions,
    pair_residuals,
    select_pairs,
)
from dualpose.calibration.hand_eye_streams import (
    CleaningReport,
    PoseStream,
    clean_pose_stream,
    default_max_gap,
    interpolate_stream,
)
from dualpose.calibration.hand_eye_time import CoarseOffset, angular_rate_signal, coarse_time_offset
from dualpose.calibration.static import (
    StaticArrays,
    StaticPeriod,
    stack_static_periods,
    static_period,
    static_period_from_run,
    static_periods,
)
from dualpose.calibration.time_offset import (
    FilterTimeOffsetEstimate,
    TimeOffsetEstimate,
    estimate_time_offset,
    frame_poses,
    gyro_mean_rates,
    refine_time_offset_in_filter,
    vision_rotation_rates,
)

__all__ = [
    "CameraImuCalibration",
    "CleaningReport",
    "CoarseOffset",
    "ExtrinsicRotation",
    "FilterTimeOffsetEstimate",
    "HandEyeStreamResult",
    "LoopResidual",
    "PoseStream",
    "SceneGravity",
    "StaticArrays",
    "StaticPeriod",
    "TimeOffsetEstimate",
    "angular_rate_signal",
    "calibrate_camera_imu",
    "calibrate_hand_eye_streams",
    "camera_imu_rotation",
    "clean_pose_stream",
    "coarse_time_offset",
    "default_max_gap",
    "estimate_time_offset",
    "fit_hand_eye",
    "frame_poses",
    "gyro_mean_rates",
    "interpolate_stream",
    "loop_residual",
    "pair_motions",
    "pair_residuals",
    "refine_time_offset_in_filter",
    "scene_gravity",
    "select_pairs",
    "stack_static_periods",
    "static_period",
    "static_period_from_run",
    "static_periods",
    "unobservability_check",
    "vision_rotation_rates",
]
