"""PoseEstimate.rotation_covariance / direction_influence: the directions-only (Wahba) covariance."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.registration import register_pose


def _problem(rng: np.random.Generator, m: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n0 = rng.normal(size=(m, 3))
    n0 /= np.linalg.norm(n0, axis=1, keepdims=True)
    q = dp.quat_from_rotvec(rng.normal(size=3))
    return n0, dp.quat_rotate(q, n0), q


def test_influence_matches_finite_differences(rng: np.random.Generator) -> None:
    n0, n1, _ = _problem(rng)
    w = rng.uniform(0.5, 2.0, len(n0))
    base = register_pose(None, None, model_directions=n0, measured_directions=n1, direction_weights=w)
    g = base.direction_influence()
    for j in range(len(n0)):
        for i in range(3):
            e = np.zeros_like(n1)
            e[j, i] = 1e-7
            moved = register_pose(None, None, model_directions=n0, measured_directions=n1 + e, direction_weights=w)
            eps = dp.rotvec_from_quat(dp.quat_mul(moved.quat, dp.quat_conj(base.quat)))
            # only the tangential part of e acts (directions are renormalized): g annihilates the radial part
            np.testing.assert_allclose(eps / 1e-7, g[j] @ np.eye(3)[i], atol=2e-6)


def test_equals_covariance_rotation_block_with_points(rng: np.random.Generator) -> None:
    p0 = rng.normal(size=(8, 3))
    n0, n1, q = _problem(rng, 4)
    p1 = dp.quat_rotate(q, p0) + [1.0, 2.0, 3.0]
    est = register_pose(p0, p1, model_directions=n0, measured_directions=n1)
    np.testing.assert_allclose(est.rotation_covariance(0.01, 0.02), est.covariance(0.01, 0.02)[:3, :3], atol=1e-15)
    cd = np.broadcast_to(np.eye(3) * 0.02**2, (4, 3, 3))
    np.testing.assert_allclose(
        est.rotation_covariance(0.01, direction_covariances=cd), est.covariance(0.01, 0.02)[:3, :3], atol=1e-15
    )


def test_directions_only_anisotropic_monte_carlo(rng: np.random.Generator) -> None:
    n0, n1, q = _problem(rng, 5)
    a = rng.normal(size=(5, 3, 3)) * 0.01
    cd = np.einsum("mij,mkj->mik", a, a)  # anisotropic per-direction covariances
    w = 2.0 / np.trace(cd, axis1=1, axis2=2)
    est = register_pose(None, None, model_directions=n0, measured_directions=n1, direction_weights=w)
    predicted = est.rotation_covariance(direction_covariances=cd)
    errs = []
    for _ in range(3000):
        noisy = n1 + np.einsum("mij,mj->mi", a, rng.normal(size=(5, 3)))
        e = register_pose(None, None, model_directions=n0, measured_directions=noisy, direction_weights=w)
        errs.append(dp.rotvec_from_quat(dp.quat_mul(e.quat, dp.quat_conj(q))))
    empirical = np.cov(np.array(errs).T)
    np.testing.assert_allclose(np.sqrt(np.diag(empirical)), np.sqrt(np.diag(predicted)), rtol=0.08)


def test_errors() -> None:
    n0 = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 2.0]])
    est = register_pose(None, None, model_directions=n0, measured_directions=n0)
    assert not est.rotation_unique
    with pytest.raises(ValueError, match="not unique"):
        est.direction_influence()
    ok = register_pose(None, None, model_directions=np.eye(3), measured_directions=np.eye(3))
    with pytest.raises(ValueError, match=r"direction_covariances.*\(3, 3, 3\)"):
        ok.rotation_covariance(direction_covariances=np.zeros((2, 3, 3)))
    with pytest.raises(ValueError, match="not both"):
        ok.rotation_covariance(sigma_directions=0.1, direction_covariances=np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="non-negative"):
        ok.rotation_covariance(sigma_directions=-1.0)
