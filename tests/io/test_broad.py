"""BROAD reader: fields, units, wxyz -> xyzw, frames (checked by integrating the gyro against the reference)."""

from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

import dualpose as dp
from dualpose.io import load_broad

BROAD = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "broad"
TRIAL = BROAD / "06_undisturbed_fast_rotation_A.mat"


def test_fields_and_quaternion_order(trial):
    raw = loadmat(TRIAL)
    n = raw["imu_gyr"].shape[0]
    assert trial.gyr.shape == trial.acc.shape == trial.mag.shape == trial.pos.shape == (n, 3)
    assert trial.rate == pytest.approx(2000 / 7)  # 285.714 Hz
    np.testing.assert_array_equal(trial.quat, raw["opt_quat"][:, [1, 2, 3, 0]])
    ok = np.isfinite(trial.quat).all(axis=1)
    np.testing.assert_allclose(np.linalg.norm(trial.quat[ok], axis=1), 1.0, atol=1e-6)
    assert trial.movement.dtype == bool and 0 < trial.static_start < n
    assert "fast" in trial.groups and trial.description
    # gravity: at rest the accelerometer reads ~ +9.81 m/s^2 along ENU up once rotated by quat (q_b^i)
    up = dp.quat_rotate(
        trial.quat[: trial.static_start][ok[: trial.static_start]],
        trial.acc[: trial.static_start][ok[: trial.static_start]],
    )
    np.testing.assert_allclose(up.mean(axis=0), [0, 0, 9.81], atol=0.15)


def test_gyro_is_body_frame_rate_of_quat(trial):
    """q̇ = ½ q (x) ω with ω = gyr: integrating 10 s of gyro stays within 2 degrees of the reference; the other
    frame convention is off by tens of degrees."""
    import dualpose.inertial as di

    s = trial.static_start
    n = int(10 * trial.rate)
    inc = (trial.gyr[s : s + n] - trial.gyr[:s].mean(axis=0)) / trial.rate
    body = di.integrate_attitude(trial.quat[s], inc, 1, frame="body")[-1]
    wrong = di.integrate_attitude(trial.quat[s], inc, 1, frame="space")[-1]
    assert np.degrees(dp.quat_angle(body, trial.quat[s + n])) < 2.0
    assert np.degrees(dp.quat_angle(wrong, trial.quat[s + n])) > 10.0


def test_bad_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_broad(tmp_path / "nope.mat")
    from scipy.io import savemat

    savemat(tmp_path / "x.mat", {"imu_gyr": np.zeros((3, 3))})
    with pytest.raises(ValueError, match="missing fields"):
        load_broad(tmp_path / "x.mat")
