"""The camera–IMU calibration type (dualpose.types.calibration): the IMU axis models it carries."""

from __future__ import annotations

import numpy as np
import pytest

from dualpose.types.calibration import CameraImuCalibration

M_G = np.array([[1.0028, -0.0003, 0.0023], [-0.0003, 1.0024, 0.0008], [0.0023, 0.0008, 0.998]])
M_A = np.array([[1.0004, -0.0019, -0.0003], [0.0034, 1.0006, 0.0012], [0.0005, -0.0009, 0.9987]])


def _cal(**kw) -> CameraImuCalibration:
    return CameraImuCalibration("cam0", [0.0, 0.0, 0.0, 1.0], [0.01, 0.02, 0.03], 0.0, 0.4, **kw)


def test_corrected_imu_inverts_the_axis_models_and_rows_equal_single_samples():
    rng = np.random.default_rng(3)
    w, f = rng.normal(size=(50, 3)), rng.normal(size=(50, 3)) * 9.81
    cal = _cal(gyro_axes_matrix=M_G, accel_axes_matrix=M_A)
    wm, fm = w @ M_G.T, f @ M_A.T  # measured ω̃ = M_g ω, f̃ = M_a f
    gw, gf = cal.corrected_imu(wm, fm)
    np.testing.assert_allclose(gw, w, atol=1e-12)
    np.testing.assert_allclose(gf, f, atol=1e-11)
    np.testing.assert_allclose(gw, np.linalg.solve(M_G, wm.T).T, atol=1e-12)  # numpy's solve as reference
    for k in (0, 17, 49):  # one sample at a time (the stream) gives the array's row (the batch) bit for bit
        a, b = cal.corrected_imu(list(wm[k]), fm[k])
        assert np.array_equal(a, gw[k]) and np.array_equal(b, gf[k])


def test_corrected_imu_without_axis_models_is_the_identity():
    rng = np.random.default_rng(4)
    w, f = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    gw, gf = _cal().corrected_imu(w, f)
    assert np.array_equal(gw, w) and np.array_equal(gf, f) and gw is not w


def test_axis_matrices_are_checked_and_serialised():
    d = _cal(gyro_axes_matrix=M_G).as_dict()
    assert d["gyro_axes_matrix"] == M_G.tolist() and d["accel_axes_matrix"] is None
    with pytest.raises(ValueError, match="gyro_axes_matrix must be a 3 x 3"):
        _cal(gyro_axes_matrix=np.eye(2))
    with pytest.raises(ValueError, match="accel_axes_matrix must be close to the identity"):
        _cal(accel_axes_matrix=2.0 * np.eye(3))
