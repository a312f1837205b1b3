"""Quaternion calculus against mpmath.diff (60 digits), float64 central differences, scipy and Dantam's formulas."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from mpmath import mp, mpf
from scipy.spatial.transform import Rotation

from dualpose.algebra import derivatives as dv
from dualpose.algebra.quat import quat_exp, quat_from_rotvec, quat_log, quat_mul, quat_normalize
from dualpose.algebra.series import series_ufunc

EPS = np.finfo(float).eps
DPS = 60
H = mpf("1e-25")
ANGLES = [0.0, 1e-300, 1e-8, 1e-4, 1.0, 3.0, math.pi - 1e-8]
AXIS = np.array([0.36, -0.48, 0.8])
QDOT = np.array([0.3, -1.1, 0.7, 0.45])

finite = st.floats(-3, 3, allow_nan=False, allow_infinity=False)
quats = arrays(np.float64, 4, elements=finite).filter(lambda q: np.linalg.norm(q) > 1e-2)
vec3 = arrays(np.float64, 3, elements=finite)


# ---------------------------------------------------------------------------------------------------------------
# mpmath references at the exact float64 inputs
# ---------------------------------------------------------------------------------------------------------------


def mp_exp(q: list) -> list:
    v, w = q[:3], q[3]
    ph = mp.sqrt(mp.fsum(x * x for x in v))
    e = mp.exp(w)
    s = mp.sinc(ph)
    return [e * s * v[0], e * s * v[1], e * s * v[2], e * mp.cos(ph)]


def mp_log(q: list) -> list:
    v, w = q[:3], q[3]
    s = mp.sqrt(mp.fsum(x * x for x in v))
    n = mp.sqrt(s * s + w * w)
    g = mp.atan2(s, w) / s if s != 0 else 1 / w
    return [g * v[0], g * v[1], g * v[2], mp.log(n)]


def mp_jacobian(f, x: np.ndarray) -> list[list]:
    """∂f_i/∂x_j by mpmath.diff (central difference with step 1e-25 at 60 digits)."""
    n = len(x)
    with mp.workdps(DPS):
        x0 = [mpf(float(v)) for v in x]
        cols = []
        for j in range(n):
            def comp(h, i, j=j):
                xx = list(x0)
                xx[j] += h
                return f(xx)[i]

            cols.append([mpmath.diff(lambda h, i=i: comp(h, i), 0, h=H) for i in range(len(f(x0)))])
        return [[cols[j][i] for j in range(n)] for i in range(len(cols[0]))]


def mp_dir_derivative(f, x: np.ndarray, xdot: np.ndarray) -> list:
    with mp.workdps(DPS):
        x0 = [mpf(float(v)) for v in x]
        d = [mpf(float(v)) for v in xdot]
        m = len(f(x0))
        return [mpmath.diff(lambda h, i=i: f([a + h * b for a, b in zip(x0, d, strict=True)])[i], 0, h=H)
                for i in range(m)]


def normwise(computed: np.ndarray, ref: list) -> float:
    """‖computed − ref‖_max / ‖ref‖_max in units of EPS."""
    c = np.asarray(computed, dtype=np.float64).ravel()
    r = [x for row in ref for x in (row if isinstance(row, list) else [row])]
    with mp.workdps(DPS):
        diff = max(abs(mpf(float(a)) - b) for a, b in zip(c, r, strict=True))
        scale = max(abs(b) for b in r)
        return float(diff / scale) / EPS


def exp_arg(phi: float, w: float) -> np.ndarray:
    return np.append(phi * AXIS, w)


def log_arg(phi: float, n: float) -> np.ndarray:
    return np.append(n * math.sin(phi) * AXIS, n * math.cos(phi))


# ---------------------------------------------------------------------------------------------------------------
# exp / log Jacobians and derivatives against mpmath
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("phi", ANGLES)
@pytest.mark.parametrize("w", [0.0, 0.4])
def test_exp_jacobian_mpmath(phi: float, w: float) -> None:
    q = exp_arg(phi, w)
    ref = mp_jacobian(mp_exp, q)
    assert normwise(dv.quat_exp_jacobian(q), ref) <= 4
    assert normwise(dv.quat_exp_derivative(q, QDOT), mp_dir_derivative(mp_exp, q, QDOT)) <= 4


@pytest.mark.parametrize("phi", ANGLES)
@pytest.mark.parametrize("n", [1.0, 2.5])
def test_log_jacobian_mpmath(phi: float, n: float) -> None:
    q = log_arg(phi, n)
    ref = mp_jacobian(mp_log, q)
    assert normwise(dv.quat_log_jacobian(q), ref) <= 4
    assert normwise(dv.quat_log_derivative(q, QDOT), mp_dir_derivative(mp_log, q, QDOT)) <= 4


@pytest.mark.parametrize("angle", ANGLES)
def test_rotvec_rate_mpmath(angle: float) -> None:
    v = angle * AXIS
    vdot = QDOT[:3]

    def q_of_v(x: list) -> list:
        return mp_exp([x[0] / 2, x[1] / 2, x[2] / 2, mpf(0)])

    ref = mp_dir_derivative(q_of_v, v, vdot)
    assert normwise(dv.quat_derivative_from_rotvec_rate(v, vdot), ref) <= 4


def test_float_central_differences(rng: np.random.Generator) -> None:
    h = 1e-6
    for _ in range(100):
        q = rng.normal(size=4)
        qd = rng.normal(size=4)
        fd = (quat_exp(q + h * qd) - quat_exp(q - h * qd)) / (2 * h)
        scale = np.abs(fd).max()
        np.testing.assert_allclose(dv.quat_exp_derivative(q, qd), fd, atol=1e-8 * scale)
        np.testing.assert_allclose(dv.quat_exp_jacobian(q) @ qd, dv.quat_exp_derivative(q, qd), atol=8 * EPS * scale)
        fd = (quat_log(q + h * qd) - quat_log(q - h * qd)) / (2 * h)
        scale = np.abs(fd).max()
        np.testing.assert_allclose(dv.quat_log_derivative(q, qd), fd, atol=1e-7 * scale)
        np.testing.assert_allclose(dv.quat_log_jacobian(q) @ qd, dv.quat_log_derivative(q, qd), atol=8 * EPS * scale)
        v, vd = rng.normal(size=3) * 2, rng.normal(size=3)
        fd = (quat_from_rotvec(v + h * vd) - quat_from_rotvec(v - h * vd)) / (2 * h)
        np.testing.assert_allclose(dv.quat_derivative_from_rotvec_rate(v, vd), fd, atol=1e-9)


@given(quats)
def test_exp_log_chain_rule(q: np.ndarray) -> None:
    """J_exp(ln q) J_log(q) = I (off the negative real axis), and J_log(q) q = [0, 0, 0, 1] (ln(λq) = ln q + ln λ)."""
    if q[3] < 0 and np.linalg.norm(q[:3]) < 0.3 * abs(q[3]):
        q = q.copy()
        q[3] = -q[3]
    jl = dv.quat_log_jacobian(q)
    scale = np.abs(jl).max() * np.linalg.norm(q)
    np.testing.assert_allclose(dv.quat_exp_jacobian(quat_log(q)) @ jl, np.eye(4), atol=64 * EPS * scale)
    np.testing.assert_allclose(jl @ q, [0, 0, 0, 1], atol=16 * EPS * scale)


# ---------------------------------------------------------------------------------------------------------------
# the log Jacobian versus Dantam's eqs. (38)-(41)
# ---------------------------------------------------------------------------------------------------------------


def dantam_41(q: np.ndarray) -> np.ndarray:
    """Dantam 2014 eq. (41), φ = acos(w), for unit q."""
    x, y, z, w = q
    ph = math.acos(w)
    s = math.sin(ph)
    v = q[:3]
    j = np.zeros((3, 4))
    j[:, :3] = ph / s * np.eye(3) - ph / s**3 * np.outer(v, v)
    j[:, 3] = -v / s**2
    return j


@pytest.mark.parametrize("phi", [0.3, 1.0, 2.0, 3.0])
def test_agrees_with_dantam_41_on_tangent_vectors(rng: np.random.Generator, phi: float) -> None:
    q = log_arg(phi, 1.0)
    for _ in range(10):
        qd = dv.quat_derivative(q, rng.normal(size=3))  # tangent to the unit sphere
        mine = dv.quat_log_jacobian(q) @ qd
        np.testing.assert_allclose(mine[:3], dantam_41(q) @ qd, rtol=0, atol=1e-13 * np.abs(mine).max())
        assert abs(mine[3]) <= 1e-15 * np.abs(qd).max()
    # off the tangent space they differ: eq. (41) is not the Jacobian of the general logarithm
    radial = dantam_41(q) @ q
    assert np.abs(radial).max() > 0.1
    np.testing.assert_allclose(dv.quat_log_jacobian(q) @ q, [0, 0, 0, 1], atol=8 * EPS)


@pytest.mark.parametrize("phi", [0.0, 1e-300, 1e-8, 1e-4, 0.5, 2.0, 3.0])
def test_matches_dantam_38_39_unit_log_derivative(rng: np.random.Generator, phi: float) -> None:
    """For unit q and tangent q̇: vector part = (φ/sin φ) v̇ + dlogc(φ) ẇ v (eqs. (38)-(40)), also at the identity."""
    q = log_arg(phi, 1.0)
    dlogc = series_ufunc("dlogc")
    g = phi / math.sin(phi) if phi > 0 else 1.0
    for _ in range(5):
        qd = dv.quat_derivative(q, rng.normal(size=3))
        ref = g * qd[:3] + dlogc(phi) * qd[3] * q[:3]
        out = dv.quat_log_derivative(q, qd)
        np.testing.assert_allclose(out[:3], ref, rtol=0, atol=16 * EPS * np.abs(ref).max())


# ---------------------------------------------------------------------------------------------------------------
# angular velocity and acceleration
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("frame", ["space", "body"])
def test_omega_round_trip_and_scipy(rng: np.random.Generator, frame: str) -> None:
    q = Rotation.random(200, rng=rng).as_quat()
    w = rng.normal(size=(200, 3))
    qd = dv.quat_derivative(q, w, frame)
    np.testing.assert_allclose(dv.omega_from_quat_derivative(q, qd, frame), w, atol=8 * EPS * np.abs(w).max())
    np.testing.assert_allclose(np.einsum("ni,ni->n", q, qd), 0.0, atol=8 * EPS * np.abs(w).max())
    # scipy: exp(ω s) applied on the left (space) or right (body) of q
    h = 1e-6
    r0 = Rotation.from_quat(q)
    if frame == "space":
        qp, qm = (Rotation.from_rotvec(w * h) * r0).as_quat(), (Rotation.from_rotvec(-w * h) * r0).as_quat()
    else:
        qp, qm = (r0 * Rotation.from_rotvec(w * h)).as_quat(), (r0 * Rotation.from_rotvec(-w * h)).as_quat()
    qp *= np.sign(np.einsum("ni,ni->n", qp, q))[:, None]
    qm *= np.sign(np.einsum("ni,ni->n", qm, q))[:, None]
    fd = (qp - qm) / (2 * h)
    np.testing.assert_allclose(qd, fd, atol=1e-9)
    np.testing.assert_allclose(dv.omega_from_quat_derivative(q, fd, frame), w, atol=1e-8)


def test_space_and_body_are_related_by_the_rotation(rng: np.random.Generator) -> None:
    q = Rotation.random(100, rng=rng).as_quat()
    qd = rng.normal(size=(100, 4))
    ws = dv.omega_from_quat_derivative(q, qd, "space")
    wb = dv.omega_from_quat_derivative(q, qd, "body")
    np.testing.assert_allclose(ws, Rotation.from_quat(q).apply(wb), atol=1e-14)
    # a non-unit q gives the angular velocity of q/|q|
    rho, rhod = 2.5, 0.7
    qd_u = dv.quat_derivative(q, ws, "space")
    np.testing.assert_allclose(dv.omega_from_quat_derivative(rho * q, rhod * q + rho * qd_u), ws, atol=1e-13)


@pytest.mark.parametrize("frame", ["space", "body"])
def test_second_derivative_and_angular_acceleration(rng: np.random.Generator, frame: str) -> None:
    """Along q(s) = exp(v(s)/2) with a quadratic v(s): q̈ and ω̇ from central differences of exact q̇ and ω."""
    h = 1e-5
    for _ in range(30):
        v0, v1, v2 = rng.normal(size=(3, 3))

        def state(s: float, v0=v0, v1=v1, v2=v2):
            v, vd = v0 + s * v1 + s * s * v2, v1 + 2 * s * v2
            q = quat_from_rotvec(v)
            qd = dv.quat_derivative_from_rotvec_rate(v, vd)
            return q, qd, dv.omega_from_quat_derivative(q, qd, frame)

        q, qd, w = state(0.0)
        qp, qdp, wp = state(h)
        qm, qdm, wm = state(-h)
        qdd = (qdp - qdm) / (2 * h)
        wd = (wp - wm) / (2 * h)
        np.testing.assert_allclose(dv.quat_derivative(q, w, frame), qd, atol=1e-14)
        np.testing.assert_allclose(dv.quat_second_derivative(q, w, wd, frame), qdd, atol=1e-8)
        np.testing.assert_allclose(dv.angular_acceleration_from_quat(q, qd, qdd, frame), wd, atol=1e-8)


@pytest.mark.parametrize("frame", ["space", "body"])
def test_angular_acceleration_inverts_second_derivative(rng: np.random.Generator, frame: str) -> None:
    q = Rotation.random(200, rng=rng).as_quat()
    w, wd = rng.normal(size=(2, 200, 3))
    qd = dv.quat_derivative(q, w, frame)
    qdd = dv.quat_second_derivative(q, w, wd, frame)
    np.testing.assert_allclose(dv.angular_acceleration_from_quat(q, qd, qdd, frame), wd, atol=1e-14)
    # Dantam eq. (49) for unit q: ω̇ = 2 (q̈ q* + q̇ q̇*), whose scalar part vanishes
    if frame == "space":
        qc = q * [-1, -1, -1, 1]
        full = 2 * (quat_mul(qdd, qc) + quat_mul(qd, qd * [-1, -1, -1, 1]))
        np.testing.assert_allclose(full[:, :3], wd, atol=1e-14)
        np.testing.assert_allclose(full[:, 3], 0.0, atol=1e-13)
    # non-unit q(s) = ρ(s) u(s): the angular acceleration is that of u
    rho, rhod, rhodd = 1.5, 0.4, 0.6
    out = dv.angular_acceleration_from_quat(rho * q, rhod * q + rho * qd, rhodd * q + 2 * rhod * qd + rho * qdd, frame)
    np.testing.assert_allclose(out, wd, atol=1e-13)


@pytest.mark.parametrize("angle", [0.0, 1e-300, 1e-8, 1.0, 3.0, math.pi - 1e-8, 5.0])
@pytest.mark.parametrize("frame", ["space", "body"])
def test_rotvec_rate_relations(rng: np.random.Generator, angle: float, frame: str) -> None:
    v = angle * AXIS
    vd = rng.normal(size=3)
    w = dv.omega_from_rotvec_rate(v, vd, frame)
    ref = dv.omega_from_quat_derivative(quat_from_rotvec(v), dv.quat_derivative_from_rotvec_rate(v, vd), frame)
    np.testing.assert_allclose(w, ref, atol=8 * EPS * np.abs(vd).max())
    np.testing.assert_allclose(dv.rotvec_rate_from_omega(v, w, frame), vd, atol=32 * EPS * np.abs(vd).max())


# ---------------------------------------------------------------------------------------------------------------
# special points, shapes, bad input
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("q", [[0.0, 0, 0, 1], [0.0, 0, 0, 2.0], [1e-300, 0, 0, 1]])
def test_no_nan_at_identity(rng: np.random.Generator, q: list) -> None:
    q = np.array(q)
    qd, qdd = rng.normal(size=(2, 4))
    w, wd = rng.normal(size=(2, 3))
    outs = [
        dv.quat_exp_jacobian(q), dv.quat_exp_derivative(q, qd), dv.quat_log_jacobian(q),
        dv.quat_log_derivative(q, qd), dv.quat_exp_jacobian(np.zeros(4)), dv.quat_exp_derivative(np.zeros(4), qd),
        dv.quat_derivative_from_rotvec_rate(np.zeros(3), w), dv.omega_from_rotvec_rate(np.zeros(3), w),
        dv.rotvec_rate_from_omega(np.zeros(3), w, "body"),
    ]
    for frame in ("space", "body"):
        outs += [
            dv.quat_derivative(q, w, frame), dv.omega_from_quat_derivative(q, qd, frame),
            dv.quat_second_derivative(q, w, wd, frame), dv.angular_acceleration_from_quat(q, qd, qdd, frame),
        ]
    assert all(np.all(np.isfinite(o)) for o in outs)
    jl = dv.quat_log_jacobian(q)
    n = q[3]
    np.testing.assert_allclose(jl, np.eye(4) / n, rtol=0, atol=EPS / n)  # at [0, 0, 0, n]: g = 1/n, A v vᵀ = 0


def test_log_jacobian_on_the_branch_cut_is_nan() -> None:
    """On the negative real axis ln q jumps (Dantam (25): φ = π); its Jacobian does not exist: quiet NaN."""
    with np.errstate(all="raise"):
        assert np.all(np.isnan(dv.quat_log_jacobian([0.0, 0.0, 0.0, -1.0])))
        assert np.all(np.isnan(dv.quat_log_derivative([0.0, 0.0, 0.0, -3.0], [1.0, 0.0, 0.0, 0.0])))


def test_shapes(rng: np.random.Generator) -> None:
    q = quat_normalize(rng.normal(size=(3, 1, 4)))
    w = rng.normal(size=(5, 3))
    assert dv.quat_derivative(q, w).shape == (3, 5, 4)
    assert dv.omega_from_quat_derivative(q, rng.normal(size=(5, 4)), "body").shape == (3, 5, 3)
    assert dv.quat_exp_jacobian(q).shape == (3, 1, 4, 4)
    assert dv.quat_log_jacobian(q).shape == (3, 1, 4, 4)
    assert dv.quat_derivative_from_rotvec_rate(w, w[0]).shape == (5, 4)
    assert dv.rotvec_rate_from_omega(w, w[:1]).shape == (5, 3)
    single = dv.quat_log_derivative([0.1, 0.2, 0.3, 0.9], [1, 0, 0, 0])
    assert single.shape == (4,) and single.dtype == np.float64


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="frame must be 'space' or 'body'"):
        dv.quat_derivative([0, 0, 0, 1], [1, 2, 3], frame="world")
    with pytest.raises(ValueError, match="frame must be"):
        dv.omega_from_rotvec_rate([0, 0, 0], [1, 2, 3], frame="Space")
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        dv.omega_from_quat_derivative(np.zeros(4), np.ones(4))
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        dv.angular_acceleration_from_quat(np.zeros(4), np.ones(4), np.ones(4), "body")
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        dv.quat_log_jacobian(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="q must be a nonzero quaternion"):
        dv.quat_log_derivative(np.zeros(4), np.ones(4))
    with pytest.raises(ValueError, match=r"omega must have shape \(\.\.\., 3\)"):
        dv.quat_derivative([0, 0, 0, 1], [1, 2, 3, 4])
    with pytest.raises(ValueError, match="batch shapes"):
        dv.quat_exp_derivative(np.ones((2, 4)), np.ones((3, 4)))
    with pytest.raises(TypeError, match="qdot"):
        dv.quat_exp_derivative([0, 0, 0, 1], ["a", "b", "c", "d"])
