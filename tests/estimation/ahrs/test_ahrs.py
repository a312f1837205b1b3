"""Orientation-only filter (AHRS) on synthetic IMU data with an analytic ground truth, its measurement Jacobians
(finite differences) and its argument checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

import dualpose as dp
from dualpose.estimation.ahrs import (
    AhrsConfig,
    accelerometer_jacobian,
    estimate_orientation,
    heading_jacobian,
    initial_orientation,
    rest_statistics,
)
from dualpose.evaluation.orientation_errors import orientation_rmse

RATE = 100.0
G = 9.81
FIELD_ENU = np.array([0.0, 19.0, -45.0])  # µT: north and down (dip ≈ 67°, like Berlin)


def synthetic_run(
    seed: int = 3, rest_s: float = 3.0, move_s: float = 40.0, disturbance: float = 0.0, lin_acc: float = 1.0
):
    """Seeded IMU streams for an exactly known orientation history.

    Truth: ``q_k = q_0 ⊗ Π_{j≤k} Exp(ω_j dt)`` (exact for a rate held over each sample), ω a sum of sines after a rest
    period; specific force ``R_kᵀ (g e_z + a_lin)`` with a zero-mean, bounded-velocity linear acceleration; field
    ``R_kᵀ (m_e + d)`` with an optional earth-fixed disturbance ``d`` from 20 s to 30 s of the motion.
    """
    rng = np.random.default_rng(seed)
    dt = 1.0 / RATE
    n_rest, n = int(rest_s * RATE), int((rest_s + move_s) * RATE)
    t = np.arange(n) * dt
    tm = np.clip(t - rest_s, 0.0, None)
    w = np.zeros((n, 3))
    for axis, (amp, f, ph) in enumerate([(1.5, 0.31, 0.2), (1.0, 0.23, 1.1), (2.0, 0.17, 2.3)]):
        w[:, axis] = amp * np.sin(2 * np.pi * f * tm + ph) * (t >= rest_s)
    q0 = dp.quat_from_rotvec(np.array([0.3, -0.2, 1.0]))
    steps = dp.quat_from_rotvec(w * dt)
    q = np.empty((n, 4))
    cur = q0
    for k in range(n):  # reference trajectory only (the filter under test has no Python loop)
        cur = dp.quat_normalize(dp.quat_mul(cur, steps[k]))
        q[k] = cur
    a_lin = np.zeros((n, 3))
    a_lin[:, 0] = lin_acc * 2.0 * np.sin(2 * np.pi * 0.8 * tm) * (t >= rest_s)
    a_lin[:, 1] = lin_acc * 1.5 * np.sin(2 * np.pi * 1.3 * tm + 0.4) * (t >= rest_s)
    field = np.broadcast_to(FIELD_ENU, (n, 3)).copy()
    if disturbance:
        on = (tm >= 20.0) & (tm < 30.0)
        field[on] += disturbance * np.array([1.0, 0.3, 0.5])
    conj = dp.quat_conj(q)
    bias = np.array([0.01, -0.02, 0.015])
    gyr = w + bias + rng.normal(scale=0.002, size=(n, 3))
    acc = dp.quat_rotate(conj, a_lin + [0.0, 0.0, G]) + rng.normal(scale=0.05, size=(n, 3))
    mag = dp.quat_rotate(conj, field) + rng.normal(scale=0.5, size=(n, 3))
    movement = t >= rest_s
    return gyr, acc, mag, q, movement, n_rest, bias


@pytest.fixture(scope="module")
def clean():
    return synthetic_run()


def test_9d_tracks_the_analytic_truth_without_linear_acceleration():
    gyr, acc, mag, q, movement, n_rest, _ = synthetic_run(lin_acc=0.0)
    score = orientation_rmse(estimate_orientation(gyr, acc, mag, RATE, n_rest=n_rest).quat, q, movement)
    assert score.total_rmse_deg < 0.5
    assert score.inclination_rmse_deg < 0.3


def test_9d_tracks_the_analytic_truth(clean):
    # 2 m/s² linear accelerations at 0.8-1.3 Hz: the 3 s earth-frame window leaves a residual mean of ~0.2 m/s²
    gyr, acc, mag, q, movement, n_rest, bias = clean
    res = estimate_orientation(gyr, acc, mag, RATE, n_rest=n_rest)
    score = orientation_rmse(res.quat, q, movement)
    assert score.total_rmse_deg < 1.5
    assert score.inclination_rmse_deg < 1.0
    # a per-sample accelerometer update (window of one sample) follows the linear acceleration instead
    per_sample_config = AhrsConfig(window=1 / RATE)
    per_sample_res = estimate_orientation(gyr, acc, mag, RATE, n_rest=n_rest, config=per_sample_config)
    per_sample = orientation_rmse(per_sample_res.quat, q, movement)
    assert per_sample.inclination_rmse_deg > score.inclination_rmse_deg
    np.testing.assert_allclose(res.gyroscope_bias[n_rest - 1], bias, atol=5e-4)  # from the rest period
    assert res.quat.shape == (q.shape[0], 4) and res.us_per_sample > 0
    assert res.acc_nis_mean < 10 and res.mag_nis_mean < 10


def test_6d_inclination_and_heading_after_offset(clean):
    gyr, acc, mag, q, movement, n_rest, _ = clean
    res = estimate_orientation(gyr, acc, None, RATE, use_mag=False, n_rest=n_rest)
    score = orientation_rmse(res.quat, q, movement, fit_heading_offset=True)
    assert score.inclination_rmse_deg < 1.0
    assert score.total_rmse_deg < 1.5
    # the 6D earth frame is the body x axis at rest, so the fitted offset is the true initial heading
    r = dp.matrix_from_quat(q[0])
    x_e = r[:, 0]
    true_heading = math.degrees(math.atan2(x_e[1], x_e[0]))  # angle of the body x axis from east
    assert abs(((score.heading_offset_deg - true_heading + 180) % 360) - 180) < 2.0


def test_magnetic_disturbance_is_rejected_and_cannot_tilt():
    clean_run = synthetic_run(seed=5)
    dist_run = synthetic_run(seed=5, disturbance=25.0)
    gyr, acc, _, q, movement, n_rest, _ = clean_run
    ref = estimate_orientation(gyr, acc, clean_run[2], RATE, n_rest=n_rest)
    dis = estimate_orientation(gyr, acc, dist_run[2], RATE, n_rest=n_rest)
    s_ref = orientation_rmse(ref.quat, q, movement)
    s_dis = orientation_rmse(dis.quat, q, movement)
    assert s_dis.heading_rmse_deg < 2.0  # a 25 µT (> half the field) disturbance for 10 s
    assert abs(s_dis.inclination_rmse_deg - s_ref.inclination_rmse_deg) < 0.05  # heading-only magnetometer
    # without the disturbance model (no inflation, no gate) the same disturbance costs much more heading
    assert dis.mag_rejected > 0 or s_dis.heading_rmse_deg < s_ref.heading_rmse_deg + 1.0


def test_without_rest_period_the_filter_converges():
    gyr, acc, mag, q, movement, _, _ = synthetic_run(seed=7, rest_s=0.0)
    res = estimate_orientation(gyr, acc, mag, RATE, n_rest=0)
    late = movement & (np.arange(len(movement)) > 20 * RATE)
    assert orientation_rmse(res.quat, q, late).total_rmse_deg < 3.0  # from an unknown 1.4 °/s bias


def test_rest_statistics_recover_the_noise(clean):
    gyr, acc, mag, _, _, n_rest, bias = clean
    st = rest_statistics(gyr, acc, mag, RATE, n_rest)
    np.testing.assert_allclose(st.gyroscope_bias, bias, atol=5e-4)
    assert st.noise.gyroscope_noise_density == pytest.approx(0.002 / math.sqrt(RATE), rel=0.15)
    assert st.noise.accelerometer_noise_density == pytest.approx(0.05 / math.sqrt(RATE), rel=0.15)
    assert st.gravity == pytest.approx(G, abs=0.01)
    assert st.field_norm == pytest.approx(np.linalg.norm(FIELD_ENU), abs=0.2)
    assert st.field_dip == pytest.approx(math.atan2(45.0, 19.0), abs=0.01)


def test_initial_orientation_maps_gravity_up_and_field_north():
    rng = np.random.default_rng(11)
    for _ in range(20):
        q = dp.quat_normalize(rng.normal(size=4))
        a = dp.quat_rotate(dp.quat_conj(q), [0.0, 0.0, G])
        m = dp.quat_rotate(dp.quat_conj(q), FIELD_ENU)
        np.testing.assert_allclose(dp.quat_angle(initial_orientation(a, m), q), 0.0, atol=1e-9)


def _fd_jacobian(fun, eps: float = 1e-6) -> np.ndarray:
    cols = []
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        cols.append((fun(d) - fun(-d)) / (2 * eps))
    return np.stack(cols, axis=-1)


def test_accelerometer_jacobian_matches_finite_differences():
    g_e = np.array([0.0, 0.0, G])

    def y(dtheta):  # horizontal part of R̂ a with R = Exp(δθ) R̂, a = Rᵀ g_e  ->  Exp(-δθ) g_e
        return dp.quat_rotate(dp.quat_from_rotvec(-dtheta), g_e)[:2]

    H = accelerometer_jacobian(G)
    np.testing.assert_allclose(H[:, :3], _fd_jacobian(y), atol=1e-8)
    np.testing.assert_array_equal(H[:, 3:], 0.0)  # no bias dependence


def test_heading_jacobian_matches_finite_differences_in_heading():
    def psi(dtheta):
        m = dp.quat_rotate(dp.quat_from_rotvec(-dtheta), FIELD_ENU)
        return np.array([math.atan2(m[0], m[1])])

    fd = _fd_jacobian(psi)
    H = heading_jacobian()
    assert H[0, 2] == pytest.approx(fd[0, 2], abs=1e-8)
    # the exact tilt terms exist (here ∂ψ/∂δθ_y = −m_z / m_y) and are deliberately not used
    assert fd[0, 1] == pytest.approx(-FIELD_ENU[2] / FIELD_ENU[1], rel=1e-6)
    np.testing.assert_array_equal(H[0, [0, 1, 3, 4, 5]], 0.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"gyr": np.zeros((5, 4))}, "gyr must have shape"),
        ({"acc": np.zeros((4, 3))}, "acc must have 5 samples"),
        ({"mag": np.full((5, 3), np.nan)}, "mag must be finite"),
        ({"mag": None}, "use_mag=True needs mag"),
        ({"rate": 0.0}, "rate must be a sampling rate"),
        ({"n_rest": 9}, "n_rest must be 0 .no rest period. or at least 10"),
        ({"n_rest": 6}, "n_rest must be in"),
    ],
)
def test_bad_arguments_raise_naming_them(kwargs, match):
    acc, mag = np.tile([0, 0, G], (5, 1)), np.tile(FIELD_ENU, (5, 1))
    args = {"gyr": np.zeros((5, 3)), "acc": acc, "mag": mag, "rate": 100.0}
    if "n_rest" in kwargs and kwargs["n_rest"] == 9:
        args = {k: (np.repeat(v, 4, axis=0) if isinstance(v, np.ndarray) else v) for k, v in args.items()}
    n_rest = kwargs.pop("n_rest", 0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        estimate_orientation(args["gyr"], args["acc"], args["mag"], args["rate"], n_rest=n_rest)


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("window", 0.0, "window must be a positive finite"),
        ("update_interval", -0.1, "update_interval must be a positive finite"),
        ("adapt_time", float("nan"), "adapt_time must be a non-negative finite"),
        ("gyro_scale_sigma", -1e-3, "gyro_scale_sigma must be a non-negative"),
        ("rest_bias_sigma", -1e-4, "rest_bias_sigma must be a non-negative"),
        ("acc_clip", float("inf"), "acc_clip must be a non-negative finite"),
        ("acc_motion_time", -1.0, "acc_motion_time must be a non-negative finite"),
        ("acc_motion_time", float("nan"), "acc_motion_time must be a non-negative finite"),
        ("gate_probability", 1.0, r"gate_probability must be in \(0, 1\)"),
    ],
)
def test_bad_config_raises_naming_the_field(field, value, match):
    with pytest.raises(ValueError, match=match):
        AhrsConfig(**{field: value})
    with pytest.raises(TypeError, match="noise must be an AhrsNoise"):
        AhrsConfig(noise={"gyroscope_noise_density": 1e-3})


def test_config_round_trips_through_a_plain_dict():
    from dualpose.estimation.ahrs import AhrsNoise

    c = AhrsConfig(noise=AhrsNoise(gyroscope_noise_density=2e-4), window=2.0)
    assert AhrsConfig.from_dict(c.as_dict()) == c
    assert AhrsConfig.from_dict(AhrsConfig().as_dict()) == AhrsConfig()


def test_native_layout_matches_the_python_layouts() -> None:
    """The compiled AHRS's error-state offsets (src/native/estimation/ahrs_layout.hpp) are those of
    :data:`dualpose.estimation.state.AHRS_ERROR`, and its params / stats indices each number their vector densely."""
    from dualpose import _native
    from dualpose.estimation import state

    assert _native.AHRS_ERROR_DIM == state.AHRS_ERROR_DIM == state.AHRS_ERROR.dim
    assert _native.AHRS_D_ATTITUDE == state.AHRS_D_ATTITUDE == state.AHRS_ERROR.offset("attitude")
    assert _native.AHRS_D_GYRO_BIAS == state.AHRS_D_GYRO_BIAS == state.AHRS_ERROR.offset("gyro_bias")
    for prefix, count in (("AHRS_P_", _native.AHRS_N_PARAMS), ("AHRS_S_", _native.AHRS_N_STATS)):
        indices = sorted(getattr(_native, k) for k in dir(_native) if k.startswith(prefix))
        assert indices == list(range(count)), prefix
