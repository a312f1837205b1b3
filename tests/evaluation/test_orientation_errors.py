"""BROAD's error metric (earth-frame error quaternion, total / heading / inclination) against scipy's Rotation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dualpose as dp
from dualpose.evaluation.orientation_errors import earth_error_quat, heading_inclination_errors, orientation_rmse


def _scipy_errors(q_est: np.ndarray, q_ref: np.ndarray):
    """Independent swing-twist split of R_err = R_est R_refᵀ: inclination = angle between z and R_err z (the swing),
    heading = angle of swing⁻¹ R_err (the twist about z)."""
    err = Rotation.from_quat(q_est) * Rotation.from_quat(q_ref).inv()
    total = err.magnitude()
    z = np.array([0.0, 0.0, 1.0])
    v = err.apply(np.tile(z, (len(q_est), 1)))
    incl = np.arccos(np.clip(v[:, 2], -1, 1))
    axis = np.cross(np.tile(z, (len(v), 1)), v)
    norm = np.linalg.norm(axis, axis=1, keepdims=True)
    axis = np.where(norm > 1e-12, axis / np.maximum(norm, 1e-300), [1.0, 0.0, 0.0])
    swing = Rotation.from_rotvec(axis * incl[:, None])
    twist = swing.inv() * err
    tv = twist.as_rotvec()
    np.testing.assert_allclose(tv[:, :2], 0.0, atol=1e-9)  # the remainder is a rotation about z
    return total, twist.magnitude(), incl


def test_split_matches_scipy_swing_twist():
    rng = np.random.default_rng(2)
    q_ref = Rotation.random(500, random_state=rng).as_quat()
    # errors of every size, including near 0 and near 180 degrees
    small = Rotation.from_rotvec(rng.normal(size=(250, 3)) * 0.05)
    large = Rotation.random(250, random_state=rng)
    errs = Rotation.concatenate([small, large])
    q_est = (errs * Rotation.from_quat(q_ref)).as_quat()
    tot, head, incl = heading_inclination_errors(earth_error_quat(q_est, q_ref))
    t2, h2, i2 = _scipy_errors(q_est, q_ref)
    np.testing.assert_allclose(tot, t2, atol=1e-9)
    np.testing.assert_allclose(head, h2, atol=1e-7)
    np.testing.assert_allclose(incl, i2, atol=1e-7)


def test_pure_heading_and_pure_tilt_errors():
    q_ref = dp.quat_from_rotvec(np.array([[0.4, -1.0, 0.3]]))
    heading_err = dp.quat_from_rotvec(np.array([[0.0, 0.0, math.radians(7.0)]]))
    tilt_err = dp.quat_from_rotvec(np.array([[math.radians(3.0), math.radians(4.0), 0.0]]))
    t, h, i = heading_inclination_errors(earth_error_quat(dp.quat_mul(heading_err, q_ref), q_ref))
    assert math.degrees(h[0]) == pytest.approx(7.0) and i[0] == pytest.approx(0.0, abs=1e-12)
    t, h, i = heading_inclination_errors(earth_error_quat(dp.quat_mul(tilt_err, q_ref), q_ref))
    assert math.degrees(i[0]) == pytest.approx(5.0) and h[0] == pytest.approx(0.0, abs=1e-12)


def test_rmse_skips_nan_reference_and_masked_samples_and_ignores_sign():
    rng = np.random.default_rng(4)
    q_ref = Rotation.random(100, random_state=rng).as_quat()
    err = Rotation.from_rotvec(np.tile([0.0, 0.0, math.radians(2.0)], (100, 1)))
    q_est = (err * Rotation.from_quat(q_ref)).as_quat()
    q_est[::2] *= -1.0  # q and -q are the same orientation
    q_est[5] = [1.0, 0.0, 0.0, 0.0]  # a bad estimate, but masked out
    q_ref[7] = np.nan  # optical dropout
    mask = np.ones(100, bool)
    mask[5] = False
    r = orientation_rmse(q_est, q_ref, mask)
    assert r.scored_samples == 98
    assert r.total_rmse_deg == pytest.approx(2.0) and r.heading_rmse_deg == pytest.approx(2.0)
    assert r.inclination_rmse_deg == pytest.approx(0.0, abs=1e-9)


def test_fitted_heading_offset_recovers_a_constant_rotation_about_up():
    rng = np.random.default_rng(6)
    q_ref = Rotation.random(400, random_state=rng).as_quat()
    noise = Rotation.from_rotvec(rng.normal(size=(400, 3)) * math.radians(0.5))
    offset = Rotation.from_rotvec([0.0, 0.0, math.radians(-123.4)])
    q_est = (offset * noise * Rotation.from_quat(q_ref)).as_quat()
    r = orientation_rmse(q_est, q_ref, fit_heading_offset=True)
    assert r.heading_offset_deg == pytest.approx(123.4, abs=0.1)
    assert r.total_rmse_deg == pytest.approx(math.degrees(np.sqrt(np.mean(noise.magnitude() ** 2))), rel=0.05)
    assert orientation_rmse(q_est, q_ref).total_rmse_deg > 100.0  # without the fit


def test_bad_inputs():
    q = np.tile([0.0, 0.0, 0.0, 1.0], (3, 1))
    with pytest.raises(ValueError, match="shape"):
        orientation_rmse(q[:, :3], q)
    with pytest.raises(ValueError, match="mask"):
        orientation_rmse(q, q, np.ones(2, bool))
    with pytest.raises(ValueError, match="no sample to score"):
        orientation_rmse(q, np.full((3, 4), np.nan))
    bad = q.copy()
    bad[1] = np.nan
    with pytest.raises(ValueError, match="q_est contains NaN"):
        orientation_rmse(bad, q)
