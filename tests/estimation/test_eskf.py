"""Error-state EKF on the simulated eight-shaped run: accuracy bars, robustness, asynchronous camera times."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.estimation import eskf, models
from dualpose.estimation.eskf import ErrorStateEKF
from dualpose.types import ImuNoise

MOVING = (1.0, 6.4)  # the 5.4 s eight (the run rests before and after)


def _start(run: sim.SimulatedRun, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Initial state drawn from the filter's own prior around the truth (so the prior is honest)."""
    P0 = eskf.initial_covariance(imu_noise=run.imu_noise)
    d = np.random.default_rng([seed, 99]).multivariate_normal(np.zeros(15), P0)
    tr = run.truth
    x = np.concatenate([tr["position"][0], tr["velocity"][0], tr["quat"][0], tr["gyro_bias"][0], tr["accel_bias"][0]])
    x = models.boxplus(x, d)
    x[10:16] = 0.0  # bias estimates start at zero; the prior covers the turn-on biases
    return x, P0


def _errors(run: sim.SimulatedRun, res: eskf.FilterResult, window=MOVING) -> tuple[float, float]:
    m = (run.t >= window[0]) & (run.t <= window[1])
    e = np.linalg.norm(res.position - run.truth["position"], axis=1)[m]
    a = np.degrees(dp.quat_angle(res.quat, run.truth["quat"]))[m]
    return float(np.sqrt(np.mean(e**2))), float(np.sqrt(np.mean(a**2)))


def _filter(run: sim.SimulatedRun, seed: int, **kw) -> eskf.ErrorStateEKF:
    x, P0 = _start(run, seed)
    return eskf.ErrorStateEKF.for_run(run, x[0:3], x[3:6], x[6:10], P0, **kw)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_eight_default_noise_meets_bars(seed: int) -> None:
    run = sim.simulate_eight(seed)
    res = _filter(run, seed).run_recording(run)
    pos_rmse, ori_rmse = _errors(run, res)
    assert pos_rmse <= 0.01, pos_rmse
    assert ori_rmse <= 0.5, ori_rmse
    rep = res.innovation
    assert 0.9 <= rep.fraction_inside <= 0.985
    assert 1.6 < rep.mean_nis < 2.4  # χ²(2) mean is 2
    # gyro bias is learned
    assert np.linalg.norm(res.gyro_bias[-1] - run.truth["gyro_bias"][-1]) < 0.5 * np.linalg.norm(
        run.truth["gyro_bias"][-1]
    )


def test_dropout_and_outliers_do_not_diverge() -> None:
    run = sim.simulate_eight(5, outlier_fraction=0.1, dropouts=((3.0, 5.0),))
    res = _filter(run, 5).run_recording(run)
    rep = res.innovation
    true_out = run.frames.outlier
    assert np.mean(~rep.accepted[true_out]) > 0.97  # gross outliers gated
    assert np.mean(~rep.accepted[~true_out]) < 0.01  # inliers kept
    err = np.linalg.norm(res.position - run.truth["position"], axis=1)
    assert err.max() < 0.15  # IMU-only for 2 s of aggressive motion, then re-acquired
    after = run.t > 5.5
    assert err[after].max() < 0.015
    ang = np.degrees(dp.quat_angle(res.quat, run.truth["quat"]))
    assert ang.max() < 1.0
    # during the dropout the 3σ bound grows and still covers the error
    sig = np.sqrt(np.einsum("nii->ni", res.covariance[:, 0:3, 0:3]).sum(axis=1))
    gap = (run.t > 3.0) & (run.t < 5.0)
    assert np.all(err[gap] < 3.5 * sig[gap])


def test_camera_times_between_imu_samples_and_time_offset() -> None:
    """Camera phase not on the IMU grid plus a known 30 ms clock offset: same accuracy; ignoring it costs."""
    run = sim.simulate_eight(3, time_offset=0.03, camera_phase=0.0071)
    known = _errors(run, _filter(run, 3).run_recording(run))
    ignored = _errors(run, _filter(run, 3, camera_time_offset=0.0).run_recording(run))
    assert known[0] <= 0.01 and known[1] <= 0.5
    assert ignored[0] > 1.5 * known[0]


def test_online_api_matches_batch_when_frames_fall_on_imu_samples() -> None:
    run = sim.simulate_eight(4, camera_phase=0.0)
    batch = _filter(run, 4).run_recording(run)
    online = _filter(run, 4)
    f = run.frames
    j = 0
    pos = []
    for k, tk in enumerate(run.t):
        online.propagate(tk, run.gyro[k], run.accel[k])
        while j < len(f) and abs(f.t[j] - tk) < 1e-9:
            online.update_camera(f.t[j], *f.frame(j))
            j += 1
        pos.append(online.position)
    np.testing.assert_allclose(np.array(pos), batch.position, atol=1e-9)
    np.testing.assert_allclose(online.quat, batch.quat[-1], atol=1e-10)
    np.testing.assert_allclose(online.innovation_report().nis, batch.innovation.nis, rtol=1e-6)


def test_position_and_pose_updates_pull_towards_measurement() -> None:
    run = sim.simulate_eight(0)
    f = _filter(run, 0)
    target = f.position + [0.05, 0.0, 0.0]
    nis = f.update_position(target, 1e-8)
    assert nis > 10 and np.allclose(f.position, target, atol=1e-4)
    q_t = dp.quat_mul(f.quat, dp.quat_from_rotvec([0.0, 0.02, 0.0]))
    f.update_pose(f.position, q_t, np.eye(6) * 1e-10)
    assert dp.quat_angle(f.quat, q_t) < 1e-4
    assert np.all(np.linalg.eigvalsh(f.P) > 0)


