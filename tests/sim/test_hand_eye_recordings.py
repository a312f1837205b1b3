"""Seeded hand–eye recordings: the truth satisfies ``B_ij X = X A_ij``, the kinds differ as documented, bad input."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.calibration import clean_pose_stream, pair_motions, pair_residuals, select_pairs
from dualpose.sim import HAND_EYE_KINDS, simulate_hand_eye


def _loop_rmse(rec):
    cam, _ = clean_pose_stream(rec.camera_stamps, rec.camera_positions, rec.camera_quats)
    body, _ = clean_pose_stream(rec.body_stamps, rec.body_positions, rec.body_quats)
    i, j = select_pairs(cam)
    qa, ta, qb, tb, ok = pair_motions(cam, body, i, j, rec.time_offset)
    rv, te = pair_residuals(qa[ok], ta[ok], qb[ok], tb[ok], rec.quat, rec.translation)
    return np.degrees(np.sqrt(np.mean(np.sum(rv**2, 1)))), np.sqrt(np.mean(np.sum(te**2, 1))), int(ok.sum())


@pytest.mark.parametrize("kind", list(HAND_EYE_KINDS))
def test_truth_closes_the_loop_up_to_noise_and_interpolation(kind):
    quiet = {k: 0.0 for k in ("camera_deg", "camera_m", "body_deg", "body_m", "outliers")}
    rot, trans, n = _loop_rmse(simulate_hand_eye(kind, 3, 1234.5, duration=20.0, waypoints=10, **quiet))
    noisy_rot, noisy_trans, _ = _loop_rmse(simulate_hand_eye(kind, 3, 1234.5, duration=20.0, waypoints=10))
    assert n > 100
    # without noise only the body interpolation at the camera stamps remains (linear/SLERP between samples)
    assert rot < 0.2 * noisy_rot and trans < 0.2 * noisy_trans


def test_recording_layout_and_truth():
    rec = simulate_hand_eye("handheld", 4, -3600.0, duration=10.0)
    n, m = len(rec.camera_stamps), len(rec.body_stamps)
    assert rec.camera_positions.shape == (n, 3) and rec.camera_quats.shape == (n, 4) and rec.body_quats.shape == (m, 4)
    assert np.all(np.diff(rec.body_stamps) > 0) and np.all(np.diff(rec.camera_stamps) > 0)
    np.testing.assert_allclose(np.linalg.norm(rec.camera_quats, axis=1), 1.0, atol=1e-12)
    assert rec.quat[3] >= 0 and rec.time_offset == -3600.0
    # camera stamps lie 3600 s after the body's for the same instants (camera t ↔ body t + τ)
    assert abs((rec.camera_stamps[0] + rec.time_offset) - rec.body_stamps[0] - 0.5) < 2e-3
    assert n == pytest.approx(30 * 9, abs=1) and m == pytest.approx(100 * 10, abs=1)
    assert dp.quat_angle(rec.quat, simulate_hand_eye("handheld", 4, 0.0, duration=10.0).quat) == 0.0  # seeded


def test_bad_kind_and_parameter():
    with pytest.raises(ValueError, match="kind must be one of"):
        simulate_hand_eye("drone", 0, 0.0)
    with pytest.raises(ValueError, match=r"unknown parameter\(s\) \['rate'\]"):
        simulate_hand_eye("arm", 0, 0.0, rate=10.0)
