"""Camera–IMU calibration (Hol 2008 §"Sensor pose calibration", gravity alignment, time synchronisation).

* :func:`camera_imu_rotation` — camera→body rotation from static poses (accelerometer verticals vs the calibration
  pattern's vertical seen by the camera), directions-only registration, first-order covariance.
* :func:`scene_gravity` — the scene model's gravity direction from periods at rest, with covariance.
* :func:`estimate_time_offset` / :func:`refine_time_offset_in_filter` — the camera–IMU clock offset
  ``t_imu = t_cam + offset`` from gyro vs vision rotation rates, refined by the error-state filter's NIS.

Import explicitly (``from dualpose.fusion import calibration``).
"""

from dualpose.calibration.extrinsic import ExtrinsicRotation, camera_imu_rotation, unobservability_check
from dualpose.calibration.gravity import SceneGravity, scene_gravity
from dualpose.calibration.static import (
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
    "ExtrinsicRotation",
    "FilterTimeOffsetEstimate",
    "SceneGravity",
    "StaticPeriod",
    "TimeOffsetEstimate",
    "camera_imu_rotation",
    "estimate_time_offset",
    "frame_poses",
    "gyro_mean_rates",
    "refine_time_offset_in_filter",
    "scene_gravity",
    "stack_static_periods",
    "static_period",
    "static_period_from_run",
    "static_periods",
    "unobservability_check",
    "vision_rotation_rates",
]
