"""SO(3)/SE(3) Jacobians, exp/log and adjoints against mpmath (50 digits), scipy and the defining identities."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from mpmath import mp, mpf
from scipy.linalg import expm
from scipy.spatial.transform import RigidTransform, Rotation

from dualpose.algebra import lie
from dualpose.algebra.quat import matrix_from_quat, quat_from_rotvec

EPS = np.finfo(float).eps
DPS = 50
ANGLES = [0.0, 1e-300, 1e-12, 1e-6, 1e-3, 0.1, 1.0, 3.0, math.pi - 1e-6]
AXIS = np.array([0.36, -0.48, 0.8])  # unit (exactly representable ratios; normalized below anyway)
AXIS = AXIS / np.linalg.norm(AXIS)
V = np.array([0.7, -1.3, 2.1])

finite = st.floats(-4, 4, allow_nan=False, allow_infinity=False)
twists = arrays(np.float64, 6, elements=finite)


# ---------------------------------------------------------------------------------------------------------------
# mpmath references (evaluated exactly at the float64 inputs)
# ---------------------------------------------------------------------------------------------------------------


def _mp_ad(xi: tuple[float, ...]) -> mp.matrix:
    """ad_ξ = [[ω×, 0], [v×, ω×]] (6x6) in mpmath."""
    w = [mpf(x) for x in xi[:3]]
    v = [mpf(x) for x in xi[3:]]

    def sk(a: list) -> list[list]:
        return [[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]]

    a, b = sk(w), sk(v)
    m = mp.matrix(6, 6)
    for i in range(3):
        for j in range(3):
            m[i, j] = a[i][j]
            m[3 + i, 3 + j] = a[i][j]
            m[3 + i, j] = b[i][j]
    return m


@functools.cache
def ref_se3_left_jacobian(xi: tuple[float, ...]) -> mp.matrix:
    """J_l(ξ) = Σ_k ad_ξ^k / (k+1)! summed in mpmath until the terms are below 10^-(DPS+5)."""
    with mp.workdps(DPS):
        ad = _mp_ad(xi)
        term = mp.eye(6)
        total = mp.eye(6)
        k = 0
        while True:
            k += 1
            term = term * ad / (k + 1)
            total += term
            if mp.mnorm(term, 1) < mpf(10) ** (-(DPS + 5)) and k > 3:
                return total


def ref_inv(m: mp.matrix) -> mp.matrix:
    with mp.workdps(DPS):
        return mp.inverse(m)


def mp_hat(xi: np.ndarray) -> mp.matrix:
    w = [mpf(float(x)) for x in xi[:3]]
    v = [mpf(float(x)) for x in xi[3:]]
    return mp.matrix(
        [[0, -w[2], w[1], v[0]], [w[2], 0, -w[0], v[1]], [-w[1], w[0], 0, v[2]], [0, 0, 0, 0]]
    )


def mp_vee(m: mp.matrix) -> list:
    return [m[2, 1], m[0, 2], m[1, 0], m[0, 3], m[1, 3], m[2, 3]]


def err(computed: np.ndarray, ref: mp.matrix) -> float:
    """max |computed − ref| / max |ref|, in units of EPS."""
    with mp.workdps(DPS):
        c = np.asarray(computed)
        rows, cols = c.shape
        diff = max(abs(mpf(float(c[i, j])) - ref[i, j]) for i in range(rows) for j in range(cols))
        scale = max(abs(ref[i, j]) for i in range(rows) for j in range(cols))
        return float(diff / scale) / EPS


def sub(m: mp.matrix, r: slice, c: slice) -> mp.matrix:
    rr = range(6)[r]
    cc = range(6)[c]
    out = mp.matrix(len(rr), len(cc))
    for a, i in enumerate(rr):
        for b, j in enumerate(cc):
            out[a, b] = m[i, j]
    return out


def twist_at(theta: float) -> np.ndarray:
    return np.concatenate([theta * AXIS, V])


# ---------------------------------------------------------------------------------------------------------------
# Jacobians against the exact series
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("theta", ANGLES)
class TestJacobiansAgainstMpmath:
    def test_se3_left_and_right(self, theta: float) -> None:
        xi = twist_at(theta)
        jl = ref_se3_left_jacobian(tuple(xi))
        jr = ref_se3_left_jacobian(tuple(-xi))
        assert err(lie.se3_left_jacobian(xi), jl) <= 8
        assert err(lie.se3_right_jacobian(xi), jr) <= 8

    def test_se3_inverses(self, theta: float) -> None:
        xi = twist_at(theta)
        assert err(lie.se3_left_jacobian_inv(xi), ref_inv(ref_se3_left_jacobian(tuple(xi)))) <= 8
        assert err(lie.se3_right_jacobian_inv(xi), ref_inv(ref_se3_left_jacobian(tuple(-xi)))) <= 8

    def test_so3(self, theta: float) -> None:
        xi = twist_at(theta)
        phi = xi[:3]
        jl = sub(ref_se3_left_jacobian(tuple(xi)), slice(0, 3), slice(0, 3))
        jr = sub(ref_se3_left_jacobian(tuple(-xi)), slice(0, 3), slice(0, 3))
        assert err(lie.so3_left_jacobian(phi), jl) <= 4
        assert err(lie.so3_right_jacobian(phi), jr) <= 4
        assert err(lie.so3_left_jacobian_inv(phi), ref_inv(jl)) <= 4
        assert err(lie.so3_right_jacobian_inv(phi), ref_inv(jr)) <= 4

    def test_se3_exp(self, theta: float) -> None:
        xi = twist_at(theta)
        with mp.workdps(DPS):
            t_ref = mp.expm(mp_hat(xi))
        r, t = lie.se3_exp(xi)
        m = np.eye(4)
        m[:3, :3], m[:3, 3] = r, t
        assert err(m, t_ref) <= 4
        np.testing.assert_allclose(r, lie.so3_exp(xi[:3]), rtol=0, atol=2 * EPS)


@pytest.mark.parametrize("theta", [1e-300, 1e-20])
def test_tiny_angles_not_flushed(theta: float) -> None:
    """The ½Φ term survives at tiny angles with full relative accuracy (off-diagonals of J_l − I are ±φ_k/2)."""
    phi = theta * AXIS
    half = 0.5 * lie.so3_hat(phi)
    off = ~np.eye(3, dtype=bool)
    for j, sign in ((lie.so3_left_jacobian(phi), 1), (lie.so3_right_jacobian(phi), -1),
                    (lie.so3_left_jacobian_inv(phi), -1), (lie.so3_right_jacobian_inv(phi), 1)):
        np.testing.assert_allclose(j[off], sign * half[off], rtol=2 * EPS, atol=0)
        assert np.all(np.diag(j) == 1.0)


@pytest.mark.parametrize("theta", [1e-6, 1.0, 3.0])
def test_defining_property_by_mpmath_differences(theta: float) -> None:
    """(d/dh exp((ξ+hδ)^)) exp(−ξ^) = (J_l δ)^ and exp(−ξ^) (d/dh exp((ξ+hδ)^)) = (J_r δ)^, at 60 digits."""
    xi = twist_at(theta)
    jl = lie.se3_left_jacobian(xi)
    jr = lie.se3_right_jacobian(xi)
    h = mpf("1e-25")
    with mp.workdps(60):
        a = mp_hat(xi)
        e_inv = mp.expm(-a)
        for k in range(6):
            d = np.zeros(6)
            d[k] = 1.0
            b = mp_hat(d)
            de = (mp.expm(a + h * b) - mp.expm(a - h * b)) / (2 * h)
            left = [float(x) for x in mp_vee(de * e_inv)]
            right = [float(x) for x in mp_vee(e_inv * de)]
            np.testing.assert_allclose(jl[:, k], left, rtol=0, atol=8 * EPS * max(1.0, np.abs(jl).max()))
            np.testing.assert_allclose(jr[:, k], right, rtol=0, atol=8 * EPS * max(1.0, np.abs(jr).max()))


def test_defining_property_by_float_differences(rng: np.random.Generator) -> None:
    """Central differences of scipy's expm, for random twists (tolerance set by the O(h²) truncation)."""
    h = 1e-6
    for _ in range(20):
        xi = rng.normal(size=6)
        d = rng.normal(size=6)
        de = (expm(lie.se3_hat(xi + h * d)) - expm(lie.se3_hat(xi - h * d))) / (2 * h)
        e_inv = np.linalg.inv(expm(lie.se3_hat(xi)))
        np.testing.assert_allclose(lie.se3_vee(de @ e_inv), lie.se3_left_jacobian(xi) @ d, atol=1e-8)
        np.testing.assert_allclose(lie.se3_vee(e_inv @ de), lie.se3_right_jacobian(xi) @ d, atol=1e-8)


