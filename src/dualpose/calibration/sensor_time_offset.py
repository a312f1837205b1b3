"""Time offset between a body-frame vector sensor (magnetometer) and the gyroscope, from the IMU data alone.

A sensor rigidly mounted on a body that rotates in a static, homogeneous field ``v_e`` (earth frame) sees the body
frame field ``v(t) = R(t)ᵀ v_e``, which obeys the kinematic equation (Poisson equation of the rotation matrix)

    dv/dt = −ω(t) × v(t)                                                                            (1)

with ``ω`` the body-frame angular rate measured by the gyroscope.  If the sensor's samples lag the gyroscope's by
``τ`` (``v_meas(t) = v(t − τ)``: a later time stamp, an internal low-pass filter's group delay, ...), then

    dv_meas/dt (t) + ω(t − τ) × v_meas(t) = 0                                                         (2)

holds for the true ``τ`` only.  :func:`estimate_sensor_time_offset` finds the ``τ`` minimising the squared residual of
(2) over the samples with enough rotation to make it informative (``|ω| ≥ min_rate``) and a field magnitude close to
its median (magnetically disturbed samples violate the static-field assumption), with

* both streams low-passed by the same zero-phase filter (2nd-order Butterworth run forwards and backwards, so no
  delay is introduced) and the derivative taken by central differences of the filtered vector;
* the gyroscope evaluated at ``t − τ`` by linear interpolation of its filtered samples;
* optionally a constant body-frame offset ``h`` of the vector (the magnetometer's uncompensated hard-iron offset:
  ``v_meas = v + h`` turns (2) into ``dv_meas/dt + ω × (v_meas − h) = 0``) fitted by linear least squares for each
  ``τ``, so that a miscalibrated magnetometer does not bias ``τ``;
* a scan over whole-sample shifts within ``±max_offset`` followed by a bounded Brent refinement between the two
  neighbours of the best shift.  A minimum on the edge of the range, or too few informative samples, gives an
  estimate flagged invalid.

The same residual holds for the accelerometer only when the body does not accelerate (gravity alone is a static
field); with linear acceleration the jerk adds a term correlated with the motion, so the estimator is *not* a
reliable accelerometer–gyroscope offset estimator (docs/broad.md shows the scatter on BROAD).

:func:`shift_samples` compensates an offset: it returns the stream re-sampled at ``t + τ`` (linear interpolation,
held at both ends), i.e. aligned with the gyroscope's time stamps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dualpose.types._inputs import imu_rows

__all__ = ["SensorTimeOffset", "estimate_sensor_time_offset", "shift_samples"]


@dataclass(frozen=True)
class SensorTimeOffset:
    """Result of :func:`estimate_sensor_time_offset`.

    Attributes
    ----------
    offset : float
        Estimated lag of the sensor behind the gyroscope, s (positive: the sensor's sample at ``t`` was taken at
        ``t − offset``).  0.0 when ``valid`` is False.
    valid : bool
        False when fewer than one second of informative samples was available or the minimum lies on the edge of
        the search range.
    samples : int
        Number of samples in the residual.
    cost_ratio : float
        Residual cost at the estimate divided by the cost at zero offset (≤ 1; small = a clear improvement).
    constant_offset : ndarray, shape (3,)
        Fitted constant body-frame offset ``h`` of the vector (hard iron), in the vector's unit; zeros when not
        fitted.
    """

    offset: float
    valid: bool
    samples: int
    cost_ratio: float
    constant_offset: np.ndarray

    @property
    def offset_ms(self) -> float:
        """The offset in milliseconds."""
        return 1e3 * self.offset


def _lowpass(x: np.ndarray, rate: float, cutoff: float) -> np.ndarray:
    from scipy.signal import butter, sosfiltfilt

    sos = butter(2, min(cutoff, 0.4 * rate), fs=rate, output="sos")
    return sosfiltfilt(sos, x, axis=0)


def check_samples(x: object, name: str, n: int | None = None) -> np.ndarray:
    """``x`` as a C-contiguous float64 (n, 3) array of finite samples (``n`` samples when given) within the plausible
    range of its sensor (:func:`dualpose.types._inputs.imu_rows`: ``gyr`` rad/s, ``acc`` m/s², any other a field);
    ValueError naming ``name`` and the first bad sample otherwise.  Shared by the AHRS entry points."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3); got shape {a.shape}")
    if n is not None and a.shape[0] != n:
        raise ValueError(f"{name} must have {n} samples like gyr; got {a.shape[0]}")
    return imu_rows(a, name, _SENSOR_KIND.get(name, "mag"))


#: the sensor kind (:data:`dualpose.types._inputs.IMU_LIMITS`) of each sample argument name
_SENSOR_KIND = {"gyr": "gyro", "gyro": "gyro", "acc": "accel", "accel": "accel"}


