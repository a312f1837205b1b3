"""The final stage of the stream calibration: started from the best of the five closed forms, never worse than that
start on either reported loop residual, at the noise floor on a simulated arm against OpenCV's five, and with ``τ`` at
the deepest minimum of the loop residual when the clocks tick at commensurate rates."""

from __future__ import annotations

import numpy as np
import pytest
from handeye_sim import OPENCV_METHODS, loop_rmse, opencv_hand_eye
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream, loop_residual, pair_motions
from dualpose.registration import HAND_EYE_CLOSED_FORMS, hand_eye_translation
from dualpose.sim import simulate_hand_eye

pytest.importorskip("cv2")


def _streams(rec):
    cam, _ = clean_pose_stream(rec.camera_stamps, rec.camera_positions, rec.camera_quats, "camera")
    body, _ = clean_pose_stream(rec.body_stamps, rec.body_positions, rec.body_quats, "body")
    return cam, body


def test_arm_at_the_noise_floor_and_within_opencv():
    rec = simulate_hand_eye("arm", 7, 0.02, duration=30.0, waypoints=13)
    cam, body = _streams(rec)
    r = calibrate_hand_eye_streams(cam, body)
    assert abs(r.time_offset - rec.time_offset) < 2e-4
    rot, trans = loop_rmse(cam, body, r.pairs, r.time_offset, r.quat, r.translation)
    floor = loop_rmse(cam, body, r.pairs, rec.time_offset, rec.quat, rec.translation)  # the truth's residual
    assert rot <= 1.02 * floor[0] and trans <= 1.02 * floor[1]
    best = [np.inf, np.inf]
    for tau in (r.time_offset, rec.time_offset):
        for m in OPENCV_METHODS:
            c = loop_rmse(cam, body, r.pairs, tau, *opencv_hand_eye(cam, body, r.pairs, tau, m))
            best = [min(best[0], c[0]), min(best[1], c[1])]
    assert rot <= 1.02 * best[0] and trans <= 1.02 * best[1]
    assert np.degrees(dp.quat_angle(r.quat, rec.quat)) < 0.05 and np.linalg.norm(r.translation - rec.translation) < 1e-3


@settings(max_examples=3, deadline=None)
@given(kind=st.sampled_from(["arm", "handheld", "sparse"]), seed=st.integers(0, 2**31 - 1),
       tau=st.floats(-3600.0, 3600.0, allow_nan=False))  # fmt: skip
def test_never_worse_than_the_closed_form_it_starts_from(kind, seed, tau):
    rec = simulate_hand_eye(kind, seed, tau, duration=20.0, waypoints=12)
    cam, body = _streams(rec)
    r = calibrate_hand_eye_streams(cam, body)
    assert r.start_method in HAND_EYE_CLOSED_FORMS
    assert r.rotation_rmse_deg <= r.start_rotation_rmse_deg and r.translation_rmse_m <= r.start_translation_rmse_m
    # the start's residuals, recomputed here from the named closed form on the same pairs at its time offset
    qa, ta, qb, tb, ok = pair_motions(cam, body, r.pairs[:, 0], r.pairs[:, 1], r.start_time_offset)
    assert ok.all()
    a, b = dp.dualquat_from_qt(qb, tb), dp.dualquat_from_qt(qa, ta)
    q, _ = HAND_EYE_CLOSED_FORMS[r.start_method](a, b)
    start = loop_rmse(cam, body, r.pairs, r.start_time_offset, q, hand_eye_translation(a, b, q))
    assert start[0] == pytest.approx(r.start_rotation_rmse_deg, rel=1e-4)
    assert start[1] == pytest.approx(r.start_translation_rmse_m, rel=1e-4)


def test_tau_at_the_deepest_minimum_with_commensurate_clocks():
    """Body and camera both at 20 Hz: the loop residual has local minima in τ a few ms apart."""
    rec = simulate_hand_eye("sparse", 1, 0.02)
    cam, body = _streams(rec)
    r = calibrate_hand_eye_streams(cam, body)
    i, j = r.pairs.T
    taus = r.time_offset + np.arange(-4, 5) * 1e-3  # the local minima lie ~3 ms apart here
    costs = [loop_residual(cam, body, i, j, t, r.quat, r.translation, r.sigma_rotation, r.sigma_translation).cost
             for t in taus]  # fmt: skip
    assert abs(taus[int(np.argmin(costs))] - r.time_offset) < 1e-3
