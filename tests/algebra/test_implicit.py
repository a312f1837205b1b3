"""Implicit dual quaternions (q, t) vs 4x4 matrices, scipy RigidTransform, the DQ product and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import RigidTransform, Rotation

from dualpose.algebra import implicit as im
from dualpose.algebra.lie import so3_left_jacobian
from dualpose.algebra.quat import matrix_from_quat, quat_conj, quat_from_rotvec, quat_mul, quat_normalize

EPS = np.finfo(float).eps
finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
unit_quats = arrays(np.float64, 4, elements=finite).filter(lambda q: np.linalg.norm(q) > 1e-2).map(
    lambda q: q / np.linalg.norm(q)
)
vec3 = arrays(np.float64, 3, elements=finite)


def homogeneous(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    m = np.zeros(np.broadcast_shapes(q.shape[:-1], t.shape[:-1]) + (4, 4))
    m[..., :3, :3] = matrix_from_quat(q)
    m[..., :3, 3] = t
    m[..., 3, 3] = 1.0
    return m


@pytest.fixture
def poses(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    q = Rotation.random(1000, rng=rng).as_quat()
    q[:20] = quat_from_rotvec(rng.normal(size=(20, 3)) * 1e-9)
    return q, rng.normal(size=(1000, 3)) * 3


class TestAgainstMatrices:
    def test_mul(self, poses, rng) -> None:
        q1, t1 = poses
        q2, t2 = np.roll(q1, 5, axis=0), rng.normal(size=t1.shape)
        q, t = im.qt_mul(q1, t1, q2, t2)
        ref = homogeneous(q1, t1) @ homogeneous(q2, t2)
        np.testing.assert_allclose(homogeneous(q, t), ref, atol=1e-14)
        np.testing.assert_array_equal(q, quat_mul(q1, q2))  # eq. (104) keeps the sign

    def test_transform(self, poses, rng) -> None:
        q, t = poses
        p = rng.normal(size=t.shape)
        ref = RigidTransform.from_components(t, Rotation.from_quat(q)).apply(p)
        np.testing.assert_allclose(im.qt_transform(q, t, p), ref, atol=1e-14)
        hom = np.einsum("nij,nj->ni", homogeneous(q, t), np.c_[p, np.ones(len(p))])[:, :3]
        np.testing.assert_allclose(im.qt_transform(q, t, p), hom, atol=1e-14)

    def test_conj_is_inverse(self, poses) -> None:
        q, t = poses
        qc, tc = im.qt_conj(q, t)
        np.testing.assert_array_equal(qc, quat_conj(q))
        ref = RigidTransform.from_components(t, Rotation.from_quat(q)).inv()
        np.testing.assert_allclose(tc, ref.translation, atol=1e-14)
        tol = 8 * EPS * np.abs(t).max()
        qi, ti = im.qt_mul(q, t, qc, tc)
        np.testing.assert_allclose(np.abs(qi[:, 3]), 1.0, atol=2 * EPS)
        np.testing.assert_allclose(ti, 0.0, atol=tol)
        qi, ti = im.qt_mul(qc, tc, q, t)
        np.testing.assert_allclose(ti, 0.0, atol=tol)

    def test_matches_dual_quaternion_product(self, poses, rng) -> None:
        """Eq. (79) on [q, ½ t (x) q], then t = 2 vec(d (x) q*) (eq. (78)): the derivation of eqs. (104)-(105)."""
        q1, t1 = poses
        q2, t2 = np.roll(q1, 3, axis=0), rng.normal(size=t1.shape)

        def pure(v: np.ndarray) -> np.ndarray:
            return np.c_[v, np.zeros(len(v))]

        d1, d2 = 0.5 * quat_mul(pure(t1), q1), 0.5 * quat_mul(pure(t2), q2)
        r = quat_mul(q1, q2)
        d = quat_mul(q1, d2) + quat_mul(d1, q2)
        t = 2 * quat_mul(d, quat_conj(r))[:, :3]
        qq, tt = im.qt_mul(q1, t1, q2, t2)
        np.testing.assert_allclose(qq, r, atol=0)
        np.testing.assert_allclose(tt, t, atol=1e-13)


@given(unit_quats, vec3, unit_quats, vec3, unit_quats, vec3)
def test_associative(qa, ta, qb, tb, qc, tc) -> None:
    q1, t1 = im.qt_mul(*im.qt_mul(qa, ta, qb, tb), qc, tc)
    q2, t2 = im.qt_mul(qa, ta, *im.qt_mul(qb, tb, qc, tc))
    np.testing.assert_allclose(q1, q2, atol=8 * EPS)
    np.testing.assert_allclose(t1, t2, atol=64 * EPS * (1 + np.abs(ta).max() + np.abs(tb).max() + np.abs(tc).max()))


@given(unit_quats, vec3, vec3)
def test_transform_is_mul_then_translation(q, t, p) -> None:
    """Transforming a point equals composing with the pure translation (1, p) (eqs. (105)-(106))."""
    _, tt = im.qt_mul(q, t, np.array([0.0, 0, 0, 1]), p)
    np.testing.assert_array_equal(im.qt_transform(q, t, p), tt)


# ---------------------------------------------------------------------------------------------------------------
# twists
# ---------------------------------------------------------------------------------------------------------------


class TestTwists:
    def test_from_twist_against_scipy(self, rng) -> None:
        xi = rng.normal(size=(1000, 6)) * 2
        xi[:20, :3] *= 1e-10
        q, t = im.qt_from_twist(xi)
        tf = RigidTransform.from_exp_coords(xi)
        np.testing.assert_allclose(t, tf.translation, atol=16 * EPS * np.abs(t).max())
        np.testing.assert_allclose(matrix_from_quat(q), tf.rotation.as_matrix(), atol=4 * EPS)
        np.testing.assert_array_equal(q, quat_from_rotvec(xi[:, :3]))  # q = exp(ω/2), sign not canonicalised
        np.testing.assert_allclose(t, np.einsum("nij,nj->ni", so3_left_jacobian(xi[:, :3]), xi[:, 3:]), atol=1e-13)

    def test_to_twist_against_scipy(self, poses) -> None:
        q, t = poses
        xi = im.twist_from_qt(q, t)
        ref = RigidTransform.from_components(t, Rotation.from_quat(q)).as_exp_coords()
        np.testing.assert_allclose(xi, ref, atol=1e-12)
        np.testing.assert_array_equal(im.twist_from_qt(-q, t), xi)  # sign invariant
        assert np.all(np.linalg.norm(xi[:, :3], axis=1) <= math.pi)

    def test_round_trip(self, rng) -> None:
        xi = rng.normal(size=(1000, 6))
        xi[:, :3] *= rng.uniform(0, 3.1, size=(1000, 1)) / np.linalg.norm(xi[:, :3], axis=1, keepdims=True)
        xi[:10, :3] *= 1e-300
        back = im.twist_from_qt(*im.qt_from_twist(xi))
        np.testing.assert_allclose(back, xi, rtol=0, atol=1e-13)
        np.testing.assert_allclose(back[:10, :3], xi[:10, :3], rtol=4 * EPS, atol=0)  # tiny angles kept
        q, t = im.qt_from_twist(back)
        q0, t0 = im.qt_from_twist(xi)
        np.testing.assert_allclose(q, q0, atol=4 * EPS)
        np.testing.assert_allclose(t, t0, atol=1e-13)

    def test_identity_and_half_turn(self) -> None:
        q, t = im.qt_from_twist(np.array([0.0, 0, 0, 1, 2, 3]))
        assert np.array_equal(q, [0, 0, 0, 1]) and np.array_equal(t, [1, 2, 3])
        assert np.array_equal(im.twist_from_qt(q, t), [0, 0, 0, 1, 2, 3])
        xi = im.twist_from_qt(np.array([0.0, 0.0, 1.0, 0.0]), np.array([1.0, 0.0, 2.0]))  # 180° about z
        assert np.all(np.isfinite(xi))
        np.testing.assert_allclose(np.linalg.norm(xi[:3]), math.pi, rtol=EPS)
        q2, t2 = im.qt_from_twist(xi)
        np.testing.assert_allclose(t2, [1.0, 0.0, 2.0], atol=1e-15)


# ---------------------------------------------------------------------------------------------------------------
# derivative (eq. (107))
# ---------------------------------------------------------------------------------------------------------------


def _path(q0, w, t0, tdot, scale_rate=0.0):
    """q(s) = (1 + c s) exp(s w/2) (x) q0 and t(s) = t0 + s tdot, with their exact derivatives at s = 0."""

    def at(s: float):
        return (1 + scale_rate * s) * quat_mul(quat_from_rotvec(s * w), q0), t0 + s * tdot

    qd = 0.5 * quat_mul(np.append(w, 0.0), q0) + scale_rate * q0
    return at, qd, tdot


@pytest.mark.parametrize("scale_rate", [0.0, 0.7])
def test_mul_derivative_against_finite_differences(rng, scale_rate) -> None:
    for _ in range(50):
        q1 = Rotation.random(rng=rng).as_quat() * (1.0 if scale_rate == 0 else 1.3)
        q2 = Rotation.random(rng=rng).as_quat()
        p1, q1d, t1d = _path(q1, rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), scale_rate)
        p2, q2d, t2d = _path(q2, rng.normal(size=3), rng.normal(size=3), rng.normal(size=3), scale_rate)
        h = 1e-5
        qp, tp = im.qt_mul(*p1(h), *p2(h))
        qm, tm = im.qt_mul(*p1(-h), *p2(-h))
        qd, td = im.qt_mul_derivative(*p1(0.0), q1d, t1d, *p2(0.0), q2d, t2d)
        np.testing.assert_allclose(qd, (qp - qm) / (2 * h), atol=1e-9)
        np.testing.assert_allclose(td, (tp - tm) / (2 * h), atol=1e-9)


def test_mul_derivative_is_eq_107_for_unit_tangent(rng) -> None:
    """For unit q1 and q̇1 = ½ ω (x) q1 the kernel equals eq. (107) written with quaternion products."""
    q1, q2 = Rotation.random(2, rng=rng).as_quat()
    t1, t2, t1d, t2d, w1, w2 = rng.normal(size=(6, 3))
    q1d = 0.5 * quat_mul(np.append(w1, 0), q1)
    q2d = 0.5 * quat_mul(np.append(w2, 0), q2)

    def pure(v):
        return np.append(v, 0.0)

    c1 = quat_conj(q1)
    ref_t = (
        t1d
        + quat_mul(quat_mul(q1d, pure(t2)), c1)[:3]
        + quat_mul(quat_mul(q1, pure(t2d)), c1)[:3]
        + quat_mul(quat_mul(q1, pure(t2)), quat_conj(q1d))[:3]
    )
    qd, td = im.qt_mul_derivative(q1, t1, q1d, t1d, q2, t2, q2d, t2d)
    np.testing.assert_allclose(qd, quat_mul(q1d, q2) + quat_mul(q1, q2d), atol=4 * EPS)
    np.testing.assert_allclose(td, ref_t, atol=32 * EPS)
    # ... which is ṫ1 + R ṫ2 + ω1 × (R t2)
    r = matrix_from_quat(q1)
    np.testing.assert_allclose(td, t1d + r @ t2d + np.cross(w1, r @ t2), atol=32 * EPS)


# ---------------------------------------------------------------------------------------------------------------
# shapes and bad input
# ---------------------------------------------------------------------------------------------------------------


def test_broadcasting(rng) -> None:
    q = quat_normalize(rng.normal(size=(4, 1, 4)))
    t = rng.normal(size=(5, 3))
    qq, tt = im.qt_mul(q, t, q[0, 0], t[0])  # both outputs take the common batch shape
    assert qq.shape == (4, 5, 4) and tt.shape == (4, 5, 3)
    assert im.qt_transform(q, t, np.zeros(3)).shape == (4, 5, 3)
    assert im.twist_from_qt(q, t).shape == (4, 5, 6)
    qc, tc = im.qt_conj(q, t)
    assert qc.shape == (4, 5, 4) and tc.shape == (4, 5, 3)
    qd, td = im.qt_mul_derivative(q, t, np.zeros(4), np.zeros(3), q[0, 0], t, np.zeros(4), np.zeros(3))
    assert qd.shape == (4, 5, 4) and td.shape == (4, 5, 3)
    a, b = im.qt_from_twist(rng.normal(size=(2, 3, 6)))
    assert a.shape == (2, 3, 4) and b.shape == (2, 3, 3)
    one = im.qt_mul([0, 0, 0, 1], [1, 2, 3], [0, 0, 0, 1], [1, 1, 1])
    assert np.array_equal(one[1], [2.0, 3.0, 4.0]) and one[1].dtype == np.float64


def test_bad_input() -> None:
    z, o = np.zeros(4), np.ones(3)
    with pytest.raises(ValueError, match="q1 must be a nonzero quaternion"):
        im.qt_mul(z, o, [0, 0, 0, 1], o)
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        im.qt_transform(z, o, o)
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        im.qt_conj(z, o)
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        im.twist_from_qt(z, o)
    with pytest.raises(ValueError, match="q1 must be a nonzero quaternion"):
        im.qt_mul_derivative(z, o, z, o, [0, 0, 0, 1], o, z, o)
    with pytest.raises(ValueError, match=r"t2 must have shape \(\.\.\., 3\)"):
        im.qt_mul([0, 0, 0, 1], o, [0, 0, 0, 1], np.ones(4))
    with pytest.raises(ValueError, match=r"xi must have shape \(\.\.\., 6\)"):
        im.qt_from_twist(np.ones(7))
    with pytest.raises(ValueError, match="batch shapes"):
        im.qt_transform(np.ones((2, 4)), np.ones((3, 3)), o)
    with pytest.raises(TypeError, match="points"):
        im.qt_transform([0, 0, 0, 1], o, "abc")
