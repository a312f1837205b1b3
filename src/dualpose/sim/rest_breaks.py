"""A seeded IMU recording of slow rotations with rest breaks and a drifting gyroscope bias (for the AHRS's rest
detector and bias update).

The shape of BROAD's "slow rotation with three breaks of 10 seconds" trials (Laidig et al. 2021): a rest period,
then segments of slow rotation separated by breaks in which the IMU is still.  The orientation is an analytic
function of a *motion clock* ``u(t)`` that advances at speed 1 inside a segment, ramps up and down smoothly over
``ramp`` seconds at its ends (``u̇ = sin²``) and stands still in the breaks: ``q(t) = Exp(φ(u(t)))`` with ``φ`` a sum
of sinusoids (rotation vector of ~1–2 rad at 0.03–0.05 Hz: ``|ω|`` up to ~25 °/s).  The gyroscope reads the body rate
``2 Im(q* ⊗ q̇)`` at the middle of each sampling interval (central difference with a 1 µs step), which is the rate
that, held over the interval, carries ``q_{k−1}`` to ``q_k`` to second order; in the breaks it is exactly zero.
The gyroscope bias is ``b0 + drift · t / duration`` plus a random walk of density ``bias_walk`` (MEMS class, the
AHRS's own :data:`~dualpose.estimation.ahrs.MEMS_GYRO_BIAS_RANDOM_WALK` by default), and optionally a
*motion-dependent offset* ``motion_bias · d · u̇`` (a fixed random direction d, full while the clock runs at speed 1,
none at rest): a bias in motion that differs from the bias at rest, as a gyroscope's g-sensitivity or vibration
rectification produces it, and optionally a slow *creep* rotation during the breaks (a break that is not
perfectly still): ``q(t) = Exp(φ(u(t))) ⊗ Exp(c(t))`` with ``c`` growing at a constant rate inside each break.  Used by
``tests/estimation/ahrs/test_ahrs_rest.py`` and ``benchmarks/bench_ahrs_rest.py`` (docs/broad.md, "Rest detector and
bias update").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import dualpose as dp
from dualpose.sim._imu_truth import FIELD_ENU, central_body_rate
from dualpose.types.imu import STANDARD_GRAVITY

__all__ = ["FIELD_ENU", "RestBreakRecording", "rest_break_recording"]


@dataclass(frozen=True)
class RestBreakRecording:
    """IMU samples with exact truth.

    Attributes
    ----------
    gyr, acc, mag : ndarray, shape (n, 3)
        rad/s, m/s², µT, IMU axes.
    quat : ndarray, shape (n, 4)
        True orientation body → ENU, xyzw, at the sample times.
    bias : ndarray, shape (n, 3)
        True gyroscope bias, rad/s.
    moving : ndarray of bool, shape (n,)
        Samples inside a rotation segment (the breaks and the initial rest are False).
    breaks : ndarray of int, shape (n_breaks, 2)
        First and one-past-last sample of each break.
    rate : float
        Sampling rate, Hz.
    n_rest : int
        Samples of the initial rest period.
    gyr_sigma, acc_sigma, mag_sigma : float
        Per-sample white-noise standard deviations, rad/s, m/s², µT.
    """

    gyr: np.ndarray
    acc: np.ndarray
    mag: np.ndarray
    quat: np.ndarray
    bias: np.ndarray
    moving: np.ndarray
    breaks: np.ndarray
    rate: float
    n_rest: int
    gyr_sigma: float
    acc_sigma: float
    mag_sigma: float

    @property
    def scored(self) -> NDArray[np.bool_]:
        """Samples after the initial rest period (segments and breaks), bool (n,)."""
        s = np.zeros(self.gyr.shape[0], dtype=bool)
        s[self.n_rest :] = True
        return s


def _motion_clock(t: np.ndarray, segments: np.ndarray, ramp: float) -> NDArray[np.float64]:
    """u(t) (s): the time spent moving so far, with u̇ = sin²(π τ / 2) over the ``ramp`` seconds at each end."""
    u = np.zeros_like(t)
    for s, e in segments:  # a handful of segments: a loop over segments, not samples

        def ramp_integral(x: np.ndarray) -> np.ndarray:  # ∫_0^x sin²(π ξ / (2 ramp)) dξ, x in [0, ramp]
            return x / 2.0 - ramp * np.sin(np.pi * x / ramp) / (2.0 * np.pi)

        d = np.clip(t - s, 0.0, e - s)
        full = ramp_integral(np.float64(ramp))
        up = ramp_integral(np.minimum(d, ramp))
        mid = np.clip(d - ramp, 0.0, e - s - 2.0 * ramp)
        tail = np.clip(d - (e - s - ramp), 0.0, ramp)
        down = full - ramp_integral(ramp - tail)
        u += up + mid + down
    return u


def _rotvec(u: np.ndarray) -> NDArray[np.float64]:
    return np.stack(
        [
            1.0 * np.sin(2 * np.pi * 0.031 * u + 0.3),
            0.7 * np.sin(2 * np.pi * 0.047 * u + 1.1),
            2.0 * np.sin(2 * np.pi * 0.023 * u + 0.4),
        ],
        axis=-1,
    )


def rest_break_recording(
    seed: int = 0,
    *,
    rate: float = 100.0,
    rest: float = 5.0,
    segment: float = 25.0,
    pause: float = 10.0,
    n_breaks: int = 3,
    ramp: float = 2.0,
    gyr_sigma: float = 0.003,
    acc_sigma: float = 0.03,
    mag_sigma: float = 0.4,
    bias_walk: float = 1.0e-4,
    drift: float = np.radians(0.3),
    lin_acc: float = 0.2,
    motion_bias: float = 0.0,
    creep: float = 0.0,
) -> RestBreakRecording:
    """Simulate the recording (module docstring).

    Parameters
    ----------
    seed : int
        Seed of the noise, the bias random walk and the directions of the initial bias and its drift.
    rate : float
        Hz.
    rest, segment, pause : float
        Seconds of the initial rest, of each rotation segment and of each break.
    n_breaks : int
        Breaks (the recording has ``n_breaks + 1`` segments and ends at the last one's end).
    ramp : float
        Seconds over which the rotation speeds up and slows down at each segment's ends.
    gyr_sigma, acc_sigma, mag_sigma : float
        Per-sample white noise, rad/s, m/s², µT.
    bias_walk : float
        Bias random-walk density, rad/s²/√Hz.
    drift : float
        Magnitude of the bias's linear drift over the whole recording, rad/s (warm-up class), random direction.
    lin_acc : float
        Amplitude of the hand-like linear acceleration during the segments, m/s².
    motion_bias : float
        Magnitude of the motion-dependent bias offset, rad/s (default 0: the bias is the same at rest and in
        motion).  Its direction is drawn after every other random number, so the recording is otherwise the one
        without it.
    creep : float
        Rate (rad/s) of a slow rotation about a random axis (one per break) during each break, the residual motion
        of an object that is set down or held still (default 0: perfectly still breaks).  Its axes come from a second
        random number generator (seeded with ``[seed, 1]``), so the recording is otherwise the one without it.

    Returns
    -------
    RestBreakRecording
    """
    rng = np.random.default_rng(seed)
    starts = rest + np.arange(n_breaks + 1) * (segment + pause)
    segments = np.stack([starts, starts + segment], axis=1)
    duration = float(segments[-1, 1])
    n = int(round(duration * rate))
    dt = 1.0 / rate
    t = np.arange(n) * dt

    ends = segments[:-1, 1]
    creep_rates = np.zeros((n_breaks, 3))

    def quat_at(times: np.ndarray) -> NDArray[np.float64]:
        q = dp.quat_from_rotvec(_rotvec(_motion_clock(times, segments, ramp)))
        if not creep:
            return q
        c = np.clip(np.asarray(times)[:, None, None] - ends[None, :, None], 0.0, pause) * creep_rates[None]
        return dp.quat_mul(q, dp.quat_from_rotvec(c.sum(axis=1)))

    if creep:  # drawn after everything else (below) would change the other draws; the rates come from a child
        d = np.random.default_rng([seed, 1]).normal(size=(n_breaks, 3))
        creep_rates[:] = creep * d / np.linalg.norm(d, axis=1, keepdims=True)
    u = _motion_clock(t, segments, ramp)
    quat = quat_at(t)
    # body rate held over (t_{k−1}, t_k]: the analytic rate at the interval's middle
    w = central_body_rate(quat_at, t - 0.5 * dt)
    moving = np.zeros(n, dtype=bool)
    for s, e in segments:
        moving |= (t >= s) & (t < e)
    speed = np.gradient(u, dt)
    b0 = rng.normal(scale=np.radians(0.5) / np.sqrt(3.0), size=3)
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    bias = (
        b0
        + drift * direction * (t / duration)[:, None]
        + np.cumsum(rng.normal(scale=bias_walk * np.sqrt(dt), size=(n, 3)), axis=0)
    )
    a_lin = lin_acc * speed[:, None] * np.stack(
        [np.sin(2 * np.pi * 0.6 * t), np.sin(2 * np.pi * 0.9 * t + 0.4), 0.5 * np.sin(2 * np.pi * 0.4 * t)], axis=1
    )
    conj = dp.quat_conj(quat)
    gyr_noise = rng.normal(scale=gyr_sigma, size=(n, 3))
    acc = dp.quat_rotate(conj, a_lin + [0.0, 0.0, STANDARD_GRAVITY]) + rng.normal(scale=acc_sigma, size=(n, 3))
    mag = dp.quat_rotate(conj, np.broadcast_to(FIELD_ENU, (n, 3))) + rng.normal(scale=mag_sigma, size=(n, 3))
    if motion_bias:
        d = rng.normal(size=3)
        bias = bias + motion_bias * (d / np.linalg.norm(d)) * np.clip(speed, 0.0, 1.0)[:, None]
    gyr = w + bias + gyr_noise
    breaks = np.stack([np.round(ends * rate), np.round((ends + pause) * rate)], axis=1).astype(np.int64)
    return RestBreakRecording(
        gyr=gyr, acc=acc, mag=mag, quat=quat, bias=bias, moving=moving, breaks=breaks, rate=float(rate),
        n_rest=int(round(rest * rate)), gyr_sigma=gyr_sigma, acc_sigma=acc_sigma, mag_sigma=mag_sigma,
    )  # fmt: skip
