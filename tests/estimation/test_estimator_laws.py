"""One law suite over every estimator of the interface (``dualpose.estimation.interface``), the way jaxlie's
``tests/utils.py`` runs one suite over every group: layouts, symmetric positive-definite covariance, a
zero-information update that changes nothing, and NEES / NIS consistency against the simulator's truth."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.estimation.ahrs import AhrsNoise
from dualpose.estimation.ahrs.estimator import AhrsFilter
from dualpose.estimation.consistency import nees_band
from dualpose.estimation.eskf import ErrorStateEKF, initial_covariance
from dualpose.estimation.hol22 import Hol22EKF, HolProcessNoise
from dualpose.estimation.interface import (
    AttitudeFix,
    Estimator,
    LinearMeasurement,
    world_attitude_error,
)
from dualpose.estimation.msckf import MsckfVio
from dualpose.estimation.state import AHRS_ERROR, ESKF_STATE, HOL22_STATE
from dualpose.types import ImuNoise

ATTITUDE_SIGMA = np.radians(0.5)  # of the attitude fixes
IMU_RATE = 100.0  # Hz, the simulator's default
FIX_EVERY = 25  # IMU samples between attitude fixes (the ESKF's trapezoid propagation models (n - ½)/n of the
# gyro noise it integrates over n samples, 2 % here)


def _draw_attitude(q_true: np.ndarray, cov: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``Exp(e) ⊗ q_true`` with a world-frame error ``e ~ N(0, cov)``."""
    return dp.quat_mul(dp.quat_from_rotvec(rng.multivariate_normal(np.zeros(3), cov)), q_true)


def _eskf(run: sim.SimulatedRun, rng: np.random.Generator) -> Estimator:
    """The error-state filter started from a draw of its own prior around the truth (zero biases: the simulator
    draws the true turn-on biases from the prior's bias sigmas)."""
    tr = run.truth
    P0 = initial_covariance(imu_noise=run.imu_noise)
    e = rng.multivariate_normal(np.zeros(15), P0)
    q0 = dp.quat_mul(tr["quat"][0], dp.quat_from_rotvec(e[6:9]))  # local error of the prior
    return ErrorStateEKF.for_run(run, tr["position"][0] + e[0:3], tr["velocity"][0] + e[3:6], q0, P0)


def _hol22(run: sim.SimulatedRun, rng: np.random.Generator) -> Estimator:
    """Hol's filter started from a draw of its prior (additive blocks, the quaternion through a world-frame error),
    with process noise matched to the simulated motion's smoothness."""
    tr = run.truth
    sig = {"position": 0.01, "velocity": 0.01, "acceleration": 0.3, "angular_velocity": 0.05,
           "gyro_bias": run.imu_noise.gyroscope_initial_bias_sigma,
           "accel_bias": run.imu_noise.accelerometer_initial_bias_sigma}  # fmt: skip
    truth = {"position": tr["position"][0], "velocity": tr["velocity"][0], "acceleration": tr["acceleration"][0],
             "angular_velocity": tr["omega"][0], "gyro_bias": tr["gyro_bias"][0],
             "accel_bias": tr["accel_bias"][0]}  # fmt: skip
    P = np.zeros((22, 22))
    blocks = {}
    for name, s in sig.items():
        HOL22_STATE.cov(P, name)[:] = np.eye(3) * s**2
        blocks[name] = truth[name] + rng.normal(0.0, s, 3)
    att_cov = np.eye(3) * np.radians(0.5) ** 2
    q_be = dp.quat_conj(_draw_attitude(tr["quat"][0], att_cov, rng))
    J = -0.5 * dp.quat_left_matrix(q_be)[:, :3]  # δq^{be} = −½ q^{be} ⊗ [e, 0]
    HOL22_STATE.cov(P, "quat_be")[:] = J @ att_cov @ J.T + np.eye(4) * 1e-12
    x = HOL22_STATE.assemble(quat_be=q_be, **blocks)
    return Hol22EKF(x, P, process_noise=HolProcessNoise(acceleration=40.0, angular_velocity=4.0),
                    **run.sensor_options())  # fmt: skip