def test_bad_input() -> None:
    with pytest.raises(ValueError, match="quat must have shape"):
        eskf.ErrorStateEKF(np.zeros(3), np.zeros(3), np.zeros(3), np.eye(15))
    with pytest.raises(ValueError, match="covariance"):
        eskf.ErrorStateEKF(np.zeros(3), np.zeros(3), [0, 0, 0, 1], np.eye(14))
    f = eskf.ErrorStateEKF(np.zeros(3), np.zeros(3), [0, 0, 0, 1], np.eye(15))
    f.propagate(1.0, np.zeros(3), [0, 0, 9.81])
    with pytest.raises(ValueError, match="older"):
        f.propagate(0.5, np.zeros(3), [0, 0, 9.81])


def _realistic_filter(run: sim.SimulatedRun, **kw) -> eskf.ErrorStateEKF:
    from dualpose.estimation import initialization
    from dualpose.registration import pnp

    rest = run.t < 0.9
    pix, pts = run.frames.frame(0)
    first = pnp.solve_pnp(pix, pts, run.camera.matrix, pixel_sigma=run.pixel_sigma)
    n = run.imu_noise
    x, P0 = initialization.initial_state_from_rest_and_frame(
        run.accel[rest], run.gyro[rest], first, run.q_bc, run.p_bc, n.gyroscope_noise_density,
        n.accelerometer_initial_bias_sigma, n.update_rate,
    )  # fmt: skip
    return eskf.ErrorStateEKF.from_state(run, x, P0, **kw)


@pytest.mark.parametrize("seed", [10, 11])
def test_eight_with_static_and_pnp_initialisation(seed: int) -> None:
    """The whole pipeline without any truth: static alignment + first-frame PnP, then the filter."""
    run = sim.simulate_eight(seed)
    res = _realistic_filter(run).run_recording(run)
    pos_rmse, ori_rmse = _errors(run, res)
    assert pos_rmse <= 0.01, pos_rmse
    assert ori_rmse <= 0.5, ori_rmse


def test_magnetometer_updates_remove_the_observable_attitude_error() -> None:
    """A magnetometer observes rotations perpendicular to the field: after updates at rest, a 5° yaw error is left
    only along the field direction (rotation about the field is unobservable from it)."""
    run = sim.simulate_eight(6, magnetometer_sigma=0.01)
    tr = run.truth
    q0 = dp.quat_mul(dp.quat_from_rotvec([0.0, 0.0, np.radians(5.0)]), tr["quat"][0])  # world-z (yaw) error
    P0 = eskf.initial_covariance(attitude_sigma=np.radians(10.0), imu_noise=run.imu_noise)
    f = eskf.ErrorStateEKF.for_run(run, tr["position"][0], tr["velocity"][0], q0, P0)
    nis = []
    for k in range(80):  # 0.8 s at rest, no camera
        f.propagate(run.t[k], run.gyro[k], run.accel[k])
        nis.append(f.update_magnetometer(run.mag[k], run.magnetic_field, 0.01**2))
    err_w = dp.rotvec_from_quat(dp.quat_mul(tr["quat"][79], dp.quat_conj(f.quat)))  # world-frame error
    m_hat = run.magnetic_field / np.linalg.norm(run.magnetic_field)
    assert np.degrees(np.linalg.norm(np.cross(err_w, m_hat))) < 0.3
    assert np.degrees(np.linalg.norm(err_w)) > 1.0  # the part along the field stays
    assert np.mean(nis[20:]) < 6.0  # χ²(3) mean 3


def test_scale_factor_uncertainty_adds_eps2_omega2_and_eps2_f2_to_the_densities() -> None:
    """From P = 0, one step of dt adds (σ_g² + ε_g² |ω|²) dt to each attitude and (σ_a² + ε_a² |f|²) dt to each
    velocity variance (ImuNoise ``*_scale_sigma``, a 1 s correlation time): the analytic values."""
    noise = ImuNoise(gyroscope_noise_density=1e-3, accelerometer_noise_density=2e-3, gyroscope_scale_sigma=0.004,
                     accelerometer_scale_sigma=0.002)
    w, f, dt = np.array([1.0, -2.0, 2.5]), np.array([0.5, 1.0, 9.0]), 0.005
    ekf = ErrorStateEKF(np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros((15, 15)), noise)
    ekf.predict(w, f, dt)
    P = ekf.covariance
    np.testing.assert_allclose(np.diag(P)[6:9], (1e-6 + 0.004**2 * (w @ w)) * dt, rtol=1e-12)
    np.testing.assert_allclose(np.diag(P)[3:6], (4e-6 + 0.002**2 * (f @ f)) * dt, rtol=1e-12)
    off = ErrorStateEKF(np.zeros(3), np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]), np.zeros((15, 15)),
                        dataclasses.replace(noise, gyroscope_scale_sigma=0.0, accelerometer_scale_sigma=0.0))
    off.predict(w, f, dt)
    np.testing.assert_allclose(np.diag(off.covariance)[6:9], 1e-6 * dt, rtol=1e-12)
