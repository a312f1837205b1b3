"""method="svd": the LAPACK-free 3x3 SVD of the native solver against numpy's (LAPACK) on full-rank, reflected,
coplanar and collinear data (Arun 1987 / Umeyama 1991: R = V diag(1, 1, d) Uᵀ, d = sign det(V Uᵀ))."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.registration import register_pose


def _cross_covariance(p0, p1):
    a, b = p0 - p0.mean(axis=0), p1 - p1.mean(axis=0)
    return a.T @ b  # H = Σ p⁰' p̃'ᵀ


@pytest.mark.parametrize("rank", [3, 2, 1])
def test_singular_values_match_lapack(rank):
    rng = np.random.default_rng(rank)
    for _ in range(50):
        p0 = rng.normal(size=(8, 3)) * [3.0, 2.0, 1.0]
        if rank < 3:
            p0[:, 2] = 0.7
        if rank < 2:
            p0[:, 1] = -1.2
        q = dp.quat_normalize(rng.normal(size=4))
        p1 = dp.quat_rotate(q, p0) + rng.normal(size=3) + 0.05 * rng.normal(size=p0.shape)
        est = register_pose(p0, p1, method="svd")
        ref = np.linalg.svd(_cross_covariance(p0, p1), compute_uv=False)
        assert np.abs(est.singular_values - ref).max() <= 1e-13 * ref[0]
        assert np.all(np.diff(est.singular_values) <= 0.0)
        if rank == 3:
            assert est.reflection_sign == np.sign(np.linalg.det(_cross_covariance(p0, p1)))
        if rank >= 2:
            horn = register_pose(p0, p1, method="horn")
            assert min(np.abs(est.quat - horn.quat).max(), np.abs(est.quat + horn.quat).max()) <= 1e-12


def test_coplanar_exact_zero_singular_value_gives_a_rotation():
    # the centred model has an exactly zero third coordinate: H has a zero row, U must still be orthonormal
    rng = np.random.default_rng(7)
    for _ in range(100):
        p0 = np.c_[rng.normal(size=(6, 2)) * 3, np.zeros(6)] + [0, 0, 4.0]
        q = dp.quat_normalize(rng.normal(size=4))
        p1 = dp.quat_rotate(q, p0) + rng.normal(size=3)
        est = register_pose(p0, p1, method="svd")
        assert est.rotation_unique
        assert min(np.abs(est.quat - q).max(), np.abs(est.quat + q).max()) <= 1e-12
        assert est.singular_values[2] <= 1e-12 * est.singular_values[0]
