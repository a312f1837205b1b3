"""``dualpose calibrate camera-imu``: refusals with exit codes (2 usage, 1 input) and the JSON keys the tracking
job reads, on a cut of the EuRoC imu_april recording (skipped when the data is absent)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from dualpose.cli.main import main
from realdata import data_dir

EUROC = data_dir("euroc/imu_april")  # the whole recording, or its 5 s cut in tests/data
#: the calibration window (s after the first frame): 10 s of the recording, or the whole 5 s cut
W0, W1 = (30, 40) if EUROC == data_dir("euroc/imu_april", full=True) else (0, 5)

KEYS = {"camera", "rotation_xyzw", "translation_m", "time_offset_s", "reprojection_rms_px", "gyro_bias", "accel_bias",
        "gravity_target", "std", "outliers", "excitation", "warnings", "imu_model", "gyro_axes_matrix",
        "accel_axes_matrix"}  # fmt: skip
STD_KEYS = {"rotation_deg", "translation_m", "time_offset_s", "gyro_bias", "accel_bias", "gravity_target_deg"}


@pytest.fixture(scope="module")
def euroc() -> Path:
    if not EUROC.is_dir():
        pytest.skip(f"EuRoC imu_april data missing ({EUROC})")
    return EUROC


def _args(d: Path, *extra: str) -> list[str]:
    return ["calibrate", "camera-imu", str(d / "imu0.csv"), str(d / "cam0_aprilgrid.csv"), "--sensors",
            str(d / "sensors.yaml"), *extra]  # fmt: skip


def test_json_keys_on_a_cut(euroc, capsys):
    assert main(_args(euroc, "--window", str(W0), str(W1), "--json")) == 0
    out = json.loads(capsys.readouterr().out)
    assert KEYS <= set(out)
    assert STD_KEYS <= set(out["std"])
    assert out["camera"] == "cam0" and out["imu_model"] == "scale_misalignment"
    assert np.allclose(out["gyro_axes_matrix"], np.eye(3), atol=0.02)
    assert len(out["rotation_xyzw"]) == 4 and len(out["translation_m"]) == 3
    assert len(out["std"]["rotation_deg"]) == 3 and out["std"]["time_offset_s"] > 0
    assert abs(out["time_offset_s"]) < 0.002
    assert out["outliers"]["frames_total"] > 15 * (W1 - W0)  # 20 Hz


def test_size_effect_model_json(euroc, capsys):
    """``--imu-model scale_misalignment_size_effect`` adds the accelerometer axis positions (x axis at the origin)."""
    assert main(_args(euroc, "--window", str(W0), str(W1), "--imu-model", "scale_misalignment_size_effect",
                      "--json")) == 0  # fmt: skip
    out = json.loads(capsys.readouterr().out)
    assert out["imu_model"] == "scale_misalignment_size_effect" and KEYS <= set(out)
    r = np.array(out["accel_axis_positions_m"])
    assert r.shape == (3, 3) and np.all(r[0] == 0.0) and np.all(np.abs(r) < 0.1)
    assert len(out["accel_axis_positions_std_m"]) == 6 and min(out["accel_axis_positions_std_m"]) > 0
    with pytest.raises(SystemExit) as exc:
        main(_args(euroc, "--imu-model", "size_effect"))
    assert exc.value.code == 2


def test_usage_errors_exit_2(euroc, capsys):
    assert main(_args(euroc, "--camera", "cam7")) == 2
    assert "unknown camera 'cam7'" in capsys.readouterr().err
    assert main(_args(euroc, "--window", "5", "1")) == 2
    assert "--window" in capsys.readouterr().err
    assert main(_args(euroc, "--min-frames", "3")) == 2
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", "camera-imu", str(euroc / "imu0.csv"), str(euroc / "cam0_aprilgrid.csv")])
    assert exc.value.code == 2


def test_input_errors_exit_1(euroc, tmp_path, capsys):
    assert main(_args(euroc, "--window", "1000", "1010")) == 1
    assert "no time overlap" in capsys.readouterr().err
    assert main(_args(euroc, "--window", str(W0), str(W0 + 1))) == 1
    assert "frames with >= 8 corners" in capsys.readouterr().err
    yaml = (euroc / "sensors.yaml").read_text().replace("radial-tangential", "equidistant", 1)
    yaml = yaml.replace("distortion_k1_k2_p1_p2", "distortion_k1_k2_k3_k4", 1)  # the key names the model's coefficients
    (tmp_path / "sensors.yaml").write_text(yaml)
    args = ["calibrate", "camera-imu", str(euroc / "imu0.csv"), str(euroc / "cam0_aprilgrid.csv"), "--sensors",
            str(tmp_path / "sensors.yaml")]  # fmt: skip
    assert main(args) == 1
    assert "not supported" in capsys.readouterr().err
    assert main(["calibrate", "camera-imu", str(tmp_path / "missing.csv"), str(euroc / "cam0_aprilgrid.csv"),
                 "--sensors", str(euroc / "sensors.yaml")]) == 1  # fmt: skip
    assert "missing.csv" in capsys.readouterr().err
