"""Leader–follower relative pose from gyro and dual increments (paper §"Simulation results"; docs/inertial.md §6).

The leader sits at the inertial origin and only rotates (attitude from its gyro increments with the N-sample
rotation-vector algorithm); the follower moves with a general screw motion (pose from its dual increments with the
N-sample screw-vector algorithm).  The relative pose ``q̂_LF = q̂_L* (x) q̂_F`` is compared with the exact one.

The paper's motion parameters were lost in extraction; :class:`Scenario` documents the motion used here:

* leader: classical coning, half-angle 0.2 rad, 0.2 Hz (``Ω = 0.4π rad/s``);
* follower: dual coning, half-angle 0.1 rad, 0.5 Hz (``Ω = π rad/s``), radius 1 m (its origin runs on a circle
  while its axes cone: at every instant a screw motion with a rotating axis);
* sub-interval ``h = 10 ms`` (100 Hz increments), so the N-sample update period is ``N h``.

Both motions have closed-form increments (:class:`dualpose.inertial.motions.Coning`), so long runs (1e5 s,
1e7 increments) are generated and integrated in chunks without storing them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

import dualpose as dp
from dualpose.inertial.integrate import integrate_attitude, integrate_pose, relative_pose
from dualpose.inertial.motions import Coning

__all__ = ["Scenario", "simulate", "summarize"]


@dataclass(frozen=True)
class Scenario:
    """Leader (attitude only) and follower (pose) motions and the increment length ``h`` (s)."""

    leader: Coning = field(default_factory=lambda: Coning(0.2, 0.4 * math.pi))
    follower: Coning = field(default_factory=lambda: Coning(0.1, math.pi, 1.0))
    h: float = 0.01


def _exact_relative(sc: Scenario, t: np.ndarray) -> np.ndarray:
    return relative_pose(sc.leader.attitude(t), sc.follower.pose(t))


def simulate(
    sc: Scenario,
    samples: int,
    duration: float,
    points: int = 2000,
    chunk_updates: int = 100_000,
    progress: Callable[[float], None] | None = None,
) -> dict[str, np.ndarray]:
    """Integrate leader and follower with the N-sample coning-optimal algorithms and return the errors.

    Parameters
    ----------
    sc : Scenario
    samples : int
        N (1..4): increments per update, for both the rotation-vector (leader) and screw-vector (follower) update.
    duration : float
        Seconds; rounded to a whole number of updates.
    points : int
        About this many error samples are returned (every ``K // points``-th update).
    chunk_updates : int
        Updates generated and integrated at a time (bounds the memory for long runs).
    progress : callable, optional
        Called with the completed fraction (0..1] after each chunk.

    Returns
    -------
    dict
        ``t`` (s), ``attitude_error`` (rad; angle of the relative-attitude error), ``position_error`` (m; norm of the
        relative-position error, leader axes), ``attitude_error_rotvec`` (rad; relative attitude with the follower
        attitude from the rotation-vector algorithm instead of the real part of the screw-vector one), all shape
        ``(P,)``.
    """
    T = samples * sc.h
    k_total = max(1, int(round(duration / T)))
    stride = max(1, k_total // points)
    q_l = sc.leader.attitude(0.0)
    s_f = sc.follower.pose(0.0)
    q_f = s_f[:4]
    out: dict[str, list[np.ndarray]] = {
        k: [] for k in ("t", "attitude_error", "position_error", "attitude_error_rotvec")
    }
    k = 0
    while k < k_total:
        kc = min(chunk_updates, k_total - k)
        t0 = k * T
        inc_l = sc.leader.increments(t0, sc.h, kc * samples)
        inc_f = sc.follower.dual_increments(t0, sc.h, kc * samples)
        lead = integrate_attitude(q_l, inc_l, samples)
        foll = integrate_pose(s_f, inc_f, samples)
        foll_q = integrate_attitude(q_f, inc_f[:, :3], samples)
        j = np.arange(1 if k else 0, kc + 1)
        j = j[((k + j) % stride == 0) | (k + j == k_total)]
        t = (k + j) * T
        true = _exact_relative(sc, t)
        est = relative_pose(lead[j], foll[j])
        est_rv = dp.quat_mul(dp.quat_conj(lead[j]), foll_q[j])
        out["t"].append(t)
        out["attitude_error"].append(dp.quat_angle(est[:, :4], true[:, :4]))
        out["position_error"].append(
            np.linalg.norm(dp.qt_from_dualquat(est)[1] - dp.qt_from_dualquat(true)[1], axis=-1)
        )
        out["attitude_error_rotvec"].append(dp.quat_angle(est_rv, true[:, :4]))
        q_l, s_f, q_f = lead[-1], foll[-1], foll_q[-1]
        k += kc
        if progress is not None:
            progress(k / k_total)
    return {key: np.concatenate(v) for key, v in out.items()}


def summarize(res: dict[str, np.ndarray]) -> dict[str, float]:
    """The numbers ``dualpose reproduce screw-vector`` reports for one :func:`simulate` result: duration (s), final
    and largest attitude error (rad) and position error (m), the position-error growth (m/s, least-squares slope
    through the origin) and the largest difference of the rotation-vector and screw-vector attitude errors (rad)."""
    t, pos, att = res["t"], res["position_error"], res["attitude_error"]
    slope = float(np.dot(t, pos) / np.dot(t, t)) if np.dot(t, t) > 0 else 0.0
    return {
        "duration_s": float(t[-1]),
        "attitude_error_final_rad": float(att[-1]),
        "attitude_error_max_rad": float(att.max()),
        "position_error_final_m": float(pos[-1]),
        "position_error_max_m": float(pos.max()),
        "position_error_growth_m_per_s": slope,
        "rotvec_minus_screw_attitude_error_max_rad": float(np.abs(res["attitude_error_rotvec"] - att).max()),
    }
