"""RTS smoothing (``dualpose.estimation.smoother``): the linear smoother against the batch least-squares solution, the
error-state smoother against a dense numpy implementation, the node record of the filter, accuracy gains and
consistency on the simulated eight-shaped run, finite-difference checks of the new Jacobians, bad input."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose import _native, sim
from dualpose.estimation import consistency, eskf, initialization, models, smoother
from dualpose.types import ImuNoise

MOVING = (1.0, 6.4)


# ---------------------------------------------------------------------------------------------- linear-Gaussian
def _random_linear_problem(rng: np.random.Generator, n: int = 4, m: int = 2, steps: int = 25):
    """A time-varying linear-Gaussian chain with a few steps without a measurement."""
    F = np.eye(n) + 0.2 * rng.standard_normal((steps, n, n))
    Q = []
    for _ in range(steps):
        A = 0.3 * rng.standard_normal((n, n))
        Q.append(A @ A.T + 0.05 * np.eye(n))
    H = rng.standard_normal((steps, m, n))
    R = np.diag(rng.uniform(0.1, 0.5, m))
    has_y = rng.random(steps) > 0.25
    has_y[0] = True
    m0 = rng.standard_normal(n)
    P0 = np.diag(rng.uniform(0.5, 2.0, n))
    x = rng.multivariate_normal(m0, P0)
    ys = []
    for k in range(steps):
        ys.append(H[k] @ x + rng.multivariate_normal(np.zeros(m), R))
        x = F[k] @ x + rng.multivariate_normal(np.zeros(n), Q[k])
    return F, np.array(Q), H, R, has_y, m0, P0, np.array(ys)


def _kalman_filter(F, Q, H, R, has_y, m0, P0, ys):
    steps, n = len(ys), len(m0)
    xa, Pa, xb, Pb = np.zeros((steps, n)), np.zeros((steps, n, n)), np.zeros((steps, n)), np.zeros((steps, n, n))
    x, P = m0.copy(), P0.copy()
    for k in range(steps):
        xa[k], Pa[k] = x, P
        if has_y[k]:
            S = H[k] @ P @ H[k].T + R
            K = np.linalg.solve(S, H[k] @ P).T
            x = x + K @ (ys[k] - H[k] @ x)
            P = P - K @ S @ K.T
        xb[k], Pb[k] = x, P
        x, P = F[k] @ x, F[k] @ P @ F[k].T + Q[k]
    return xa, Pa, xb, Pb


def _batch_least_squares(F, Q, H, R, has_y, m0, P0, ys):
    """Posterior of the whole chain in information form: Λ X = η over all states stacked (independent of RTS)."""
    steps, n = len(ys), len(m0)
    Lam = np.zeros((steps * n, steps * n))
    eta = np.zeros(steps * n)

    def blk(i: int) -> slice:
        return slice(i * n, (i + 1) * n)

    W0 = np.linalg.inv(P0)
    Lam[blk(0), blk(0)] += W0
    eta[blk(0)] += W0 @ m0
    Ri = np.linalg.inv(R)
    for k in range(steps):
        if has_y[k]:
            Lam[blk(k), blk(k)] += H[k].T @ Ri @ H[k]
            eta[blk(k)] += H[k].T @ Ri @ ys[k]
        if k + 1 < steps:
            Qi = np.linalg.inv(Q[k])
            # residual x_{k+1} - F x_k: Jacobian [-F, I]
            Lam[blk(k), blk(k)] += F[k].T @ Qi @ F[k]
            Lam[blk(k), blk(k + 1)] -= F[k].T @ Qi
            Lam[blk(k + 1), blk(k)] -= Qi @ F[k]
            Lam[blk(k + 1), blk(k + 1)] += Qi
    cov = np.linalg.inv(Lam)
    mean = cov @ eta
    return mean.reshape(steps, n), np.array([cov[blk(k), blk(k)] for k in range(steps)])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_linear_rts_equals_batch_least_squares(seed: int) -> None:
    prob = _random_linear_problem(np.random.default_rng([seed, 31]))
    xa, Pa, xb, Pb = _kalman_filter(*prob)
    xs, Ps = smoother.rts_smooth_linear(xb, Pb, xa, Pa, prob[0])
    ref_x, ref_P = _batch_least_squares(*prob)
    np.testing.assert_allclose(xs, ref_x, atol=1e-9, rtol=1e-9)
    np.testing.assert_allclose(Ps, ref_P, atol=1e-10, rtol=1e-8)
    # the last step is the filter's; smoothing never increases the variance
    np.testing.assert_array_equal(xs[-1], xb[-1])
    assert np.all(np.trace(Ps, axis1=1, axis2=2) <= np.trace(Pb, axis1=1, axis2=2) * (1 + 1e-12))


def test_linear_rts_bad_input() -> None:
    x, P = np.zeros((3, 2)), np.tile(np.eye(2), (3, 1, 1))
    with pytest.raises(ValueError, match="prior_covariances must have shape"):
        smoother.rts_smooth_linear(x, P, x, P[:2], P)
    with pytest.raises(ValueError, match="posterior_means must have shape"):
        smoother.rts_smooth_linear(np.zeros(3), P, x, P, P)
    bad = x.copy()
    bad[1, 0] = np.nan
    with pytest.raises(ValueError, match="prior_means must be finite"):
        smoother.rts_smooth_linear(x, P, bad, P, P)


# ---------------------------------------------------------------------------------------------- error-state
def _filtered(run: sim.SimulatedRun, **kw) -> eskf.FilterResult:
    """Filter from static alignment + first-frame PnP (no truth), recording the nodes."""
    x, P0 = initialization.initial_state_from_run(run)
    f = eskf.ErrorStateEKF.from_state(run, x, P0, **kw)
    return f.run_recording(run, record_nodes=True)


@pytest.fixture(scope="module")
def eight() -> tuple[sim.SimulatedRun, eskf.FilterResult, smoother.SmoothedResult]:
    run = sim.simulate_eight(0)
    res = _filtered(run)
    return run, res, smoother.rts_smooth(res)


def _dense_error_state_rts(nodes: eskf.FilterNodes) -> tuple[np.ndarray, np.ndarray]:
    """The error-state recursion of docs/fusion.md written plainly with the public algebra (test reference)."""

    def boxminus(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        d = np.concatenate([x[0:6] - y[0:6], np.zeros(3), x[10:16] - y[10:16]])
        d[6:9] = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(y[6:10]), x[6:10]))
        return d

    def chart(phi: np.ndarray, inverse: bool) -> np.ndarray:
        J = np.eye(15)
        J[6:9, 6:9] = dp.so3_right_jacobian_inv(phi) if inverse else dp.so3_right_jacobian(phi)
        return J

    xa, Pa, xb, Pb, F = (nodes.prior_states, nodes.prior_covariance, nodes.posterior_states,
                         nodes.posterior_covariance, nodes.transition)  # fmt: skip
    K = len(xa)
    xs, Ps = np.empty_like(xb), np.empty_like(Pb)
    xs[-1], Ps[-1] = xb[-1], Pb[-1]
    for i in range(K - 2, -1, -1):
        mu = boxminus(xs[i + 1], xa[i + 1])
        J = chart(mu[6:9], inverse=True)
        Sig = J @ Ps[i + 1] @ J.T
        C = Pb[i] @ F[i].T @ np.linalg.inv(Pa[i + 1])
        d = C @ mu
        S = Pb[i] + C @ (Sig - Pa[i + 1]) @ C.T
        xs[i] = models.boxplus(xb[i], d)
        Jr = chart(d[6:9], inverse=False)
        Ps[i] = Jr @ S @ Jr.T
    return xs, Ps


def test_error_state_rts_equals_dense_reference(eight) -> None:
    run, res, sm = eight
    ref_x, ref_P = _dense_error_state_rts(res.nodes)
    np.testing.assert_allclose(sm.node_states[:, 0:6], ref_x[:, 0:6], atol=1e-10)
    np.testing.assert_allclose(sm.node_states[:, 10:16], ref_x[:, 10:16], atol=1e-10)
    assert np.max(dp.quat_angle(sm.node_states[:, 6:10], ref_x[:, 6:10])) < 1e-10
    np.testing.assert_allclose(sm.node_covariance, ref_P, atol=1e-14, rtol=1e-7)


def test_node_record(eight) -> None:
    run, res, sm = eight
    nodes = res.nodes
    # the recording run is the plain run
    x, P0 = initialization.initial_state_from_run(run)
    plain = eskf.ErrorStateEKF.from_state(run, x, P0).run_recording(run)
    np.testing.assert_array_equal(plain.position, res.position)
    np.testing.assert_array_equal(plain.covariance, res.covariance)
    # one node per IMU time and per camera time (the camera phase is off the IMU grid)
    cam_t = run.frames.t + run.time_offset
    inside = (cam_t >= run.t[0]) & (cam_t <= run.t[-1])
    assert len(nodes.t) == len(run.t) + np.count_nonzero(inside)
    np.testing.assert_array_equal(nodes.t[nodes.imu_node], run.t)
    np.testing.assert_allclose(nodes.t[nodes.frame_node[inside]], cam_t[inside], atol=1e-15)
    assert np.all(np.diff(nodes.t) > 0)
    np.testing.assert_array_equal(nodes.posterior_states[nodes.imu_node, 0:3], res.position)
    np.testing.assert_array_equal(nodes.posterior_covariance[nodes.imu_node], res.covariance)
    # updates happen only at camera nodes
    updated = np.any(nodes.prior_states != nodes.posterior_states, axis=1)
    assert set(np.flatnonzero(updated)) <= set(nodes.frame_node[inside])
    # the prior covariance is F P⁺ Fᵀ + Q with Q diagonal (σ² Δt on δv, δθ, δb_g, δb_a)
    n = run.imu_noise
    q = np.repeat([0.0, n.accelerometer_noise_density**2, n.gyroscope_noise_density**2,
                   n.gyroscope_random_walk**2, n.accelerometer_random_walk**2], 3)  # fmt: skip
    F, Pb, Pa = nodes.transition, nodes.posterior_covariance, nodes.prior_covariance
    Qk = Pa[1:] - F[:-1] @ Pb[:-1] @ np.swapaxes(F[:-1], 1, 2)
    dt = np.diff(nodes.t)
    np.testing.assert_allclose(Qk, q[None, :, None] * np.eye(15) * dt[:, None, None], atol=1e-15)


def test_stored_transition_is_the_jacobian_of_the_prediction() -> None:
    """Finite-difference check of the recorded F: the error of the first-order F (Solà eq. 269) against central
    differences of the nominal propagation ``(f(x ⊞ h e_j) ⊟ f(x ⊞ −h e_j)) / 2h`` shrinks as dt² (F is exact to
    O(dt))."""
    rng = np.random.default_rng(5)
    q0 = dp.quat_from_rotvec(rng.standard_normal(3))
    x0 = np.concatenate([rng.standard_normal(6), q0, 0.01 * rng.standard_normal(6)])
    gyro, accel = np.array([0.3, -0.5, 0.8]), np.array([1.0, -2.0, 9.0])
    gravity, noise = np.array([0.0, 0.0, -9.81]), np.zeros(6)

    def propagate(x: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        x = x.copy()
        F = np.empty((15, 15))
        _native.eskf_predict_transition(x, np.eye(15), gyro, accel, dt, gravity, noise, F)
        return x, F

    errs = []
    for dt in (0.01, 0.005):
        x1, F = propagate(x0, dt)
        Jfd = np.empty((15, 15))
        h = 1e-6
        for j in range(15):
            e = np.zeros(15)
            e[j] = h
            xp, _ = propagate(models.boxplus(x0, e), dt)
            xm, _ = propagate(models.boxplus(x0, -e), dt)
            d = np.empty(15)
            _native.smoother_boxminus(xp, xm, d)
            Jfd[:, j] = d / (2 * h)
        errs.append(np.abs(Jfd - F).max())
        assert errs[-1] < 10.0 * dt**2  # the dropped terms, e.g. δp ← −½ R [a]× dt² δθ with |a| ≈ 9 m/s²
    assert 3.0 < errs[0] / errs[1] < 5.0  # second order


def test_chart_jacobians_against_finite_differences(rng) -> None:
    """``right_jacobian``: Exp(φ + δ) = Exp(φ) Exp(J_r δ) and its inverse, by central differences; ``boxminus``
    inverts ``boxplus``."""
    big = rng.standard_normal(3)
    for phi in (rng.standard_normal(3), 1e-7 * rng.standard_normal(3), 2.8 * big / np.linalg.norm(big)):
        J, Ji = np.empty((3, 3)), np.empty((3, 3))
        _native.smoother_right_jacobian(phi, 0.0, J)
        _native.smoother_right_jacobian(phi, 1.0, Ji)
        q = dp.quat_from_rotvec(phi)
        Jfd = np.empty((3, 3))
        h = 1e-6
        for j in range(3):
            e = np.zeros(3)
            e[j] = h
            plus = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(q), dp.quat_from_rotvec(phi + e)))
            minus = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(q), dp.quat_from_rotvec(phi - e)))
            Jfd[:, j] = (plus - minus) / (2 * h)
        np.testing.assert_allclose(J, Jfd, atol=1e-8)
        np.testing.assert_allclose(Ji @ J, np.eye(3), atol=1e-12)
    x = np.concatenate([rng.standard_normal(6), dp.quat_from_rotvec([0.3, -1.0, 2.0]), rng.standard_normal(6)])
    d = rng.standard_normal(15)
    d[6:9] *= 0.9
    y = np.empty(16)
    _native.smoother_boxplus(x, d, y)
    np.testing.assert_allclose(y, models.boxplus(x, d), atol=1e-14)
    back = np.empty(15)
    _native.smoother_boxminus(y, x, back)
    np.testing.assert_allclose(back, d, atol=1e-12)


def test_smoother_ends_at_the_filter_and_never_increases_the_covariance(eight) -> None:
    run, res, sm = eight
    assert sm.covariance.shape == (len(run.t), 15, 15)
    for name in ("position", "velocity", "quat", "gyro_bias", "accel_bias"):
        np.testing.assert_array_equal(getattr(sm, name)[-1], getattr(res, name)[-1])
    np.testing.assert_array_equal(sm.covariance[-1], res.covariance[-1])
    tr_s = np.trace(sm.covariance, axis1=1, axis2=2)
    tr_f = np.trace(res.covariance, axis1=1, axis2=2)
    assert np.all(tr_s <= tr_f * (1 + 1e-9))
    assert np.median(tr_s / tr_f) < 0.5
    # symmetric (the last one is the filter's, symmetric to rounding only) and positive definite
    np.testing.assert_array_equal(sm.covariance[:-1], np.swapaxes(sm.covariance[:-1], 1, 2))
    assert np.linalg.eigvalsh(sm.covariance).min() > 0


def _rmse(run: sim.SimulatedRun, position: np.ndarray, quat: np.ndarray) -> tuple[float, float]:
    m = (run.t >= MOVING[0]) & (run.t <= MOVING[1])
    e = np.linalg.norm(position - run.truth["position"], axis=1)[m]
    a = np.degrees(dp.quat_angle(quat, run.truth["quat"]))[m]
    return float(np.sqrt(np.mean(e**2))), float(np.sqrt(np.mean(a**2)))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_smoother_reduces_position_and_orientation_error_on_the_eight(seed: int) -> None:
    run = sim.simulate_eight(seed)
    res = _filtered(run)
    sm = smoother.rts_smooth(res)
    pf, of = _rmse(run, res.position, res.quat)
    ps, os_ = _rmse(run, sm.position, sm.quat)
    assert ps < 0.8 * pf, (ps, pf)
    assert os_ < 0.8 * of, (os_, of)
    # the gyro bias after smoothing is as good at the start as the filter's at the end
    gb_err = np.linalg.norm(sm.gyro_bias[0] - run.truth["gyro_bias"][0])
    assert gb_err < np.linalg.norm(res.gyro_bias[0] - run.truth["gyro_bias"][0])


def test_smoother_bridges_a_vision_dropout() -> None:
    """2 s without frames and 10 % outliers: the filter drifts in the gap, the smoother (IMU + frames on both sides)
    stays at the few-mm level, and its 3σ bound covers its error."""
    run = sim.simulate_eight(0, outlier_fraction=0.1, dropouts=((3.0, 5.0),))
    res = _filtered(run)
    sm = smoother.rts_smooth(res)
    gap = (run.t > 3.0) & (run.t < 5.0)
    ef = np.linalg.norm(res.position - run.truth["position"], axis=1)[gap]
    es = np.linalg.norm(sm.position - run.truth["position"], axis=1)[gap]
    assert es.max() < 0.2 * ef.max() and es.max() < 0.01, (es.max(), ef.max())
    sig = np.sqrt(np.trace(sm.covariance[gap, 0:3, 0:3], axis1=1, axis2=2))
    assert np.all(es < 3.0 * sig)


def test_smoothed_nees_is_consistent() -> None:
    """10 Monte-Carlo runs started from the prior around the truth: the run-averaged 15-dim NEES of the smoothed
    states, averaged over time, lies in the two-sided 95 % band of the 10-run average (χ²₁₅₀/10)."""
    traj = sim.eight_motion()
    runs = 10
    total = 0.0
    for s in range(runs):
        run = sim.simulate(traj, seed=7000 + s)
        res = consistency.filter_from_prior(run, np.random.default_rng([s, 11])).run_recording(run, record_nodes=True)
        total = total + consistency.nees_against_truth(run.truth, smoother.rts_smooth(res))
    avg = total / runs
    lo, hi = consistency.nees_band(15, runs)
    assert lo < avg.mean() < hi, (avg.mean(), lo, hi)
    assert np.mean((avg >= lo) & (avg <= hi)) > 0.6


def test_frames_on_the_imu_grid_share_the_imu_nodes() -> None:
    """Camera phase 0: every frame falls on an IMU sample (the first one on ``t[0]``), so there is exactly one node
    per IMU time and the updates happen at IMU nodes; smoothing still helps."""
    run = sim.simulate_eight(4, camera_phase=0.0)
    res = _filtered(run)
    nodes = res.nodes
    assert len(nodes.t) == len(run.t)
    cam_t = run.frames.t + run.time_offset
    np.testing.assert_allclose(nodes.t[nodes.frame_node], cam_t, atol=1e-12)
    assert nodes.frame_node[0] == 0 and np.any(nodes.prior_states[0] != nodes.posterior_states[0])
    sm = smoother.rts_smooth(res)
    pf, of = _rmse(run, res.position, res.quat)
    ps, os_ = _rmse(run, sm.position, sm.quat)
    assert ps < 0.8 * pf and os_ < 0.8 * of


def test_rts_smooth_bad_input() -> None:
    run = sim.simulate_eight(0)
    x, P0 = initialization.initial_state_from_run(run)
    res = eskf.ErrorStateEKF.for_run(run, x[0:3], x[3:6], x[6:10], P0).run_recording(run)
    assert res.nodes is None
    with pytest.raises(ValueError, match="record_nodes=True"):
        smoother.rts_smooth(res)
    with pytest.raises(TypeError, match="FilterResult"):
        smoother.rts_smooth(res.position)
    # biases without prior uncertainty or random walk: the predicted covariance is singular
    P = P0.copy()
    P[9:, :] = 0.0
    P[:, 9:] = 0.0
    noise = ImuNoise(gyroscope_random_walk=0.0, accelerometer_random_walk=0.0)
    res = eskf.ErrorStateEKF.for_run(run, x[0:3], x[3:6], x[6:10], P, imu_noise=noise).run_recording(
        run, record_nodes=True
    )
    with pytest.raises(ValueError, match="singular"):
        smoother.rts_smooth(res)