def estimate_sensor_time_offset(
    gyr: np.ndarray,
    vec: np.ndarray,
    rate: float,
    *,
    gyroscope_bias: np.ndarray | None = None,
    max_offset: float = 0.03,
    cutoff: float = 10.0,
    min_rate: float = 0.5,
    norm_tolerance: float = 0.1,
    fit_constant_offset: bool = True,
) -> SensorTimeOffset:
    """Estimate how much a body-frame field sensor (magnetometer) lags the gyroscope, from eq. (2) of the module.

    Parameters
    ----------
    gyr : array_like, shape (n, 3)
        Angular rate, rad/s, IMU axes.
    vec : array_like, shape (n, 3)
        Samples of a vector that is constant in the earth frame (magnetic field, any unit), IMU axes, same time
        stamps as ``gyr``.
    rate : float
        Sampling rate, Hz (uniform sampling).
    gyroscope_bias : array_like, shape (3,), optional
        Subtracted from ``gyr`` first (rad/s).
    max_offset : float
        Search range ``[−max_offset, max_offset]``, s (default 30 ms).
    cutoff : float
        Low-pass cut-off applied (zero-phase) to both streams, Hz (default 10 Hz, capped at 0.4 × rate).
    min_rate : float
        Samples whose filtered ``|ω|`` is below this (rad/s) are not used (default 0.5 rad/s ≈ 29 °/s).
    norm_tolerance : float
        Samples whose ``|vec|`` differs from its median by more than this fraction are not used (default 10 %).
    fit_constant_offset : bool
        Fit a constant body-frame offset of ``vec`` (hard iron) jointly (default True).

    Returns
    -------
    SensorTimeOffset
    """
    from scipy.optimize import minimize_scalar

    gyr = check_samples(gyr, "gyr")
    n = gyr.shape[0]
    vec = check_samples(vec, "vec", n)
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive number of Hz; got {rate}")
    if not (np.isfinite(max_offset) and max_offset > 0):
        raise ValueError(f"max_offset must be a positive number of seconds; got {max_offset}")
    if gyroscope_bias is not None:
        bias = np.asarray(gyroscope_bias, dtype=np.float64)
        if bias.shape != (3,):
            raise ValueError(f"gyroscope_bias must have shape (3,); got {bias.shape}")
        gyr = gyr - bias
    k_max = max(1, math.ceil(max_offset * rate))
    edge = k_max + 1 + int(math.ceil(3.0 * rate / min(cutoff, 0.4 * rate)))  # filter transients + shift range
    invalid = SensorTimeOffset(0.0, False, 0, math.nan, np.zeros(3))
    if n <= 2 * edge + 3:
        return invalid
    w_f = _lowpass(gyr, rate, cutoff)
    v_f = _lowpass(vec, rate, cutoff)
    dv = np.gradient(v_f, 1.0 / rate, axis=0)
    norm = np.linalg.norm(vec, axis=1)
    norm_med = np.median(norm)
    sel = (np.linalg.norm(w_f, axis=1) >= min_rate) & (np.abs(norm - norm_med) <= norm_tolerance * norm_med)
    sel[:edge] = False
    sel[n - edge:] = False
    idx = np.flatnonzero(sel)
    if idx.size < rate:
        return invalid
    # the filtered streams carry nothing above the cut-off: keeping ~4 samples per cut-off period loses (almost) no
    # information and makes every cost evaluation several times cheaper
    idx = idx[:: max(1, int(rate / (4.0 * cutoff)))]
    d, v = dv[idx], v_f[idx]
    t_idx = idx.astype(np.float64)
    grid = np.arange(n, dtype=np.float64)

    def residual(tau: float) -> tuple[float, np.ndarray]:
        ts = t_idx - tau * rate
        w = np.stack([np.interp(ts, grid, w_f[:, j]) for j in range(3)], axis=1)
        e = d + np.cross(w, v)
        h = np.zeros(3)
        if fit_constant_offset:
            # e − w × h = e + h × w ... minimise Σ|e − [w]× h|²:  (Σ [w]×ᵀ[w]×) h = Σ [w]×ᵀ e = Σ e × w
            ww = np.einsum("ni,ni->n", w, w)
            A = np.eye(3) * ww.sum() - w.T @ w
            rhs = np.cross(e, w).sum(axis=0)
            A += np.eye(3) * 1e-9 * np.trace(A)
            h = np.linalg.solve(A, rhs)
            e = e - np.cross(w, h)
        return float(np.einsum("ni,ni->", e, e)), h

    ks = np.arange(-k_max, k_max + 1)
    costs = np.array([residual(k / rate)[0] for k in ks])
    i = int(np.argmin(costs))
    c0 = costs[k_max]
    if i == 0 or i == ks.size - 1:
        return SensorTimeOffset(0.0, False, int(idx.size), math.nan, np.zeros(3))
    opt = minimize_scalar(lambda s: residual(s)[0], bounds=((ks[i] - 1) / rate, (ks[i] + 1) / rate),
                          method="bounded", options={"xatol": 1e-5})
    tau = float(opt.x)
    cost, h = residual(tau)
    return SensorTimeOffset(tau, True, int(idx.size), cost / c0 if c0 > 0 else math.nan, h)


def shift_samples(x: np.ndarray, rate: float, offset: float) -> np.ndarray:
    """Re-sample a stream that lags the gyroscope by ``offset`` onto the gyroscope's time stamps.

    Parameters
    ----------
    x : array_like, shape (n, k)
        Uniformly sampled stream.
    rate : float
        Sampling rate, Hz.
    offset : float
        Lag of ``x`` behind the reference clock, s (as returned by :func:`estimate_sensor_time_offset`).

    Returns
    -------
    ndarray, shape (n, k)
        ``x(t + offset)`` by linear interpolation between samples, held constant beyond the first / last sample.
    """
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2:
        raise ValueError(f"x must have shape (n, k); got shape {a.shape}")
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive number of Hz; got {rate}")
    if not np.isfinite(offset):
        raise ValueError(f"offset must be a finite number of seconds; got {offset}")
    if offset == 0.0:
        return np.array(a)  # a copy (typed; ndarray.copy is untyped before Python 3.11)
    grid = np.arange(a.shape[0], dtype=np.float64)
    ts = grid + offset * rate
    shifted: NDArray[np.float64] = np.stack([np.interp(ts, grid, a[:, j]) for j in range(a.shape[1])], axis=1)
    return shifted
