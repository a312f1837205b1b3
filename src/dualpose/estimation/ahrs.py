"""Orientation-only error-state filter (AHRS): gyroscope + accelerometer (+ magnetometer), compiled kernel.

The error-state filter of :mod:`dualpose.estimation.eskf` reduced to orientation and gyroscope bias:

* nominal state ``q`` (4,) xyzw rotating IMU (body) vectors into the earth frame (ENU, x = magnetic east,
  y = magnetic north, z = up), and the gyroscope bias ``b`` (3,) rad/s;
* error state ``δx = [δθ, δb]`` (6,) with a **global** 3-parameter attitude error ``q = Exp(δθ) ⊗ q̂``: ``δθ_z``
  is the heading error and ``(δθ_x, δθ_y)`` the inclination error, so the two are separated by construction;
* predict with the gyroscope as input (Solà 2017 §5 with the global error: ``δθ̇ = −R δb + R n_g``);
* measurements are earth-frame averages: the specific force ``a`` and the field ``m`` of every sample are rotated into
  the estimated earth frame with that sample's estimate; the field is averaged over the last ``window`` seconds (default
  3 s, a boxcar), the specific force is low-passed by a 2nd-order Butterworth with DC group delay ``τ = window / 2``
  (the discretisation of VQF's inertial-frame accelerometer filter, Laidig & Seel 2023); an update is made every
  ``update_interval`` (0.1 s). That low-pass has the boxcar's delay (T / 2) and the boxcar's noise-equivalent bandwidth
  (1 / (2T)), so it averages white noise as much, but its response to a linear acceleration oscillating at f falls as
  ``(f_c / f)²`` (``f_c = √2 / (2π τ)``) instead of the boxcar's ``1 / (π f T)``: in the earth frame the mean linear
  acceleration of a body whose velocity stays bounded is Δv / T over a boxcar, which the low-pass attenuates further.
  Averaging also removes sensor noise and fast tilt-coupled heading errors. The window's vectors and the low-pass state
  are stored in the *uncorrected* frame (``C⁻¹ R̂ v`` with ``C`` the product of all corrections applied so far; both are
  linear in the samples), so every correction rotates all past samples at once (current-frame value ``= C · stored``).
  Consecutive updates share samples: each update's noise is multiplied by the overlap ``window / update_interval``;
* accelerometer update: the horizontal components of the mean earth-frame specific force must vanish (2-D
  measurement ``y = [mean R̂ a]_{x,y}``, ``H = [[0, −g, 0, 0₃], [g, 0, 0, 0₃]]``).  It carries no heading
  information and its gain row for ``δθ_z`` is zeroed;
* magnetometer update (9D), **heading only**: ``y = atan2(m̄_x, m̄_y)`` of the mean earth-frame field (the heading of
  its horizontal projection, 0 = magnetic north), ``H = [0, 0, 1, 0₃]``, gain rows for ``δθ_x, δθ_y`` zeroed.  A
  magnetic disturbance therefore cannot tilt the estimate: it can only rotate it about the vertical, which is the
  one thing the magnetometer is needed for (the full 3-D field model would let a disturbed field pull
  inclination, which the accelerometer measures better).  The price is that the field's own tilt information is
  unused, which costs little because the accelerometer dominates inclination;
* adaptive rejection (innovation-based): each update's noise is inflated by a lower bound of the disturbance
  present -- ``(| |ā| − g | − 2δg)₊²`` for the accelerometer (the mean linear acceleration has at least that
  magnitude once the sensor's own error δ, ``acc_scale_sigma``, is allowed for; its direction error ``(δg)² / 3``
  per axis is part of the noise too), the
  window mean of ``(|m| − m₀)² + (m₀ Δdip)²`` for the magnetometer (change of the field's magnitude and dip from the
  reference measured at rest) -- and the accelerometer noise additionally gets an innovation-based (Sage-Husa /
  Mehra) estimate of the unmodelled acceleration variance (time constant ``adapt_time``).  Every innovation is
  χ²-gated (NIS above the ``gate_probability`` quantile is rejected; after ``gate_release`` seconds of
  uninterrupted rejection the gate re-opens and stays open until an innovation fits again, so that the filter
  re-acquires instead of locking itself out);
* covariance updates in Joseph form (valid for the zeroed, sub-optimal gains) followed by the reset Jacobian.
* magnetometer–gyroscope time offset, strictly causal by default: the field measured at ``t`` is the field at
  ``t − τ``, so it is rotated into the earth frame with the orientation at ``t − τ̂``,
  ``R̂(t) Exp(−∫_{t−τ̂}^{t} (ω − b) dt)`` from the gyroscope samples already seen; ``τ̂`` is estimated online inside
  the filter from the kinematic residual ``dm/dt + ω(t − τ) × (m − h) = 0`` of a static field with a hard-iron term
  ``h`` on causally filtered data (running sufficient statistics per candidate ``τ`` on a ±30 ms grid, ``h`` in
  closed form; ``src/native/estimation/ahrs_mag_lag.hpp``, docs/broad.md "Magnetometer–gyroscope time offset").  In
  fast rotation a lag τ turns the measured field by ``ω τ`` (at 5 rad/s and 11 ms: 3°).  The whole-recording
  (offline, not causal) estimate of :mod:`dualpose.calibration.sensor_time_offset` remains an option;
* rest detection with a gyroscope-bias update (strictly causal, in the same per-sample step): when the variances
  of the gyroscope and the accelerometer over the trailing ``rest_window`` (1.5 s) are both within ``rest_margin²``
  (9) times their white-noise variance measured at rest, the window's mean rate measures the bias (``H = [0, I]``,
  noise ``σ_g² / N`` times the window overlap, χ²(3)-gated without release; ``src/native/estimation/ahrs_rest.hpp``,
  docs/broad.md, "Rest detector and bias update");
* causal rest period: inside the rest period (before its statistics are complete) the output is the orientation of
  the running mean specific force and field of the samples so far; at its last sample the filter is initialised from
  the rest statistics and run over the rest samples (all in the past by then), so no output depends on a later
  sample;
* optional magnetometer self-calibration (``mag_calibration="auto"``; hard iron / per-axis scale / symmetric soft
  iron) from the recording's own field samples, applied only when objective criteria say the data support it
  (orientation coverage, well-determined parameters, the field-magnitude spread in excess of the noise at least halved;
  :mod:`dualpose.calibration.magnetometer`); otherwise the raw field is used.  It runs before the time-offset
  estimate and the rest statistics (and, being fitted to the whole recording, is not causal).

Noise is set on principle, never per trial: white-noise levels of the three sensors are estimated from the rest period
at the start of the recording (robustly: median absolute deviation); the bias random walk and the relative gyroscope
scale-factor / misalignment uncertainty (0.5 %, calibrated-MEMS class; rate-proportional process noise) are fixed
sensor-class values; the window (3 s; the accelerometer low-pass's delay is half of it) and adaptation time (2 windows)
are motion-class choices for hand-held motion. The same values are used for every recording. Initialisation: the
gyroscope bias is the median rate over the rest period, the orientation comes from the rest period's median specific
force (inclination) and magnetic field (heading; 6D: the body x axis projected on the horizontal is east), and the
field's magnitude and dip at rest are the magnetometer's reference. In 6D the earth frame's heading is defined by that
initial orientation, so the initial heading uncertainty is small by definition (a huge value would only feed spurious
cross-covariances into the linearisation).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np
from scipy.stats import chi2

from dualpose import _native
from dualpose.calibration.magnetometer import MagCalibration, estimate_mag_calibration
from dualpose.calibration.sensor_time_offset import (
    SensorTimeOffset,
    check_samples,
    estimate_sensor_time_offset,
    shift_samples,
)

__all__ = [
    "AhrsNoise",
    "AhrsConfig",
    "AhrsResult",
    "RestStatistics",
    "initial_orientation",
    "rest_statistics",
    "estimate_orientation",
    "AhrsSetup",
    "filter_setup",
    "PreparedRecording",
    "prepare_recording",
    "run_result",
    "check_mag_time_offset",
    "accelerometer_jacobian",
    "heading_jacobian",
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
    :class:`~dualpose.estimation.ahrs_stream.AhrsStream`, so that the batch and the streaming filter cannot be set up
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
        Time constant (s) of the innovation-based (Sage-Husa) estimate of the unmodelled acceleration variance that
        is added to the accelerometer noise (default 6 s; 0 switches it off).
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
    acc_scale_sigma : float
        Relative error δ of the accelerometer (scale factor + axis misalignment; calibrated MEMS class, default
        0.5 %, as the gyroscope's): a specific force ≈ g is measured off by up to δ g.  So the lower bound
        ``| |ā| − g |`` of the filtered linear acceleration added to the accelerometer noise is reduced by ``2 δ g``
        (the magnitude difference the sensor can produce by itself between the rest orientation that set ``g`` and
        the current one), and the direction error's per-axis variance ``(δ g)² / 3`` is added instead
        (docs/broad.md, "Design in brief").
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

    def __post_init__(self) -> None:
        if self.noise is not None and not isinstance(self.noise, AhrsNoise):
            raise TypeError(f"noise must be an AhrsNoise or None; got {type(self.noise).__name__}")
        if not 0.0 < self.gate_probability < 1.0:
            raise ValueError(f"gate_probability must be in (0, 1); got {self.gate_probability}")
        checks = (("gate_release", self.gate_release, False), ("adapt_time", self.adapt_time, False),
                  ("window", self.window, True), ("gyro_scale_sigma", self.gyro_scale_sigma, False),
                  ("update_interval", self.update_interval, True),
                  ("acc_scale_sigma", self.acc_scale_sigma, False), ("rest_window", self.rest_window, False),
                  ("rest_margin", self.rest_margin, True))  # fmt: skip
        for name, value, positive in checks:
            if not (math.isfinite(value) and (value > 0.0 if positive else value >= 0.0)):
                kind = "a positive" if positive else "a non-negative"
                raise ValueError(f"{name} must be {kind} finite number; got {value}")

    def as_dict(self) -> dict:
        """The settings as plain Python values (``noise`` as a dict or None), for saving; inverse :meth:`from_dict`."""
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> AhrsConfig:
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
        up = self.specific_force / np.linalg.norm(self.specific_force)
        m = self.magnetic_field
        down_part = -float(m @ up)
        return math.atan2(down_part, float(np.linalg.norm(m - (m @ up) * up)))


@dataclass
class AhrsResult:
    """Output of :func:`estimate_orientation`.

    Attributes
    ----------
    quat : ndarray, shape (n, 4)
        Estimated orientation per sample, xyzw, IMU → earth (ENU; 6D: heading arbitrary but constant-offset).
    gyroscope_bias : ndarray, shape (n, 3)
        Estimated gyroscope bias per sample, rad/s.
    covariance : ndarray, shape (6, 6)
        Final error covariance of ``[δθ (earth frame), δb]``.
    use_mag : bool
        9D (True) or 6D (False).
    rest : RestStatistics or None
        Statistics of the rest period used for initialisation.
    acc_rejected, mag_rejected : int
        Updates rejected by the χ² gates.
    acc_nis_mean, mag_nis_mean : float
        Mean NIS of the accepted updates (2 and 1 degrees of freedom).
    acc_fraction_inside, mag_fraction_inside : float
        Fraction of accepted updates whose NIS lies in the two-sided 95 % χ² band.
    seconds : float
        Wall time of the filter kernel (excluding compilation and set-up).
    mag_time_offset : float
        Lag of the magnetometer behind the gyroscope that was compensated, s (0.0 in 6D or when not estimable); with
        ``mag_time_offset="online"`` the online estimate τ̂ after the last sample.
    mag_time_offset_estimate : SensorTimeOffset or None
        The offline estimator's full result when ``mag_time_offset="estimate"`` (None otherwise).
    mag_time_offset_samples : int
        Informative samples the online estimate has seen (0 unless ``mag_time_offset="online"``).
    rest_samples : int
        Samples the rest detector flagged as at rest (the initial rest period is not seen by it).
    rest_updates : int
        Gyroscope-bias updates made at rest (accepted by the χ² gate).
    mag_calibration : MagCalibration or None
        The magnetometer self-calibration decision and parameters when ``mag_calibration="auto"`` in 9D (None
        otherwise); see :attr:`mag_calibration_applied`.
    """

    quat: np.ndarray
    gyroscope_bias: np.ndarray
    covariance: np.ndarray
    use_mag: bool
    rest: RestStatistics | None
    acc_rejected: int = 0
    mag_rejected: int = 0
    acc_nis_mean: float = math.nan
    mag_nis_mean: float = math.nan
    acc_fraction_inside: float = math.nan
    mag_fraction_inside: float = math.nan
    seconds: float = 0.0
    mag_time_offset: float = 0.0
    mag_time_offset_estimate: SensorTimeOffset | None = None
    mag_calibration: MagCalibration | None = None
    mag_time_offset_samples: int = 0
    rest_samples: int = 0
    rest_updates: int = 0

    @property
    def mag_calibration_applied(self) -> bool:
        """Whether a magnetometer self-calibration was applied before filtering."""
        return self.mag_calibration is not None and self.mag_calibration.applied

    @property
    def mag_time_offset_ms(self) -> float:
        """Compensated magnetometer lag, ms."""
        return 1e3 * self.mag_time_offset

    @property
    def us_per_sample(self) -> float:
        """Kernel wall time per sample, µs."""
        return 1e6 * self.seconds / max(self.quat.shape[0], 1)


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

    Shared by :func:`estimate_orientation` and :class:`~dualpose.estimation.ahrs_stream.AhrsStream`, so that both
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
    c = config if config is not None else AhrsConfig()
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
    if use_mag:
        up = a_ref / np.linalg.norm(a_ref)
        field_norm = float(np.linalg.norm(m_ref))
        field_dip = math.atan2(-float(m_ref @ up), float(np.linalg.norm(m_ref - (m_ref @ up) * up)))
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
    # initial attitude uncertainty: the direction of a mean of N noisy specific forces (inclination) and fields
    # (heading); heading is unknown in 6D (π is only a nominal value: no update ever uses it)
    n_avg = rest.samples if rest is not None else 1
    incl_sigma = noise.accelerometer_noise_density * math.sqrt(rate / n_avg) / gravity + math.radians(0.1)
    head_sigma = math.radians(5.0) if use_mag else math.radians(5.0)
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


def check_mag_time_offset(mag_time_offset: object, allowed: tuple[str, ...]) -> float | None:
    """``mag_time_offset`` validated: None for "online", the number for a number; "estimate" returned as is when
    allowed (ValueError naming the argument otherwise)."""
    if isinstance(mag_time_offset, str):
        if mag_time_offset not in allowed:
            choices = " or ".join(f'"{a}"' for a in allowed)
            raise ValueError(f"mag_time_offset must be {choices} or a number of seconds; got {mag_time_offset!r}")
        return None if mag_time_offset == "online" else mag_time_offset  # type: ignore[return-value]
    try:
        value = float(mag_time_offset)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise TypeError(f"mag_time_offset must be a string or a number; got {type(mag_time_offset).__name__}") from None
    if not math.isfinite(value):
        raise ValueError(f"mag_time_offset must be a finite number of seconds; got {mag_time_offset}")
    return value


@dataclass(frozen=True)
class PreparedRecording:
    """One recording made ready for the AHRS kernel (:func:`prepare_recording`): checked arrays, the corrections
    that need the whole recording applied, the rest statistics and the filter's set-up.

    Attributes
    ----------
    gyr, acc : ndarray, shape (n, 3)
        rad/s and m/s², IMU axes (checked, C-contiguous float64).
    mag : ndarray, shape (n, 3)
        The field after the self-calibration and the time-offset compensation (zeros in 6D), IMU axes.
    rate : float
        Sampling rate, Hz.
    use_mag : bool
        9D (True) or 6D (False).
    rest : RestStatistics or None
        Statistics of the rest period.
    setup : AhrsSetup
        Parameters and initial state of the kernel.
    n_rest : int
        Leading rest samples (0: none).
    mag_time_offset : float or None
        Lag of the magnetometer behind the gyroscope compensated before or inside the kernel, s; None when the kernel
        estimates it online (its value is then in the kernel's statistics).
    mag_time_offset_estimate : SensorTimeOffset or None
        The estimator's result when it was asked for.
    mag_calibration : MagCalibration or None
        The self-calibration decision when it was asked for.
    """

    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    rate: float
    use_mag: bool
    rest: RestStatistics | None
    setup: AhrsSetup
    n_rest: int
    mag_time_offset: float | None
    mag_time_offset_estimate: SensorTimeOffset | None
    mag_calibration: MagCalibration | None


def prepare_recording(
    gyr: np.ndarray,
    acc: np.ndarray,
    mag: np.ndarray | None,
    rate: float,
    *,
    use_mag: bool = True,
    n_rest: int | None = None,
    config: AhrsConfig | None = None,
    mag_time_offset: str | float = "online",
    mag_calibration: str | MagCalibration | None = None,
) -> PreparedRecording:
    """Check the inputs of :func:`estimate_orientation` and do everything before its kernel runs.

    Shared by :func:`estimate_orientation` and :func:`dualpose.estimation.ahrs_smoother.smooth_orientation`, so that
    both filter the same data from the same start.  The parameters are those of :func:`estimate_orientation`; the
    magnetometer self-calibration runs first, then the rest statistics, then the time-offset estimate and
    compensation, then :func:`filter_setup`.

    Returns
    -------
    PreparedRecording

    Raises
    ------
    ValueError, TypeError
        As :func:`estimate_orientation`.
    """
    gyr = check_samples(gyr, "gyr")
    n = gyr.shape[0]
    if n < 1:
        raise ValueError("gyr must contain at least one sample")
    acc = check_samples(acc, "acc", n)
    if use_mag and mag is None:
        raise ValueError("use_mag=True needs mag samples (n, 3); pass use_mag=False for 6D")
    mag_arr = check_samples(mag, "mag", n) if mag is not None else None
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive number of Hz; got {rate}")
    if n_rest is None:
        n_rest = min(n, int(round(rate)))
        n_rest = n_rest if n_rest >= 10 else 0
    if not 0 <= n_rest <= n:
        raise ValueError(f"n_rest must be in [0, {n}]; got {n_rest}")
    if 0 < n_rest < 10:
        raise ValueError(f"n_rest must be 0 (no rest period) or at least 10 samples; got {n_rest}")

    lag_setting = check_mag_time_offset(mag_time_offset, ("online", "estimate"))

    if isinstance(mag_calibration, str) and mag_calibration != "auto":
        raise ValueError(f'mag_calibration must be "auto", a MagCalibration or None; got {mag_calibration!r}')
    if not (mag_calibration is None or isinstance(mag_calibration, (str, MagCalibration))):
        raise TypeError(f'mag_calibration must be "auto", a MagCalibration or None; got {type(mag_calibration)}')
    mag_cal = None
    if use_mag and mag_calibration is not None:
        if mag_calibration == "auto":
            noise_spread = None
            if n_rest:
                rn = np.linalg.norm(mag_arr[:n_rest], axis=1)
                noise_spread = float(1.4826 * np.median(np.abs(rn - np.median(rn))) / np.median(rn))
            mag_cal = estimate_mag_calibration(mag_arr, noise_spread=noise_spread)
        else:
            mag_cal = mag_calibration
        mag_arr = np.ascontiguousarray(mag_cal.apply(mag_arr))
    rest = rest_statistics(gyr, acc, mag_arr, rate, n_rest) if n_rest else None
    mag_offset_est, kernel_lag = None, lag_setting
    if use_mag and lag_setting == "estimate":
        mag_offset_est = estimate_sensor_time_offset(
            gyr, mag_arr, rate, gyroscope_bias=rest.gyroscope_bias if rest is not None else None
        )
        if mag_offset_est.valid and mag_offset_est.offset != 0.0:
            mag_arr = shift_samples(mag_arr, rate, mag_offset_est.offset)
        kernel_lag = 0.0
    if not use_mag:
        mag_offset: float | None = 0.0
    elif mag_offset_est is not None:
        mag_offset = mag_offset_est.offset if mag_offset_est.valid else 0.0
    else:
        mag_offset = kernel_lag  # a fixed lag, or None: estimated online by the kernel
    setup = filter_setup(
        rate, rest, acc[0], mag_arr[0] if mag_arr is not None else None,
        use_mag=use_mag, config=config, mag_time_offset=kernel_lag, rest_skip=n_rest,
    )  # fmt: skip
    return PreparedRecording(
        gyr=gyr, acc=acc, mag=mag_arr if mag_arr is not None else np.zeros((n, 3)), rate=float(rate),
        use_mag=use_mag, rest=rest, setup=setup, n_rest=n_rest, mag_time_offset=mag_offset,
        mag_time_offset_estimate=mag_offset_est, mag_calibration=mag_cal,
    )  # fmt: skip


def estimate_orientation(
    gyr: np.ndarray,
    acc: np.ndarray,
    mag: np.ndarray | None,
    rate: float,
    *,
    use_mag: bool = True,
    n_rest: int | None = None,
    config: AhrsConfig | None = None,
    mag_time_offset: str | float = "online",
    mag_calibration: str | MagCalibration | None = None,
) -> AhrsResult:
    """Estimate the orientation of an IMU from gyroscope, accelerometer and (9D) magnetometer samples.

    Parameters
    ----------
    gyr : array_like, shape (n, 3)
        Angular rate, rad/s, IMU axes.
    acc : array_like, shape (n, 3)
        Specific force, m/s², IMU axes.
    mag : array_like, shape (n, 3) or None
        Magnetic field (µT or any unit), IMU axes; required when ``use_mag``.
    rate : float
        Sampling rate, Hz (uniform sampling).
    use_mag : bool
        9D (True) or 6D (False, the magnetometer is ignored).
    n_rest : int, optional
        Leading samples at rest, used for initialisation and noise estimation (default: the first second).  With
        ``n_rest=0`` nothing is estimated: ``noise`` (or :class:`AhrsNoise` defaults), zero initial bias with the
        MEMS turn-on uncertainty and the first sample's directions are used.
    config : AhrsConfig, optional
        Tuning: noise override, gates, adaptation, window, update interval, scale-factor uncertainty (default
        :class:`AhrsConfig`, the same for every recording).
    mag_time_offset : "online", "estimate" or float
        Lag of the magnetometer samples behind the gyroscope's, s (docs/broad.md, "Magnetometer–gyroscope time
        offset").  In fast rotation a lag τ makes the magnetometer read a heading rotated by ``ω τ``.

        * ``"online"`` (default, strictly causal): estimated inside the filter from the samples seen so far
          (kinematic residual ``dm/dt + ω(t − τ) × (m − h) = 0`` of a static field with a hard-iron term ``h``,
          causally filtered, ±30 ms grid; 0 until one second of informative samples -- ``|ω| ≥ 0.5`` rad/s, ``|m|``
          within 10 % of the rest field -- has been seen and the minimum is inside the range) and compensated by
          rotating each field sample with the orientation at ``t − τ̂`` (``R̂(t) Exp(−∫_{t−τ̂}^{t} (ω − b) dt)``);
        * a number: that lag, compensated the same causal way; 0 switches the compensation off;
        * ``"estimate"`` (not causal): the whole recording's offline estimate
          (:func:`~dualpose.calibration.sensor_time_offset.estimate_sensor_time_offset`, gyroscope bias from the
          rest period), compensated by re-sampling the magnetometer at ``t + τ``
          (:func:`~dualpose.calibration.sensor_time_offset.shift_samples`); nothing is shifted when it is not
          estimable.

        Ignored in 6D.
    mag_calibration : "auto", MagCalibration or None
        None (default): raw magnetometer.  ``"auto"``: fit hard iron / per-axis scale / symmetric soft iron to this
        recording's field samples and apply the smallest model that passes the decision rule of
        :func:`~dualpose.calibration.magnetometer.estimate_mag_calibration` (noise level of ``|m|`` from the rest
        period when there is one); raw data otherwise.  A :class:`MagCalibration` is applied as given (if its
        ``applied`` flag is set).  Off by default; its effect and cost on BROAD are in docs/broad.md
        ("Magnetometer self-calibration").  Runs before the time-offset estimate.  Ignored in 6D.

    Returns
    -------
    AhrsResult
        Every output is causal (depends on no later sample) unless ``mag_time_offset="estimate"`` or
        ``mag_calibration`` is used: inside the rest period the orientation of the running mean specific force and
        field so far and the running mean rate as bias; from the rest period's last sample on, the filter's.
    """
    prep = prepare_recording(
        gyr, acc, mag, rate, use_mag=use_mag, n_rest=n_rest, config=config, mag_time_offset=mag_time_offset,
        mag_calibration=mag_calibration,
    )  # fmt: skip
    n = prep.gyr.shape[0]
    setup = prep.setup
    q, b, P = setup.q.copy(), setup.b.copy(), setup.P.copy()
    out_q = np.empty((n, 4))
    out_b = np.empty((n, 3))
    stats = np.zeros(_native.AHRS_N_STATS)
    t0 = time.perf_counter()
    _native.ahrs_run(prep.gyr, prep.acc, prep.mag, 1.0 / prep.rate, q, b, P, setup.params, setup.Ha, setup.Hm, out_q,
                     out_b, stats)  # fmt: skip
    seconds = time.perf_counter() - t0
    n_rest = prep.n_rest
    if n_rest > 1:  # the outputs before the rest period is complete: running means of the samples so far
        k = n_rest - 1
        _native.ahrs_rest_run(prep.gyr[:k], prep.acc[:k], prep.mag[:k], prep.use_mag, np.zeros(10), out_q[:k],
                              out_b[:k])  # fmt: skip
    return run_result(prep, out_q, out_b, P, stats, seconds)


def run_result(
    prep: PreparedRecording, quat: np.ndarray, gyroscope_bias: np.ndarray, covariance: np.ndarray, stats: np.ndarray,
    seconds: float,
) -> AhrsResult:
    """The :class:`AhrsResult` of one kernel run over a :class:`PreparedRecording`.

    Parameters
    ----------
    prep : PreparedRecording
    quat : ndarray, shape (n, 4)
        Filtered orientation, xyzw.
    gyroscope_bias : ndarray, shape (n, 3)
        Filtered gyroscope bias, rad/s.
    covariance : ndarray, shape (6, 6)
        Final error covariance.
    stats : ndarray, shape (AHRS_N_STATS,)
        The kernel's counters.
    seconds : float
        Kernel wall time.

    Returns
    -------
    AhrsResult
    """
    n, n_win, stride = quat.shape[0], prep.setup.n_win, prep.setup.stride
    use_mag = prep.use_mag
    n_updates = max(0, (n - n_win) // stride + 1)
    acc_acc = n_updates - stats[_native.AHRS_S_ACC_REJECTED]
    mag_acc = (n_updates - stats[_native.AHRS_S_MAG_REJECTED] - stats[_native.AHRS_S_MAG_SKIPPED]) if use_mag else 0
    mag_offset = prep.mag_time_offset if prep.mag_time_offset is not None else float(stats[_native.AHRS_S_MAG_LAG])
    return AhrsResult(
        quat=quat,
        gyroscope_bias=gyroscope_bias,
        covariance=covariance,
        use_mag=use_mag,
        rest=prep.rest,
        acc_rejected=int(stats[_native.AHRS_S_ACC_REJECTED]),
        mag_rejected=int(stats[_native.AHRS_S_MAG_REJECTED]),
        acc_nis_mean=float(stats[_native.AHRS_S_ACC_NIS_SUM] / acc_acc) if acc_acc else math.nan,
        mag_nis_mean=float(stats[_native.AHRS_S_MAG_NIS_SUM] / mag_acc) if mag_acc else math.nan,
        acc_fraction_inside=float(stats[_native.AHRS_S_ACC_INSIDE] / acc_acc) if acc_acc else math.nan,
        mag_fraction_inside=float(stats[_native.AHRS_S_MAG_INSIDE] / mag_acc) if mag_acc else math.nan,
        seconds=seconds,
        mag_time_offset=mag_offset,
        mag_time_offset_estimate=prep.mag_time_offset_estimate,
        mag_calibration=prep.mag_calibration,
        mag_time_offset_samples=int(stats[_native.AHRS_S_MAG_LAG_SAMPLES]),
        rest_samples=int(stats[_native.AHRS_S_REST_SAMPLES]),
        rest_updates=int(stats[_native.AHRS_S_REST_UPDATES]),
    )
