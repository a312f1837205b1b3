"""ETH's real hand-eye recordings: residual RMSE against OpenCV's five methods at the same τ on the same pairs, and τ
at the minimum of the loop residual.  Skipped when ``<repo>/../shared/data/handeye`` is missing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from handeye_sim import OPENCV_METHODS, loop_rmse, opencv_hand_eye

from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream, loop_residual
from dualpose.io.pose_csv import read_pose_csv

cv2 = pytest.importorskip("cv2")

DATA = Path(__file__).parents[2] / ".." / "shared" / "data" / "handeye"
SETS = {
    "prime_sense_1": ("prime_sense_1_camera_in_target.csv", "prime_sense_1_marker_in_vicon.csv"),
    "robot_arm_real": ("robot_arm_real_camera_in_target.csv", "robot_arm_real_hand_in_base.csv"),
}


@pytest.mark.parametrize("name", list(SETS))
def test_real_dataset_against_opencv_and_loop_minimum(name):
    if not DATA.is_dir():
        pytest.skip(f"hand-eye data directory missing: {DATA}")
    cam, _ = clean_pose_stream(*read_pose_csv(DATA / SETS[name][0]))
    body, _ = clean_pose_stream(*read_pose_csv(DATA / SETS[name][1]))
    r = calibrate_hand_eye_streams(cam, body)
    rot, trans = loop_rmse(cam, body, r.pairs, r.time_offset, r.quat, r.translation)
    assert rot == pytest.approx(r.rotation_rmse_deg) and trans == pytest.approx(r.translation_rmse_m)
    tau = r.time_offset
    cv = [loop_rmse(cam, body, r.pairs, tau, *opencv_hand_eye(cam, body, r.pairs, tau, m)) for m in OPENCV_METHODS]
    assert rot <= 1.02 * min(c[0] for c in cv) and trans <= 1.02 * min(c[1] for c in cv)
    assert r.rotation_rmse_deg <= r.start_rotation_rmse_deg and r.translation_rmse_m <= r.start_translation_rmse_m
    assert r.pairs_used > 0.7 * r.pairs_total > 500
    # dense scan of the loop residual, X re-fitted at every τ
    i, j = r.pairs.T
    taus = r.time_offset + np.arange(-20, 21) * 1e-3
    costs = [loop_residual(cam, body, i, j, t, r.quat, r.translation, r.sigma_rotation, r.sigma_translation).cost
             for t in taus]  # fmt: skip
    assert abs(taus[int(np.argmin(costs))] - r.time_offset) <= 5e-3
