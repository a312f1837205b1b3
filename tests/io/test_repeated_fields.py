"""File formats that state one fact twice refuse the file when the two disagree, naming the file, the line and both
fields (docs/refusals.md, "Fields that repeat one fact"), and every real file of the shared data still loads."""

from __future__ import annotations

import json

import numpy as np
import pytest

import dualpose as dp
from dualpose.io import read_trajectory
from dualpose.io._output import MANIFEST, OutputDirectory, OutputError
from dualpose.io.recording import RecordingError, read_imu
from dualpose.io.sensors_yaml import read_rig_sensors
from dualpose.io.target.recording import read_camera_imu_calibration, read_target_recording
from dualpose.types.trajectory import seconds_from_ns
from realdata import data_dir

CAM = """
  resolution: [752, 480]
  camera_model: pinhole
  intrinsics_fx_fy_cx_cy: [458.654, 457.296, 367.215, 248.375]
  distortion_model: {model}
  {key}: [-0.28, 0.07, 0.0002, 0.00002]
"""


def _transform(yaw: float, t) -> list[float]:
    m = np.eye(4)
    m[:3, :3] = dp.matrix_from_quat([0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)])
    m[:3, 3] = t
    return m.ravel().tolist()


def _rig(tmp_path, extra: str = "", imu: str = "rate_hz: 200.0", cam0_key: str = "distortion_k1_k2_p1_p2",
         model: str = "radial-tangential"):  # fmt: skip
    text = (f"imu0: {{{imu}, gyroscope_noise_density: 1.7e-4, gyroscope_random_walk: 1.9e-5, "
            "accelerometer_noise_density: 2.0e-3, accelerometer_random_walk: 3.0e-3}\n"
            "cam0:" + CAM.format(model=model, key=cam0_key) + "cam1:" + CAM.format(model="radtan",
            key="distortion_k1_k2_p1_p2") + extra)  # fmt: skip
    path = tmp_path / "sensors.yaml"
    path.write_text(text)
    return path


def test_a_rig_file_stating_the_imu_rate_twice_must_agree(tmp_path):
    rig = read_rig_sensors(_rig(tmp_path, imu="rate_hz: 200.0, update_rate: 200"))
    assert rig.imu_rate == 200.0
    with pytest.raises(RecordingError, match=r"sensors.yaml:1: imu0.update_rate: imu0.rate_hz and imu0.update_rate "
                                             r"disagree \(the IMU rate\).*tolerance"):  # fmt: skip
        read_rig_sensors(_rig(tmp_path, imu="rate_hz: 200.0, update_rate: 100.0"))


def test_the_distortion_key_must_name_the_coefficients_of_the_distortion_model(tmp_path):
    with pytest.raises(RecordingError, match=r"cam0.distortion_k1_k2_k3_k4: the key names the coefficients of "
                                             r"another distortion model than distortion_model"):  # fmt: skip
        read_rig_sensors(_rig(tmp_path, cam0_key="distortion_k1_k2_k3_k4"))
    rig = read_rig_sensors(_rig(tmp_path, cam0_key="distortion_k1_k2_k3_k4", model="equidistant"))
    assert rig.cameras["cam0"].model == "equi"


@pytest.mark.parametrize("yaw_error", [0.0, 1e-4])
def test_a_transform_and_its_inverse_must_agree(tmp_path, yaw_error):
    T = _transform(0.3, [0.11, 0.0, 0.001])
    inv = np.linalg.inv(np.reshape(_transform(0.3 + yaw_error, [0.11, 0.0, 0.001]), (4, 4))).ravel().tolist()
    path = _rig(tmp_path, f"T_cam0_cam1: {{data: {T}}}\nT_cam1_cam0: {{data: {inv}}}\n")
    if yaw_error == 0.0:
        assert np.allclose(read_rig_sensors(path).camera_extrinsics[("cam0", "cam1")], np.reshape(T, (4, 4)))
        return
    with pytest.raises(RecordingError) as exc:
        read_rig_sensors(path)
    text = str(exc.value)
    assert "T_cam0_cam1 rotation and T_cam1_cam0⁻¹ rotation disagree" in text and "tolerance 1e-05" in text, text


def test_kalibr_t_cn_cnm1_must_agree_with_both_cameras_t_cam_imu(tmp_path):
    t0 = np.reshape(_transform(0.1, [0.0, 0.02, 0.0]), (4, 4))
    t1 = np.reshape(_transform(-0.2, [0.1, 0.0, 0.0]), (4, 4))
    chain = t1 @ np.linalg.inv(t0)
    cam = ("  camera_model: pinhole\n  intrinsics: [458.0, 457.0, 367.0, 248.0]\n  distortion_model: radtan\n"
           "  distortion_coeffs: [-0.28, 0.07, 0.0002, 0.00002]\n  resolution: [752, 480]\n")  # fmt: skip

    def write(c) -> object:
        path = tmp_path / "camchain-imucam.yaml"
        path.write_text(f"cam0:\n{cam}  T_cam_imu: {t0.tolist()}\ncam1:\n{cam}  T_cam_imu: {t1.tolist()}\n"
                        f"  T_cn_cnm1: {c.tolist()}\n")  # fmt: skip
        return path

    read_rig_sensors(write(chain))
    shifted = chain.copy()
    shifted[0, 3] += 1e-3  # 1 mm
    with pytest.raises(RecordingError, match=r"cam1.T_cn_cnm1: cam1.T_cn_cnm1 translation and cam1.T_cam_imu "
                                             r"cam0.T_cam_imu⁻¹ translation disagree"):  # fmt: skip
        read_rig_sensors(write(shifted))


