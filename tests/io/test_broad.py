"""BROAD reader: fields, units, wxyz -> xyzw, frames (checked by integrating the gyro against the reference)."""

from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

import dualpose as dp
from dualpose.io import load_broad
from realdata import data_dir

BROAD = data_dir("broad")
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


def write_synthetic_trial(path: Path, n: int = 600, **changes) -> Path:
    """A small BROAD-like trial at rest (level, facing north) written with scipy.io.savemat; ``changes`` replace
    fields (None removes one)."""
    from scipy.io import savemat

    rng = np.random.default_rng(5)
    fields = {
        "imu_gyr": rng.normal(0.0, 1e-3, (n, 3)),
        "imu_acc": np.array([0.0, 0.0, 9.81]) + rng.normal(0.0, 1e-2, (n, 3)),
        "imu_mag": np.array([0.0, 20.0, -40.0]) + rng.normal(0.0, 0.1, (n, 3)),
        "opt_quat": np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)),
        "opt_pos": np.zeros((n, 3)),
        "movement": (np.arange(n) >= n // 2).astype(np.uint8),
        "sampling_rate": 2000.0 / 7.0,
    }
    for key, value in changes.items():
        if value is None:
            fields.pop(key)
        else:
            fields[key] = value
    savemat(path, fields)
    return path


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"opt_quat": np.zeros((600, 4))}, r"field opt_quat: 600 of 600 reference quaternions are not unit"),
        ({"sampling_rate": 0.0}, r"field sampling_rate must be one finite number > 0"),
        ({"sampling_rate": np.nan}, r"field sampling_rate"),
        ({"imu_acc": np.where(np.arange(600)[:, None] == 9, 1e300, 9.81 * np.ones((600, 3)))},
         r"field imu_acc: sample 9 has \|value\| 1e\+300"),
        ({"imu_gyr": np.zeros((0, 3))}, r"field imu_gyr: no samples"),
    ],
)
def test_invalid_values_name_file_and_field(tmp_path, changes, message):
    path = write_synthetic_trial(tmp_path / "t.mat", **changes)
    with pytest.raises(ValueError, match=message) as exc:
        load_broad(path)
    assert "t.mat" in str(exc.value)


def test_empty_mat_and_missing_magnetometer(tmp_path):
    from scipy.io import savemat

    savemat(tmp_path / "empty.mat", {})
    with pytest.raises(ValueError, match=r"empty.mat is not a BROAD trial: missing fields"):
        load_broad(tmp_path / "empty.mat")
    (tmp_path / "zero.mat").write_bytes(b"")
    with pytest.raises(ValueError, match=r"zero.mat: not a readable MATLAB .mat file"):
        load_broad(tmp_path / "zero.mat")
    t = load_broad(write_synthetic_trial(tmp_path / "nomag.mat", imu_mag=None))
    assert not t.has_mag and np.isnan(t.mag).all()
    nan_gyro = np.zeros((600, 3))
    nan_gyro[100, 0] = np.nan  # a dropout: kept (refused later, naming the sample, by the AHRS and by fuse)
    assert np.isnan(load_broad(write_synthetic_trial(tmp_path / "nan.mat", imu_gyr=nan_gyro)).gyr[100, 0])


def test_shape_and_storage_defects_are_named(tmp_path):
    """A transposed imu_gyr is named (not the field compared with it); a MATLAB sparse field is read as the dense
    matrix it stores; the file is named once, as given."""
    import scipy.sparse

    gyr = np.random.default_rng(1).normal(0.0, 1e-3, (600, 3))
    path = write_synthetic_trial(tmp_path / "t.mat", imu_gyr=gyr.T)
    with pytest.raises(ValueError, match=r"field imu_gyr has shape \(3, 600\).*transposed") as exc:
        load_broad(path)
    assert str(exc.value).count("t.mat") == 1
    path = write_synthetic_trial(tmp_path / "t2.mat", imu_mag=np.zeros((3, 600)))
    with pytest.raises(ValueError, match=r"field imu_mag must have shape \(600, 3\).*transposed"):
        load_broad(path)
    dense = load_broad(write_synthetic_trial(tmp_path / "dense.mat", imu_gyr=gyr))
    sparse = load_broad(write_synthetic_trial(tmp_path / "sparse.mat", imu_gyr=scipy.sparse.csc_matrix(gyr),
                                              sampling_rate=scipy.sparse.csc_matrix([[2000.0 / 7.0]])))  # fmt: skip
    np.testing.assert_array_equal(sparse.gyr, dense.gyr)
    assert sparse.rate == dense.rate


def test_require_finite_names_the_field_and_the_trials_sample(tmp_path):
    gyr = np.zeros((600, 3))
    gyr[400, 1] = np.nan
    t = load_broad(write_synthetic_trial(tmp_path / "nan.mat", imu_gyr=gyr))
    t.require_finite(start=401)  # nothing left to refuse from sample 401 on
    with pytest.raises(ValueError, match=r"field imu_gyr: sample 400 \(t = 1\.400000 s\) is not finite"):
        t.require_finite(start=10)
