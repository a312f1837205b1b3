"""Offline AHRS: a Rauch–Tung–Striebel smoother over the error-state model of :mod:`dualpose.estimation.ahrs`.

The forward pass is the AHRS itself (the same compiled per-sample step,
:func:`~dualpose.estimation.ahrs.estimate_orientation`); the backward pass (Rauch, Tung & Striebel 1965; Särkkä
2013, "Bayesian Filtering and Smoothing", §8, Thm 8.2) runs over the stored filtered states ``x_{k|k}, P_{k|k}``,
the predictions ``x_{k+1|k}, P_{k+1|k}`` and the transitions ``F_k = [[I, −R̂_k dt], [0, I]]`` of the global attitude
error ``q = Exp(δθ) ⊗ q̂`` (Solà 2017, §5 and §7):

* ``μ = x^s_{k+1} ⊖ x_{k+1|k} = [Log(q^s_{k+1} ⊗ q_{k+1|k}*), b^s_{k+1} − b_{k+1|k}]``;
* ``G_k = P_{k|k} F_kᵀ P_{k+1|k}⁻¹`` (a linear solve), ``δ = G_k μ``,
  ``S = P_{k|k} + G_k (J_l⁻¹(μ_θ) P^s_{k+1} J_l⁻ᵀ(μ_θ) − P_{k+1|k}) G_kᵀ``;
* ``x^s_k = x_{k|k} ⊕ δ = (Exp(δ_θ) ⊗ q_{k|k}, b_{k|k} + δ_b)``, ``P^s_k = J_l(δ_θ) S J_lᵀ(δ_θ)``,

with the SO(3) left Jacobian ``J_l`` (Solà 2017, eqs. 183–186; the two congruences move a covariance between the
charts of two nearby nominal states).  At the last sample the smoother is the filter.  Approximation: the AHRS's
updates measure sliding-window means over the last ``window`` seconds (rotated with every correction); the smoother,
like the filter, treats each as a measurement of the state at its update time.  Derivation and BROAD results:
docs/broad.md, "Offline (smoothed)".

Offline also allows what needs the whole recording: the magnetometer–gyroscope time offset (``"estimate"``, as the
forward estimator's default) and the magnetometer self-calibration (``"auto"`` here: applied only when its
reference-free decision rule passes; docs/broad.md says why it is the offline default).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dualpose import _native
from dualpose.calibration.magnetometer import MagCalibration
from dualpose.estimation.ahrs.batch import AhrsResult, prepare_recording, run_result
from dualpose.estimation.ahrs.config import AhrsConfig, _check_config

__all__ = ["SmoothedOrientation", "smooth_orientation"]


@dataclass
class SmoothedOrientation:
    """Output of :func:`smooth_orientation`.

    Attributes
    ----------
    quat : ndarray, shape (n, 4)
        Smoothed orientation per sample, xyzw, IMU → earth (ENU; 6D: heading arbitrary but constant-offset).
    gyroscope_bias : ndarray, shape (n, 3)
        Smoothed gyroscope bias per sample, rad/s.
    covariance : ndarray, shape (n, 6, 6)
        Smoothed error covariance per sample over ``[δθ (earth frame, global: q = Exp(δθ) ⊗ q̂), δb]``; the attitude
        block ``covariance[:, :3, :3]`` is in rad², its diagonal the variances of the errors about east, north, up.
    filtered_covariance : ndarray, shape (n, 6, 6)
        The forward filter's ``P_{k|k}`` in the same chart.
    forward : AhrsResult
        The forward filter's result (what :func:`~dualpose.estimation.ahrs.estimate_orientation` returns for the
        same arguments).
    seconds : float
        Wall time of the forward and backward kernel together.
    """

    quat: np.ndarray
    gyroscope_bias: np.ndarray
    covariance: np.ndarray
    filtered_covariance: np.ndarray
    forward: AhrsResult
    seconds: float = 0.0

    @property
    def attitude_sigma(self) -> np.ndarray:
        """Standard deviations of the smoothed attitude error about east, north, up, rad; shape (n, 3)."""
        sigma: NDArray[np.float64] = np.sqrt(np.maximum(np.diagonal(self.covariance[:, :3, :3], axis1=1, axis2=2), 0.0))
        return sigma

    @property
    def us_per_sample(self) -> float:
        """Wall time of the forward and backward kernel per sample, µs."""
        return float(1e6 * self.seconds / max(self.quat.shape[0], 1))


def smooth_orientation(
    gyr: np.ndarray,
    acc: np.ndarray,
    mag: np.ndarray | None,
    rate: float,
    *,
    use_mag: bool = True,
    n_rest: int | None = None,
    config: AhrsConfig | None = None,
    mag_time_offset: str | float = "estimate",
    mag_calibration: str | MagCalibration | None = None,
    rest_update: bool = False,
) -> SmoothedOrientation:
    """Offline orientation: the AHRS forward, then its RTS smoother backward (module docstring).

    Parameters
    ----------
    gyr, acc, mag, rate, use_mag, n_rest, config, mag_time_offset
        As :func:`~dualpose.estimation.ahrs.estimate_orientation`: (n, 3) rad/s, m/s², field (any unit, None in 6D),
        IMU axes; Hz; 9D or 6D; leading rest samples; tuning; the magnetometer lag (``"estimate"``: from this
        recording, the default).
    mag_calibration : "auto", MagCalibration or None
        As :func:`~dualpose.estimation.ahrs.estimate_orientation` (off by default, as there: on the one BROAD trial
        where its reference-free rule fires it costs accuracy; docs/broad.md, "Offline (smoothed)").  Ignored in 6D.
    rest_update : bool
        Keep the forward pass's rest detector and gyroscope-bias update (``config.rest_window``).  Off by default
        offline (``rest_window`` set to 0): the smoother carries a rest's bias back into the movement before it,
        where on BROAD the effective bias differs from the one at rest by ~0.02 °/s; there it sees only the rest
        after the movement and costs 9D accuracy (docs/broad.md, "Rest detector and bias update").

    Returns
    -------
    SmoothedOrientation

    Raises
    ------
    ValueError, TypeError
        Bad arguments, as :func:`~dualpose.estimation.ahrs.estimate_orientation`; ValueError when a predicted
        covariance is singular (only with a :class:`~dualpose.estimation.ahrs.AhrsNoise` of zero process noise and
        zero initial uncertainty).
    """
    config = _check_config(config)
    if not rest_update:
        config = dataclasses.replace(config, rest_window=0.0)
    prep = prepare_recording(
        gyr, acc, mag, rate, use_mag=use_mag, n_rest=n_rest, config=config, mag_time_offset=mag_time_offset,
        mag_calibration=mag_calibration,
    )  # fmt: skip
    n = prep.gyr.shape[0]
    setup = prep.setup
    q, b, P = setup.q.copy(), setup.b.copy(), setup.P.copy()
    out_q, out_b, out_P = np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 6, 6))
    sm_q, sm_b, sm_P = np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 6, 6))
    stats = np.zeros(_native.AHRS_N_STATS)
    t0 = time.perf_counter()
    try:
        _native.ahrs_smooth(
            prep.gyr, prep.acc, prep.mag, 1.0 / prep.rate, q, b, P, setup.params, setup.Ha, setup.Hm, out_q, out_b,
            out_P, stats, sm_q, sm_b, sm_P,
        )  # fmt: skip
    except np.linalg.LinAlgError:
        raise ValueError(
            "a predicted error covariance is singular: the RTS gain needs every error-state component to have prior "
            "uncertainty or process noise (nonzero gyroscope noise density and bias random walk)"
        ) from None
    seconds = time.perf_counter() - t0
    forward = run_result(prep, out_q, out_b, P, stats, seconds)
    return SmoothedOrientation(
        quat=sm_q, gyroscope_bias=sm_b, covariance=sm_P, filtered_covariance=out_P, forward=forward, seconds=seconds
    )
