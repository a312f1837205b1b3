"""ETH's real hand-eye recordings: residual RMSE against OpenCV's five methods at the same τ on the same pairs, and τ
at the minimum of the loop residual.  On ``<repo>/../shared/data/handeye``, or on the 25 s cuts in
``tests/data/handeye`` without it."""

from __future__ import annotations

import numpy as np
import pytest
from handeye_sim import OPENCV_METHODS, loop_rmse, opencv_hand_eye

from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream, loop_residual
from dualpose.io.pose_csv import read_pose_csv
from realdata import data_dir

cv2 = pytest.importorskip("cv2")

DATA = data_dir("handeye")
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
    full = DATA == data_dir("handeye", full=True)
    cv = [loop_rmse(cam, body, r.pairs, tau, *opencv_hand_eye(cam, body, r.pairs, tau, m)) for m in OPENCV_METHODS]
    # the target holds on the whole recordings; the 25 s cuts in tests/data keep the earlier 5 % margin
    tol = 1.02 if full else 1.05
    assert rot <= tol * min(c[0] for c in cv) and trans <= tol * min(c[1] for c in cv)
    assert r.rotation_rmse_deg <= r.start_rotation_rmse_deg and r.translation_rmse_m <= r.start_translation_rmse_m
    # the whole recordings give > 500 valid pairs, the 25 s cuts in tests/data > 250
    assert r.pairs_used > 0.7 * r.pairs_total > (500 if full else 250)
    # dense scan of the loop residual, X re-fitted at every τ
    i, j = r.pairs.T
    taus = r.time_offset + np.arange(-20, 21) * 1e-3
    costs = [loop_residual(cam, body, i, j, t, r.quat, r.translation, r.sigma_rotation, r.sigma_translation).cost
             for t in taus]  # fmt: skip
    assert abs(taus[int(np.argmin(costs))] - r.time_offset) <= 5e-3


def test_a_third_of_one_recording_against_the_other_recording_is_not_credible():
    # the lowest residual ratio of an unrelated pairing in benchmarks/diag_thresholds_real.py (3.45; true pairs of
    # these recordings, whole and in halves and thirds: 0.87-1.76): refused, where a threshold of 5 only doubted it
    full = data_dir("handeye", full=True)
    if not full.is_dir():
        pytest.skip(f"needs the full hand-eye recordings ({full}; tests/data has 25 s cuts)")
    cam, _ = clean_pose_stream(*read_pose_csv(full / SETS["robot_arm_real"][0]))
    other, _ = clean_pose_stream(*read_pose_csv(full / SETS["prime_sense_1"][1]))
    edge = cam.stamps[0] + (cam.stamps[-1] - cam.stamps[0]) / 3
    keep = cam.stamps <= edge
    third = type(cam)(cam.stamps[keep], cam.positions[keep], cam.quats[keep], cam.name)
    with pytest.warns(UserWarning, match="not credible"):
        r = calibrate_hand_eye_streams(third, other)
    assert not r.credible and r.residual_to_noise > 3.0
