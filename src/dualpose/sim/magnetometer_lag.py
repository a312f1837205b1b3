"""An analytic tumbling IMU recording whose magnetometer lags the gyroscope by a known time (for time-offset tests).

The body orientation is an analytic function of time (a rotation vector made of sinusoids of ~1 rad at 0.2-0.9 Hz:
``|ω|`` up to ~5 rad/s, like hand-held fast rotation), so the magnetometer can be sampled exactly at ``t − lag`` and the
gyroscope's body rate is the analytic ``2 q* ⊗ q̇`` (central difference with a 1 µs step, error ~1e-10 rad/s): the
truth does not depend on any estimator's model.  Used by ``tests/calibration/test_sensor_time_offset.py`` and
``benchmarks/bench_mag_lag_online.py`` (docs/broad.md, "Magnetometer–gyroscope time offset").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose.sim._imu_truth import FIELD_ENU, central_body_rate
from dualpose.types.imu import STANDARD_GRAVITY

__all__ = ["FIELD_ENU", "LaggedRecording", "tumbling_quat", "tumbling_body_rate", "lagged_recording"]


def tumbling_quat(t: ArrayLike) -> NDArray[np.float64]:
    """Orientation body → ENU, xyzw, shape (n, 4), at the times ``t`` (s, shape (n,))."""
    t = np.asarray(t, dtype=np.float64)
    phi = np.stack(
        [
            1.1 * np.sin(2 * np.pi * 0.37 * t + 0.3),
            0.8 * np.sin(2 * np.pi * 0.53 * t + 1.1) + 0.2 * np.sin(2 * np.pi * 0.91 * t),
            1.4 * np.sin(2 * np.pi * 0.23 * t + 2.0),
        ],
        axis=-1,
    )
    return dp.quat_from_rotvec(phi)


def tumbling_body_rate(t: ArrayLike) -> NDArray[np.float64]:
    """Body-frame angular rate, rad/s, shape (n, 3), of :func:`tumbling_quat` at the times ``t`` (s, shape (n,))."""
    return central_body_rate(tumbling_quat, np.asarray(t, dtype=np.float64))


@dataclass(frozen=True)
class LaggedRecording:
    """Output of :func:`lagged_recording` (arrays per sample, components on the last axis).

    Attributes
    ----------
    gyr, acc, mag : ndarray, shape (n, 3)
        rad/s, m/s², µT in body axes; ``mag`` taken ``lag`` seconds before the gyroscope's sample time.
    n_rest : int
        Leading samples at rest.
    moving : ndarray of bool, shape (n,)
        Samples after the rest period.
    quat : ndarray, shape (n, 4)
        True orientation body → ENU (xyzw) at the gyroscope's sample times.
    rate : float
        Sampling rate, Hz.
    """

    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    n_rest: int
    moving: np.ndarray
    quat: np.ndarray
    rate: float


def _motion_time(t: np.ndarray, ramp: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Motion time s(t) and its rate ds/dt (both (n,)): 0 before t = 0; with ``ramp`` > 0 the rate rises as
    (1 − cos(π t / ramp)) / 2 to 1 (continuous angular rate and acceleration), else it jumps to 1 at t = 0."""
    started = t >= 0.0
    t = np.maximum(t, 0.0)
    if ramp <= 0.0:
        return t, started.astype(np.float64)
    inside = t < ramp
    s = np.where(inside, 0.5 * t - ramp / (2 * np.pi) * np.sin(np.pi * t / ramp), t - 0.5 * ramp)
    return s, np.where(inside, 0.5 * (1.0 - np.cos(np.pi * t / ramp)), 1.0)


def lagged_recording(
    lag: float,
    seconds: float = 32.0,
    *,
    rate: float = 200.0,
    rest_seconds: float = 2.0,
    ramp_seconds: float = 0.0,
    seed: int = 0,
) -> LaggedRecording:
    """``rest_seconds`` at rest (the motion frozen at its start), then the tumbling motion; the magnetometer lags.

    Noise (seeded): gyroscope 0.005 rad/s, accelerometer 0.02 m/s², magnetometer 0.3 µT per sample; no bias, no
    linear acceleration, field :data:`FIELD_ENU`.  With ``ramp_seconds`` = 0 the angular rate jumps from 0 to the
    motion's at the end of the rest (an infinite angular acceleration); with ``ramp_seconds`` > 0 the motion's time
    runs up smoothly over that many seconds (rate and acceleration continuous), as a real motion starts.

    Parameters
    ----------
    lag : float
        Lag of the magnetometer behind the gyroscope, s (negative: it leads).
    seconds : float
        Length of the recording, s, rest included.
    rate : float
        Sampling rate, Hz.
    rest_seconds : float
        Leading rest, s.
    ramp_seconds : float
        Smooth start of the motion, s (0: abrupt).
    seed : int
        Noise seed.

    Returns
    -------
    LaggedRecording
    """
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate)) / rate
    tm, rate_tm = _motion_time(t - rest_seconds, ramp_seconds)  # motion time: frozen during the rest
    moving = t >= rest_seconds
    gyr = rate_tm[:, None] * tumbling_body_rate(tm) + rng.normal(0.0, 0.005, (t.size, 3))
    q = tumbling_quat(tm)
    acc = dp.quat_rotate(dp.quat_conj(q), np.broadcast_to([0.0, 0.0, STANDARD_GRAVITY], (t.size, 3)))
    acc = acc + rng.normal(0.0, 0.02, (t.size, 3))
    q_mag = tumbling_quat(_motion_time(t - rest_seconds - lag, ramp_seconds)[0])
    mag = dp.quat_rotate(dp.quat_conj(q_mag), np.broadcast_to(FIELD_ENU, (t.size, 3)))
    mag = mag + rng.normal(0.0, 0.3, (t.size, 3))
    return LaggedRecording(gyr, acc, mag, int(round(rest_seconds * rate)), moving, q, float(rate))
