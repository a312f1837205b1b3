"""File formats: TUM and KITTI trajectories, EuRoC IMU and ground-truth CSV, format detection, BROAD IMU trials.

Camera-IMU recordings for ``dualpose fuse --data`` (:mod:`dualpose.io.recording`): :func:`read_recording`,
:func:`write_recording`; their sensor set-up with a filter start for ``dualpose fuse --stream --calibration``:
:func:`read_sensor_setup`, :func:`write_sensor_setup`.  Point CSV files for ``dualpose register``:
:mod:`dualpose.io.csv_points`.
Calibration-target corner files (:func:`read_target_detections`) and rig sensor files in YAML, ``sensors.yaml`` or
Kalibr ``camchain.yaml`` (:func:`read_rig_sensors`).  Target-recording directories (``imu0.csv``,
``camN_aprilgrid.csv``, ``sensors.yaml``: :func:`read_target_recording`) and the camera-IMU calibration JSON
(:func:`read_camera_imu_calibration`, :func:`write_camera_imu_calibration`).
Pose streams ``t, x, y, z, qx, qy, qz, qw`` for ``dualpose calibrate hand-eye``: :func:`read_pose_csv`.  A ``.npy``
file as a lazy dask array read block by block from its memory map (out-of-core work): :func:`read_npy_lazy`.  ROS 1 and
ROS 2 bags (``FILE.bag:/topic``, read by :func:`read_trajectory` and the IMU readers too): :mod:`dualpose.io.rosbag`
(needs ``rosbags``, the extra ``dualpose[ros]``).  Import explicitly; ``import dualpose`` does not load this.

Quaternions are returned xyzw (scalar last) whatever the file stores; EuRoC nanosecond timestamps are kept exact as
int64.  Writers never replace an existing file unless ``overwrite=True``.
"""

from dualpose.io._npy_lazy import read_npy_lazy
from dualpose.io.broad import load_broad
from dualpose.io.detect import detect_format, read_trajectory
from dualpose.io.euroc import ImuData, read_euroc_groundtruth, read_euroc_imu, write_euroc_groundtruth, write_euroc_imu
from dualpose.io.kitti import read_kitti, write_kitti
from dualpose.io.pose_csv import read_pose_csv
from dualpose.io.recording import (
    RecordingError,
    read_recording,
    read_sensor_setup,
    write_recording,
    write_sensor_setup,
)
from dualpose.io.sensors_yaml import read_rig_sensors
from dualpose.io.target.detections import read_target_detections
from dualpose.io.target.recording import (
    TargetRecording,
    read_camera_imu_calibration,
    read_target_recording,
    write_camera_imu_calibration,
)
from dualpose.io.tum import read_tum, write_tum
from dualpose.types.target import RigSensors, TargetDetections
from dualpose.types.trajectory import Trajectory, seconds_from_ns

__all__ = [
    "Trajectory",
    "ImuData",
    "seconds_from_ns",
    "read_tum",
    "write_tum",
    "read_kitti",
    "write_kitti",
    "read_euroc_imu",
    "write_euroc_imu",
    "read_euroc_groundtruth",
    "write_euroc_groundtruth",
    "detect_format",
    "read_trajectory",
    "read_pose_csv",
    "read_npy_lazy",
    "load_broad",
    "RecordingError",
    "read_recording",
    "write_recording",
    "read_sensor_setup",
    "write_sensor_setup",
    "TargetDetections",
    "read_target_detections",
    "RigSensors",
    "read_rig_sensors",
    "TargetRecording",
    "read_target_recording",
    "read_camera_imu_calibration",
    "write_camera_imu_calibration",
]
