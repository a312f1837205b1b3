"""Registration at any coordinate scale: the solver normalises the centred points by a power of two (exact), so
points scaled by 1e-200 (or 1e200) give the rotation of scale 1 and the translation scaled back, not the identity
with cost 0 and "single-point" (docs/refusals.md); overflow of the centroid sums is refused by one rule."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
from dualpose.registration import register_pose, register_pose_batch, register_pose_ransac


def _problem(seed: int, n: int = 12) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    q = dp.quat_canonical(dp.quat_normalize(rng.normal(size=4)))
    t = rng.normal(size=3)
    y = dp.quat_rotate(q, x) + t + rng.normal(0.0, 1e-3, (n, 3))
    return x, y, q, t


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10_000), st.integers(-1000, 990), st.sampled_from(["dq", "horn", "svd"]), st.booleans())
def test_power_of_two_scaled_points_give_the_same_rotation_and_a_scaled_translation(seed, e, method, scale):
    x, y, _, _ = _problem(seed)
    ref = register_pose(x, y, method=method, scale=scale)
    est = register_pose(np.ldexp(x, e), np.ldexp(y, e), method=method, scale=scale)
    np.testing.assert_allclose(est.quat, ref.quat, rtol=0, atol=1e-11)  # the solvers agree to ~1e-12
    np.testing.assert_allclose(np.ldexp(est.translation, -e), ref.translation, rtol=1e-12, atol=1e-12)
    assert est.scale == pytest.approx(ref.scale, rel=1e-13)
    assert est.rotation_unique and est.degeneracy == ref.degeneracy
    assert np.ldexp(est.rmsd, -e) == pytest.approx(ref.rmsd, rel=1e-9)
    if abs(e) <= 500:  # eigenvalues are squares, in the input's units: representable up to |e| ~ 511
        np.testing.assert_allclose(np.ldexp(est.eigenvalues, -2 * e), ref.eigenvalues, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("k", [1e-160, 1e-200, 1e-300, 1e150, 1e200, 1e300])
def test_decimal_scales_of_the_issue(k):
    x, y, q, _ = _problem(7)
    ref = register_pose(x, y)
    est = register_pose(x * k, y * k)
    assert est.degeneracy == "none" and est.rotation_unique
    np.testing.assert_allclose(est.quat, ref.quat, atol=1e-12)
    np.testing.assert_allclose(est.translation / k, ref.translation, rtol=1e-10, atol=1e-10)
    assert est.rmsd / k == pytest.approx(ref.rmsd, rel=1e-6)
    batch = register_pose_batch(np.stack([x, x * k]), np.stack([y, y * k]))
    np.testing.assert_allclose(batch.quat[1], ref.quat, atol=1e-12)
    assert batch.rmsd[1] / k == pytest.approx(ref.rmsd, rel=1e-6)


def test_tiny_offset_spread_directions_ransac_and_overflow():
    x, y, q, t = _problem(3, n=30)
    # a spread of 1e-200 at an offset of 1e-198: the centred coordinates are normalised, not the raw ones
    est = register_pose(1e-198 + 1e-200 * x, 2e-198 + 1e-200 * y)
    np.testing.assert_allclose(est.quat, register_pose(x, y).quat, atol=1e-12)
    # directions keep their weight relative to the points after the normalisation
    n0 = np.eye(3)
    n1 = dp.quat_rotate(q, n0)
    ref = register_pose(x, y, model_directions=n0, measured_directions=n1, direction_weights=np.full(3, 1e-4))
    k = 2.0**-300
    est = register_pose(x * k, y * k, model_directions=n0, measured_directions=n1,
                        direction_weights=np.full(3, 1e-4) * k**2)  # fmt: skip
    np.testing.assert_allclose(est.quat, ref.quat, atol=1e-12)
    # RANSAC on 1e-200 points: residuals compared with a threshold in the same units (no squares underflow)
    yo = y.copy()
    yo[:5] += 3.0  # outliers
    rob = register_pose_ransac(x * 1e-200, yo * 1e-200, threshold=1e-202, seed=1)
    assert rob.inlier_mask[:5].sum() == 0 and rob.inlier_mask[5:].all()
    np.testing.assert_allclose(rob.pose.quat, register_pose(x[5:], y[5:]).quat, atol=1e-9)
    with pytest.raises(ValueError, match="exceed the largest double"):
        register_pose(np.full((4, 3), 1.5e308) * [[1], [-1], [1], [1]], np.ones((4, 3)))
