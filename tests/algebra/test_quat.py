"""Quaternion core: cross-checks against scipy, algebraic laws (hypothesis), special points and bad input."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation, Slerp

import dualpose as dp

EPS = np.finfo(float).eps
finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
quats = arrays(np.float64, 4, elements=finite).filter(lambda q: np.linalg.norm(q) > 1e-3)
vec3 = arrays(np.float64, 3, elements=finite)


def unit(q):
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def same_rotation(p, q, atol):
    """p and q equal up to sign (double cover)."""
    d = np.minimum(np.abs(p - q).max(axis=-1), np.abs(p + q).max(axis=-1))
    return np.all(d <= atol)


@pytest.fixture
def batch(rng):
    q = Rotation.random(2000, rng=rng).as_quat()
    # include angles near 0 and pi
    q[:50] = Rotation.from_rotvec(rng.normal(size=(50, 3)) * 1e-9).as_quat()
    ax = unit(rng.normal(size=(50, 3)))
    q[50:100] = Rotation.from_rotvec(ax * (np.pi - 1e-9)).as_quat()
    return q


class TestAgainstScipy:
    def test_product(self, batch, rng):
        p = np.roll(batch, 7, axis=0)
        ref = (Rotation.from_quat(p) * Rotation.from_quat(batch)).as_quat()
        assert same_rotation(dp.quat_mul(p, batch), ref, 4 * EPS)

    def test_rotate_and_matrix(self, batch, rng):
        v = rng.normal(size=(len(batch), 3))
        r = Rotation.from_quat(batch)
        np.testing.assert_allclose(dp.quat_rotate(batch, v), r.apply(v), atol=1e-14)
        np.testing.assert_allclose(dp.matrix_from_quat(batch), r.as_matrix(), atol=1e-15)

    def test_matrix_to_quat(self, batch):
        m = Rotation.from_quat(batch).as_matrix()
        assert same_rotation(dp.quat_from_matrix(m), batch, 1e-15)
        assert np.all(dp.quat_from_matrix(m)[..., 3] >= 0)

    def test_rotvec(self, batch, rng):
        r = Rotation.from_quat(batch)
        np.testing.assert_allclose(dp.rotvec_from_quat(batch), r.as_rotvec(), atol=1e-14)
        rv = rng.normal(size=(500, 3)) * 2
        assert same_rotation(dp.quat_from_rotvec(rv), Rotation.from_rotvec(rv).as_quat(), 1e-15)

    def test_axis_angle(self, batch):
        axis, angle = dp.axis_angle_from_quat(batch)
        np.testing.assert_allclose(axis * angle[..., None], Rotation.from_quat(batch).as_rotvec(), atol=1e-14)
        assert same_rotation(dp.quat_from_axis_angle(axis * 3.0, angle), batch, 1e-15)

    def test_slerp(self, rng):
        key = Rotation.random(2, rng=rng)
        t = np.linspace(0, 1, 11)
        ref = Slerp([0, 1], key)(t).as_quat()
        out = dp.quat_slerp(key[0].as_quat(), key[1].as_quat(), t)
        assert same_rotation(out, ref, 1e-14)

    def test_angle(self, batch):
        p = np.roll(batch, 3, axis=0)
        ref = (Rotation.from_quat(p).inv() * Rotation.from_quat(batch)).magnitude()
        np.testing.assert_allclose(dp.quat_angle(p, batch), ref, atol=1e-13)

    def test_mean(self, rng):
        q = Rotation.from_rotvec(rng.normal(size=(30, 3)) * 0.3).as_quat()
        q[::2] *= -1  # double cover must not matter
        w = rng.uniform(0.1, 2.0, size=30)
        ref = Rotation.from_quat(q).mean(weights=w).as_quat()
        assert same_rotation(dp.quat_mean(q, w), ref, 1e-12)
        # batched means over leading axes
        qq = np.stack([q, q[::-1]])
        np.testing.assert_allclose(dp.quat_mean(qq), np.stack([dp.quat_mean(q)] * 2), atol=1e-12)

    def test_integrate_both_frames(self, batch, rng):
        w = rng.normal(size=(len(batch), 3))
        dt = 0.37
        step = Rotation.from_rotvec(w * dt)
        r = Rotation.from_quat(batch)
        assert same_rotation(dp.quat_integrate(batch, w, dt, frame="space"), (step * r).as_quat(), 1e-14)
        assert same_rotation(dp.quat_integrate(batch, w, dt, frame="body"), (r * step).as_quat(), 1e-14)


class TestLaws:
    @given(quats, quats, quats)
    def test_associative(self, a, b, c):
        lhs = dp.quat_mul(dp.quat_mul(a, b), c)
        rhs = dp.quat_mul(a, dp.quat_mul(b, c))
        scale = np.linalg.norm(a) * np.linalg.norm(b) * np.linalg.norm(c)
        assert np.abs(lhs - rhs).max() <= 16 * EPS * scale

    @given(quats, quats)
    def test_norm_multiplicative_and_inverse(self, a, b):
        na, nb = dp.quat_norm(a), dp.quat_norm(b)
        np.testing.assert_allclose(dp.quat_norm(dp.quat_mul(a, b)), na * nb, rtol=8 * EPS)
        np.testing.assert_allclose(dp.quat_mul(a, dp.quat_inv(a)), [0, 0, 0, 1], atol=8 * EPS)

    @given(quats)
    def test_exp_log(self, q):
        np.testing.assert_allclose(dp.quat_exp(dp.quat_log(q)), q, atol=32 * EPS * np.linalg.norm(q))

    @given(arrays(np.float64, 4, elements=st.floats(-1.5, 1.5)))
    def test_log_exp_principal_branch(self, x):
        # |x_v| < pi lies on the principal branch
        np.testing.assert_allclose(dp.quat_log(dp.quat_exp(x)), x, atol=64 * EPS)

    @given(quats, st.floats(-3, 3), st.floats(-3, 3))
    def test_pow_adds_exponents(self, q, s, t):
        q = unit(q)
        lhs = dp.quat_mul(dp.quat_pow(q, s), dp.quat_pow(q, t))
        np.testing.assert_allclose(lhs, dp.quat_pow(q, s + t), atol=64 * EPS)

    @given(quats, vec3)
    def test_rotation_preserves_norm_and_matches_matrix(self, q, v):
        r = dp.quat_rotate(q, v)
        np.testing.assert_allclose(np.linalg.norm(r), np.linalg.norm(v), atol=16 * EPS * (1 + np.linalg.norm(v)))
        np.testing.assert_allclose(dp.matrix_from_quat(q) @ v, r, atol=16 * EPS * (1 + np.linalg.norm(v)))

    @given(quats, quats)
    def test_angle_double_cover(self, p, q):
        a = dp.quat_angle(p, q)
        assert 0 <= a <= np.pi
        assert dp.quat_angle(p, -q) == a
        assert dp.quat_angle(-p, q) == a

    @given(quats, quats, st.floats(0, 1))
    def test_slerp_double_cover(self, p, q, t):
        assert same_rotation(dp.quat_slerp(p, q, t), dp.quat_slerp(p, -q, t), 32 * EPS)

    @given(quats)
    def test_canonical(self, q):
        c = dp.quat_canonical(q)
        assert c[3] >= 0
        assert same_rotation(c, q, 0.0)


class TestSpecialPoints:
    @pytest.mark.parametrize("angle", [0.0, 1e-300, 1e-20, 1e-8, 1.0, np.pi - 1e-12, np.pi])
    def test_rotvec_round_trip(self, angle):
        rv = np.array([2.0, -3.0, 6.0]) / 7.0 * angle
        np.testing.assert_allclose(dp.rotvec_from_quat(dp.quat_from_rotvec(rv)), rv, rtol=4 * EPS, atol=0)

    def test_log_of_negative_real_is_finite(self):
        out = dp.quat_log([0.0, 0.0, 0.0, -2.0])
        np.testing.assert_allclose(out, [np.pi, 0, 0, np.log(2.0)])
        np.testing.assert_allclose(dp.quat_exp(out), [0, 0, 0, -2.0], atol=1e-15)

    def test_pow_of_negative_real(self):
        out = dp.quat_pow([0.0, 0.0, 0.0, -1.0], 0.5)
        np.testing.assert_allclose(dp.quat_mul(out, out), [0, 0, 0, -1.0], atol=1e-15)

    def test_matrix_180_degrees(self):
        for axis in np.eye(3):
            q = dp.quat_from_matrix(Rotation.from_rotvec(np.pi * axis).as_matrix())
            np.testing.assert_allclose(np.abs(q), [*axis, 0.0], atol=1e-16)

    def test_walker_matrices(self, rng):
        a, b = rng.normal(size=(2, 4))
        np.testing.assert_allclose(dp.quat_left_matrix(a) @ b, dp.quat_mul(a, b), atol=1e-15)
        np.testing.assert_allclose(dp.quat_right_matrix(b) @ a, dp.quat_mul(a, b), atol=1e-15)
        # Walker Table 2: Q(a)^T Q(a) = |a|^2 I, and Q(a) W(b)^T = W(b)^T Q(a)
        qa, wb = dp.quat_left_matrix(a), dp.quat_right_matrix(b)
        np.testing.assert_allclose(qa.T @ qa, a @ a * np.eye(4), atol=1e-14)
        np.testing.assert_allclose(qa @ wb.T, wb.T @ qa, atol=1e-14)

    def test_broadcasting(self, rng):
        p = rng.normal(size=(5, 1, 4))
        q = rng.normal(size=(1, 7, 4))
        out = dp.quat_mul(p, q)
        assert out.shape == (5, 7, 4)
        np.testing.assert_allclose(out[3, 4], dp.quat_mul(p[3, 0], q[0, 4]))
        assert dp.quat_slerp(p[0, 0], q[0, 0], np.linspace(0, 1, 3)).shape == (3, 4)

    def test_float32_and_lists_accepted(self):
        out = dp.quat_mul(np.array([0, 0, 0, 1], np.float32), [1, 2, 3, 4])
        assert out.dtype == np.float64
        np.testing.assert_array_equal(out, [1, 2, 3, 4])

    def test_nan_propagates_in_algebra(self):
        out = dp.quat_mul([np.nan, 0, 0, 1], [0, 0, 0, 1])
        assert np.isnan(out).any()


class TestBadInput:
    def test_wrong_trailing_size_names_argument(self):
        with pytest.raises(ValueError, match=r"q must have shape \(\.\.\., 4\)"):
            dp.quat_mul([0, 0, 0, 1], [1, 2, 3])
        with pytest.raises(ValueError, match=r"matrix must have shape \(\.\.\., 3, 3\)"):
            dp.quat_from_matrix(np.eye(4))

    def test_mismatched_batches_name_both(self):
        with pytest.raises(ValueError, match="p has batch shape \\(2,\\), q has batch shape \\(3,\\)"):
            dp.quat_mul(np.ones((2, 4)), np.ones((3, 4)))

    @pytest.mark.parametrize("bad", ["abcd", [1, 2, 3, 4j], [[1, 2], [3]], [True, False, True, False]])
    def test_non_numeric_is_type_error(self, bad):
        with pytest.raises(TypeError, match="q must be"):
            dp.quat_normalize(bad)

    @pytest.mark.parametrize(
        "fn",
        [dp.quat_normalize, dp.quat_inv, dp.quat_log, dp.rotvec_from_quat, dp.matrix_from_quat,
         lambda q: dp.quat_rotate(q, [1, 2, 3]), lambda q: dp.quat_pow(q, 0.5)],
    )
    @pytest.mark.filterwarnings("error")  # the refusal is the only message: no raw NumPy warning before it
    def test_zero_quaternion_raises(self, fn):
        with pytest.raises(ValueError, match="must be a nonzero quaternion"):
            fn(np.array([[0, 0, 0, 1.0], [0, 0, 0, 0]]))

    def test_zero_in_slerp_and_angle(self):
        with pytest.raises(ValueError, match="q1 must be a nonzero"):
            dp.quat_slerp([0, 0, 0, 1], [0, 0, 0, 0], 0.5)
        with pytest.raises(ValueError, match="p must be a nonzero"):
            dp.quat_angle([0, 0, 0, 0], [0, 0, 0, 1])

    def test_zero_axis(self):
        with pytest.raises(ValueError, match="axis must be a nonzero"):
            dp.quat_from_axis_angle([0, 0, 0], 1.0)

    def test_non_finite_matrix(self):
        m = np.eye(3)
        m[1, 2] = np.inf
        with pytest.raises(ValueError, match="matrix contains NaN or infinity"):
            dp.quat_from_matrix(m)

    def test_bad_frame_and_weights(self):
        with pytest.raises(ValueError, match="frame must be"):
            dp.quat_integrate([0, 0, 0, 1], [1, 0, 0], 0.1, frame="world")
        with pytest.raises(ValueError, match="weights must"):
            dp.quat_mean(np.tile([0, 0, 0, 1.0], (3, 1)), [1, -1, 1])
        with pytest.raises(ValueError, match="quats must have shape"):
            dp.quat_mean([0, 0, 0, 1.0])


class TestOut:
    def test_out_is_filled_and_returned(self, rng):
        p, q = rng.normal(size=(2, 10, 4))
        v = rng.normal(size=(10, 3))
        o4, o3 = np.empty((10, 4)), np.empty((10, 3))
        assert dp.quat_mul(p, q, out=o4) is o4
        np.testing.assert_array_equal(o4, dp.quat_mul(p, q))
        assert dp.quat_rotate(q, v, out=o3) is o3
        np.testing.assert_array_equal(o3, dp.quat_rotate(q, v))
        s = dp.dualquat_from_qt(q, v)
        o8 = np.empty((10, 8))
        assert dp.dualquat_mul(s, s[::-1], out=o8) is o8
        np.testing.assert_array_equal(o8, dp.dualquat_mul(s, s[::-1]))
        assert dp.dualquat_transform(s, v, out=o3) is o3
        np.testing.assert_array_equal(o3, dp.dualquat_transform(s, v))

    def test_bad_out(self):
        with pytest.raises(TypeError, match="out must be a float64"):
            dp.quat_mul([0, 0, 0, 1], [0, 0, 0, 1], out=np.empty(4, np.float32))
        with pytest.raises(ValueError, match="out has the wrong shape"):
            dp.quat_mul(np.ones((3, 4)), np.ones((3, 4)), out=np.empty((2, 4)))

    def test_zero_still_raises_with_out(self):
        with pytest.raises(ValueError, match="must be a nonzero quaternion"):
            dp.quat_rotate(np.zeros((2, 4)), np.ones((2, 3)), out=np.empty((2, 3)))