def test_a_reflection_is_not_a_rigid_transform(tmp_path):
    T = np.reshape(_transform(0.3, [0.1, 0.0, 0.0]), (4, 4)) @ np.diag([1.0, 1.0, -1.0, 1.0])
    with pytest.raises(RecordingError, match=r"T_cam0_cam1.*proper rotation.*reflection"):
        read_rig_sensors(_rig(tmp_path, f"T_cam0_cam1: {{data: {T.ravel().tolist()}}}\n"))


CALIBRATION = {"camera": "cam0", "rotation_xyzw": [0.0, 0.0, 0.0, 1.0], "translation_m": [0.01, 0.02, 0.03],
               "time_offset_s": 0.0001, "reprojection_rms_px": 0.3, "gyro_bias": [0.0, 0.0, 0.0],
               "std": {"translation_m": [0.001, 0.001, 0.001], "time_offset_s": 1e-5}}  # fmt: skip


@pytest.mark.parametrize(
    ("change", "names"),
    [
        ({"imu_model": "scale_misalignment"}, ("imu_model", "gyro_axes_matrix")),
        ({"imu_model": "calibrated", "gyro_axes_matrix": np.eye(3).tolist()}, ("imu_model", "gyro_axes_matrix")),
        ({"std": {"translation_m": [0.001, 0.001]}}, ("std.translation_m", "translation_m")),
        ({"std": {"accel_bias": [0.01, 0.01, 0.01]}}, ("std.accel_bias", "accel_bias")),
    ],
)
def test_a_calibration_json_stating_one_fact_twice_must_agree(tmp_path, change, names):
    path = tmp_path / "calib.json"
    path.write_text(json.dumps(CALIBRATION | {"imu_model": "calibrated"}))
    assert read_camera_imu_calibration(path).camera == "cam0"
    path.write_text(json.dumps(CALIBRATION | change))
    with pytest.raises(RecordingError) as exc:
        read_camera_imu_calibration(path)
    text = str(exc.value)
    assert text.startswith(str(path)) and all(n in text for n in names) and "disagree" in text, text


def test_force_does_not_replace_a_file_changed_since_its_manifest(tmp_path):
    out = tmp_path / "run"
    names = ("a.txt", "b.txt")
    with OutputDirectory(out, names=names, command="x").writing() as stage:
        (stage / "a.txt").write_text("first run\n")
    OutputDirectory(out, names=names, command="x", force=True)  # unchanged: replaceable
    (out / "a.txt").write_text("first run, with my notes\n")
    with pytest.raises(OutputError, match=r"a.txt and manifest.json disagree \(what the run wrote\): the file's bytes"):
        OutputDirectory(out, names=names, command="x", force=True)
    (out / "a.txt").write_text("first rux\n")  # same size, other content
    with pytest.raises(OutputError, match=r"a.txt and manifest.json disagree.*sha256"):
        OutputDirectory(out, names=names, command="x", force=True)
    assert json.loads((out / MANIFEST).read_text())["files"][0]["name"] == "a.txt"


# ------------------------------------------------------------------------------------------------ real files


@pytest.mark.parametrize("name", ["V102.txt", "V102_groundtruth.csv", "fr2_desk_ORB.txt", "fr2_desk_groundtruth.txt"])
def test_the_shared_trajectories_still_load(name):
    path = data_dir("tum", full=True) / name
    if not path.is_file():
        pytest.skip(f"shared TUM/EuRoC trajectory missing ({path}; GPL: not copied into tests/data)")
    traj = read_trajectory(path)
    assert len(traj) > 100
    if traj.stamps_ns is not None:
        assert np.array_equal(traj.stamps, seconds_from_ns(traj.stamps_ns))


def test_the_shared_target_recording_and_rig_file_still_load():
    d = data_dir("euroc/imu_april")
    if not (d / "sensors.yaml").is_file():
        pytest.skip(f"EuRoC imu_april data missing ({d})")
    rec = read_target_recording(d)
    assert set(rec.detections) == {"cam0", "cam1"} and len(read_imu(d / "imu0.csv")) == len(rec.imu)
    assert rec.rig.imu_rate == 200.0 and ("cam0", "cam1") in rec.rig.camera_extrinsics
