"""An analytic tumbling IMU recording whose magnetometer lags the gyroscope by a known time (for time-offset tests).

The body orientation is an analytic function of time (a rotation vector made of sinusoids of ~1 rad at 0.2-0.9 Hz:
|ω| up to ~5 rad/s, like hand-held fast rotation), so the magnetometer can be sampled exactly at ``t − lag`` and the
gyroscope's body rate is the analytic ``2 q* ⊗ q̇`` (central difference with a 1 µs step, error ~1e-10 rad/s): the
truth does not depend on any estimator's model.  Used by ``tests/calibration/test_sensor_time_offset.py`` and
``benchmarks/bench_mag_lag_online.py`` (docs/broad.md, "Magnetometer–gyroscope time offset").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import dualpose as dp

__all__ = ["FIELD_ENU", "LaggedRecording", "tumbling_quat", "tumbling_body_rate", "lagged_recording"]

#: the earth-frame field of the recordings, µT, ENU (north and down components)
FIELD_ENU = np.array([0.0, 20.0, -44.0])


def tumbling_quat(t: np.ndarray) -> np.ndarray:
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


def tumbling_body_rate(t: np.ndarray) -> np.ndarray:
    """Body-frame angular rate, rad/s, shape (n, 3), of :func:`tumbling_quat` at the times ``t`` (s, shape (n,))."""
    t = np.asarray(t, dtype=np.float64)
    h = 1e-6
    q = tumbling_quat(t)
    dq = (tumbling_quat(t + h) - tumbling_quat(t - h)) / (2 * h)
    return 2.0 * dp.quat_mul(dp.quat_conj(q), dq)[:, :3]


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


def lagged_recording(
    lag: float, seconds: float = 32.0, *, rate: float = 200.0, rest_seconds: float = 2.0, seed: int = 0
) -> LaggedRecording:
    """``rest_seconds`` at rest (the motion frozen at its start), then the tumbling motion; the magnetometer lags.

    Noise (seeded): gyroscope 0.005 rad/s, accelerometer 0.02 m/s², magnetometer 0.3 µT per sample; no bias, no
    linear acceleration, field :data:`FIELD_ENU`.

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
    seed : int
        Noise seed.

    Returns
    -------
    LaggedRecording
    """
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate)) / rate
    tm = np.maximum(t - rest_seconds, 0.0)  # motion time: frozen during the rest
    moving = t >= rest_seconds
    gyr = np.where(moving[:, None], tumbling_body_rate(tm), 0.0) + rng.normal(0.0, 0.005, (t.size, 3))
    q = tumbling_quat(tm)
    acc = dp.quat_rotate(dp.quat_conj(q), np.broadcast_to([0.0, 0.0, 9.81], (t.size, 3)))
    acc = acc + rng.normal(0.0, 0.02, (t.size, 3))
    q_mag = tumbling_quat(np.maximum(tm - lag, 0.0))
    mag = dp.quat_rotate(dp.quat_conj(q_mag), np.broadcast_to(FIELD_ENU, (t.size, 3)))
    mag = mag + rng.normal(0.0, 0.3, (t.size, 3))
    return LaggedRecording(gyr, acc, mag, int(round(rest_seconds * rate)), moving, q, float(rate))
