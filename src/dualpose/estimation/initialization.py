"""Filter initialisation: static accelerometer (+ magnetometer) alignment and a body prior from a first-frame PnP.

Orientations ``q_wb`` (4,) xyzw body→world; error conventions as in :mod:`dualpose.estimation.eskf`
(``q = q̂ ⊗ Exp(δθ)``, body-frame δθ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import dualpose as dp
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE
from dualpose.registration.pnp import PnPResult, solve_pnp_ransac

__all__ = [
    "StaticAlignment",
    "static_alignment",
    "body_pose_from_camera",
    "initial_state_from_rest_and_frame",
    "detect_rest",
    "initial_state_from_run",
]


@dataclass
class StaticAlignment:
    """``q_wb`` (4,) levelled orientation (yaw 0, or from the magnetometer), ``gyro_bias`` (3,) rad/s mean gyro,
    ``specific_force`` (3,) mean accelerometer (m/s²), ``n_samples``."""

    q_wb: np.ndarray
    gyro_bias: np.ndarray
    specific_force: np.ndarray
    n_samples: int


def static_alignment(
    accel: np.ndarray,
    gyro: np.ndarray,
    gravity: np.ndarray = (0.0, 0.0, -9.81),
    mag: np.ndarray | None = None,
    field_w: np.ndarray | None = None,
) -> StaticAlignment:
    """Level the body from accelerometer samples taken at rest (and fix yaw from a magnetometer if given).

    At rest ``accel ≈ −R_wbᵀ g_w``, so the mean specific force is the body-frame "up" direction; the returned
    ``q_wb`` is the smallest rotation taking it onto ``−g_w`` (yaw about ``g_w`` is unobservable and set to 0),
    or, with ``mag`` (N, 3) and ``field_w`` (3,), the TRIAD solution (gravity exact, field horizontal component).

    Parameters
    ----------
    accel, gyro : (N, 3) body-frame samples at rest (m/s², rad/s).
    """
    accel = np.asarray(accel, dtype=np.float64)
    gyro = np.asarray(gyro, dtype=np.float64)
    if accel.ndim != 2 or accel.shape[1] != 3 or gyro.shape != accel.shape:
        raise ValueError(f"accel and gyro must both have shape (N, 3); got {accel.shape} and {gyro.shape}")
    f = accel.mean(axis=0)
    up_w = -np.asarray(gravity, float) / np.linalg.norm(gravity)
    up_b = f / np.linalg.norm(f)
    if mag is None:
        axis = np.cross(up_b, up_w)
        s, c = np.linalg.norm(axis), float(up_b @ up_w)
        rotvec = np.zeros(3) if s < 1e-15 else axis / s * np.arctan2(s, c)
        q = dp.quat_from_rotvec(rotvec)
    else:
        if field_w is None:
            raise ValueError("field_w (3,) is required with mag")
        m_b = np.asarray(mag, float).mean(axis=0)

        def triad(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            t1 = a / np.linalg.norm(a)
            t2 = np.cross(a, b)
            t2 /= np.linalg.norm(t2)
            return np.stack([t1, t2, np.cross(t1, t2)], axis=1)

        q = dp.quat_from_matrix(triad(up_w, np.asarray(field_w, float)) @ triad(up_b, m_b).T)
    return StaticAlignment(q_wb=q, gyro_bias=gyro.mean(axis=0), specific_force=f, n_samples=len(accel))


def body_pose_from_camera(
    pnp: PnPResult, q_bc: np.ndarray, p_bc: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body pose ``(p_wb (3,), q_wb (4,), covariance (6, 6) over [δp, δθ_b])`` from a camera PnP pose.

    ``R_wb = R_wc R_bcᵀ``, ``p_wb = c_w − R_wb p_bc``; errors map as ``δθ_b = R_bc δθ_c`` and
    ``δp = δc + R_wb [p_bc]× δθ_b``.
    """
    q_bc = np.asarray(q_bc, float)
    p_bc = np.asarray(p_bc, float)
    q_wb = dp.quat_mul(pnp.q_wc, dp.quat_conj(q_bc))
    p_wb = pnp.c_w - dp.quat_rotate(q_wb, p_bc)
    R_bc = dp.matrix_from_quat(q_bc)
    R_wb = dp.matrix_from_quat(q_wb)
    J = np.zeros((6, 6))  # [δp, δθ_b] from [δθ_c, δc]
    J[3:6, 0:3] = R_bc
    J[0:3, 3:6] = np.eye(3)
    J[0:3, 0:3] = R_wb @ dp.so3_hat(p_bc) @ R_bc
    cov = J @ pnp.covariance @ J.T
    return p_wb, q_wb, 0.5 * (cov + cov.T)


