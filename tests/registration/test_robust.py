"""RANSAC and IRLS: 40% gross outliers, pose recovered to the noise level, inliers identified."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.registration import ransac_iterations, register_pose, register_pose_irls, register_pose_ransac

SIGMA = 0.01


def _outlier_problem(seed: int, n: int = 100, frac: float = 0.4):
    rng = np.random.default_rng(seed)
    q = dp.quat_normalize(rng.normal(size=4))
    t = rng.normal(size=3) * 5
    p0 = rng.uniform(-5, 5, size=(n, 3))
    p1 = dp.quat_rotate(q, p0) + t + SIGMA * rng.normal(size=(n, 3))
    bad = rng.permutation(n)[: int(frac * n)]
    p1[bad] = rng.uniform(-20, 20, size=(len(bad), 3))  # gross outliers
    inlier = np.ones(n, bool)
    inlier[bad] = False
    return q, t, p0, p1, inlier


@pytest.mark.parametrize("method", ["dq", "horn", "svd"])
def test_ransac_40_percent_outliers(method):
    q, t, p0, p1, inlier = _outlier_problem(3)
    res = register_pose_ransac(p0, p1, threshold=5 * SIGMA, seed=1, method=method)
    assert np.array_equal(res.inlier_mask, inlier)
    # the refit equals least squares on the true inliers, and sits within the noise of the truth
    ref = register_pose(p0[inlier], p1[inlier])
    assert np.abs(res.pose.quat - ref.quat).max() <= 1e-10
    assert np.abs(res.pose.translation - ref.translation).max() <= 1e-10
    cov = ref.covariance(SIGMA)
    err_rot = dp.rotvec_from_quat(dp.quat_mul(q, dp.quat_conj(res.pose.quat)))
    err = np.r_[err_rot, t - res.pose.translation]
    assert float(err @ np.linalg.solve(cov, err)) <= 30.0  # chi-square(6): p ~ 4e-5
    # adaptive count: with w = 0.6 a 99.9% confidence needs ~29 triples; far fewer than the cap
    assert res.iterations < 1000
    assert res.inlier_ratio == pytest.approx(0.6)


def test_ransac_then_cauchy_irls_and_reproducible():
    q, t, p0, p1, inlier = _outlier_problem(5)
    a = register_pose_ransac(p0, p1, threshold=5 * SIGMA, seed=7, irls="cauchy")
    b = register_pose_ransac(p0, p1, threshold=5 * SIGMA, seed=7, irls="cauchy")
    assert np.array_equal(a.pose.quat, b.pose.quat)
    assert np.array_equal(a.inlier_mask, inlier)
    assert a.weights[~inlier].max() < 1e-4 and a.weights[inlier].min() > 0.05  # c = threshold / 3
    assert dp.quat_angle(a.pose.quat, q) < 6 * SIGMA / 5 / np.sqrt(60) * 3
    assert np.abs(a.pose.translation - t).max() < 10 * SIGMA


def test_irls_huber_moderate_outliers():
    rng = np.random.default_rng(9)
    q = dp.quat_normalize(rng.normal(size=4))
    t = np.array([1.0, -2.0, 0.5])
    p0 = rng.uniform(-3, 3, size=(60, 3))
    p1 = dp.quat_rotate(q, p0) + t + SIGMA * rng.normal(size=(60, 3))
    p1[:6] += rng.normal(size=(6, 3)) * 0.5  # 10% moderate outliers
    ls = register_pose(p0, p1)
    rob = register_pose_irls(p0, p1, loss="huber", c=2 * SIGMA)
    clean = register_pose(p0[6:], p1[6:])
    assert dp.quat_angle(rob.pose.quat, q) < 0.3 * dp.quat_angle(ls.quat, q)
    assert dp.quat_angle(rob.pose.quat, clean.quat) < 2e-3
    assert rob.weights[:6].max() < rob.weights[6:].min()
    assert rob.iterations < 50
    default_c = register_pose_irls(p0, p1, loss="cauchy")
    assert default_c.threshold > 0 and dp.quat_angle(default_c.pose.quat, clean.quat) < 2e-3


def test_ransac_iterations_formula():
    assert ransac_iterations(0.5, 0.99) == int(np.ceil(np.log(0.01) / np.log(1 - 0.125)))
    assert ransac_iterations(1.0, 0.99) == 1
    assert ransac_iterations(0.0, 0.99) > 10**12


def test_robust_bad_input():
    p = np.random.default_rng(0).normal(size=(10, 3))
    with pytest.raises(ValueError, match="threshold"):
        register_pose_ransac(p, p, threshold=0.0)
    with pytest.raises(ValueError, match="confidence"):
        register_pose_ransac(p, p, threshold=1.0, confidence=1.0)
    with pytest.raises(ValueError, match="irls"):
        register_pose_ransac(p, p, threshold=1.0, irls="tukey")
    with pytest.raises(ValueError, match="loss"):
        register_pose_irls(p, p, loss="l1")
    line = np.outer(np.arange(10.0), [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="no triple"):
        register_pose_ransac(line, line, threshold=1.0, max_iterations=50, seed=0)
