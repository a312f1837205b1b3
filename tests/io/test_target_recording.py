"""Target-recording directories and the camera-IMU calibration JSON (dualpose.io.target.recording)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.io import RecordingError, write_recording
from dualpose.io.target.recording import (
    is_target_recording,
    read_camera_imu_calibration,
    read_target_recording,
    write_camera_imu_calibration,
)
from dualpose.types import CameraImuCalibration


def _calibration() -> CameraImuCalibration:
    q = dp.quat_from_rotvec([0.1, -0.2, 1.5])
    return CameraImuCalibration("cam0", q, [0.01, -0.06, 0.02], -2.5e-3, 0.4, gyro_bias=[1e-3, 2e-3, -3e-3],
                                accel_bias=None, gravity_target=[0.0, -9.5, -2.4], std={"rotation_deg": [0.01] * 3})


def test_calibration_round_trip_is_exact_and_refuses_overwrite(tmp_path):
    cal = _calibration()
    path = write_camera_imu_calibration(tmp_path / "c.json", cal)
    back = read_camera_imu_calibration(path)
    for key in ("rotation_xyzw", "translation_m", "gyro_bias", "gravity_target"):
        np.testing.assert_array_equal(getattr(back, key), getattr(cal, key))
    assert back.accel_bias is None and back.time_offset_s == cal.time_offset_s and back.std == cal.std
    with pytest.raises(FileExistsError):
        write_camera_imu_calibration(path, cal)


def test_calibration_extra_report_keys_are_ignored_and_errors_name_the_file(tmp_path):
    d = _calibration().as_dict()
    d["iterations"] = 21  # a calibration's own report
    p = tmp_path / "c.json"
    p.write_text(json.dumps(d))
    assert read_camera_imu_calibration(p).camera == "cam0"
    p.write_text("{\n  \"camera\": \"cam0\",\n  oops\n}")
    with pytest.raises(RecordingError, match=r"c\.json:3: not valid JSON"):
        read_camera_imu_calibration(p)
    with pytest.raises(RecordingError, match="calibration file not found"):
        read_camera_imu_calibration(tmp_path / "none.json")
    d.pop("reprojection_rms_px")
    d["reprojection_rms"] = 0.4
    p.write_text(json.dumps(d))
    with pytest.raises(RecordingError, match="'reprojection_rms' instead of 'reprojection_rms_px'"):
        read_camera_imu_calibration(p)


def test_a_dualpose_recording_directory_is_not_a_target_recording(tmp_path):
    d = tmp_path / "rec"
    write_recording(d, sim.recording_from_simulation(sim.simulate_eight(0)))
    assert not is_target_recording(d)
    (d / "imu0.csv").write_text("")
    (d / "sensors.yaml").write_text("")
    assert not is_target_recording(d)  # correspondences.csv: still a dualpose recording
    (d / "cam0_aprilgrid.csv").write_text("")
    assert is_target_recording(d)


def test_imu_april_cameras_and_overlap(euroc_april):
    rec = read_target_recording(euroc_april, ("cam1",))
    assert list(rec.detections) == ["cam1"] and len(rec.detections["cam1"]) == 1439
    with pytest.raises(RecordingError, match="unknown camera 'cam3'; available: cam0, cam1"):
        read_target_recording(euroc_april, ("cam3",))


def test_calibration_axis_matrices_round_trip_and_null_reads_as_none(tmp_path):
    M = np.eye(3) + 1e-3 * np.arange(9.0).reshape(3, 3)
    cal = dataclasses.replace(_calibration(), gyro_axes_matrix=M)
    back = read_camera_imu_calibration(write_camera_imu_calibration(tmp_path / "c.json", cal))
    np.testing.assert_array_equal(back.gyro_axes_matrix, M)
    assert back.accel_axes_matrix is None
    d = cal.as_dict() | {"gyro_axes_matrix": [[1.0, 0.0], [0.0, 1.0]]}
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(RecordingError, match=r"bad\.json: gyro_axes_matrix must be a 3 x 3"):
        read_camera_imu_calibration(tmp_path / "bad.json")
