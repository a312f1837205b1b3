"""Offline AHRS (RTS smoother over the AHRS error-state model): better than the forward filter on a synthetic
recording with an analytic truth, equal to it at the last sample and without updates, covariance never above the
filter's, the backward covariance recursion equal to the linear RTS smoother (Särkkä 2013, Thm 8.2) fed with
independently recomputed predictions, and its argument checks."""

from __future__ import annotations

import numpy as np
import pytest
from test_ahrs import RATE, synthetic_run

import dualpose as dp
from dualpose import _native
from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation, prepare_recording
from dualpose.estimation.ahrs.smoother import SmoothedOrientation, smooth_orientation
from dualpose.estimation.smoother import rts_smooth_linear
from dualpose.evaluation.orientation_errors import orientation_rmse


@pytest.fixture(scope="module")
def run():
    return synthetic_run(seed=11, move_s=30.0)


@pytest.fixture(scope="module", params=[True, False], ids=["9D", "6D"])
def smoothed(request, run):
    gyr, acc, mag, _, _, n_rest, _ = run
    use_mag = request.param
    return use_mag, smooth_orientation(gyr, acc, mag if use_mag else None, RATE, use_mag=use_mag, n_rest=n_rest)


def test_smoother_beats_the_forward_filter(run, smoothed):
    _, _, _, q, movement, _, bias = run
    use_mag, s = smoothed
    fwd = orientation_rmse(s.forward.quat, q, movement, fit_heading_offset=not use_mag)
    smo = orientation_rmse(s.quat, q, movement, fit_heading_offset=not use_mag)
    assert smo.total_rmse_deg < 0.9 * fwd.total_rmse_deg
    assert smo.inclination_rmse_deg < 0.9 * fwd.inclination_rmse_deg
    if not use_mag:
        return  # 6D: the bias about the vertical is unobservable
    # the smoothed bias uses the whole recording: its error over the movement is smaller on average
    err_s = np.linalg.norm(s.gyroscope_bias[movement] - bias, axis=1).mean()
    err_f = np.linalg.norm(s.forward.gyroscope_bias[movement] - bias, axis=1).mean()
    assert err_s < err_f


def test_forward_pass_is_the_filter_and_the_last_sample_is_filtered(run, smoothed):
    gyr, acc, mag, _, _, n_rest, _ = run
    use_mag, s = smoothed
    assert isinstance(s, SmoothedOrientation)
    f = estimate_orientation(gyr, acc, mag if use_mag else None, RATE, use_mag=use_mag, n_rest=n_rest,
                             mag_time_offset="estimate", mag_calibration="auto")  # fmt: skip
    # the filter's outputs before the rest period is complete are the causal running means; offline the forward
    # pass keeps the initialised filter's there too
    np.testing.assert_array_equal(s.forward.quat[n_rest - 1 :], f.quat[n_rest - 1 :])
    np.testing.assert_array_equal(s.forward.gyroscope_bias[n_rest - 1 :], f.gyroscope_bias[n_rest - 1 :])
    np.testing.assert_array_equal(s.forward.covariance, f.covariance)
    np.testing.assert_array_equal(s.filtered_covariance[-1], f.covariance)
    np.testing.assert_array_equal(s.quat[-1], f.quat[-1])
    np.testing.assert_array_equal(s.gyroscope_bias[-1], f.gyroscope_bias[-1])
    np.testing.assert_array_equal(s.covariance[-1], f.covariance)
    n = gyr.shape[0]
    assert s.quat.shape == (n, 4) and s.gyroscope_bias.shape == (n, 3) and s.covariance.shape == (n, 6, 6)
    assert s.attitude_sigma.shape == (n, 3) and np.all(np.isfinite(s.attitude_sigma))
    np.testing.assert_allclose(np.linalg.norm(s.quat, axis=1), 1.0, atol=1e-12)


def test_smoothed_covariance_is_not_above_the_filtered(smoothed):
    """P_{k|k} − P^s_k is PSD.  Exactly so for the linear RTS step; the two chart changes (J_l congruences,
    J ≈ I + ½[φ]×) perturb it at first order, by ~|φ| ‖P‖ each, for φ = μ_θ and δ_θ, where ‖P‖ is that of the
    covariance being re-expressed (P^s_{k+1}, then S), not of P_{k|k}: the bound below allows twice the first-order
    estimate for that difference.  Visible in 6D only, where the heading variance is large and the smoother learns
    nothing about heading (measured with the earth-frame low-pass accelerometer window: 0.85 of the allowance in 6D,
    2·10⁻⁷ of it in 9D)."""
    use_mag, s = smoothed
    Pf, Ps = s.filtered_covariance, s.covariance
    diff_min = np.linalg.eigvalsh(Pf - Ps)[:, 0]
    scale = np.linalg.eigvalsh(Pf)[:, -1]
    delta = dp.quat_angle(s.quat, s.forward.quat)  # |δ_θ| per sample, rad
    # the corrections at step k: δ_θ (sample k) and μ_θ (≈ δ_θ of sample k + 1; the filter's own update there is
    # ≲ 1e-4 rad)
    phi = delta + np.append(delta[1:], 0.0)
    allowed = 1e-12 * scale + 2.0 * phi * scale
    assert np.all(diff_min >= -allowed)
    # and the smoother reduces the inclination variance substantially in the middle of the recording
    mid = Pf.shape[0] // 2
    assert np.trace(Ps[mid, :2, :2]) < 0.8 * np.trace(Pf[mid, :2, :2])


