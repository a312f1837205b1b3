"""Exact motions: closed forms checked against finite differences of the pose and against quadrature."""

import numpy as np
import pytest

import dualpose as dp
from dualpose.inertial import motions as m

MOTIONS = [m.Coning(0.3, 2.0), m.Coning(0.3, 2.0, 0.7), m.SmoothTrajectory()]


@pytest.mark.parametrize("frame", ["body", "space"])
@pytest.mark.parametrize("motion", MOTIONS, ids=["coning", "dual-coning", "smooth"])
def test_twist_satisfies_kinematics(motion, frame):
    """q̂̇ = ½ q̂ (x) [ω^b, v^b] (body) or ½ [ω^i, v_s] (x) q̂ (inertial), q̂̇ by central differences."""
    t = np.linspace(0.0, 3.0, 7)
    e = 1e-5
    qdot = (motion.pose(t + e) - motion.pose(t - e)) / (2 * e)
    tw = motion.twist(t, frame)
    z = np.zeros((t.size, 1))
    pure = np.concatenate([tw[:, :3], z, tw[:, 3:], z], axis=-1)
    s = motion.pose(t)
    rhs = 0.5 * (dp.dualquat_mul(s, pure) if frame == "body" else dp.dualquat_mul(pure, s))
    np.testing.assert_allclose(rhs, qdot, atol=1e-8)


def test_classical_coning_formulas_of_docs_inertial():
    a, om = 0.4, 1.7
    c = m.Coning(a, om)
    t = np.array([0.0, 0.3, 1.9])
    q = c.attitude(t)
    np.testing.assert_allclose(q[:, 1], np.sin(a / 2) * np.cos(om * t), atol=1e-15)
    np.testing.assert_allclose(q[:, 3], np.cos(a / 2), atol=1e-15)
    w = c.twist(t)[:, :3]
    np.testing.assert_allclose(w[:, 0], -2 * om * np.sin(a / 2) ** 2, atol=1e-15)
    np.testing.assert_allclose(w[:, 2], om * np.sin(a) * np.cos(om * t), atol=1e-15)
    # zero translation for d = 0
    np.testing.assert_array_equal(c.pose(t)[:, 4:], 0.0)


def test_dual_coning_origin_moves_on_circle():
    d, om = 0.7, 2.0
    c = m.Coning(0.3, om, d)
    t = np.linspace(0.0, 5.0, 11)
    circle = d * np.stack([0 * t, np.cos(om * t), np.sin(om * t)], axis=-1)
    np.testing.assert_allclose(c.position(t), circle, atol=1e-15)
    np.testing.assert_allclose(dp.dualquat_norm(c.pose(t))[..., 1], 0.0, atol=1e-15)  # unit dual quaternion


@pytest.mark.parametrize("frame", ["body", "space"])
@pytest.mark.parametrize("d", [0.0, 0.9])
def test_coning_exact_increments_match_quadrature(frame, d):
    c = m.Coning(0.5, 3.0, d)
    exact = c.dual_increments(0.37, 0.05, 20, frame)
    quad = m.Motion.dual_increments(c, 0.37, 0.05, 20, frame)  # Gauss-Legendre on the twist
    np.testing.assert_allclose(exact, quad, atol=2e-16, rtol=0)
    np.testing.assert_allclose(c.increments(0.37, 0.05, 20, frame), exact[:, :3], atol=0)


def test_quadrature_converges_on_smooth_trajectory():
    """Sum of increments over one sub-interval split 1 vs 16 ways agrees (8-point Gauss-Legendre is exact here)."""
    s = m.SmoothTrajectory()
    one = s.dual_increments(0.2, 0.1, 1)
    many = s.dual_increments(0.2, 0.1 / 16, 16).sum(axis=0)
    np.testing.assert_allclose(one[0], many, atol=1e-15)


def test_constant_twist_increments_and_pose():
    tw = (0.1, -0.2, 0.3, 1.0, 0.5, -0.4)
    c = m.ConstantTwist(tw)
    np.testing.assert_allclose(c.dual_increments(0.0, 0.01, 3), 0.01 * np.tile(tw, (3, 1)), atol=0)
    np.testing.assert_allclose(c.pose(2.0), dp.dualquat_from_twist(2.0 * np.asarray(tw)), atol=1e-15)
    with pytest.raises(ValueError, match="frame"):
        c.twist(0.0, "space")


def test_bad_arguments():
    c = m.Coning(0.1, 1.0)
    with pytest.raises(ValueError, match="h must be"):
        c.dual_increments(0.0, -1.0, 3)
    with pytest.raises(ValueError, match="n must be"):
        c.dual_increments(0.0, 0.1, 0)
    with pytest.raises(ValueError, match="frame"):
        c.twist(0.0, "world")