# ---------------------------------------------------------------------------------------------------------------
# algebraic identities
# ---------------------------------------------------------------------------------------------------------------


def _cond(j: np.ndarray, ji: np.ndarray) -> float:
    """‖J‖∞ ‖J⁻¹‖∞ (large near |ω| = 2π, where J_l⁻¹ has its pole)."""
    return float(np.abs(j).sum(axis=1).max() * np.abs(ji).sum(axis=1).max())


@given(twists)
def test_inverse_times_jacobian_is_identity(xi: np.ndarray) -> None:
    for j, ji in (
        (lie.se3_left_jacobian(xi), lie.se3_left_jacobian_inv(xi)),
        (lie.se3_right_jacobian(xi), lie.se3_right_jacobian_inv(xi)),
        (lie.so3_left_jacobian(xi[:3]), lie.so3_left_jacobian_inv(xi[:3])),
        (lie.so3_right_jacobian(xi[:3]), lie.so3_right_jacobian_inv(xi[:3])),
    ):
        n = len(j)
        np.testing.assert_allclose(ji @ j, np.eye(n), atol=8 * EPS * _cond(j, ji))
        np.testing.assert_allclose(j @ ji, np.eye(n), atol=8 * EPS * _cond(j, ji))


@given(twists)
def test_left_is_adjoint_times_right(xi: np.ndarray) -> None:
    """J_l(ξ) = Ad(exp ξ^) J_r(ξ) (and the same for SO(3))."""
    q, t = quat_from_rotvec(xi[:3]), lie.se3_exp(xi)[1]
    scale = max(1.0, np.abs(xi[3:]).max())
    np.testing.assert_allclose(
        lie.se3_left_jacobian(xi), lie.se3_adjoint(q, t) @ lie.se3_right_jacobian(xi), atol=64 * EPS * scale
    )
    np.testing.assert_allclose(
        lie.so3_left_jacobian(xi[:3]), lie.so3_adjoint(q) @ lie.so3_right_jacobian(xi[:3]), atol=32 * EPS
    )


