"""Filter initialisation: static accelerometer (+ magnetometer) alignment and a body prior from a first-frame PnP.

Orientations ``q_wb`` (4,) xyzw body→world; error conventions as in :mod:`dualpose.fusion.eskf`
(``q = q̂ ⊗ Exp(δθ)``, body-frame δθ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import dualpose as dp
from dualpose.fusion.pnp import PnPResult

__all__ = ["StaticAlignment", "static_alignment", "body_pose_from_camera", "initial_state_from_rest_and_frame"]


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
    x = np.concatenate([p_wb, np.zeros(3), q_wb, al.gyro_bias, np.zeros(3)])
    P = np.zeros((15, 15))
    P[0:3, 0:3] = cov[0:3, 0:3]
    P[0:3, 6:9] = cov[0:3, 3:6]
    P[6:9, 0:3] = cov[3:6, 0:3]
    P[6:9, 6:9] = cov[3:6, 3:6]
    P[3:6, 3:6] = np.eye(3) * 1e-3**2
    t_rest = al.n_samples / rate
    P[9:12, 9:12] = np.eye(3) * (gyroscope_noise_density**2 / t_rest + 1e-4**2)
    P[12:15, 12:15] = np.eye(3) * accelerometer_initial_bias_sigma**2
    return x, P


def initial_state_from_run(run, rest_seconds: float = 0.9) -> tuple[np.ndarray, np.ndarray]:  # noqa: ANN001
    """:func:`initial_state_from_rest_and_frame` for a :class:`~dualpose.fusion.sim.SimulatedRun` (or any object with
    its fields): the IMU samples of the first ``rest_seconds`` s are the rest period, frame 0 gives the PnP pose
    (seeded RANSAC + Gauss–Newton, :func:`dualpose.fusion.pnp.solve_pnp_ransac`)."""
    from dualpose.fusion.pnp import solve_pnp_ransac

    rest = run.t < run.t[0] + rest_seconds
    pix, pts = run.frames.frame(0)
    first, _ = solve_pnp_ransac(pix, pts, run.camera.matrix, pixel_sigma=run.pixel_sigma)
    n = run.imu_noise
    return initial_state_from_rest_and_frame(
        run.accel[rest], run.gyro[rest], first, run.q_bc, run.p_bc, n.gyroscope_noise_density,
        n.accelerometer_initial_bias_sigma, n.update_rate,
    )  # fmt: skip
