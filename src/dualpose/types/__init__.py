"""Sensor types and data containers shared by every layer above the algebra.

* :class:`Trajectory` (:mod:`~dualpose.types.trajectory`): timestamped poses, what readers return and metrics take.
* :class:`ImuNoise` (:mod:`~dualpose.types.imu`): IMU noise densities and random walks (Kalibr conventions).
* :class:`PinholeCamera`, :class:`CameraIntrinsics`, :class:`FrameCorrespondences` (:mod:`~dualpose.types.camera`).
* :class:`RadTanCamera`, :class:`EquidistantCamera`, :func:`camera_from_parameters`: cameras with lens distortion
  (:mod:`~dualpose.types.camera_models`).
* :class:`TargetDetections`, :class:`RigSensors` (:mod:`~dualpose.types.target`): calibration-target corners per
  frame; a camera rig's sensors as a calibration file states them.
* :class:`Recording` (:mod:`~dualpose.types.recording`): one camera-IMU run, whatever its source;
  :class:`SensorSetup` / :class:`FilterStart`: its sensor set-up and a filter start without the data (streaming).
* :class:`CameraImuCalibration` (:mod:`~dualpose.types.calibration`): a camera's extrinsic, clock offset and IMU
  biases, as a camera-IMU calibration states them.

Layouts: positions ``(N, 3)`` metres, quaternions ``(N, 4)`` xyzw Hamilton body -> world, times in seconds.
"""

from dualpose.types.calibration import CameraImuCalibration
from dualpose.types.camera import CameraFrame, CameraIntrinsics, FrameCorrespondences, PinholeCamera, PinholeModel
from dualpose.types.camera_models import (
    DistortedCamera,
    EquidistantCamera,
    RadTanCamera,
    camera_from_parameters,
)
from dualpose.types.features import FeatureTracks, TrackFrame, TrackRecording
from dualpose.types.imu import STANDARD_GRAVITY, ImuNoise
from dualpose.types.recording import FilterStart, Recording, SensorRun, SensorSetup
from dualpose.types.target import RigSensors, TargetDetections
from dualpose.types.trajectory import Trajectory, seconds_from_ns

__all__ = [
    "FeatureTracks",
    "TrackFrame",
    "TrackRecording",
    "STANDARD_GRAVITY",
    "CameraFrame",
    "CameraIntrinsics",
    "DistortedCamera",
    "EquidistantCamera",
    "RadTanCamera",
    "RigSensors",
    "TargetDetections",
    "camera_from_parameters",
    "FrameCorrespondences",
    "FilterStart",
    "ImuNoise",
    "PinholeCamera",
    "PinholeModel",
    "Recording",
    "SensorRun",
    "SensorSetup",
    "Trajectory",
    "seconds_from_ns",
    "CameraImuCalibration",
]