def test_adjoint_identity(rng: np.random.Generator) -> None:
    """exp((Ad_T ξ)^) = T exp(ξ^) T⁻¹ (scipy expm)."""
    q = Rotation.random(50, rng=rng).as_quat()
    t = rng.normal(size=(50, 3))
    xi = rng.normal(size=(50, 6))
    ad = lie.se3_adjoint(q, t)
    tm = RigidTransform.from_components(t, Rotation.from_quat(q)).as_matrix()
    lhs = expm(lie.se3_hat(np.einsum("nij,nj->ni", ad, xi)))
    rhs = tm @ expm(lie.se3_hat(xi)) @ np.linalg.inv(tm)
    np.testing.assert_allclose(lhs, rhs, atol=1e-12)
    np.testing.assert_allclose(lie.se3_adjoint_from_matrix(tm), ad, atol=4 * EPS * np.abs(t).max())
    np.testing.assert_allclose(lie.so3_adjoint(q), tm[:, :3, :3], atol=2 * EPS)
    # Ad(exp ξ) = exp(ad ξ)
    r, tt = lie.se3_exp(xi[0])
    np.testing.assert_allclose(lie.se3_adjoint_from_matrix(np.block([[r, tt[:, None]], [np.zeros((1, 3)), 1.0]])),
                               expm(lie.se3_ad(xi[0])), atol=1e-13)


@given(twists, twists)
def test_small_adjoint_is_the_bracket(a: np.ndarray, b: np.ndarray) -> None:
    ha, hb = lie.se3_hat(a), lie.se3_hat(b)
    np.testing.assert_allclose(lie.se3_hat(lie.se3_ad(a) @ b), ha @ hb - hb @ ha, atol=1e-13)


@given(twists)
def test_hat_vee_round_trip(xi: np.ndarray) -> None:
    assert np.array_equal(lie.se3_vee(lie.se3_hat(xi)), xi)
    assert np.array_equal(lie.so3_vee(lie.so3_hat(xi[:3])), xi[:3])
    u = np.array([0.3, -2.0, 1.1])
    np.testing.assert_allclose(lie.so3_hat(xi[:3]) @ u, np.cross(xi[:3], u), atol=1e-15)


# ---------------------------------------------------------------------------------------------------------------
# exp / log against scipy
# ---------------------------------------------------------------------------------------------------------------


def test_exp_log_against_scipy(rng: np.random.Generator) -> None:
    xi = rng.normal(size=(500, 6))
    xi[:20, :3] *= 1e-9
    xi[20:40, :3] *= (math.pi - 1e-7) / np.linalg.norm(xi[20:40, :3], axis=1, keepdims=True)
    tf = RigidTransform.from_exp_coords(xi)
    r, t = lie.se3_exp(xi)
    np.testing.assert_allclose(r, tf.rotation.as_matrix(), atol=4 * EPS)
    np.testing.assert_allclose(t, tf.translation, atol=16 * EPS * np.abs(t).max())
    np.testing.assert_allclose(lie.so3_exp(xi[:, :3]), matrix_from_quat(quat_from_rotvec(xi[:, :3])), atol=4 * EPS)
    principal = xi[np.linalg.norm(xi[:, :3], axis=1) < math.pi]
    rp, tp = lie.se3_exp(principal)
    np.testing.assert_allclose(lie.se3_log(rp, tp), principal, atol=1e-7)
    ok = np.linalg.norm(principal[:, :3], axis=1) < 3.0
    np.testing.assert_allclose(lie.se3_log(rp, tp)[ok], principal[ok], atol=1e-13)
    np.testing.assert_allclose(lie.se3_log(rp, tp), tf.as_exp_coords()[np.linalg.norm(xi[:, :3], axis=1) < math.pi],
                               atol=1e-7)
    np.testing.assert_allclose(lie.so3_log(rp), Rotation.from_matrix(rp).as_rotvec(), atol=1e-13)


