"""Camera–IMU calibration on the simulator: extrinsic rotation from static poses (with a Monte-Carlo check of its
covariance), scene gravity alignment, camera–IMU time offset (rate matching + filter refinement), bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

import dualpose as dp
from dualpose import calibration as cal
from dualpose import sim
from dualpose.pipelines.calibrate import calibrate_run_time_offset
from dualpose.sim import calibration_scenarios
from dualpose.sim.calibration_scenarios import random_extrinsic, simulate_static_poses
from dualpose.types import ImuNoise

BIAS_FREE_ACCEL = ImuNoise(accelerometer_initial_bias_sigma=0.0, accelerometer_random_walk=0.0)


def _calibrate(seed: int, extrinsic, pose_seed: int | None = None, imu_noise=BIAS_FREE_ACCEL, **kwargs):
    runs = simulate_static_poses(6, seed, extrinsic=extrinsic, duration=0.5, pose_seed=pose_seed, imu_noise=imu_noise)
    periods = [cal.static_period_from_run(r) for r in runs]
    return cal.camera_imu_rotation(**cal.stack_static_periods(periods), **kwargs)


def _rotation_error(q_est: np.ndarray, q_true: np.ndarray) -> np.ndarray:
    """ε with R̂ = Exp(ε) R_true (the result's error convention), rad."""
    return dp.rotvec_from_quat(dp.quat_mul(q_est, dp.quat_conj(q_true)))


# ---------------------------------------------------------------------------------------------- extrinsic rotation
@pytest.mark.parametrize("which", ["default", "random-3", "random-11"])
def test_known_extrinsic_recovered_within_predicted_3_sigma(which: str) -> None:
    ext = sim.default_extrinsic() if which == "default" else random_extrinsic(int(which.split("-")[1]))
    res = _calibrate(7, ext)
    eps = _rotation_error(res.q_bc, ext[0])
    assert np.all(np.abs(eps) <= 3 * np.sqrt(np.diag(res.covariance)))
    assert np.degrees(np.linalg.norm(eps)) < 0.5  # and it is a real calibration, not a loose bound
    assert res.spread_deg > 10 and res.registration.degeneracy == "directions-only"
    assert np.all(res.residual_deg < 1.0) and not res.noise_from_residuals


def test_accelerometer_bias_enters_as_correlated_term() -> None:
    ext = random_extrinsic(4)
    noise = ImuNoise()  # turn-on accelerometer bias σ 0.05 m/s² (≈ 0.3° of tilt), the same in every pose
    bias_cov = np.eye(3) * noise.accelerometer_initial_bias_sigma**2
    without = _calibrate(5, ext, imu_noise=noise)
    with_bias = _calibrate(5, ext, imu_noise=noise, accel_bias_covariance=bias_cov)
    np.testing.assert_allclose(with_bias.q_bc, without.q_bc, atol=1e-12)  # the term changes σ, not the estimate
    assert np.all(with_bias.sigma_deg > without.sigma_deg)
    eps = _rotation_error(with_bias.q_bc, ext[0])
    chi2 = eps @ np.linalg.solve(with_bias.covariance, eps)
    assert chi2 < 16.27  # χ²(3) 99.9 %


def test_covariance_matches_monte_carlo() -> None:
    """One geometry, 150 noise seeds: predicted per-axis σ within 15 % of the empirical one, mean error ≈ 0."""
    ext = sim.default_extrinsic()
    errs, covs = [], []
    for seed in range(150):
        res = _calibrate(seed, ext, pose_seed=0)
        errs.append(_rotation_error(res.q_bc, ext[0]))
        covs.append(res.covariance)
    errs, covs = np.array(errs), np.array(covs)
    predicted = np.sqrt(np.diag(covs.mean(axis=0)))
    empirical = errs.std(axis=0, ddof=1)
    np.testing.assert_allclose(empirical / predicted, 1.0, atol=0.15)
    assert np.all(np.abs(errs.mean(axis=0)) < 4 * empirical / math.sqrt(len(errs)))
    nees = np.einsum("ni,nij,nj->n", errs, np.linalg.inv(covs), errs).mean()
    assert 3 * 0.8 < nees < 3 * 1.2


def test_noise_estimated_from_residuals_without_noise_information() -> None:
    ext = sim.default_extrinsic()
    runs = simulate_static_poses(6, 3, extrinsic=ext, duration=0.5, imu_noise=BIAS_FREE_ACCEL)
    stacked = cal.stack_static_periods([cal.static_period_from_run(r) for r in runs])
    informed = cal.camera_imu_rotation(**stacked)
    blind = cal.camera_imu_rotation(stacked["specific_force"], stacked["q_wc"])
    assert blind.noise_from_residuals
    assert dp.quat_angle(blind.q_bc, ext[0]) < 0.5 * math.pi / 180
    # the residual-based σ has 2K − 3 = 9 dof: within a factor 3 of the model-based one
    ratio = np.sqrt(np.trace(blind.covariance) / np.trace(informed.covariance))
    assert 1 / 3 < ratio < 3


def test_parallel_gravity_directions_are_rejected() -> None:
    ext = sim.default_extrinsic()
    q_wc, _ = calibration_scenarios.calibration_camera_poses(1, 0)
    f = dp.quat_rotate(dp.quat_conj(dp.quat_mul(q_wc[0], dp.quat_conj(ext[0]))), [0.0, 0.0, 9.81])
    # exact data: every pose has the same body-frame gravity (rotation about the vertical between poses)
    yaw = dp.quat_from_rotvec(np.outer(np.linspace(0, 1.5, 5), [0, 0, 1]))
    q_many = dp.quat_mul(yaw, np.broadcast_to(q_wc[0], (5, 4)))
    with pytest.raises(ValueError, match="unobservable"):
        cal.camera_imu_rotation(np.tile(f, (5, 1)), q_many)
    # noisy data with known noise: still rejected (spread below 3× the noise)
    rng = np.random.default_rng(1)
    noisy = np.tile(f, (5, 1)) + rng.normal(0, 2e-3, (5, 3))
    with pytest.raises(ValueError, match="unobservable"):
        cal.camera_imu_rotation(noisy, q_many, specific_force_covariance=np.eye(3) * 4e-6)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"specific_force": np.ones((4, 2)), "q_wc": np.tile([0, 0, 0, 1.0], (4, 1))}, r"specific_force.*\(K, 3\)"),
        ({"specific_force": np.ones((1, 3)), "q_wc": np.tile([0, 0, 0, 1.0], (1, 1))}, r"K >= 2"),
        ({"specific_force": np.eye(3), "q_wc": np.tile([0, 0, 0, 1.0], (4, 1))}, r"q_wc.*\(3, 4\)"),
        (
            {"specific_force": np.eye(3), "q_wc": np.tile([0, 0, 0, 1.0], (3, 1)), "attitude_covariance": np.eye(2)},
            r"attitude_covariance.*\(3, 3, 3\)",
        ),
        (
            {"specific_force": np.eye(3), "q_wc": np.tile([0, 0, 0, 1.0], (3, 1)), "pattern_up_w": [0, 1]},
            r"pattern_up_w.*\(3,\)",
        ),
        ({"specific_force": np.zeros((3, 3)), "q_wc": np.tile([0, 0, 0, 1.0], (3, 1))}, r"nonzero"),
    ],
)
def test_bad_input_names_argument_and_shape(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        cal.camera_imu_rotation(**kwargs)


# ---------------------------------------------------------------------------------------------- gravity alignment
@pytest.mark.parametrize("misalignment_deg", [1.0, 5.0])
def test_scene_gravity_alignment(misalignment_deg: float) -> None:
    for noise, bound_deg in ((ImuNoise(), 1.2), (BIAS_FREE_ACCEL, 0.4)):
        run = sim.simulate_eight(seed=4, gravity_misalignment_deg=misalignment_deg, imu_noise=noise)
        rest = cal.static_period_from_run(run, 0.0, 0.9)  # the eight starts with 1 s at rest
        bias_cov = np.eye(3) * noise.accelerometer_initial_bias_sigma**2
        g = cal.scene_gravity(rest.specific_force, rest.q_wc, run.q_bc, rest.specific_force_covariance,
                              rest.attitude_covariance, accel_bias_covariance=bias_cov)  # fmt: skip
        true_dir = run.gravity / np.linalg.norm(run.gravity)
        err = math.degrees(math.atan2(np.linalg.norm(np.cross(g.direction, true_dir)), g.direction @ true_dir))
        assert err < 3 * g.sigma_deg and err < bound_deg
        assert abs(g.tilt_deg - misalignment_deg) < 3 * g.sigma_deg
        assert abs(g.magnitude - 9.81) < 0.2
        np.testing.assert_allclose(dp.quat_rotate(g.q_level, g.direction), [0, 0, -1], atol=1e-12)
        np.testing.assert_allclose(g.covariance @ g.direction, 0.0, atol=1e-15)  # tangent-plane covariance


def test_scene_gravity_averages_periods_and_propagates_extrinsic() -> None:
    runs = simulate_static_poses(4, 2, duration=0.5, imu_noise=BIAS_FREE_ACCEL, gravity_misalignment_deg=3.0)
    periods = [cal.static_period_from_run(r) for r in runs]
    st = cal.stack_static_periods(periods)
    q_bc = runs[0].q_bc
    one = cal.scene_gravity(st["specific_force"][0], st["q_wc"][0], q_bc, st["specific_force_covariance"][0],
                            st["attitude_covariance"][0])  # fmt: skip
    four = cal.scene_gravity(st["specific_force"], st["q_wc"], q_bc, st["specific_force_covariance"],
                             st["attitude_covariance"])  # fmt: skip
    assert four.sigma_deg < one.sigma_deg
    assert four.per_period.shape == (4, 3)
    true_dir = runs[0].gravity / 9.81
    assert dp.quat_angle(dp.quat_from_rotvec(np.cross(four.direction, true_dir)), [0, 0, 0, 1.0]) < math.radians(
        3 * four.sigma_deg
    )
    ext_cov = np.eye(3) * math.radians(0.2) ** 2
    with_ext = cal.scene_gravity(st["specific_force"], st["q_wc"], q_bc, st["specific_force_covariance"],
                                 st["attitude_covariance"], extrinsic_covariance=ext_cov)  # fmt: skip
    # an extrinsic error tilts every period the same way: it does not average out (≈ 0.2° × √2 tangent axes)
    assert with_ext.sigma_deg > math.hypot(four.sigma_deg, 0.2 * 0.9)


# ---------------------------------------------------------------------------------------------- time offset
def test_gyro_mean_rates_exact_integral() -> None:
    t = np.linspace(0.0, 2.0, 201)
    w = np.column_stack([np.sin(3 * t), t**2, np.cos(t)])
    a = np.array([0.013, 0.5, 1.2345])
    b = np.array([0.0911, 0.9, 1.9876])
    got = cal.gyro_mean_rates(t, w, a, b)
    for i in range(3):
        for j, f in enumerate((lambda x: np.sin(3 * x), lambda x: x**2, np.cos)):
            ref = quad(f, a[i], b[i])[0] / (b[i] - a[i])
            assert abs(got[i, j] - ref) < 1e-4  # trapezoid of a smooth signal: O(h²)
    # a piecewise-linear signal is integrated exactly
    lin = np.column_stack([2 * t + 1, -t, 0 * t])
    np.testing.assert_allclose(cal.gyro_mean_rates(t, lin, a, b)[:, 0], (a + b) + 1, atol=1e-12)


def test_vision_rates_equal_true_mean_rates_without_noise() -> None:
    run = sim.simulate_eight(seed=1, pixel_sigma=0.0, imu_noise=ImuNoise().scaled(0.0))
    f = run.frames
    q, _ = cal.frame_poses(f.t, f.offsets, f.pixels, f.points, run.camera.matrix)
    t0, t1, w_c = cal.vision_rotation_rates(f.t, q)
    w_b = cal.gyro_mean_rates(run.t, run.truth["omega"], t0, t1)
    # ω_c = R_bcᵀ ω_b; Log of the relative rotation vs the mean rate differ by O(ω² Δt²) (< 2e-3 rad/s here)
    np.testing.assert_allclose(w_c, dp.quat_rotate(dp.quat_conj(run.q_bc), w_b), atol=2e-3)


@pytest.fixture(scope="module")
def offset_runs() -> dict[float, tuple]:
    out = {}
    for i, off in enumerate((-0.030, -0.015, -0.005, 0.005, 0.015, 0.030)):
        run = sim.simulate_eight(seed=40 + i, time_offset=off)
        f = run.frames
        out[off] = (run, *cal.frame_poses(f.t, f.offsets, f.pixels, f.points, run.camera.matrix))
    return out


@pytest.mark.parametrize("offset", [-0.030, -0.015, -0.005, 0.005, 0.015, 0.030])
def test_time_offset_rate_matching_then_filter(offset_runs: dict, offset: float) -> None:
    run, q, cov = offset_runs[offset]
    f = run.frames
    plain = cal.estimate_time_offset(run.t, run.gyro, f.t, q, run.q_bc)
    first = cal.estimate_time_offset(run.t, run.gyro, f.t, q, run.q_bc, attitude_covariance=cov,
                                     gyroscope_noise_density=run.imu_noise.gyroscope_noise_density)  # fmt: skip
    for est in (plain, first):
        assert abs(est.offset - offset) < 4 * est.sigma and abs(est.offset - offset) < 0.012
        assert 1e-3 < est.sigma < 1e-2 and est.mode == "extrinsic"
    again, refined = calibrate_run_time_offset(run, run.q_bc)  # the same stage 1, then the filter search
    assert again.offset == first.offset
    assert refined.bounds[1] - refined.bounds[0] >= 0.01
    assert abs(refined.offset - offset) < 0.002  # the goal: ≤ 1–2 ms after refinement
    assert refined.mean_nis == pytest.approx(refined.scores.min())


def test_time_offset_sigma_is_calibrated() -> None:
    """24 seeded eights: the stage-1 σ (sandwich over PnP + gyro covariances) matches the empirical RMS error."""
    errs, sigmas = [], []
    for i in range(24):
        off = (-0.02, 0.01, 0.025)[i % 3]
        run = sim.simulate_eight(seed=300 + i, time_offset=off)
        f = run.frames
        q, cov = cal.frame_poses(f.t, f.offsets, f.pixels, f.points, run.camera.matrix)
        est = cal.estimate_time_offset(run.t, run.gyro, f.t, q, run.q_bc, attitude_covariance=cov,
                                       gyroscope_noise_density=run.imu_noise.gyroscope_noise_density)  # fmt: skip
        errs.append(est.offset - off)
        sigmas.append(est.sigma)
    ratio = math.sqrt(np.mean(np.square(errs))) / float(np.mean(sigmas))
    assert 0.65 < ratio < 1.45  # 60 runs in the benchmark: 3.39 ms RMS vs 3.42 ms predicted
    assert abs(np.mean(errs)) < 3 * np.mean(sigmas) / math.sqrt(len(errs))


def test_time_offset_without_extrinsic_estimates_rotation(offset_runs: dict) -> None:
    run, q, _ = offset_runs[0.015]
    est = cal.estimate_time_offset(run.t, run.gyro, run.frames.t, q)
    assert est.mode == "registration"
    assert abs(est.offset - 0.015) < max(4 * est.sigma, 0.004)
    assert dp.quat_angle(est.q_bc, run.q_bc) < math.radians(3.0)


def test_time_offset_sign_convention_matches_simulator() -> None:
    """Noise-free: t_imu = t_cam + offset exactly as sim.simulate injects it (frames.t = t_true − offset)."""
    clean = sim.simulate_eight(seed=3, pixel_sigma=0.0, imu_noise=ImuNoise().scaled(0.0), time_offset=0.02)
    np.testing.assert_allclose(clean.frames.t + 0.02, clean.frames.t_true)
    f = clean.frames
    q, _ = cal.frame_poses(f.t, f.offsets, f.pixels, f.points, clean.camera.matrix)
    est = cal.estimate_time_offset(clean.t, clean.gyro, f.t, q, clean.q_bc)
    assert abs(est.offset - 0.02) < 2e-4


def test_time_offset_bad_input() -> None:
    t = np.arange(100) * 0.01
    with pytest.raises(ValueError, match=r"gyro must have shape \(100, 3\)"):
        cal.estimate_time_offset(t, np.zeros((100, 2)), t[::8], np.tile([0, 0, 0, 1.0], (13, 1)))
    with pytest.raises(ValueError, match=r"q_wc must have shape \(13, 4\)"):
        cal.estimate_time_offset(t, np.zeros((100, 3)), t[::8], np.tile([0, 0, 0, 1.0], (12, 1)))
    with pytest.raises(ValueError, match="at least 8"):
        cal.estimate_time_offset(t, np.zeros((100, 3)), t[:5], np.tile([0, 0, 0, 1.0], (5, 1)))
    with pytest.raises(ValueError, match="no rotation"):
        cal.estimate_time_offset(t, np.zeros((100, 3)), t[::5], np.tile([0, 0, 0, 1.0], (20, 1)), max_offset=0.05)
