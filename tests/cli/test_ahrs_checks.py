"""``dualpose ahrs`` and ``dualpose fuse`` on invalid BROAD files built in the test: one-line errors (exit 1)
naming the file and the field; ``--no-mag`` needs no magnetometer field."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from dualpose.cli.main import main

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
from test_broad import write_synthetic_trial


def _one_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_all_zero_reference_is_a_data_error(tmp_path, capsys):
    path = write_synthetic_trial(tmp_path / "zeros.mat", opt_quat=np.zeros((600, 4)))
    assert main(["ahrs", str(path)]) == 1
    line = _one_error(capsys)
    assert line.startswith("dualpose ahrs: error: ") and "zeros.mat" in line and "opt_quat" in line


def test_no_mag_does_not_need_the_magnetometer_field(tmp_path, capsys):
    path = write_synthetic_trial(tmp_path / "nomag.mat", imu_mag=None)
    assert main(["ahrs", str(path), "--no-mag", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["mode"] == "6D" and np.isfinite(out["total_rmse_deg"])
    assert main(["ahrs", str(path)]) == 1
    line = _one_error(capsys)
    assert "imu_mag" in line and "--no-mag" in line


def test_sampling_rate_zero_and_empty_mat(tmp_path, capsys):
    assert main(["ahrs", str(write_synthetic_trial(tmp_path / "r0.mat", sampling_rate=0.0))]) == 1
    assert "sampling_rate" in _one_error(capsys)
    from scipy.io import savemat

    savemat(tmp_path / "empty.mat", {})
    assert main(["fuse", "--data", str(tmp_path / "empty.mat")]) == 1
    line = _one_error(capsys)
    assert "empty.mat" in line and "missing fields" in line


def test_nan_gyro_sample_is_a_one_line_error_in_ahrs_and_fuse(tmp_path, capsys):
    gyr = np.random.default_rng(1).normal(0.0, 1e-3, (600, 3))
    gyr[400, 1] = np.nan
    path = write_synthetic_trial(tmp_path / "nan.mat", imu_gyr=gyr)
    assert main(["ahrs", str(path), "--json"]) == 1
    assert "nan.mat: field imu_gyr: sample 400 " in _one_error(capsys)
    assert main(["fuse", "--data", str(path)]) == 1
    line = [s for s in capsys.readouterr().err.splitlines() if "error" in s]
    assert len(line) == 1 and line[0].count("nan.mat") == 1 and "not finite" in line[0]
    assert "field imu_gyr: sample 400 " in line[0]  # the trial's own sample number, not the recording's
