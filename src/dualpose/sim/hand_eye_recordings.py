"""Seeded hand–eye recordings of three kinds, with known ``X`` and time offset ``τ``.

The body (robot hand or motion-capture marker) moves between random waypoints along minimum-jerk segments (Flash &
Hogan, J. Neurosci. 5(7), 1985: ``s(u) = 10u³ − 15u⁴ + 6u⁵``; SLERP of the orientation, linear position), optionally
dwelling at each waypoint.  The camera, rigidly mounted with pose ``X`` in the body frame, sees a fixed target ``T``:
its pose in the target is ``A = T⁻¹ B(s + τ) X`` at camera stamp ``s`` (camera time ``s`` ↔ body time ``s + τ``).

Kinds (:data:`HAND_EYE_KINDS`):

* ``"arm"`` — a robot arm with a perfect camera model: exact hand poses at 50 Hz, camera poses at 20 Hz with small
  noise (0.02°, 0.2 mm), dwelling at the waypoints;
* ``"handheld"`` — a hand-held rig: marker at 100 Hz (0.05°, 0.3 mm), camera at 30 Hz (0.2°, 2 mm), continuous
  motion, meant for offsets of minutes to hours;
* ``"sparse"`` — sparse, noisy motion capture: marker at 20 Hz (0.3°, 2 mm), camera at the same rate (0.4°, 4 mm)
  and 5% outlier detections; the clocks tick at commensurate rates, so the loop residual has local minima in ``τ``.

Frames and layouts: positions in metres, quaternions xyzw (sensor/body -> reference), stamps in seconds of each
stream's own clock (the body clock starts at 1.6e9 s).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

import dualpose as dp

__all__ = ["HAND_EYE_KINDS", "HandEyeRecording", "simulate_hand_eye"]

HAND_EYE_KINDS: dict[str, dict[str, float]] = {
    "arm": dict(duration=60.0, waypoints=25, rot_amp=0.5, pos_amp=0.15, dwell=0.3, body_rate=50.0, camera_rate=20.0,
                camera_deg=0.02, camera_m=2e-4, body_deg=0.0, body_m=0.0, outliers=0.0),
    "handheld": dict(duration=60.0, waypoints=60, rot_amp=0.6, pos_amp=0.2, dwell=0.0, body_rate=100.0,
                     camera_rate=30.0, camera_deg=0.2, camera_m=2e-3, body_deg=0.05, body_m=3e-4, outliers=0.0),
    "sparse": dict(duration=60.0, waypoints=50, rot_amp=0.5, pos_amp=0.3, dwell=0.0, body_rate=20.0, camera_rate=20.0,
                   camera_deg=0.4, camera_m=4e-3, body_deg=0.3, body_m=2e-3, outliers=0.05),
}  # fmt: skip


@dataclass(frozen=True)
class HandEyeRecording:
    """A simulated pair of pose streams and the truth.

    Attributes
    ----------
    camera_stamps, camera_positions, camera_quats : ndarray, shapes (n,), (n, 3), (n, 4)
        Camera in the target frame, camera clock (s, m, xyzw).
    body_stamps, body_positions, body_quats : ndarray, shapes (m,), (m, 3), (m, 4)
        Body in its reference frame, body clock.
    quat, translation : ndarray, shapes (4,), (3,)
        True ``X`` (camera -> body), xyzw with ``w >= 0``, metres.
    time_offset : float
        True ``τ`` (s).
    """

    camera_stamps: np.ndarray
    camera_positions: np.ndarray
    camera_quats: np.ndarray
    body_stamps: np.ndarray
    body_positions: np.ndarray
    body_quats: np.ndarray
    quat: np.ndarray
    translation: np.ndarray
    time_offset: float


def _waypoint_motion(
    rng: np.random.Generator, duration: float, n: int, rot_amp: float, pos_amp: float, dwell: float,
) -> Callable[[NDArray[np.float64]], tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """``pose(t)``: ``(q (n, 4) xyzw, p (n, 3) m)`` through ``n`` random waypoints, dwelling ``dwell`` of each
    segment (``duration`` s in all)."""
    rv, pos = rng.normal(scale=rot_amp, size=(n, 3)), rng.normal(scale=pos_amp, size=(n, 3))
    seg = duration / (n - 1)

    def pose(t: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        k = np.clip((t // seg).astype(int), 0, n - 2)
        u = np.clip((t - k * seg - dwell * seg) / ((1.0 - dwell) * seg), 0.0, 1.0)
        s = 10 * u**3 - 15 * u**4 + 6 * u**5
        q = dp.quat_slerp(dp.quat_from_rotvec(rv[k]), dp.quat_from_rotvec(rv[k + 1]), s)
        return q, pos[k] + s[:, None] * (pos[k + 1] - pos[k])

    return pose


def simulate_hand_eye(kind: str, seed: int, time_offset: float, **overrides: float) -> HandEyeRecording:
    """A recording of the given kind (a key of :data:`HAND_EYE_KINDS`).

    Parameters
    ----------
    kind : str
        ``"arm"``, ``"handheld"`` or ``"sparse"``.
    seed : int
        Seed of every random draw (motion, ``X``, target, noise).
    time_offset : float
        ``τ`` (s), any size.
    **overrides : float
        Replace entries of the kind's parameters (``duration`` s, ``waypoints``, ``rot_amp`` rad, ``pos_amp`` m,
        ``dwell`` fraction of a segment, rates Hz, noise standard deviations per component in deg and m,
        ``outliers`` fraction of camera samples).

    Raises
    ------
    ValueError
        Unknown kind or parameter.
    """
    if kind not in HAND_EYE_KINDS:
        raise ValueError(f"kind must be one of {sorted(HAND_EYE_KINDS)}; got {kind!r}")
    p = dict(HAND_EYE_KINDS[kind])
    unknown = set(overrides) - set(p)
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; expected some of {sorted(p)}")
    p.update(overrides)
    rng = np.random.default_rng(seed)
    pose = _waypoint_motion(rng, p["duration"], int(p["waypoints"]), p["rot_amp"], p["pos_amp"], p["dwell"])
    qx = dp.quat_canonical(dp.quat_from_rotvec(rng.normal(size=3)))
    tx = rng.uniform(-0.1, 0.1, 3)
    qt, tt = dp.quat_from_rotvec(rng.normal(size=3)), rng.normal(size=3) + np.array([0.0, 0.0, 1.0])
    tb = np.arange(0.0, p["duration"], 1.0 / p["body_rate"])
    qb, pb = pose(tb)
    qb = dp.quat_mul(dp.quat_from_rotvec(rng.normal(scale=np.deg2rad(p["body_deg"]), size=(len(tb), 3))), qb)
    pb = pb + rng.normal(scale=p["body_m"], size=pb.shape)
    s = np.arange(0.5, p["duration"] - 0.5, 1.0 / p["camera_rate"]) + rng.uniform(-1e-3, 1e-3)  # body time
    qa, ta = dp.qt_mul(*dp.qt_conj(qt, tt), *dp.qt_mul(*pose(s), qx, tx))
    qa = dp.quat_mul(qa, dp.quat_from_rotvec(rng.normal(scale=np.deg2rad(p["camera_deg"]), size=(len(s), 3))))
    ta = ta + rng.normal(scale=p["camera_m"], size=ta.shape)
    n_out = int(p["outliers"] * len(s))
    if n_out:
        bad = rng.choice(len(s), n_out, replace=False)
        qa[bad] = dp.quat_mul(dp.quat_from_rotvec(rng.normal(scale=0.3, size=(n_out, 3))), qa[bad])
        ta[bad] += rng.normal(scale=0.1, size=(n_out, 3))
    t0 = 1.6e9
    return HandEyeRecording(s - time_offset + t0, ta, qa, tb + t0, pb, qb, qx, tx, float(time_offset))
