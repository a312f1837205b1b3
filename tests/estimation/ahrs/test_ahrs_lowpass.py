"""The AHRS's earth-frame low-pass of the specific force (docs/broad.md, "Design in brief"): on a synthetic recording
at a constant tilt with a sinusoidal horizontal acceleration, the inclination error is the analytic response of a
2nd-order Butterworth with DC group delay window / 2, not that of a boxcar mean over the window."""

from __future__ import annotations

import math

import numpy as np

import dualpose as dp
from dualpose.estimation.ahrs import AhrsConfig, AhrsNoise, estimate_orientation
from dualpose.evaluation.orientation_errors import earth_error_quat

RATE = 200.0
G = 9.81
WINDOW = 3.0  # s, the estimator's default


def _tilt_error_amplitude(freq: float, accel: float, seed: int = 5) -> float:
    """Amplitude (rad) of the estimated tilt error at ``freq`` for a body held at a constant tilt while it is shaken
    horizontally (earth x) with acceleration ``accel sin(2π f t)``; fitted by least squares over the last 20 s."""
    rng = np.random.default_rng(seed)
    rest_s, move_s = 3.0, 43.0
    n = int((rest_s + move_s) * RATE)
    t = np.arange(n) / RATE
    q_true = dp.quat_from_rotvec(np.array([math.radians(20.0), math.radians(-10.0), 0.7]))
    a_lin = np.zeros((n, 3))
    a_lin[:, 0] = accel * np.sin(2 * np.pi * freq * (t - rest_s)) * (t >= rest_s)
    conj = np.broadcast_to(dp.quat_conj(q_true), (n, 4))
    acc = dp.quat_rotate(conj, a_lin + [0.0, 0.0, G]) + rng.normal(scale=0.01, size=(n, 3))
    gyr = rng.normal(scale=1e-4, size=(n, 3))
    # a gyroscope noise far above the accelerometer's: the updates follow the low-passed measurement (gain ≈ 1), so
    # the tilt error is the filter's response to the acceleration itself; no adaptive noise (adapt_time=0) and no
    # accelerometer calibration error (acc_scale_sigma=0: its (δg)²/3 would dominate this accelerometer's noise)
    noise = AhrsNoise(gyroscope_noise_density=0.05, accelerometer_noise_density=1e-3)
    config = AhrsConfig(noise=noise, adapt_time=0.0, window=WINDOW, acc_scale_sigma=0.0)
    res = estimate_orientation(gyr, acc, None, RATE, use_mag=False, n_rest=int(rest_s * RATE), config=config)
    e = earth_error_quat(res.quat, np.broadcast_to(q_true, (n, 4)))
    tilt = 2.0 * e[:, :2] * np.sign(e[:, 3])[:, None]
    last = t >= t[-1] - 20.0
    basis = np.column_stack([np.cos(2 * np.pi * freq * t), np.sin(2 * np.pi * freq * t), np.ones(n)])[last]
    coef, *_ = np.linalg.lstsq(basis, tilt[last], rcond=None)
    return float(np.linalg.norm(coef[:2]))


def _butterworth_gain(freq: float, tau: float) -> float:
    """|H(f)| of the continuous 2nd-order Butterworth with DC group delay tau: cut-off fc = √2 / (2π tau)."""
    fc = math.sqrt(2.0) / (2.0 * math.pi * tau)
    return 1.0 / math.sqrt(1.0 + (freq / fc) ** 4)


def test_shaking_at_constant_tilt_leaves_the_butterworth_residual_not_the_boxcars():
    freq, accel = 2.5 / WINDOW, 5.0  # the boxcar's largest side lobe: |sinc(f T)| = 1 / (2.5 π) = 0.127
    amplitude = _tilt_error_amplitude(freq, accel)
    expected = math.atan(_butterworth_gain(freq, WINDOW / 2.0) * accel / G)  # 0.032 · 5 / 9.81 → 0.95°
    boxcar = math.atan(abs(np.sinc(freq * WINDOW)) * accel / G)  # 3.7°
    assert abs(amplitude - expected) < 0.05 * expected, (math.degrees(amplitude), math.degrees(expected))
    assert amplitude < 0.4 * boxcar


def test_the_residual_falls_as_the_square_of_the_frequency():
    # a 2nd-order low-pass above its cut-off: (fc / f)², so doubling f divides the tilt error by ≈ 4 (a boxcar's
    # envelope 1 / (π f T) only by 2)
    low, high = _tilt_error_amplitude(0.7, 5.0), _tilt_error_amplitude(1.4, 5.0)
    ratio = low / high
    expected = _butterworth_gain(0.7, WINDOW / 2.0) / _butterworth_gain(1.4, WINDOW / 2.0)
    assert abs(ratio - expected) < 0.05 * expected, (ratio, expected)