def _ahrs(run: sim.SimulatedRun, rng: np.random.Generator) -> Estimator:
    """The orientation filter started from a draw of its prior (global attitude error)."""
    n = run.imu_noise
    P0 = np.diag(np.r_[np.full(3, np.radians(0.5) ** 2), np.full(3, n.gyroscope_initial_bias_sigma**2)])
    q0 = _draw_attitude(run.truth["quat"][0], AHRS_ERROR.cov(P0, "attitude"), rng)
    b0 = run.truth["gyro_bias"][0] + rng.normal(0.0, n.gyroscope_initial_bias_sigma, 3)
    noise = AhrsNoise(gyroscope_noise_density=n.gyroscope_noise_density, gyroscope_random_walk=n.gyroscope_random_walk)
    return AhrsFilter(q0, b0, P0, noise=noise, gyro_scale_sigma=0.0)


def _msckf(run: sim.SimulatedRun, rng: np.random.Generator) -> Estimator:
    """The MSCKF (feature tracks of an unknown scene) started as the error-state filter (zero biases: the simulator
    draws the true ones from the prior); the laws use its IMU state and the interface's measurements (its
    feature-track updates: tests/estimation/test_msckf.py)."""
    tr = run.truth
    P0 = initial_covariance(imu_noise=run.imu_noise)
    e = rng.multivariate_normal(np.zeros(15), P0)
    q0 = dp.quat_mul(tr["quat"][0], dp.quat_from_rotvec(e[6:9]))
    x = ESKF_STATE.assemble(position=tr["position"][0] + e[0:3], velocity=tr["velocity"][0] + e[3:6], quat=q0,
                            gyro_bias=np.zeros(3), accel_bias=np.zeros(3))  # fmt: skip
    return MsckfVio(x, P0, run.imu_noise, run.q_bc, run.p_bc, feature_sigma=1e-3)


FACTORIES: dict[str, Callable[[sim.SimulatedRun, np.random.Generator], Estimator]] = {
    "eskf": _eskf,
    "hol22": _hol22,
    "ahrs": _ahrs,
    "msckf": _msckf,
}


def _simulated_run(seed: int, duration: float = 2.0) -> sim.SimulatedRun:
    return sim.simulate(sim.random_motion(seed, duration=duration), seed=seed, imu_noise=ImuNoise(update_rate=IMU_RATE))


@pytest.fixture(scope="module")
def run() -> sim.SimulatedRun:
    return _simulated_run(3)


def _fix(run: sim.SimulatedRun, k: int, rng: np.random.Generator) -> AttitudeFix:
    cov = np.eye(3) * ATTITUDE_SIGMA**2
    return AttitudeFix(_draw_attitude(run.truth["quat"][k], cov, rng), cov)


def _filter(est: Estimator, run: sim.SimulatedRun, rng: np.random.Generator, check=None) -> list[float]:
    """Propagate through the run with an attitude fix every ``FIX_EVERY`` samples; returns the fixes' NIS."""
    nis = []
    for k in range(len(run.t)):
        est.propagate(run.t[k], run.gyro[k], run.accel[k])
        if k % FIX_EVERY == FIX_EVERY - 1:
            res = est.update(_fix(run, k, rng))
            assert res.dof == 3 and res.accepted
            nis.append(float(res.nis))
        if check is not None:
            check(est)
    return nis


@pytest.mark.parametrize("kind", FACTORIES)
def test_layouts_and_accessors(kind: str, run: sim.SimulatedRun) -> None:
    est = FACTORIES[kind](run, np.random.default_rng(0))
    assert isinstance(est, Estimator)
    assert est.state.shape == (est.state_layout.dim,)
    assert est.covariance.shape == (est.covariance_layout.dim,) * 2
    for name in est.state_layout.names:
        assert est.block(name).shape == (est.state_layout.size(name),)
    np.testing.assert_allclose(np.linalg.norm(est.quat), 1.0, rtol=0, atol=1e-15)
    assert est.attitude_covariance().shape == (3, 3)
    # the accessors return copies: changing them leaves the estimator alone
    est.state[:] = 0.0
    est.covariance[:] = 0.0
    assert np.any(est.state != 0.0) and np.any(est.covariance != 0.0)