def initial_state_from_rest_and_frame(
    accel_rest: np.ndarray,
    gyro_rest: np.ndarray,
    pnp: PnPResult,
    q_bc: np.ndarray,
    p_bc: np.ndarray,
    gyroscope_noise_density: float,
    accelerometer_initial_bias_sigma: float,
    rate: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Error-state-filter start ``(x (16,), P0 (15, 15))`` for a sensor at rest seeing the scene.

    Pose from the first-frame PnP (its covariance), zero velocity (σ 1 mm/s), gyro bias = mean gyro at rest
    (σ = noise density / √T_rest), accelerometer bias 0 with its turn-on σ (at rest it is not separable from tilt).
    """
    al = static_alignment(accel_rest, gyro_rest)
    p_wb, q_wb, cov = body_pose_from_camera(pnp, q_bc, p_bc)
    x = ESKF_STATE.assemble(position=p_wb, velocity=np.zeros(3), quat=q_wb, gyro_bias=al.gyro_bias,
                            accel_bias=np.zeros(3))  # fmt: skip
    E = ESKF_ERROR
    P = np.zeros((E.dim, E.dim))
    pose = [E.slice("position"), E.slice("attitude")]  # the order of cov's [δp, δθ_b]
    for i, a in enumerate(pose):
        for j, b in enumerate(pose):
            P[a, b] = cov[3 * i : 3 * i + 3, 3 * j : 3 * j + 3]
    E.cov(P, "velocity")[:] = np.eye(3) * 1e-3**2
    t_rest = al.n_samples / rate
    E.cov(P, "gyro_bias")[:] = np.eye(3) * (gyroscope_noise_density**2 / t_rest + 1e-4**2)
    E.cov(P, "accel_bias")[:] = np.eye(3) * accelerometer_initial_bias_sigma**2
    return x, P


def detect_rest(
    t: np.ndarray,
    gyro: np.ndarray,
    accel: np.ndarray,
    gyroscope_noise_density: float,
    accelerometer_noise_density: float,
    window_s: float = 0.2,
    threshold_sigma: float = 5.0,
    noise_from_samples: bool = False,
) -> float:
    """Length (s) of the rest period at the start of an IMU stream, from the samples themselves.

    The stream is cut into windows of ``window_s``; the rest ends before the first window whose mean gyro or
    accelerometer reading differs from the first window's on some axis by more than ``threshold_sigma`` times the
    standard deviation of that difference under white noise alone (``σ_d = density · √(rate) · √(2 / m)`` for
    m samples per window), or whose sample standard deviation exceeds 3 × the white-noise one (vibration).
    The first window is assumed to be at rest.  ``noise_from_samples``: for a platform that vibrates at rest (a
    multirotor with its rotors spinning), the per-sample σ of each axis is the largest of the white-noise one and
    the sample standard deviations of the first and the tested window, and the vibration test is skipped: the rest
    ends when the window means move.

    Parameters
    ----------
    t : (N,) s.  gyro, accel : (N, 3) rad/s, m/s².
    gyroscope_noise_density, accelerometer_noise_density : float
        Kalibr white-noise densities (rad/s/√Hz, m/s²/√Hz).

    Returns
    -------
    float
        End of the last rest window minus ``t[0]``, seconds (a whole number of windows, at least one).
    """
    t = np.asarray(t, dtype=np.float64)
    rate = 1.0 / float(np.median(np.diff(t)))
    m = max(int(round(window_s * rate)), 3)
    nw = len(t) // m
    if nw < 1:
        raise ValueError(f"the IMU stream ({len(t)} samples) is shorter than one rest-detection window ({m})")
    out = nw
    for sig, data in ((gyroscope_noise_density, gyro), (accelerometer_noise_density, accel)):
        w = np.asarray(data, dtype=np.float64)[: nw * m].reshape(nw, m, 3)
        mean, std = w.mean(axis=1), w.std(axis=1)
        s_sample = max(sig, 1e-12) * np.sqrt(rate)
        if noise_from_samples:
            s_axis = np.maximum(s_sample, np.maximum(std[0], std))
            moving = np.any(np.abs(mean - mean[0]) > threshold_sigma * s_axis * np.sqrt(2.0 / m), axis=1)
        else:
            moving = np.any(np.abs(mean - mean[0]) > threshold_sigma * s_sample * np.sqrt(2.0 / m), axis=1)
            moving |= np.any(std > 3.0 * s_sample, axis=1)
        if moving.any():
            out = min(out, int(np.argmax(moving)))
    out = max(out, 1)
    return float(t[out * m - 1] - t[0]) if out * m - 1 < len(t) else float(t[-1] - t[0])


def initial_state_from_run(run, rest_seconds: float | None = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """:func:`initial_state_from_rest_and_frame` for a :class:`~dualpose.sim.SimulatedRun` or a
    :class:`~dualpose.types.recording.Recording` (any object with their fields ``t``, ``gyro``, ``accel``,
    ``frames``, ``camera``, ``pixel_sigma``, ``q_bc``, ``p_bc``, ``imu_noise`` and ``time_offset``).

    The IMU samples of the first ``rest_seconds`` s are the rest period (None: :func:`detect_rest` with the
    run's noise densities); the first frame captured during the rest with at least 6 correspondences gives the
    PnP pose (seeded RANSAC + Gauss–Newton, :func:`dualpose.registration.pnp.solve_pnp_ransac`).  The pose at that
    frame is the pose at ``t[0]`` because the body is at rest.

    Raises
    ------
    ValueError
        No camera frame with >= 6 correspondences during the rest period.
    """
    n = run.imu_noise
    if rest_seconds is None:
        rest_seconds = detect_rest(run.t, run.gyro, run.accel, n.gyroscope_noise_density, n.accelerometer_noise_density)
    rest = run.t < run.t[0] + rest_seconds
    t_frames = np.asarray(run.frames.t) + getattr(run, "time_offset", 0.0)
    usable = (t_frames >= run.t[0]) & (t_frames <= run.t[0] + rest_seconds) & (np.diff(run.frames.offsets) >= 6)
    if not usable.any():
        raise ValueError(
            f"no camera frame with >= 6 correspondences during the rest period [{run.t[0]:.6f}, "
            f"{run.t[0] + rest_seconds:.6f}] s (IMU clock): the filter starts from a first-frame PnP at rest"
        )
    pix, pts = run.frames.frame(int(np.argmax(usable)))
    first, _ = solve_pnp_ransac(pix, pts, run.camera.matrix, pixel_sigma=run.pixel_sigma)
    return initial_state_from_rest_and_frame(
        run.accel[rest], run.gyro[rest], first, run.q_bc, run.p_bc, n.gyroscope_noise_density,
        n.accelerometer_initial_bias_sigma, n.update_rate,
    )  # fmt: skip
