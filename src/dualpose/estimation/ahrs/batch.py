"""The AHRS over a whole recording: :func:`estimate_orientation` (real time by default: every output causal) and the
preparation it shares with the offline smoother (:func:`prepare_recording`, :func:`run_result`).  The model is
described in :mod:`dualpose.estimation.ahrs`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from dualpose import _native
from dualpose.calibration.magnetometer import MagCalibration, estimate_mag_calibration
from dualpose.calibration.sensor_time_offset import (
    SensorTimeOffset,
    check_samples,
    estimate_sensor_time_offset,
    shift_samples,
)
from dualpose.estimation.ahrs.config import (
    AhrsConfig,
    AhrsSetup,
    RestStatistics,
    _check_config,
    _rest_length,
    check_field_samples,
    check_mag_time_offset,
    filter_setup,
    rest_statistics,
)

__all__ = ["AhrsResult", "PreparedRecording", "prepare_recording", "estimate_orientation", "run_result"]


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
        return float(1e6 * self.seconds / max(self.quat.shape[0], 1))


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

    Shared by :func:`estimate_orientation` and :func:`dualpose.estimation.ahrs.smoother.smooth_orientation`, so that
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
    if use_mag and mag_arr is not None:
        check_field_samples(mag_arr)  # no zero sample: it has no direction (docs/refusals.md)
    n_rest = _rest_length(rate, n_rest, n)
    config = _check_config(config)

    lag_setting = check_mag_time_offset(mag_time_offset, ("online", "estimate"))

    if isinstance(mag_calibration, str) and mag_calibration != "auto":
        raise ValueError(f'mag_calibration must be "auto", a MagCalibration or None; got {mag_calibration!r}')
    if not (mag_calibration is None or isinstance(mag_calibration, (str, MagCalibration))):
        raise TypeError(f'mag_calibration must be "auto", a MagCalibration or None; got {type(mag_calibration)}')
    mag_cal = None
    if use_mag and mag_arr is not None and mag_calibration is not None:  # (use_mag: mag_arr is not None)
        if not isinstance(mag_calibration, MagCalibration):  # "auto"
            noise_spread = None
            if n_rest:
                rn = np.linalg.norm(mag_arr[:n_rest], axis=1)
                noise_spread = float(1.4826 * np.median(np.abs(rn - np.median(rn))) / np.median(rn))
            mag_cal = estimate_mag_calibration(mag_arr, noise_spread=noise_spread)
        else:
            mag_cal = mag_calibration
        mag_arr = np.ascontiguousarray(mag_cal.apply(mag_arr))
    rest = rest_statistics(gyr, acc, mag_arr, rate, n_rest) if n_rest else None
    mag_offset_est = None
    # "estimate": compensated offline (a zero lag in the kernel) with a magnetometer, unused without
    kernel_lag = None if isinstance(lag_setting, str) else lag_setting
    if use_mag and mag_arr is not None and lag_setting == "estimate":
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
