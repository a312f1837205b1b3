"""ETH's real hand-eye recordings: residual RMSE against OpenCV's five methods at the same τ on the same pairs, and τ
at the minimum of the loop residual.  On ``<repo>/../shared/data/handeye``, or on the 25 s cuts in
``tests/data/handeye`` without it."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.calibration import (
    calibrate_hand_eye_streams,
    clean_pose_stream,
    interpolate_stream,
    loop_residual,
    pair_motions,
    pair_residuals,
)
from dualpose.io.pose_csv import read_pose_csv
from realdata import data_dir

cv2 = pytest.importorskip("cv2")

DATA = data_dir("handeye")
SETS = {
    "prime_sense_1": ("prime_sense_1_camera_in_target.csv", "prime_sense_1_marker_in_vicon.csv"),
    "robot_arm_real": ("robot_arm_real_camera_in_target.csv", "robot_arm_real_hand_in_base.csv"),
}
METHODS = ("TSAI", "PARK", "HORAUD", "ANDREFF", "DANIILIDIS")


def _rmse(cam, body, pairs, tau, q, t):
    qa, ta, qb, tb, ok = pair_motions(cam, body, pairs[:, 0], pairs[:, 1], tau)
    rv, te = pair_residuals(qa[ok], ta[ok], qb[ok], tb[ok], q, t)
    return np.degrees(np.sqrt(np.mean(np.sum(rv**2, 1)))), np.sqrt(np.mean(np.sum(te**2, 1)))


def _opencv(cam, body, pairs, tau, method, max_poses=150):
    idx = np.unique(pairs)
    idx = idx[np.linspace(0, len(idx) - 1, min(max_poses, len(idx))).round().astype(int)]
    pb, qb, ok = interpolate_stream(body, cam.stamps[idx] + tau)
    qc, tc = dp.qt_conj(cam.quats[idx[ok]], cam.positions[idx[ok]])
    r, t = cv2.calibrateHandEye(list(dp.matrix_from_quat(qb[ok])), list(pb[ok][:, :, None]),
                                list(dp.matrix_from_quat(qc)), list(tc[:, :, None]),
                                method=getattr(cv2, f"CALIB_HAND_EYE_{method}"))  # fmt: skip
    return dp.quat_from_matrix(r), t.ravel()


@pytest.mark.parametrize("name", list(SETS))
def test_real_dataset_against_opencv_and_loop_minimum(name):
    if not DATA.is_dir():
        pytest.skip(f"hand-eye data directory missing: {DATA}")
    cam, _ = clean_pose_stream(*read_pose_csv(DATA / SETS[name][0]))
    body, _ = clean_pose_stream(*read_pose_csv(DATA / SETS[name][1]))
    r = calibrate_hand_eye_streams(cam, body)
    rot, trans = _rmse(cam, body, r.pairs, r.time_offset, r.quat, r.translation)
    assert rot == pytest.approx(r.rotation_rmse_deg) and trans == pytest.approx(r.translation_rmse_m)
    cv = [_rmse(cam, body, r.pairs, r.time_offset, *_opencv(cam, body, r.pairs, r.time_offset, m)) for m in METHODS]
    assert rot <= 1.05 * min(c[0] for c in cv) and trans <= 1.05 * min(c[1] for c in cv)
    # the whole recordings give > 500 valid pairs, the 25 s cuts in tests/data > 250
    assert r.pairs_used > 0.7 * r.pairs_total > (500 if DATA == data_dir("handeye", full=True) else 250)
    # dense scan of the loop residual, X re-fitted at every τ
    i, j = r.pairs.T
    taus = r.time_offset + np.arange(-20, 21) * 1e-3
    costs = [loop_residual(cam, body, i, j, t, r.quat, r.translation, r.sigma_rotation, r.sigma_translation).cost
             for t in taus]  # fmt: skip
    assert abs(taus[int(np.argmin(costs))] - r.time_offset) <= 5e-3
