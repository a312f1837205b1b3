"""Hand–eye calibration (Daniilidis 1999) against the truth and against OpenCV's calibrateHandEye."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import dualpose as dp
from dualpose.registration import HandEyeWarning, calibrate_hand_eye, hand_eye_motions

cv2 = pytest.importorskip("cv2")


def _poses(rng, n, x, rot_noise=0.0, trans_noise=0.0, axis=None):
    """Gripper-to-base poses G_i, target-to-camera poses C_i = X⁻¹ G_i⁻¹ T (noisy), as 4x4 matrices."""
    target = dp.matrix_from_dualquat(dp.dualquat_from_qt(dp.quat_normalize(rng.normal(size=4)), [1.0, 0.5, 0.2]))
    g = []
    for _ in range(n):
        ax = rng.normal(size=3) if axis is None else np.asarray(axis, float)
        q = dp.quat_from_axis_angle(ax, rng.uniform(0.3, 1.5))
        g.append(dp.matrix_from_dualquat(dp.dualquat_from_qt(q, rng.uniform(-0.5, 0.5, 3))))
    g = np.array(g)
    c = np.linalg.inv(x) @ np.linalg.inv(g) @ target
    def noisy(m):
        out = m.copy()
        for k in range(len(m)):
            dq = dp.quat_from_rotvec(rot_noise * rng.normal(size=3))
            out[k, :3, :3] = dp.matrix_from_quat(dq) @ m[k, :3, :3]
            out[k, :3, 3] += trans_noise * rng.normal(size=3)
        return out
    return noisy(g), noisy(c)


def _x(rng):
    return dp.matrix_from_dualquat(dp.dualquat_from_qt(dp.quat_normalize(rng.normal(size=4)), [0.05, -0.1, 0.2]))


def _errors(x_est, x_true):
    # the angle of R_est R_trueᵀ as atan2(sin, cos): an arccos of (trace - 1)/2 cannot resolve angles below ~2e-8
    r = x_est[:3, :3] @ x_true[:3, :3].T
    s = np.linalg.norm([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2
    ang = np.arctan2(s, (np.trace(r) - 1) / 2)
    return float(ang), float(np.linalg.norm(x_est[:3, 3] - x_true[:3, 3]))


def test_exact_data_and_random_signs():
    rng = np.random.default_rng(0)
    x = _x(rng)
    g, c = _poses(rng, 6, x)
    a, b = hand_eye_motions(g, c)
    b = b * rng.choice([-1.0, 1.0], size=(len(b), 1))  # the double cover: signs must be aligned inside
    res = calibrate_hand_eye(a, b)
    ang, dt = _errors(res.matrix, x)
    assert ang <= 1e-10 and dt <= 1e-10
    assert res.rotation_residuals.max() <= 1e-10 and res.translation_residuals.max() <= 1e-10
    assert res.incongruent_pairs.size == 0 and not res.parallel_axes
    assert np.abs(dp.matrix_from_dualquat(res.dualquat) - res.matrix).max() <= 1e-14
    assert res.singular_values[-2:].max() <= 1e-10 < res.singular_values[-3]
    # 4x4 input gives the same answer as dual quaternions
    res_m = calibrate_hand_eye(dp.matrix_from_dualquat(a), dp.matrix_from_dualquat(b))
    assert np.abs(res_m.matrix - res.matrix).max() <= 1e-12


def test_at_least_as_accurate_as_opencv():
    rng = np.random.default_rng(1)
    errs = {"ours": [], "DANIILIDIS": [], "TSAI": []}
    for _ in range(15):
        x = _x(rng)
        g, c = _poses(rng, 10, x, rot_noise=2e-3, trans_noise=2e-3)
        a, b = hand_eye_motions(g, c)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", HandEyeWarning)
            errs["ours"].append(_errors(calibrate_hand_eye(a, b).matrix, x))
        for name in ("DANIILIDIS", "TSAI"):
            r, t = cv2.calibrateHandEye(
                list(g[:, :3, :3]), list(g[:, :3, 3]), list(c[:, :3, :3]), list(c[:, :3, 3]),
                method=getattr(cv2, f"CALIB_HAND_EYE_{name}"),
            )  # fmt: skip
            m = np.eye(4)
            m[:3, :3], m[:3, 3] = r, t.ravel()
            errs[name].append(_errors(m, x))
    mean = {k: np.mean(v, axis=0) for k, v in errs.items()}
    for name in ("DANIILIDIS", "TSAI"):
        assert mean["ours"][0] <= 1.05 * mean[name][0], mean
        assert mean["ours"][1] <= 1.05 * mean[name][1], mean
    assert mean["ours"][0] < 5e-3 and mean["ours"][1] < 2e-2


def test_covariance_is_consistent_with_errors():
    rng = np.random.default_rng(2)
    x = _x(rng)
    g, c = _poses(rng, 12, x, rot_noise=1e-3, trans_noise=1e-3)
    res = calibrate_hand_eye(*hand_eye_motions(g, c), distance_tol=0.02)
    std = np.sqrt(np.diag(res.covariance))
    assert np.all(np.isfinite(std)) and np.all(std > 0)
    ang, dt = _errors(res.matrix, x)
    assert ang <= 6 * np.linalg.norm(std[:3]) and dt <= 6 * np.linalg.norm(std[3:])


def test_incongruent_pair_reported_and_parallel_axes_warned():
    rng = np.random.default_rng(3)
    x = _x(rng)
    g, c = _poses(rng, 5, x)
    a, b = hand_eye_motions(g, c, pairs="consecutive")
    b[2] = dp.dualquat_mul(b[2], dp.dualquat_from_qt(dp.quat_from_axis_angle([0, 0, 1], 0.3), [0, 0, 0]))
    with pytest.warns(HandEyeWarning, match="screw congruence"):
        res = calibrate_hand_eye(a, b, exclude_incongruent=True)
    assert res.incongruent_pairs.tolist() == [2]
    assert _errors(res.matrix, x)[0] <= 1e-9
    g, c = _poses(rng, 5, x, axis=[0, 0, 1])
    with pytest.warns(HandEyeWarning, match="parallel"):
        res = calibrate_hand_eye(*hand_eye_motions(g, c))
    assert res.parallel_axes and np.isinf(res.covariance[5, 5]) and not np.isnan(res.covariance).any()
    assert _errors(res.matrix, x)[0] <= 1e-8  # the rotation is still determined


def test_hand_eye_bad_input():
    with pytest.raises(ValueError, match="A_motions must have shape"):
        calibrate_hand_eye(np.zeros((3, 3, 3)), np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="at least 2"):
        calibrate_hand_eye(np.eye(4)[None], np.eye(4)[None])
    with pytest.raises(ValueError, match="rotate"):
        calibrate_hand_eye(np.stack([np.eye(4)] * 3), np.stack([np.eye(4)] * 3))
