"""Hand-eye calibration with time offset on simulated streams with known X and τ (faulty rows, gaps, outliers)."""

from __future__ import annotations

import numpy as np
import pytest
from handeye_sim import simulate

import dualpose as dp
from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream, loop_residual


def _streams(rec):
    cam, rc = clean_pose_stream(rec.camera[:, 0], rec.camera[:, 1:4], rec.camera[:, 4:], "camera")
    body, rb = clean_pose_stream(rec.body[:, 0], rec.body[:, 1:4], rec.body[:, 4:], "body")
    return cam, body, rc, rb


@pytest.mark.parametrize(("tau", "seed"), [(3600.0123, 11), (-0.04, 12)])
def test_recovers_x_and_tau(tau, seed):
    rec = simulate(tau, seed)
    cam, body, rc, rb = _streams(rec)
    assert rc.exact_duplicates > 0 and not rc.was_sorted and rb.exact_duplicates > 0
    r = calibrate_hand_eye_streams(cam, body)
    rot_err = np.degrees(dp.quat_angle(r.quat, rec.quat))
    trans_err = np.linalg.norm(r.translation - rec.translation)
    assert abs(r.time_offset - tau) < 2e-3
    assert rot_err < 0.15 and trans_err < 2e-3
    # the first-order uncertainties are of the size of the errors (pairs share samples: σ is optimistic, allow 6x)
    assert abs(r.time_offset - tau) < 6 * r.time_offset_sigma + 2e-4
    assert trans_err < 6 * np.linalg.norm(r.translation_sigma_m) + 2e-4
    # every simulated outlier detection is left out; nearly all good pairs are kept
    used = np.unique(r.pairs)
    assert r.pairs_used > 0.9 * r.pairs_total and len(used) < len(cam) - 0.8 * rec.outliers
    assert r.rotation_rmse_deg < 0.6 and r.translation_rmse_m < 5e-3


def test_tau_is_the_loop_residual_minimum():
    rec = simulate(-0.04, 13)
    cam, body, _, _ = _streams(rec)
    r = calibrate_hand_eye_streams(cam, body)
    i, j = r.pairs.T
    taus = r.time_offset + np.arange(-10, 11) * 1e-3
    costs = [loop_residual(cam, body, i, j, t, r.quat, r.translation, r.sigma_rotation, r.sigma_translation).cost
             for t in taus]  # fmt: skip
    assert abs(taus[int(np.argmin(costs))] - r.time_offset) <= 1e-3


def test_fixed_offset_and_no_overlap():
    rec = simulate(-0.04, 14, duration=20.0, gaps=())
    cam, body, _, _ = _streams(rec)
    r = calibrate_hand_eye_streams(cam, body, time_offset=-0.04, fix_time_offset=True)
    assert r.time_offset == -0.04 and r.time_offset_sigma == 0.0
    with pytest.raises(ValueError, match="no overlap in time after the time offset"):
        calibrate_hand_eye_streams(cam, body, time_offset=1000.0)
    with pytest.raises(ValueError, match="needs a time_offset"):
        calibrate_hand_eye_streams(cam, body, fix_time_offset=True)
