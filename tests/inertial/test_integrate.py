"""Rotation-vector / screw-vector algorithms and the fused integrators (docs/inertial.md §2–§3)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
import dualpose.inertial as di
from dualpose.inertial import motions as m

RNG = np.random.default_rng(20261130)
FRAMES = ["body", "space"]


def _x(a, b):
    return np.cross(a, b)


# --------------------------------------------------------------------------------------------------------------
# the per-update formulas, written out as in docs/inertial.md §2
# --------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("frame", FRAMES)
def test_rotation_vector_restored_formulas(frame):
    s = 1.0 if frame == "body" else -1.0
    th = RNG.normal(size=(12, 3)) * 0.1
    t = th.reshape(4, 3, 3)
    t1, t2, t3 = t[:, 0], t[:, 1], t[:, 2]
    np.testing.assert_array_equal(di.rotation_vector(th, 1, frame=frame), th)
    p2 = th.reshape(6, 2, 3)
    exp2 = p2.sum(1) + s * 2 / 3 * _x(p2[:, 0], p2[:, 1])
    np.testing.assert_allclose(di.rotation_vector(th, 2, frame=frame), exp2, atol=1e-16)
    poly = t.sum(1) + s * (33 / 80 * _x(t1, t3) + 57 / 80 * _x(t2, t3 - t1))
    np.testing.assert_allclose(di.rotation_vector(th, 3, "polynomial", frame), poly, atol=1e-16)
    opt = t.sum(1) + s * (9 / 20 * _x(t1, t3) + 27 / 40 * (_x(t1, t2) + _x(t2, t3)))
    np.testing.assert_allclose(di.rotation_vector(th, 3, "coning-optimal", frame), opt, atol=1e-16)
    t4 = th.reshape(3, 4, 3)
    a, b, c, d = (t4[:, i] for i in range(4))
    opt4 = t4.sum(1) + s * (
        214 / 315 * (_x(a, b) + _x(b, c) + _x(c, d)) + 46 / 105 * (_x(a, c) + _x(b, d)) + 54 / 105 * _x(a, d)
    )
    np.testing.assert_allclose(di.rotation_vector(th, 4, frame=frame), opt4, atol=1e-16)
    prev = np.vstack([np.zeros((1, 3)), th[:-1]])
    np.testing.assert_allclose(
        di.rotation_vector(th, 1, "one-plus-previous", frame), th + s / 12 * _x(prev, th), atol=1e-16
    )


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize(
    "n, family", [(2, "coning-optimal"), (3, "polynomial"), (4, "coning-optimal"), (1, "one-plus-previous")]
)
def test_screw_vector_is_the_dual_number_algorithm(n, family, frame):
    s = 1.0 if frame == "body" else -1.0
    inc = RNG.normal(size=(4 * n, 6)) * 0.1
    sv = di.screw_vector(inc, n, family, frame)
    np.testing.assert_array_equal(sv[:, :3], di.rotation_vector(inc[:, :3], n, family, frame))
    # dual part: d/dε of the rotation-vector formula at θ + ε u (the dual cross product), by exact bilinearity
    k = di.coning_coefficients(n, family)
    x = inc.reshape(-1, n, 6)
    dual = x[:, :, 3:].sum(1)
    for i in range(n):
        for j in range(i + 1, n):
            dual += s * k[i, j] * (_x(x[:, i, :3], x[:, j, 3:]) + _x(x[:, i, 3:], x[:, j, :3]))
    if family == "one-plus-previous":
        prev = np.vstack([np.zeros((1, 6)), inc[:-1]])
        dual += s / 12 * (_x(prev[:, :3], inc[:, 3:]) + _x(prev[:, 3:], inc[:, :3]))
    np.testing.assert_allclose(sv[:, 3:], dual, atol=1e-16)


def test_screw_exp_is_twist_exponential_with_left_jacobian():
    sc = RNG.normal(size=(50, 6))
    sc[:5, :3] *= 1e-9  # tiny rotations: the guarded series
    e = di.screw_exp(sc)
    np.testing.assert_allclose(e, dp.dualquat_from_twist(sc), atol=2e-15)
    q, t = dp.qt_from_dualquat(e)
    np.testing.assert_allclose(t, np.einsum("nij,nj->ni", dp.so3_left_jacobian(sc[:, :3]), sc[:, 3:]), atol=1e-14)
    np.testing.assert_allclose(q, dp.quat_from_rotvec(sc[:, :3]), atol=1e-15)


# --------------------------------------------------------------------------------------------------------------
# the fused fold against a plain sequential product
# --------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("n", [1, 3])
def test_fold_equals_sequential_products(n, frame):
    inc = RNG.normal(size=(20 * n, 6)) * 0.2
    dq0 = dp.dualquat_from_qt(dp.quat_from_rotvec(RNG.normal(size=3)), RNG.normal(size=3))
    steps = di.screw_exp(di.screw_vector(inc, n, frame=frame))
    qsteps = dp.quat_from_rotvec(di.rotation_vector(inc[:, :3], n, frame=frame))
    ref, qref = [dq0], [dq0[:4]]
    for e, qe in zip(steps, qsteps, strict=True):
        ref.append(dp.dualquat_mul(ref[-1], e) if frame == "body" else dp.dualquat_mul(e, ref[-1]))
        qref.append(dp.quat_mul(qref[-1], qe) if frame == "body" else dp.quat_mul(qe, qref[-1]))
    np.testing.assert_allclose(di.integrate_pose(dq0, inc, n, frame=frame), np.array(ref), atol=1e-14)
    np.testing.assert_allclose(di.integrate_attitude(dq0[:4], inc[:, :3], n, frame=frame), np.array(qref), atol=1e-14)


@settings(max_examples=30, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.sampled_from([1, 2, 3, 4]),
    st.sampled_from(FRAMES),
    st.sampled_from(["coning-optimal", "polynomial"]),
)
def test_pose_real_part_is_the_attitude_algorithm(seed, n, frame, family):
    """Transference: the real part of the screw-vector update is the rotation-vector update."""
    rng = np.random.default_rng(seed)
    inc = rng.normal(size=(5 * n, 6)) * 0.3
    dq0 = dp.dualquat_from_qt(dp.quat_from_rotvec(rng.normal(size=3)), rng.normal(size=3))
    pose = di.integrate_pose(dq0, inc, n, family, frame)
    att = di.integrate_attitude(dq0[:4], inc[:, :3], n, family, frame)
    np.testing.assert_allclose(pose[:, :4], att, atol=1e-15)


def test_batch_axes_broadcast():
    inc = RNG.normal(size=(2, 3, 12, 6)) * 0.1
    dq0 = dp.dualquat_from_qt(dp.quat_from_rotvec(RNG.normal(size=(3, 3))), RNG.normal(size=(3, 3)))
    out = di.integrate_pose(dq0, inc, 3)
    assert out.shape == (2, 3, 5, 8)
    np.testing.assert_array_equal(out[1, 2], di.integrate_pose(dq0[2], inc[1, 2], 3))
    att = di.integrate_attitude([0, 0, 0, 2.0], inc[..., :3], 2, frame="space")  # q0 normalized
    assert att.shape == (2, 3, 7, 4)
    np.testing.assert_array_equal(
        att[0, 1], di.integrate_attitude([0, 0, 0, 1.0], inc[0, 1, :, :3], 2, frame="space")
    )


def test_bad_input():
    inc = np.zeros((6, 3))
    with pytest.raises(ValueError, match="not a positive multiple of samples=4"):
        di.integrate_attitude([0, 0, 0, 1.0], inc, 4)
    with pytest.raises(ValueError, match=r"dtheta must have shape \(\.\.\., 3\)"):
        di.integrate_attitude([0, 0, 0, 1.0], np.zeros((6, 4)), 1)
    with pytest.raises(ValueError, match="dtheta must have shape"):
        di.integrate_attitude([0, 0, 0, 1.0], np.zeros(3), 1)
    with pytest.raises(ValueError, match="NaN"):
        di.integrate_attitude([0, 0, 0, 1.0], np.full((3, 3), np.nan), 1)
    with pytest.raises(ValueError, match="q0 must have a nonzero"):
        di.integrate_attitude([0, 0, 0, 0.0], inc, 1)
    with pytest.raises(ValueError, match="frame"):
        di.integrate_attitude([0, 0, 0, 1.0], inc, 1, frame="world")
    with pytest.raises(ValueError, match="one-plus-previous"):
        di.integrate_pose(dp.dualquat_identity(), np.zeros((6, 6)), 2, "one-plus-previous")
    with pytest.raises(ValueError, match="dual_increments"):
        di.integrate_pose(dp.dualquat_identity(), np.zeros((6, 3)), 1)
    with pytest.raises(ValueError, match="batch|broadcast"):
        di.integrate_pose(np.tile(dp.dualquat_identity(), (3, 1)), np.zeros((2, 6, 6)), 1)


# --------------------------------------------------------------------------------------------------------------
# accuracy against exact motions
# --------------------------------------------------------------------------------------------------------------


def _coning_error(n, family, a, omega, omega_t, k, frame, d=0.0):
    """Final error screw vector / elapsed time for (dual) coning: [rad/s, m/s]."""
    T = omega_t / omega
    c = m.Coning(a, omega, d)
    inc = c.dual_increments(0.0, T / n, k * n, frame)
    true = c.pose(T * k)
    est = di.integrate_pose(c.pose(0.0), inc, n, family, frame)[-1]
    err = (
        dp.dualquat_mul(dp.dualquat_conj(true), est)
        if frame == "body"
        else dp.dualquat_mul(est, dp.dualquat_conj(true))
    )
    return dp.twist_from_dualquat(err) / (T * k)


# (N, a, ΩT): a small enough that the O(a⁴) error the algorithms do not cancel stays < 2% of the a² term,
# ΩT small enough that the next Taylor term is < 2.5%, and the drift far above round-off.
CONING_CASES = [(1, 0.01, 0.1), (2, 0.01, 0.3), (3, 0.01, 1.0), (4, 5e-4, 1.0)]


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize("n, a, omega_t", CONING_CASES)
def test_coning_optimal_drift_matches_prediction(n, a, omega_t, frame):
    omega, d = 1.3, 0.8
    err = _coning_error(n, "coning-optimal", a, omega, omega_t, 2000, frame, d)
    pred = m.coning_drift(a, omega, omega_t / omega, n)  # ρ_N a² Ω (ΩT)^{2N}
    assert abs(err[0]) == pytest.approx(pred, rel=0.05)
    assert abs(err[3]) == pytest.approx(2 * d / a * pred, rel=0.05)  # dual part: 2 a d ρ_N Ω (ΩT)^{2N}
    assert np.hypot(err[1], err[2]) < 0.2 * abs(err[0])  # the drift is about the cone axis (rest: round-off)


@pytest.mark.parametrize("frame", FRAMES)
def test_polynomial_n3_has_its_own_larger_residual(frame):
    a, omega, omega_t = 0.01, 1.0, 0.3
    poly = _coning_error(3, "polynomial", a, omega, omega_t, 2000, frame)[0]
    opt = _coning_error(3, "coning-optimal", a, omega, omega_t, 2000, frame)[0]
    assert abs(poly) == pytest.approx(a * a * omega * omega_t**4 / 6480, rel=0.05)  # see test_coefficients
    assert abs(poly) > 20 * abs(opt)


def test_one_plus_previous_drift():
    a, omega, omega_t = 0.01, 1.0, 0.3
    err = _coning_error(1, "one-plus-previous", a, omega, omega_t, 5000, "body")[0]
    assert abs(err) == pytest.approx(a * a * omega * omega_t**4 / 60, rel=0.05)
    plain = _coning_error(1, "coning-optimal", a, omega, omega_t, 5000, "body")[0]
    assert abs(plain) > 50 * abs(err)


@pytest.mark.parametrize("frame", FRAMES)
@pytest.mark.parametrize(
    "n, family",
    [
        (1, "coning-optimal"),
        (1, "one-plus-previous"),
        (2, "coning-optimal"),
        (3, "polynomial"),
        (3, "coning-optimal"),
        (4, "polynomial"),
        (4, "coning-optimal"),
    ],
)
def test_constant_twist_exact_over_1e5_updates(n, family, frame):
    rng = np.random.default_rng(n)
    tw = np.r_[rng.normal(size=3) * 0.5, rng.normal(size=3)]
    dq0 = dp.dualquat_from_qt(dp.quat_from_rotvec(rng.normal(size=3)), rng.normal(size=3))
    c = m.ConstantTwist(tuple(tw), tuple(dq0), frame)
    k, h = 100_000, 1e-4
    inc = c.dual_increments(0.0, h, k * n, frame)
    t = n * h * np.arange(0, k + 1, 1000)
    true = c.pose(t)
    pose = di.integrate_pose(dq0, inc, n, family, frame)[::1000]
    att = di.integrate_attitude(dq0[:4], inc[:, :3], n, family, frame)[::1000]
    sign = np.sign(np.sum(pose[:, :4] * true[:, :4], axis=-1))[:, None]
    scale = max(1.0, np.abs(dp.qt_from_dualquat(true)[1]).max())  # dual part ~ ½|t|: relative to the size
    assert np.abs(att - sign * true[:, :4]).max() < 1e-12
    assert np.abs(pose - sign * true).max() < 1e-12 * scale


def test_smooth_trajectory_convergence_order():
    """Error of the N-sample algorithm on a general motion falls with the step (order ≥ 2 for N ≥ 2)."""
    s = m.SmoothTrajectory()
    errs = {}
    for n in (1, 2, 3):
        for h in (0.01, 0.005):
            k = int(round(4.0 / (n * h)))
            inc = s.dual_increments(0.0, h, k * n)
            est = di.integrate_pose(s.pose(0.0), inc, n)[-1]
            err = dp.twist_from_dualquat(dp.dualquat_mul(dp.dualquat_conj(s.pose(k * n * h)), est))
            errs[n, h] = np.abs(err).max()
    for n in (1, 2, 3):
        assert errs[n, 0.01] / errs[n, 0.005] > 3.5  # at least second order
    assert errs[3, 0.01] < errs[1, 0.01]


# --------------------------------------------------------------------------------------------------------------
# relative pose
# --------------------------------------------------------------------------------------------------------------


def test_relative_pose():
    ql, qf = dp.quat_from_rotvec(RNG.normal(size=(2, 3)))
    tl, tf = RNG.normal(size=(2, 3))
    follower = dp.dualquat_from_qt(qf, tf)
    rel = di.relative_pose(ql, follower)  # attitude-only leader at the origin
    q, t = dp.qt_from_dualquat(rel)
    np.testing.assert_allclose(q, dp.quat_mul(dp.quat_conj(ql), qf), atol=1e-15)
    np.testing.assert_allclose(t, dp.matrix_from_quat(ql).T @ tf, atol=1e-14)
    rel2 = di.relative_pose(dp.dualquat_from_qt(ql, tl), follower)
    m_rel = np.linalg.inv(dp.matrix_from_dualquat(dp.dualquat_from_qt(ql, tl))) @ dp.matrix_from_dualquat(follower)
    np.testing.assert_allclose(dp.matrix_from_dualquat(rel2), m_rel, atol=1e-14)
    with pytest.raises(ValueError, match="leader"):
        di.relative_pose(np.zeros(5), follower)