@pytest.mark.parametrize("kind", FACTORIES)
def test_covariance_stays_symmetric_positive_definite(kind: str, run: sim.SimulatedRun) -> None:
    rng = np.random.default_rng(1)
    est = FACTORIES[kind](run, rng)
    worst = []

    def check(e: Estimator) -> None:
        P = e.covariance
        assert np.abs(P - P.T).max() <= 1e-12 * np.abs(P).max()  # symmetric to rounding
        T = e.tangent_covariance()  # positive definite in minimal coordinates
        worst.append(np.linalg.eigvalsh(0.5 * (T + T.T)).min())

    _filter(est, run, rng, check)
    assert min(worst) > 0.0
    A = est.attitude_covariance()
    assert np.linalg.eigvalsh(0.5 * (A + A.T)).min() > 0.0


@pytest.mark.parametrize("kind", FACTORIES)
def test_zero_information_update_changes_nothing(kind: str, run: sim.SimulatedRun) -> None:
    rng = np.random.default_rng(2)
    est = FACTORIES[kind](run, rng)
    for k in range(20):
        est.propagate(run.t[k], run.gyro[k], run.accel[k])
    x, P = est.state, est.covariance
    r = rng.normal(size=2)
    res = est.update(LinearMeasurement(r, np.zeros((2, est.covariance_layout.dim)), np.diag([2.0, 0.5])))
    np.testing.assert_allclose(res.nis, r[0] ** 2 / 2.0 + r[1] ** 2 / 0.5, rtol=1e-14)
    # K = 0: nothing moves beyond rounding (re-symmetrising P, renormalising the quaternion)
    np.testing.assert_allclose(est.covariance, P, rtol=1e-12, atol=1e-15 * np.abs(P).max())
    np.testing.assert_allclose(est.state, x, rtol=1e-14, atol=4 * np.finfo(float).eps)


@pytest.mark.parametrize("kind", FACTORIES)
def test_an_update_needs_a_jacobian_of_the_covariance_layout(kind: str, run: sim.SimulatedRun) -> None:
    est = FACTORIES[kind](run, np.random.default_rng(3))
    n = est.covariance_layout.dim
    with pytest.raises(ValueError, match=f"jacobian must have shape \\(2, {n}\\)"):
        est.update(LinearMeasurement(np.zeros(2), np.zeros((2, n + 1)), np.eye(2)))
    with pytest.raises(TypeError, match="no model for a str"):
        est.update("not a measurement")


@pytest.mark.parametrize("kind", FACTORIES)
def test_nees_and_nis_are_consistent_on_the_simulator(kind: str) -> None:
    """Monte Carlo over simulated runs started from draws of the prior: the average world-frame attitude NEES at
    the end and the average NIS of all attitude fixes lie in their two-sided 95 % χ² bands (Bar-Shalom et al.
    2001, §5.4.2)."""
    runs = 100
    nees, nis = [], []
    for i in range(runs):
        run = _simulated_run(100 + i)
        rng = np.random.default_rng(1000 + i)
        est = FACTORIES[kind](run, rng)
        nis += _filter(est, run, rng)
        e = world_attitude_error(run.truth["quat"][-1], est.quat)
        nees.append(e @ np.linalg.solve(est.attitude_covariance(), e))
    lo, hi = nees_band(3, runs)
    assert lo <= np.mean(nees) <= hi, (np.mean(nees), lo, hi)
    lo, hi = nees_band(3, len(nis))
    assert lo <= np.mean(nis) <= hi, (np.mean(nis), lo, hi)


def test_the_orientation_filter_has_no_camera_model(run: sim.SimulatedRun) -> None:
    est = _ahrs(run, np.random.default_rng(4))
    with pytest.raises(TypeError, match="AhrsFilter has no camera model"):
        est.update(run.frames.camera_frame(0))


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_camera_frames_go_through_the_interface(kind: str, run: sim.SimulatedRun) -> None:
    est = FACTORIES[kind](run, np.random.default_rng(5))
    offset = run.time_offset
    k = 0
    for j in range(len(run.frames)):
        frame = run.frames.camera_frame(j)
        while k < len(run.t) and run.t[k] <= frame.t + offset:
            est.propagate(run.t[k], run.gyro[k], run.accel[k])
            k += 1
        res = est.update(frame)
        assert res.dof == 2 and res.nis.shape == (len(frame.pixels),) and res.accepted.dtype == bool
        assert est.time == pytest.approx(frame.t + offset)
    e = world_attitude_error(run.truth["quat"][k - 1], est.quat)
    assert np.degrees(np.linalg.norm(e)) < 1.0
