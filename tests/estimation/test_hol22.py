"""Hol's 22-state EKF: process-model Jacobian, accuracy on the eight-shaped run, robustness."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.estimation import eskf, hol22, models


def _start(run: sim.SimulatedRun, seed: int) -> hol22.Hol22EKF:
    P0 = eskf.initial_covariance(imu_noise=run.imu_noise)
    d = np.random.default_rng([seed, 99]).multivariate_normal(np.zeros(15), P0)
    tr = run.truth
    x = np.concatenate([tr["position"][0], tr["velocity"][0], tr["quat"][0], np.zeros(6)])
    x = models.boxplus(x, d)
    x[10:16] = 0.0
    return hol22.Hol22EKF.from_eskf_state(x, P0, run)


@pytest.mark.parametrize("omega", [[0.3, -0.7, 0.5], [1e-9, 0.0, 2e-9]])
def test_process_model_jacobian(omega, rng) -> None:
    x = np.concatenate([rng.normal(size=9), dp.quat_normalize(rng.normal(size=4)), omega, rng.normal(size=6)])
    T = 0.013
    _, F = hol22.process_model(x, T)
    num = np.empty((22, 22))
    for i in range(22):
        d = np.zeros(22)
        d[i] = 1e-6
        num[:, i] = (hol22.process_model(x + d, T)[0] - hol22.process_model(x - d, T)[0]) / 2e-6
    np.testing.assert_allclose(F, num, atol=1e-8)
    # eq. 9d rotates q^{be} by -T ω in the body frame: q_wb advances by +T ω (body)
    x1 = hol22.process_model(x, T)[0]
    q_wb0, q_wb1 = dp.quat_conj(x[9:13]), dp.quat_conj(x1[9:13])
    np.testing.assert_allclose(
        dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(q_wb0), q_wb1)), np.asarray(omega) * T, atol=1e-12
    )


def test_hol22_on_eight_run() -> None:
    run = sim.simulate_eight(0)
    res = _start(run, 0).run_recording(run)
    m = (run.t >= 1.0) & (run.t <= 6.4)
    pos = np.sqrt(np.mean(np.sum((res.position - run.truth["position"]) ** 2, axis=1)[m]))
    ori = np.sqrt(np.mean(np.degrees(dp.quat_angle(res.quat, run.truth["quat"]))[m] ** 2))
    assert pos <= 0.01 and ori <= 0.5, (pos, ori)
    np.testing.assert_allclose(np.linalg.norm(res.quat, axis=1), 1.0, atol=1e-12)
    assert 0.9 < res.innovation.fraction_inside < 0.985
    # ω and b̈ states track the truth (they are states here, inputs in the error-state filter)
    assert np.sqrt(np.mean((res.omega - run.truth["omega"])[m] ** 2)) < 0.05
    assert np.sqrt(np.mean((res.acceleration - run.truth["acceleration"])[m] ** 2)) < 0.3


def test_hol22_dropout_and_outliers() -> None:
    run = sim.simulate_eight(5, outlier_fraction=0.1, dropouts=((3.0, 5.0),))
    res = _start(run, 5).run_recording(run)
    err = np.linalg.norm(res.position - run.truth["position"], axis=1)
    assert err.max() < 0.2
    assert err[run.t > 5.5].max() < 0.02
    assert np.mean(~res.innovation.accepted[run.frames.outlier]) > 0.95


def test_bad_shapes() -> None:
    with pytest.raises(ValueError, match="x0 must"):
        hol22.Hol22EKF(np.zeros(21), np.eye(22))
    with pytest.raises(ValueError, match="x must"):
        hol22.process_model(np.zeros(16), 0.01)


def _python_algorithm_1(f: hol22.Hol22EKF, run: sim.SimulatedRun, n: int) -> tuple[np.ndarray, np.ndarray, list]:
    """Hol's Algorithm 1 written with the step methods (the numpy reference of the compiled ``run``)."""
    fr = run.frames
    cam_t = fr.t + f.camera_time_offset
    X, Ps, accepted = [], [], []
    j, tc = 0, run.t[0]
    while j < len(cam_t) and cam_t[j] < run.t[0]:
        j += 1
    for k in range(n):
        while j < len(cam_t) and cam_t[j] <= run.t[k]:
            f.time_update(cam_t[j] - tc)
            tc = cam_t[j]
            px, pts = fr.frame(j)
            accepted.append(f.camera_update(px, pts))
            j += 1
        f.time_update(run.t[k] - tc)
        tc = run.t[k]
        f.imu_update(run.accel[k], run.gyro[k])
        X.append(f.x.copy())
        Ps.append(f.P.copy())
    return np.array(X), np.array(Ps), accepted


@pytest.mark.parametrize("scale_sigma", [0.0, 0.005])
def test_compiled_run_equals_the_step_methods(scale_sigma: float) -> None:
    """The compiled Algorithm 1 reproduces the numpy step methods (states, covariances, gating decisions), also
    with the scale-factor noise (ImuNoise ``*_scale_sigma``) added to the IMU measurement noise."""
    run = sim.simulate_eight(5, outlier_fraction=0.1)
    noise = dataclasses.replace(run.imu_noise, gyroscope_scale_sigma=scale_sigma, accelerometer_scale_sigma=scale_sigma)
    run = dataclasses.replace(run, imu_noise=noise)
    n = 160  # 1.6 s: 20 camera frames
    ref_filter, fast_filter = _start(run, 5), _start(run, 5)
    X, Ps, accepted = _python_algorithm_1(ref_filter, run, n)
    fr = run.frames
    nf = int(np.searchsorted(fr.t, run.t[n - 1], side="right"))
    res = fast_filter.run(run.t[:n], run.gyro[:n], run.accel[:n], fr.t[:nf], fr.offsets[: nf + 1],
                          fr.pixels[: fr.offsets[nf]], fr.points[: fr.offsets[nf]])  # fmt: skip
    assert len(accepted) == nf > 15
    np.testing.assert_allclose(res.position, X[:, 0:3], rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.quat, dp.quat_conj(X[:, 9:13]), rtol=0, atol=1e-10)
    np.testing.assert_allclose(res.covariance, Ps, rtol=1e-6, atol=1e-14)
    np.testing.assert_array_equal(res.innovation.accepted, np.concatenate(accepted))
    assert not res.innovation.accepted.all()  # the outliers were gated


def test_native_layout_matches_the_python_layout() -> None:
    """The compiled filter's state offsets (src/native/estimation/hol22_layout.hpp) are those of
    :data:`dualpose.estimation.state.HOL22_STATE`."""
    from dualpose import _native
    from dualpose.estimation import state

    assert _native.HOL22_DIM == state.HOL22_DIM == state.HOL22_STATE.dim
    for name in state.HOL22_STATE.names:
        const = "HOL22_" + name.upper()
        assert getattr(_native, const) == getattr(state, const) == state.HOL22_STATE.offset(name), name
