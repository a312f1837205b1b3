"""The AHRS's settings and start: noise densities, tuning (:class:`AhrsConfig`), rest-period statistics, the initial
orientation and the native kernel's parameter vector (:func:`filter_setup`).  The model is described in
:mod:`dualpose.estimation.ahrs`; the layout of the parameter vector in ``src/native/estimation/ahrs_layout.hpp``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

from dualpose import _native
from dualpose.types._inputs import check_rate

__all__ = [
    "MEMS_GYRO_BIAS_RANDOM_WALK",
    "MEMS_GYRO_TURN_ON_BIAS",
    "REST_BIAS_SIGMA",
    "AhrsNoise",
    "AhrsConfig",
    "RestStatistics",
    "AhrsSetup",
    "accelerometer_jacobian",
    "heading_jacobian",
    "rest_statistics",
    "initial_orientation",
    "filter_setup",
    "check_mag_time_offset",
    "check_field_samples",
]


#: MEMS-class gyroscope bias random walk, rad/s²/√Hz (bias wanders ~0.1 °/s over 10 min); not estimable from a
#: short rest period, so it is a fixed sensor-class value.
MEMS_GYRO_BIAS_RANDOM_WALK = 1.0e-4
#: initial bias uncertainty (rad/s) when no rest period is given: MEMS turn-on bias, ~0.5 °/s
MEMS_GYRO_TURN_ON_BIAS = math.radians(0.5)

#: online magnetometer–gyroscope time offset (docs/broad.md, "Magnetometer–gyroscope time offset"): search range ±s,
#: grid step s, low-pass cut-off Hz (a boxcar of round(0.443 rate / cut-off) samples: its -3 dB frequency; 5 Hz,
#: below the offline estimator's 10 Hz, because the differentiated field's noise biases τ̂: docs/broad.md), informative
#: samples (|ω| ≥ rad/s, |m| within the fraction of the rest field's norm), seconds of informative samples before τ̂
#: is used -- otherwise the offline estimator's generic values (dualpose.calibration.sensor_time_offset)
MAG_LAG_RANGE = 0.03
MAG_LAG_STEP = 0.001
MAG_LAG_CUTOFF = 5.0
MAG_LAG_MIN_RATE = 0.5
MAG_LAG_NORM_TOLERANCE = 0.1
MAG_LAG_MIN_SECONDS = 1.0

#: rest detector (docs/broad.md, "Rest detector and bias update"): quantisation floor of the per-sample noise used
#: for its thresholds and its bias measurement, the standard deviation LSB/√12 of one least significant bit of a
#: 16-bit MEMS gyroscope at ±2000 °/s (0.061 °/s) and accelerometer at ±16 g (0.0048 m/s²)
REST_GYRO_QUANTISATION = math.radians(2000.0 / 32768.0) / math.sqrt(12.0)
REST_ACC_QUANTISATION = 16.0 * 9.80665 / 32768.0 / math.sqrt(12.0)
#: standard deviation (rad/s, per axis) of the error of a rest spell's mean rate as a bias measurement, common to the
#: whole spell: the residual rotation of an object set down or held still (0.02 °/s per axis RMS over BROAD's nine
#: breaks) and the difference between the bias at rest and in motion; the role of VQF's ``biasSigmaRest`` (0.03 °/s,
#: Laidig & Seel 2023).  docs/broad.md, "Rest detector and bias update"
REST_BIAS_SIGMA = math.radians(0.02)


@dataclass(frozen=True)
class AhrsNoise:
    """Sensor noise of the AHRS (continuous-time densities, Kalibr-style).

    Attributes
    ----------
    gyroscope_noise_density : float
        rad/s/√Hz.
    gyroscope_random_walk : float
        rad/s²/√Hz (bias random walk).
    accelerometer_noise_density : float
        m/s²/√Hz.
    magnetometer_noise_density : float
        µT/√Hz.
    """

    gyroscope_noise_density: float = 1.2e-4
    gyroscope_random_walk: float = MEMS_GYRO_BIAS_RANDOM_WALK
    accelerometer_noise_density: float = 3.5e-3
    magnetometer_noise_density: float = 4.0e-2


@dataclass(frozen=True)
class AhrsConfig:
    """Tuning of the AHRS: the same values for every recording (docs/broad.md, "Design in brief").

    One object shared by :func:`estimate_orientation`, :func:`filter_setup` and
    :class:`~dualpose.estimation.ahrs.stream.AhrsStream`, so that the batch and the streaming filter cannot be set up
    differently.

    Attributes
    ----------
    noise : AhrsNoise, optional
        Overrides the densities estimated from the rest period (None: estimate them; :class:`AhrsNoise` defaults
        without a rest period).
    gate_probability : float
        χ² gate of both updates (default 0.999).
    gate_release : float
        Seconds of uninterrupted rejection after which a gate re-opens (default 2 s).
    adapt_time : float
        Time constant (s) of the innovation-based (Sage-Husa) estimate of the unmodelled acceleration's covariance
        that is added to the accelerometer noise (default 6 s; 0 switches it off; ``acc_adapt_matrix``).
    window : float
        Seconds of samples averaged in the estimated earth frame per magnetometer update (default 3 s); the
        accelerometer's earth-frame low-pass has the same delay and noise bandwidth (2nd-order Butterworth, DC group
        delay ``window / 2``).  The mean linear acceleration over T is Δv / T, so bounded-velocity motion averages
        out.  Rounded to whole samples; the outputs are still per sample.
    mag_adapt : bool
        Also adapt the heading noise from the innovations (default False: a drifting heading would be absorbed into
        the estimated noise instead of being corrected).
    gyro_scale_sigma : float
        Relative gyroscope scale-factor + axis-misalignment uncertainty ε (calibrated MEMS class, default 0.5 %);
        adds ``ε² |ω|² · 1 s`` to the attitude process-noise density (rad²/s).
    update_interval : float
        Seconds between updates (default 0.1 s, capped at ``window``).  Consecutive windows then overlap by
        ``window / update_interval`` and share their samples, so each update's noise is multiplied by that overlap
        factor (an update carries only its share of a window's information).  The result is insensitive to the
        interval once it is well below the window (docs/broad.md, "Design in brief").
    rest_window : float
        Seconds of gyroscope and accelerometer samples that must be quiet before the filter takes the IMU to be at
        rest and measures the gyroscope bias with their mean rate (default 1.5 s, VQF's minimum rest time; 0
        switches the rest detector off).  Only samples after the initial rest period are seen.
    rest_margin : float
        Quiet means: the window's variance of each sensor (pooled over the axes) at most ``rest_margin²`` times its
        per-sample noise variance measured at rest (default 3; docs/broad.md, "Rest detector and bias update").
    rest_bias_sigma : float
        Standard deviation (rad/s, per axis) of the error of a quiet spell's mean rate as a bias measurement that is
        common to the whole spell: the residual rotation of a "still" object and the difference between the bias
        at rest and in motion (default :data:`REST_BIAS_SIGMA`, 0.02 °/s).  A spell of L quiet samples measures
        the bias to at best √(σ²/L + rest_bias_sigma²), however long the rest (0: to σ/√L).
    acc_clip : float
        Impulse clipping of the accelerometer (default 5; 0: off): a sample of the earth-frame specific force enters
        the low-pass at most ``acc_clip`` times the running RMS (time constant 1 s, of the clipped values) of its
        change from the low-pass's last output away from that output.  A tap or shock (milliseconds, up to tens of g)
        is cut to that size; hand motion, whose acceleration builds up over tens of milliseconds, raises the RMS as
        it comes and passes (docs/broad.md, "Twelve trials", (b)).
    acc_scale_sigma : float
        Relative error δ of the accelerometer (scale factor + axis misalignment; calibrated MEMS class, default
        0.5 %, as the gyroscope's): a specific force ≈ g is measured off by up to δ g.  So the lower bound
        ``| |ā| − g |`` of the filtered linear acceleration added to the accelerometer noise is reduced by ``2 δ g``
        (the magnitude difference the sensor can produce by itself between the rest orientation that set ``g`` and
        the current one), and the direction error's per-axis variance ``(δ g)² / 3`` is added instead
        (docs/broad.md, "Design in brief").
    acc_motion_time : float or None
        Time constant (s) of the running mean of the squared bound ``(| |ā| − g | − 2 δ g)₊²`` that is added to the
        accelerometer noise (default None: ``window / 2``, the low-pass's delay; 0: each update's own bound, the
        earlier rule).  The bound is one realisation of the filtered linear acceleration along the vertical, while
        the update needs its variance along the horizontal axes; in oscillating motion the instantaneous value passes
        zero twice a cycle, when the horizontal components need not (docs/broad.md, "Twelve trials", (d)).
    acc_adapt_matrix : bool
        The innovation-based estimate of the unmodelled acceleration (``adapt_time``) is a 2×2 covariance in the
        estimated horizontal plane (default True) instead of one variance shared by both horizontal axes (False,
        the earlier rule): what the low-pass lets through of hand motion lies along the direction the hand moves,
        so the accelerometer is distrusted along it and not across it (docs/broad.md, "Twelve trials", (e)).
    acc_adapt_rest_hold : bool
        While the rest detector reports rest (``rest_window``), that estimate is held for the motion to come, and
        it enters the accelerometer noise with the share of the motion's acceleration still inside the low-pass,
        ``exp(−2 t / τ)`` after t seconds of rest (τ = ``window / 2``, the low-pass's poles have real part −1/τ)
        (default True): a body at rest does not accelerate, so its innovations say nothing about the motion's
        acceleration.  Both False: the earlier rule bit for bit.
    """

    noise: AhrsNoise | None = None
    gate_probability: float = 0.999
    gate_release: float = 2.0
    adapt_time: float = 6.0
    window: float = 3.0
    mag_adapt: bool = False
    gyro_scale_sigma: float = 0.005
    update_interval: float = 0.1
    acc_scale_sigma: float = 0.005
    rest_window: float = 1.5
    rest_margin: float = 3.0
    rest_bias_sigma: float = REST_BIAS_SIGMA
    acc_clip: float = 5.0
    acc_motion_time: float | None = None
    acc_adapt_matrix: bool = True
    acc_adapt_rest_hold: bool = True

    def __post_init__(self) -> None:
        if self.noise is not None and not isinstance(self.noise, AhrsNoise):
            raise TypeError(f"noise must be an AhrsNoise or None; got {type(self.noise).__name__}")
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f"gate_probability must be in (0, 1); got {self.gate_probability}")
        checks = (("gate_release", self.gate_release, False), ("adapt_time", self.adapt_time, False),
                  ("window", self.window, True), ("gyro_scale_sigma", self.gyro_scale_sigma, False),
                  ("update_interval", self.update_interval, True),
                  ("acc_scale_sigma", self.acc_scale_sigma, False), ("rest_window", self.rest_window, False),
                  ("rest_margin", self.rest_margin, True),
                  ("rest_bias_sigma", self.rest_bias_sigma, False), ("acc_clip", self.acc_clip, False),
                  ("acc_motion_time", 0.0 if self.acc_motion_time is None else self.acc_motion_time,
                   False))  # fmt: skip
        for name in ("acc_adapt_matrix", "acc_adapt_rest_hold"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"{name} must be a bool; got {type(getattr(self, name)).__name__}")
        for name, value, positive in checks:
            if not (math.isfinite(value) and (value > 0.0 if positive else value >= 0.0)):
                kind = "a positive" if positive else "a non-negative"
                raise ValueError(f"{name} must be {kind} finite number; got {value}")

    def as_dict(self) -> dict[str, Any]:
        """The settings as plain Python values (``noise`` as a dict or None), for saving; inverse :meth:`from_dict`."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> AhrsConfig:
        """The configuration saved by :meth:`as_dict`."""
        d = dict(d)
        if d.get("noise") is not None:
            d["noise"] = AhrsNoise(**d["noise"])
        return cls(**d)


@dataclass(frozen=True)
class RestStatistics:
    """What a rest period tells about the sensors (all in IMU axes).

    Attributes
    ----------
    samples : int
        Number of rest samples used.
    gyroscope_bias : ndarray, shape (3,)
        Median angular rate at rest, rad/s.
    specific_force : ndarray, shape (3,)
        Median specific force at rest, m/s² (points up: ``−g`` in the body frame).
    magnetic_field : ndarray, shape (3,)
        Median magnetic field at rest, µT.
    noise : AhrsNoise
        White-noise densities estimated from the per-axis median absolute deviation (× 1.4826, × 1/√rate); the
        bias random walk is :data:`MEMS_GYRO_BIAS_RANDOM_WALK`.
    """

    samples: int
    gyroscope_bias: np.ndarray
    specific_force: np.ndarray
    magnetic_field: np.ndarray
    noise: AhrsNoise

    @property
    def gravity(self) -> float:
        """Magnitude of the specific force at rest, m/s² (local gravity as this accelerometer sees it)."""
        return float(np.linalg.norm(self.specific_force))

    @property
    def field_norm(self) -> float:
        """Magnitude of the magnetic field at rest, µT."""
        return float(np.linalg.norm(self.magnetic_field))

    @property
    def field_dip(self) -> float:
        """Dip (inclination) of the field at rest: angle below the horizon, rad (atan2 of the components along and
        across the specific force)."""
        return _field_dip(self.specific_force, self.magnetic_field)


def _field_dip(specific_force: np.ndarray, field: np.ndarray) -> float:
    """Dip of ``field`` (3,) below the plane normal to ``specific_force`` (3,, up), rad: atan2 of its components
    along −up and across it."""
    up = specific_force / np.linalg.norm(specific_force)
    return math.atan2(-float(field @ up), float(np.linalg.norm(field - (field @ up) * up)))


def accelerometer_jacobian(gravity: float) -> np.ndarray:
    """Jacobian (2, 6) of the accelerometer measurement w.r.t. the error state ``[δθ, δb]``.

    Measurement: ``y = [R̂ a]_{x,y}``, the horizontal components of the specific force rotated into the estimated
    earth frame.  With ``R = Exp(δθ) R̂`` and a noise-free specific force ``a = Rᵀ g_e``, ``g_e = (0, 0, g)``:
    ``y = [Exp(−δθ) g_e]_{x,y} ≈ [g_e × δθ]_{x,y} = (−g δθ_y, g δθ_x)``.
    """
    H = np.zeros((2, 6))
    H[0, 1] = -gravity
    H[1, 0] = gravity
    return H


def heading_jacobian() -> np.ndarray:
    """Jacobian (1, 6) of the heading measurement as used: ``∂ψ/∂δθ_z = 1``, nothing else.

    Measurement: ``ψ = atan2(m̂_x, m̂_y)`` of the field in the estimated earth frame, ``m̂ = Exp(−δθ) m_e``.  A
    rotation of the estimate by ``−δθ_z`` about the vertical turns the field's horizontal projection by ``+δθ_z``
    (clockwise, from north towards east), so ``∂ψ/∂δθ_z = 1``.  The exact derivative also has tilt terms
    (``∂ψ/∂δθ_{x,y}`` ∝ ``m_z / |m_h|``): they are deliberately dropped, and the gain rows of ``δθ_{x,y}`` are zeroed,
    so that the magnetometer observes heading only (a magnetic disturbance cannot tilt the estimate).
    """
    H = np.zeros((1, 6))
    H[0, 2] = 1.0
    return H


def _robust_sigma(x: np.ndarray) -> float:
    """Per-sample white-noise sigma pooled over the axes: 1.4826 × median absolute deviation (robust to a few
    disturbed samples in the rest period)."""
    med = np.median(x, axis=0)
    return float(np.sqrt(np.mean((1.4826 * np.median(np.abs(x - med), axis=0)) ** 2)))


def rest_statistics(
    gyr: np.ndarray, acc: np.ndarray, mag: np.ndarray | None, rate: float, n_rest: int
) -> RestStatistics:
    """Estimate bias, gravity, field reference and white-noise densities from the first ``n_rest`` samples.

    Parameters
    ----------
    gyr, acc, mag : ndarray, shape (n, 3)
        rad/s, m/s², µT (``mag`` may be None: its statistics are then NaN).
    rate : float
        Sampling rate, Hz.
    n_rest : int
        Number of leading samples during which the IMU is at rest (at least 10).

    Returns
    -------
    RestStatistics
    """
    if n_rest < 10:
        raise ValueError(f"n_rest must be at least 10 samples; got {n_rest}")
    g, a = gyr[:n_rest], acc[:n_rest]
    m = mag[:n_rest] if mag is not None else np.full((n_rest, 3), np.nan)
    sq = math.sqrt(rate)
    noise = AhrsNoise(
        gyroscope_noise_density=_robust_sigma(g) / sq,
        accelerometer_noise_density=_robust_sigma(a) / sq,
        magnetometer_noise_density=_robust_sigma(m) / sq if mag is not None else math.nan,
    )
    return RestStatistics(
        samples=int(n_rest),
        gyroscope_bias=np.median(g, axis=0),
        specific_force=np.median(a, axis=0),
        magnetic_field=np.median(m, axis=0),
        noise=noise,
    )


def initial_orientation(specific_force: np.ndarray, magnetic_field: np.ndarray | None = None) -> np.ndarray:
    """Orientation (xyzw, IMU → ENU) from one specific-force direction and, optionally, one field direction.

    ``z`` (up) is along the specific force, ``x`` (east) along ``m × a``, ``y`` (north) completes the frame.  Without
    a field (6D) the body x axis projected on the horizontal plane is taken as east (the heading is unobservable).

    Parameters
    ----------
    specific_force : array_like, shape (3,)
        m/s² in IMU axes (any scale).
    magnetic_field : array_like, shape (3,), optional
        µT in IMU axes.

    Returns
    -------
    ndarray, shape (4,)
    """
    import dualpose as dp

    a = np.asarray(specific_force, dtype=np.float64)
    if a.shape != (3,) or not np.linalg.norm(a) > 0:
        raise ValueError(f"specific_force must be a non-zero (3,) vector; got {a}")
    up = a / np.linalg.norm(a)
    ref = np.asarray(magnetic_field, dtype=np.float64) if magnetic_field is not None else None
    east = np.cross(ref, up) if ref is not None else np.array([1.0, 0.0, 0.0]) - up[0] * up
    if not np.linalg.norm(east) > 1e-9 * max(1.0, np.linalg.norm(ref) if ref is not None else 1.0):
        east = np.cross(np.array([0.0, 1.0, 0.0]), up)  # degenerate: field (or x axis) parallel to gravity
    east /= np.linalg.norm(east)
    north = np.cross(up, east)
    return dp.quat_from_matrix(np.stack([east, north, up]))  # rows: earth axes in body coordinates


@dataclass(frozen=True)
class AhrsSetup:
    """The constants and the initial state of one AHRS run (:func:`filter_setup`).

    Attributes
    ----------
    params : ndarray, shape (AHRS_N_PARAMS,)
        The kernel's parameter vector (``src/native/estimation/ahrs_layout.hpp``).
    q : ndarray, shape (4,)
        Initial orientation, xyzw, IMU → earth (ENU).
    b : ndarray, shape (3,)
        Initial gyroscope bias, rad/s.
    P : ndarray, shape (6, 6)
        Initial error covariance of ``[δθ (earth frame), δb]``.
    Ha, Hm : ndarray, shape (2, 6) and (1, 6)
        :func:`accelerometer_jacobian` and :func:`heading_jacobian`.
    n_win, stride : int
        Samples per window and between updates.
    noise : AhrsNoise
        The noise densities used.
    """

    params: np.ndarray
    q: np.ndarray
    b: np.ndarray
    P: np.ndarray
    Ha: np.ndarray
    Hm: np.ndarray
    n_win: int
    stride: int
    noise: AhrsNoise


def filter_setup(
    rate: float,
    rest: RestStatistics | None,
    first_acc: np.ndarray | None = None,
    first_mag: np.ndarray | None = None,
    *,
    use_mag: bool = True,
    config: AhrsConfig | None = None,
    mag_time_offset: float | None = None,
    rest_skip: int = 0,
) -> AhrsSetup:
    """Parameters and initial state of the AHRS, as :func:`estimate_orientation` sets them up.

    Shared by :func:`estimate_orientation` and :class:`~dualpose.estimation.ahrs.stream.AhrsStream`, so that both
    start from the same numbers.

    Parameters
    ----------
    rate : float
        Sampling rate, Hz.
    rest : RestStatistics or None
        Statistics of the rest period (:func:`rest_statistics`); None: no rest period, then ``first_acc`` (and in 9D
        ``first_mag``) give the initial directions, the bias starts at zero with the MEMS turn-on uncertainty.
    first_acc, first_mag : array_like, shape (3,), optional
        The first sample's specific force (m/s²) and field (µT), IMU axes; used only when ``rest`` is None.
    use_mag : bool
        9D (True) or 6D (False).
    config : AhrsConfig, optional
        Tuning (default :class:`AhrsConfig`).
    mag_time_offset : float, optional
        None (default): estimate the magnetometer lag online inside the filter; a number: the fixed lag, s, that the
        causal compensation uses (0: none).  See :func:`estimate_orientation`.
    rest_skip : int
        Leading samples the rest detector does not see: the initial rest period, whose samples already gave the
        initial bias (default 0).

    Returns
    -------
    AhrsSetup
    """
    c = _check_config(config)
    noise = c.noise
    if rest is not None:
        est = rest.noise
        noise = noise or AhrsNoise(
            gyroscope_noise_density=est.gyroscope_noise_density,
            accelerometer_noise_density=est.accelerometer_noise_density,
            magnetometer_noise_density=est.magnetometer_noise_density,
        )
        b0 = rest.gyroscope_bias.copy()
        # bias uncertainty after averaging the rest samples, floored at one bias-random-walk second
        bias_sigma = max(noise.gyroscope_noise_density * math.sqrt(rate / rest.samples), noise.gyroscope_random_walk)
        a_ref, m_ref = rest.specific_force, (rest.magnetic_field if use_mag else None)
        gravity = rest.gravity
    else:
        noise = noise or AhrsNoise()
        b0 = np.zeros(3)
        bias_sigma = MEMS_GYRO_TURN_ON_BIAS
        a_ref = np.asarray(first_acc, dtype=np.float64)
        m_ref = np.asarray(first_mag, dtype=np.float64) if use_mag else None
        gravity = float(np.linalg.norm(a_ref))
    q0 = initial_orientation(a_ref, m_ref if use_mag else None)
    if use_mag:  # the field's reference at rest (RestStatistics.field_norm / field_dip), or of the first sample
        assert m_ref is not None  # use_mag: the rest statistics or the first sample have a field
        field_norm, field_dip = float(np.linalg.norm(m_ref)), _field_dip(a_ref, m_ref)
    else:
        field_norm, field_dip = 1.0, 0.0

    params = np.zeros(_native.AHRS_N_PARAMS)
    params[_native.AHRS_P_GYR_VAR] = noise.gyroscope_noise_density**2
    params[_native.AHRS_P_BIAS_VAR] = noise.gyroscope_random_walk**2
    params[_native.AHRS_P_ACC_VAR] = noise.accelerometer_noise_density**2 * rate
    params[_native.AHRS_P_GRAVITY] = gravity
    params[_native.AHRS_P_MAG_VAR] = noise.magnetometer_noise_density**2 * rate if use_mag else 1.0
    params[_native.AHRS_P_MAG_NORM] = field_norm
    params[_native.AHRS_P_MAG_DIP] = field_dip
    params[_native.AHRS_P_USE_MAG] = 1.0 if use_mag else 0.0
    params[_native.AHRS_P_ACC_GATE] = float(chi2.ppf(c.gate_probability, 2))
    params[_native.AHRS_P_MAG_GATE] = float(chi2.ppf(c.gate_probability, 1))
    params[_native.AHRS_P_GATE_RELEASE] = max(1.0, c.gate_release * rate)
    n_win = max(1, int(round(c.window * rate)))
    params[_native.AHRS_P_WINDOW] = n_win
    stride = min(n_win, max(1, int(round(c.update_interval * rate))))
    params[_native.AHRS_P_STRIDE] = stride
    params[_native.AHRS_P_GYR_SCALE_VAR] = c.gyro_scale_sigma**2 * 1.0
    params[_native.AHRS_P_ACC_SCALE] = c.acc_scale_sigma
    params[_native.AHRS_P_ACC_ADAPT] = 1.0 / (c.adapt_time * rate) if c.adapt_time > 0 else 0.0
    params[_native.AHRS_P_MAG_ADAPT] = 1.0 / (c.adapt_time * rate) if c.adapt_time > 0 and c.mag_adapt else 0.0
    _set_lag_params(params, rate, use_mag, mag_time_offset)
    _set_rest_params(params, rate, noise, c, rest_skip)
    # initial attitude uncertainty: the direction of a mean of N noisy specific forces (inclination); heading 5° in
    # 9D and 6D alike (in 6D the initial orientation defines the earth frame's heading: module docstring)
    n_avg = rest.samples if rest is not None else 1
    incl_sigma = noise.accelerometer_noise_density * math.sqrt(rate / n_avg) / gravity + math.radians(0.1)
    head_sigma = math.radians(5.0)
    P = np.diag([incl_sigma**2, incl_sigma**2, head_sigma**2, bias_sigma**2, bias_sigma**2, bias_sigma**2])
    q = np.ascontiguousarray(q0, dtype=np.float64)
    b = np.ascontiguousarray(b0, dtype=np.float64)
    Ha, Hm = accelerometer_jacobian(gravity), heading_jacobian()
    return AhrsSetup(params=params, q=q, b=b, P=P, Ha=Ha, Hm=Hm, n_win=n_win, stride=stride, noise=noise)


def _set_lag_params(params: np.ndarray, rate: float, use_mag: bool, mag_time_offset: float | None) -> None:
    """The P_LAG_* entries of the kernel's parameters: online (None) or fixed lag, the estimator's constants."""
    online = use_mag and mag_time_offset is None
    params[_native.AHRS_P_LAG_ONLINE] = 1.0 if online else 0.0
    params[_native.AHRS_P_LAG_FIXED] = float(mag_time_offset) if use_mag and mag_time_offset is not None else 0.0
    params[_native.AHRS_P_LAG_BOX] = max(1, int(round(0.443 * rate / MAG_LAG_CUTOFF)))
    params[_native.AHRS_P_LAG_MAX] = MAG_LAG_RANGE
    params[_native.AHRS_P_LAG_STEP] = MAG_LAG_STEP
    params[_native.AHRS_P_LAG_MIN_RATE] = MAG_LAG_MIN_RATE
    params[_native.AHRS_P_LAG_NORM_TOL] = MAG_LAG_NORM_TOLERANCE
    params[_native.AHRS_P_LAG_THIN] = max(1, int(rate / (4.0 * MAG_LAG_CUTOFF)))
    params[_native.AHRS_P_LAG_MIN_COUNT] = max(1, int(round(MAG_LAG_MIN_SECONDS * rate)))


def _set_rest_params(params: np.ndarray, rate: float, noise: AhrsNoise, c: AhrsConfig, skip: int) -> None:
    """The P_REST_* entries of the kernel's parameters (docs/broad.md, "Rest detector and bias update"): per-sample
    noise σ = density · √rate floored at the quantisation σ; quiet = the window's pooled variance ≤ (margin σ)²."""
    sg = max(noise.gyroscope_noise_density * math.sqrt(rate), REST_GYRO_QUANTISATION)
    sa = max(noise.accelerometer_noise_density * math.sqrt(rate), REST_ACC_QUANTISATION)
    params[_native.AHRS_P_REST_WINDOW] = int(round(c.rest_window * rate))
    params[_native.AHRS_P_REST_GYR_TH] = (c.rest_margin * sg) ** 2
    params[_native.AHRS_P_REST_ACC_TH] = (c.rest_margin * sa) ** 2
    params[_native.AHRS_P_REST_GYR_VAR] = sg**2
    params[_native.AHRS_P_REST_GATE] = float(chi2.ppf(c.gate_probability, 3))
    params[_native.AHRS_P_REST_SKIP] = int(skip)
    params[_native.AHRS_P_REST_OFFSET_VAR] = c.rest_bias_sigma**2
    params[_native.AHRS_P_ACC_CLIP] = c.acc_clip
    motion_time = 0.5 * c.window if c.acc_motion_time is None else c.acc_motion_time
    params[_native.AHRS_P_ACC_MOTION_TIME] = motion_time
    params[_native.AHRS_P_ACC_ADAPT_MATRIX] = 1.0 if c.acc_adapt_matrix else 0.0
    params[_native.AHRS_P_ACC_ADAPT_REST_HOLD] = 1.0 if c.acc_adapt_rest_hold else 0.0


def check_field_samples(mag: NDArray[np.float64], name: str = "mag", single: bool = False) -> None:
    """Refuse magnetometer samples ``mag`` (n, 3), already finite, that carry no field measurement: a sample whose
    squared magnitude is zero in float64 (all components zero, or below ~1e-154 so that the square underflows) has no
    direction, and the filter normalises the field.  Every sample zero is a magnetometer that measured nothing (6D);
    one zero sample among real ones is named by its row (``single``: the one sample of a stream step).

    Raises
    ------
    ValueError
        Naming ``name``, the first such row and how many there are.
    """
    zero = ~(np.einsum("ij,ij->i", mag, mag) > 0.0)
    if not zero.any():
        return
    if zero.all():
        what = "the sample is" if single else "every sample is"
        raise ValueError(f"{name}: {what} zero (no magnetic field measured); pass use_mag=False for 6D "
                         "(CLI: --no-mag)")  # fmt: skip
    k = int(np.argmax(zero))
    raise ValueError(f"{name}: sample {k} is zero ({int(zero.sum())} of {len(zero)} such): no magnetic field "
                     "measured there; drop or interpolate those samples, or pass use_mag=False for 6D "
                     "(CLI: --no-mag)")  # fmt: skip


def _check_config(config: object) -> AhrsConfig:
    """``config`` (an :class:`AhrsConfig`, or None for the defaults) checked: TypeError naming it otherwise.  The
    check of every AHRS entry point (batch, smoother, stream)."""
    if config is None:
        return AhrsConfig()
    if not isinstance(config, AhrsConfig):
        raise TypeError(f"config must be an AhrsConfig or None; got {type(config).__name__}")
    return config


def _rest_length(rate: float, n_rest: int | None, n: int | None = None) -> int:
    """The sampling ``rate`` (Hz) checked and the number of leading rest samples: ``n_rest``, or by default one
    second (at most ``n``, the recording's length when known), 0 when that is below 10 samples.  ValueError naming
    ``rate`` / ``n_rest`` for a rate that is not a positive number, or a rest period outside ``[0, n]`` or of 1 to 9
    samples."""
    rate = check_rate(rate)  # the sampling-rate check every path shares (docs/refusals.md)
    if n_rest is None:
        n_rest = int(round(rate)) if n is None else min(n, int(round(rate)))
        n_rest = n_rest if n_rest >= 10 else 0
    if n is not None and not 0 <= n_rest <= n:
        raise ValueError(f"n_rest must be in [0, {n}]; got {n_rest}")
    if not (n_rest == 0 or n_rest >= 10):
        raise ValueError(f"n_rest must be 0 (no rest period) or at least 10 samples; got {n_rest}")
    return n_rest


def check_mag_time_offset(mag_time_offset: object, allowed: tuple[str, ...]) -> float | str | None:
    """``mag_time_offset`` validated: None for "online", the number for a number; "estimate" returned as is when
    allowed (ValueError naming the argument otherwise)."""
    if isinstance(mag_time_offset, str):
        if mag_time_offset not in allowed:
            choices = " or ".join(f'"{a}"' for a in allowed)
            raise ValueError(f"mag_time_offset must be {choices} or a number of seconds; got {mag_time_offset!r}")
        return None if mag_time_offset == "online" else mag_time_offset
    try:
        value = float(mag_time_offset)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"mag_time_offset must be a string or a number; got {type(mag_time_offset).__name__}") from None
    if not math.isfinite(value):
        raise ValueError(f"mag_time_offset must be a finite number of seconds; got {mag_time_offset}")
    return value