def test_without_updates_the_smoother_is_the_filter():
    """Closed form: with no measurement (window longer than the recording) x^s_{k+1} = x_{k+1|k}, so μ = 0, the
    smoothed mean is the filtered one and P^s_k = P_{k|k} + G (P_{k+1|k} − P_{k+1|k}) Gᵀ = P_{k|k}."""
    rng = np.random.default_rng(4)
    n = 500
    gyr = np.array([0.3, -0.2, 0.5]) + rng.normal(scale=0.01, size=(n, 3))  # constant rotation
    acc = np.tile([0.0, 0.0, 9.81], (n, 1))
    s = smooth_orientation(gyr, acc, None, RATE, use_mag=False, n_rest=0, config=AhrsConfig(window=100.0))
    assert s.forward.acc_rejected == 0 and np.isnan(s.forward.acc_nis_mean)  # no update ran
    np.testing.assert_allclose(s.quat, s.forward.quat, rtol=0, atol=1e-13)
    np.testing.assert_allclose(s.gyroscope_bias, s.forward.gyroscope_bias, rtol=0, atol=1e-15)
    np.testing.assert_allclose(s.covariance, s.filtered_covariance, rtol=1e-10, atol=1e-18)


def test_backward_covariance_matches_the_linear_rts_smoother(run):
    """The covariance recursion against :func:`dualpose.estimation.smoother.rts_smooth_linear`, fed with predictions
    recomputed here one sample at a time (``_native.ahrs_predict`` from each filtered covariance) and the transitions
    F_k = [[I, −R(q_{k|k}) dt], [0, I]] built from the filtered quaternions: equal up to the smoother's chart changes
    (first order in |δ_θ| ≲ 0.5°)."""
    gyr, acc, mag, _, _, n_rest, _ = run
    k0, k1 = n_rest, n_rest + 600  # 6 s of motion (a Python loop over samples is fine in a test)
    s = smooth_orientation(gyr[:k1], acc[:k1], mag[:k1], RATE, n_rest=n_rest)
    prep = prepare_recording(gyr[:k1], acc[:k1], mag[:k1], RATE, n_rest=n_rest, mag_calibration="auto")
    p, dt = prep.setup.params, 1.0 / RATE
    Pf, qf, bf = s.filtered_covariance[k0:], s.forward.quat[k0:], s.forward.gyroscope_bias[k0:]
    m = Pf.shape[0]
    prior = np.empty_like(Pf)
    F = np.tile(np.eye(6), (m, 1, 1))
    for i in range(m - 1):
        q, b, P = qf[i].copy(), bf[i].copy(), Pf[i].copy()
        _native.ahrs_predict(q, b, P, *prep.gyr[k0 + i + 1], dt, p[_native.AHRS_P_GYR_VAR],
                             p[_native.AHRS_P_BIAS_VAR], p[_native.AHRS_P_GYR_SCALE_VAR])  # fmt: skip
        prior[i + 1] = P
        F[i, :3, 3:] = -dp.matrix_from_quat(qf[i]) * dt
    prior[0] = Pf[0]
    zeros = np.zeros((m, 6))
    _, P_lin = rts_smooth_linear(zeros, Pf, zeros, prior, F)
    # the linear RTS ends at the filter: compare from the same end point (the last sample of the shortened run)
    err = np.abs(P_lin - s.covariance[k0:]).max(axis=(1, 2)) / np.abs(P_lin).max(axis=(1, 2))
    # measured 8.2e-4 / 2.3e-4; 1.5e-4 / 3e-5 with one accelerometer noise variance for both horizontal axes
    # (acc_adapt_matrix=False): a chart change J P Jᵀ leaves a horizontally isotropic attitude block unchanged to
    # first order, and the 2×2 acceleration covariance makes that block anisotropic
    assert err.max() < 1e-3
    assert np.median(err) < 5e-4


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"gyr": np.zeros((10, 2))}, ValueError, "gyr"),
        ({"acc": np.zeros((9, 3))}, ValueError, "acc"),
        ({"mag": None}, ValueError, "use_mag"),
        ({"rate": 0.0}, ValueError, "rate"),
        ({"n_rest": 5}, ValueError, "n_rest"),
        ({"mag_time_offset": "soon"}, ValueError, "mag_time_offset"),
        ({"mag_calibration": "always"}, ValueError, "mag_calibration"),
        ({"mag_calibration": 3}, TypeError, "mag_calibration"),
    ],
)
def test_bad_arguments_raise_naming_them(kwargs, error, match):
    n = 200
    args = {"gyr": np.zeros((n, 3)), "acc": np.tile([0.0, 0.0, 9.81], (n, 1)),
            "mag": np.tile([0.0, 20.0, -40.0], (n, 1)), "rate": RATE, **kwargs}  # fmt: skip
    with pytest.raises(error, match=match):
        smooth_orientation(args.pop("gyr"), args.pop("acc"), args.pop("mag"), args.pop("rate"), **args)