@pytest.mark.parametrize("theta", [1e-6, 1e-3])
def test_se3_exp_uses_left_jacobian_not_rotation(theta: float) -> None:
    """Regression (jaxlie trap): at small angles t = J_l(ω) v, which differs from R v by about ½ ω × v."""
    xi = twist_at(theta)
    r, t = lie.se3_exp(xi)
    with mp.workdps(DPS):
        ref = mp.expm(mp_hat(xi))
        t_ref = np.array([float(ref[i, 3]) for i in range(3)])
    np.testing.assert_allclose(t, t_ref, rtol=4 * EPS)
    gap = np.linalg.norm(r @ V - t_ref)
    assert gap > 0.4 * theta * np.linalg.norm(np.cross(AXIS, V))  # using R would be this far off
    jac = lie.se3_left_jacobian(xi)
    np.testing.assert_allclose(jac[3:, 3:], lie.so3_left_jacobian(xi[:3]), rtol=0, atol=0)
    assert np.abs(jac[3:, 3:] - r).max() > 0.4 * theta
    np.testing.assert_allclose(jac[3:, 3:] @ V, t, rtol=2 * EPS)


def test_zero_is_exact() -> None:
    xi = np.array([0.0, 0.0, 0.0, 1.0, 2.0, 3.0])
    jl = lie.se3_left_jacobian(xi)
    expect = np.eye(6)
    expect[3:, :3] = 0.5 * lie.so3_hat(xi[3:])
    assert np.array_equal(jl, expect)
    assert np.array_equal(lie.se3_left_jacobian_inv(xi), 2 * np.eye(6) - expect)
    r, t = lie.se3_exp(xi)
    assert np.array_equal(r, np.eye(3)) and np.array_equal(t, xi[3:])
    assert np.all(np.isfinite(lie.se3_log(np.eye(3), np.zeros(3))))


# ---------------------------------------------------------------------------------------------------------------
# shapes and bad input
# ---------------------------------------------------------------------------------------------------------------


def test_broadcasting_shapes(rng: np.random.Generator) -> None:
    xi = rng.normal(size=(2, 5, 6))
    assert lie.se3_left_jacobian(xi).shape == (2, 5, 6, 6)
    assert lie.so3_right_jacobian_inv(xi[..., :3]).shape == (2, 5, 3, 3)
    r, t = lie.se3_exp(xi)
    assert r.shape == (2, 5, 3, 3) and t.shape == (2, 5, 3)
    assert lie.se3_log(r, t).shape == (2, 5, 6)
    assert lie.se3_log(r, t[0, 0]).shape == (2, 5, 6)
    q = quat_from_rotvec(xi[..., :3])
    assert lie.se3_adjoint(q, np.zeros(3)).shape == (2, 5, 6, 6)
    assert lie.se3_ad(xi).shape == (2, 5, 6, 6)
    single = lie.se3_left_jacobian(xi[1, 2].tolist())
    np.testing.assert_array_equal(single, lie.se3_left_jacobian(xi)[1, 2])


def test_bad_input() -> None:
    with pytest.raises(ValueError, match=r"xi must have shape \(\.\.\., 6\)"):
        lie.se3_left_jacobian(np.zeros(3))
    with pytest.raises(ValueError, match=r"phi must have shape \(\.\.\., 3\)"):
        lie.so3_left_jacobian(np.zeros(4))
    with pytest.raises(TypeError, match="xi"):
        lie.se3_exp(["a"] * 6)
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        lie.se3_adjoint(np.zeros(4), np.ones(3))
    with pytest.raises(ValueError, match="batch shapes"):
        lie.se3_adjoint(np.ones((2, 4)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="NaN or infinity"):
        lie.se3_adjoint_from_matrix(np.full((4, 4), np.nan))
    with pytest.raises(ValueError, match=r"matrix must have shape \(\.\.\., 3, 3\)"):
        lie.so3_vee(np.zeros((4, 4)))
