"""Filter initialisation: static accelerometer (+ magnetometer) alignment and a body prior from a first-frame PnP;
for a sensor that is already moving, the visual-inertial alignment of :func:`align_with_camera_poses` (gyro bias,
gravity in the scene frame, velocities and accelerometer bias from the camera poses of the first seconds).

Orientations ``q_wb`` (4,) xyzw body→world; error conventions as in :mod:`dualpose.estimation.eskf`
(``q = q̂ ⊗ Exp(δθ)``, body-frame δθ).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import sparse
from scipy.sparse.linalg import splu

import dualpose as dp
from dualpose.calibration.static import _StaticRun
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE
from dualpose.registration.pnp import PnPResult, solve_pnp_ransac
from dualpose.types._inputs import Doubt, gravity_sigma_doubt, rest_gravity_sigma

__all__ = [
    "StaticAlignment",
    "static_alignment",
    "body_pose_from_camera",
    "initial_state_from_rest_and_frame",
    "detect_rest",
    "initial_state_from_run",
    "CameraImuAlignment",
    "align_with_camera_poses",
]


@dataclass
class StaticAlignment:
    """``q_wb`` (4,) levelled orientation (yaw 0, or from the magnetometer), ``gyro_bias`` (3,) rad/s mean gyro,
    ``specific_force`` (3,) mean accelerometer (m/s²), ``n_samples``; ``gravity_sigma`` the 1σ of the gravity
    direction (rad, ``dualpose.types._inputs.rest_gravity_sigma``: the samples' spread, floored at the
    accelerometer's white noise when :func:`static_alignment` is given it, over ``N``), which bounds the tilt of
    ``q_wb``."""

    q_wb: np.ndarray
    gyro_bias: np.ndarray
    specific_force: np.ndarray
    n_samples: int
    gravity_sigma: float = math.nan

    def gravity_doubt(self, where: str) -> Doubt | None:
        """The shared rule on ``gravity_sigma`` (``dualpose.types._inputs.gravity_sigma_doubt``): a
        ValueError naming ``where`` when the rest period does not determine the gravity direction (σ above 5°), a
        ``"gravity_sigma"`` doubt above 1°, else None."""
        return gravity_sigma_doubt(self.gravity_sigma, where, f"the {self.n_samples} accelerometer samples at rest")


def static_alignment(
    accel: np.ndarray,
    gyro: np.ndarray,
    gravity: ArrayLike = (0.0, 0.0, -9.81),
    mag: np.ndarray | None = None,
    field_w: np.ndarray | None = None,
    accelerometer_noise_density: float = 0.0,
    rate: float = 0.0,
) -> StaticAlignment:
    """Level the body from accelerometer samples taken at rest (and fix yaw from a magnetometer if given).

    At rest ``accel ≈ −R_wbᵀ g_w``, so the mean specific force is the body-frame "up" direction; the returned
    ``q_wb`` is the smallest rotation taking it onto ``−g_w`` (yaw about ``g_w`` is unobservable and set to 0),
    or, with ``mag`` (N, 3) and ``field_w`` (3,), the TRIAD solution (gravity exact, field horizontal component).

    Parameters
    ----------
    accel, gyro : (N, 3) body-frame samples at rest (m/s², rad/s).
    accelerometer_noise_density, rate : the accelerometer's white noise (m/s²/√Hz) and sampling rate (Hz), the floor
        of the spread that ``gravity_sigma`` is computed from (0: the samples' spread alone).
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
    return StaticAlignment(q_wb=q, gyro_bias=gyro.mean(axis=0), specific_force=f, n_samples=len(accel),
                           gravity_sigma=rest_gravity_sigma(accel, accelerometer_noise_density, rate))


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


class _RunAtRest(_StaticRun, Protocol):
    """The fields of a run :func:`initial_state_from_run` reads (``time_offset`` too when it has one): those of a
    static period's run, the gyro and the extrinsic."""

    @property
    def gyro(self) -> np.ndarray: ...
    @property
    def q_bc(self) -> np.ndarray: ...
    @property
    def p_bc(self) -> np.ndarray: ...


def initial_state_from_run(run: _RunAtRest, rest_seconds: float | None = 0.9) -> tuple[np.ndarray, np.ndarray]:
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


@dataclass
class CameraImuAlignment:
    """Result of :func:`align_with_camera_poses` (frames: scene/world ``w``, body ``b``).

    Attributes
    ----------
    gravity : ndarray, shape (3,)
        Gravity in the scene frame, m/s²: the estimated direction scaled to the given magnitude (what the filter
        uses).
    gravity_estimated : ndarray, shape (3,)
        The unconstrained least-squares gravity vector, m/s² (its magnitude is a check of the accelerometer).
    gravity_sigma_deg : float
        1σ of the gravity direction (root of the tangent-plane covariance trace), degrees.
    velocity : ndarray, shape (K, 3)
        Body velocity in the scene frame at each frame time, m/s.
    velocity_sigma : float
        1σ per axis (root of the mean diagonal) of the first frame's velocity, m/s.
    gyro_bias, accel_bias : ndarray, shape (3,)
        rad/s, m/s² (as given, or estimated).
    accel_bias_sigma : float
        1σ per axis of the estimated accelerometer bias (0 when it was given), m/s².
    residual_rms : float
        RMS of the whitened least-squares residuals (≈ 1 when the stated sigmas fit).
    doubt : Doubt or None
        ``"gravity_sigma"`` when ``gravity_sigma_deg`` exceeds 1° (``dualpose.types._inputs.gravity_sigma_doubt``;
        above 5° the alignment is refused).
    """

    gravity: np.ndarray
    gravity_estimated: np.ndarray
    gravity_sigma_deg: float
    velocity: np.ndarray
    velocity_sigma: float
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    accel_bias_sigma: float
    residual_rms: float
    doubt: Doubt | None = None


def _interval_samples(
    t: NDArray[np.float64], gyro: NDArray[np.float64], accel: NDArray[np.float64], frame_t: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Sub-steps of every frame interval ``[frame_t[k], frame_t[k+1]]``: the IMU samples inside plus the linearly
    interpolated ends, padded with zero-length steps to a common count.  Returns ``(dt (K-1, L), gyro, accel
    (K-1, L + 1, 3))``: step j runs from node j to node j + 1."""
    lo = np.searchsorted(t, frame_t[:-1], side="right")
    hi = np.searchsorted(t, frame_t[1:], side="left")
    inside = hi - lo
    L = int(inside.max()) + 1
    j = np.arange(L + 1)
    idx = lo[:, None] + j[None, :] - 1  # node j (1..inside) is sample lo + j - 1
    node_t = t[np.clip(idx, 0, len(t) - 1)]
    node_t[:, 0] = frame_t[:-1]
    last = inside + 1
    node_t = np.where(j[None, :] >= last[:, None], frame_t[1:, None], node_t)
    g = np.stack([np.interp(node_t, t, gyro[:, i]) for i in range(3)], axis=-1)
    a = np.stack([np.interp(node_t, t, accel[:, i]) for i in range(3)], axis=-1)
    return np.diff(node_t, axis=1), g, a


def _preintegrate(
    dt: NDArray[np.float64], g: NDArray[np.float64], a: NDArray[np.float64], gyro_bias: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Trapezoidal preintegration over every interval (vectorised over intervals, a loop over the L sub-steps):
    ``ΔR`` (K-1, 3, 3), position and velocity increments ``α, β`` (K-1, 3) in the frame of the interval's start, and
    their derivatives ``Jα, Jβ`` (K-1, 3, 3) with respect to a constant accelerometer bias (``α(b) = α − Jα b``)."""
    n = dt.shape[0]
    R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    al, be = np.zeros((n, 3)), np.zeros((n, 3))
    Ja, Jb = np.zeros((n, 3, 3)), np.zeros((n, 3, 3))
    for j in range(dt.shape[1]):
        h = dt[:, j]
        w = 0.5 * (g[:, j] + g[:, j + 1]) - gyro_bias
        R1 = R @ dp.matrix_from_quat(dp.quat_from_rotvec(w * h[:, None]))
        f = 0.5 * (np.einsum("nij,nj->ni", R, a[:, j]) + np.einsum("nij,nj->ni", R1, a[:, j + 1]))
        Rm = 0.5 * (R + R1)
        al += be * h[:, None] + 0.5 * f * (h * h)[:, None]
        Ja += Jb * h[:, None, None] + 0.5 * Rm * (h * h)[:, None, None]
        be += f * h[:, None]
        Jb += Rm * h[:, None, None]
        R = R1
    return R, al, be, Ja, Jb


def align_with_camera_poses(
    t: np.ndarray,
    gyro: np.ndarray,
    accel: np.ndarray,
    frame_t: np.ndarray,
    p_wb: np.ndarray,
    q_wb: np.ndarray,
    gravity_magnitude: float,
    position_sigma: float,
    attitude_sigma: float,
    accelerometer_noise_density: float,
    gyro_bias: np.ndarray | None = None,
    accel_bias: np.ndarray | None = None,
) -> CameraImuAlignment:
    """Visual-inertial alignment of a moving sensor from camera poses (a short batch, linear least squares).

    Hol (2008) aligns the scene with gravity from accelerometer readings taken while the camera pose is known;
    for a sensor that never rests, the accelerometer's specific force has to be corrected for the motion, which the
    camera poses give.  With ``K`` camera-derived body poses ``(p_k, R_k)`` over a short window:

    1. **gyro bias** (unless given): the rotation of the bias-corrected gyro between consecutive frames must equal
       ``R_kᵀ R_k+1``; ``Log(ΔR_gyro(b)ᵀ R_kᵀ R_k+1) ≈ r_k + Δt_k b`` is solved for ``b`` (two Gauss–Newton
       passes; the sum telescopes, so the pose noise enters only through the first and last frames);
    2. **preintegration** between frames (trapezoidal, in the body frame of the interval's start): ``α_k, β_k``;
    3. **linear least squares** for every frame velocity ``v_k``, gravity ``g`` (3 free components) and, unless
       given, the accelerometer bias ``b_a``:
       ``p_k+1 − p_k − R_k α_k = v_k Δt + ½ g Δt² − R_k Jα_k b_a`` (σ: √2 × ``position_sigma``) and
       ``R_k β_k = v_k+1 − v_k − g Δt + R_k Jβ_k b_a`` (σ: accelerometer white noise over Δt and
       ``attitude_sigma`` × ‖β_k‖) — the linear alignment of visual-inertial odometry (Qin, Li & Shen, VINS-Mono,
       IEEE T-RO 2018, §V-B), here with metric camera poses and the accelerometer bias.

    The first solve leaves the magnitude of ``g`` free (``gravity_estimated``: a check of the accelerometer's
    scale); the result then fixes it to ``gravity_magnitude`` and re-solves with the direction's two tangent-plane
    components as unknowns (relinearised four times), so the velocities and the accelerometer bias are consistent
    with the gravity the filter uses.

    Parameters
    ----------
    t : (N,) IMU times, s.  gyro, accel : (N, 3) rad/s, m/s², body frame.
    frame_t : (K,) frame times on the IMU clock, s, strictly increasing, within ``[t[0], t[-1]]``; K >= 3.
    p_wb : (K, 3) body positions in the scene frame, m.  q_wb : (K, 4) body attitudes, xyzw body -> scene.
    gravity_magnitude : float, m/s².
    position_sigma, attitude_sigma : float
        1σ of the camera-derived body positions (m, per axis) and attitudes (rad).
    accelerometer_noise_density : float, m/s²/√Hz.
    gyro_bias, accel_bias : (3,) or None
        Known biases (rad/s, m/s²); None estimates them.

    Raises
    ------
    ValueError
        Fewer than 3 frames, frames outside the IMU span, or an alignment that is not determined (e.g. a window
        without rotation when the accelerometer bias is estimated).
    """
    t = np.asarray(t, dtype=np.float64)
    gyro = np.asarray(gyro, dtype=np.float64)
    accel = np.asarray(accel, dtype=np.float64)
    ft = np.asarray(frame_t, dtype=np.float64)
    p = np.asarray(p_wb, dtype=np.float64)
    Rk = dp.matrix_from_quat(np.asarray(q_wb, dtype=np.float64))
    K = len(ft)
    if K < 3 or p.shape != (K, 3) or Rk.shape != (K, 3, 3):
        raise ValueError(f"frame_t (K,), p_wb (K, 3) and q_wb (K, 4) must describe K >= 3 frames; got {ft.shape}, "
                         f"{p.shape}, {np.shape(q_wb)}")  # fmt: skip
    if np.any(np.diff(ft) <= 0) or ft[0] < t[0] or ft[-1] > t[-1]:
        raise ValueError("frame_t must increase strictly and lie within the IMU times")
    dt, g_s, a_s = _interval_samples(t, gyro, accel, ft)
    D = ft[1:] - ft[:-1]
    rel = np.einsum("kji,kjl->kil", Rk[:-1], Rk[1:])  # R_kᵀ R_k+1
    bg = np.zeros(3) if gyro_bias is None else np.asarray(gyro_bias, dtype=np.float64)
    for _ in range(0 if gyro_bias is not None else 2):
        dR = _preintegrate(dt, g_s, a_s, bg)[0]
        r = dp.rotvec_from_quat(dp.quat_from_matrix(np.einsum("kji,kjl->kil", dR, rel)))
        bg = bg - (D @ r) / (D @ D)
    _, al, be, Ja, Jb = _preintegrate(dt, g_s, a_s, bg)
    est_ba = accel_bias is None
    ba = np.zeros(3) if est_ba else np.asarray(accel_bias, dtype=np.float64)
    n = 3 * K + 3 + (3 if est_ba else 0)
    m = K - 1
    A = np.zeros((m, 6, n))
    y = np.zeros((m, 6))
    k = np.arange(m)
    for i in range(3):
        A[k, i, 3 * k + i] = D
        A[k, i, 3 * K + i] = 0.5 * D * D
        A[k, 3 + i, 3 * k + i] = -1.0
        A[k, 3 + i, 3 * k + 3 + i] = 1.0
        A[k, 3 + i, 3 * K + i] = -D
    RJa = np.einsum("kij,kjl->kil", Rk[:-1], Ja)
    RJb = np.einsum("kij,kjl->kil", Rk[:-1], Jb)
    y[:, :3] = p[1:] - p[:-1] - np.einsum("kij,kj->ki", Rk[:-1], al)
    y[:, 3:] = np.einsum("kij,kj->ki", Rk[:-1], be)
    if est_ba:
        A[:, :3, 3 * K + 3 :] = -RJa
        A[:, 3:, 3 * K + 3 :] = RJb
    else:
        y[:, :3] += np.einsum("kij,j->ki", RJa, ba)
        y[:, 3:] -= np.einsum("kij,j->ki", RJb, ba)
    s_pos = np.sqrt(2.0) * position_sigma
    s_vel = np.sqrt(accelerometer_noise_density**2 * D + (attitude_sigma * np.linalg.norm(be, axis=1)) ** 2)
    w = np.concatenate([np.full((m, 3), 1.0 / s_pos), np.repeat(1.0 / s_vel[:, None], 3, axis=1)], axis=1)
    Aw = sparse.csc_matrix((A * w[:, :, None]).reshape(-1, n))  # each row: two velocities and the global unknowns
    yw = (y * w).reshape(-1)
    undetermined = ValueError("the camera-IMU alignment is not determined by these frames (too little motion or "
                              "rotation to separate gravity, velocities and the accelerometer bias)")  # fmt: skip
    try:
        x = splu((Aw.T @ Aw).tocsc()).solve(Aw.T @ yw)
    except RuntimeError:
        raise undetermined from None
    g_est = x[3 * K : 3 * K + 3].copy()
    if not np.isfinite(x).all() or not np.linalg.norm(g_est) > 0:
        raise undetermined
    # gravity of known magnitude: g = |g| (u + B δ) with δ in the tangent plane of u (2 unknowns instead of 3;
    # VINS-Mono's gravity refinement), a few relinearisations
    G = float(gravity_magnitude)
    u = g_est / np.linalg.norm(g_est)
    Av, Ag, Ab = Aw[:, : 3 * K], Aw[:, 3 * K : 3 * K + 3], Aw[:, 3 * K + 3 :]
    for _ in range(4):
        a0 = np.cross(u, np.eye(3)[int(np.argmin(np.abs(u)))])
        a0 /= np.linalg.norm(a0)
        B = np.stack([a0, np.cross(u, a0)], axis=1)  # (3, 2)
        Ar = sparse.hstack([Av, sparse.csc_matrix(Ag @ (G * B)), Ab]).tocsc()
        yr = yw - Ag @ (G * u)
        try:
            lu = splu((Ar.T @ Ar).tocsc())
        except RuntimeError:
            raise undetermined from None
        xr = lu.solve(Ar.T @ yr)
        u = u + B @ xr[3 * K : 3 * K + 2]
        u /= np.linalg.norm(u)
    res = yr - Ar @ xr
    nr = Ar.shape[1]
    dof = max(len(yr) - nr, 1)
    scale = max(float(res @ res) / dof, 1.0)  # inflate the covariance when the residuals exceed the stated sigmas
    want = np.r_[0, 1, 2, np.arange(3 * K, nr)]  # v_0, δ, b_a: the covariance columns needed
    E = np.zeros((nr, len(want)))
    E[want, np.arange(len(want))] = 1.0
    C = lu.solve(E)[want] * scale
    Cd = C[3:5, 3:5]
    ba_sigma = float(np.sqrt(np.mean(np.diag(C[5:, 5:])))) if est_ba else 0.0
    if not (np.isfinite(C).all() and ba_sigma < 1.0):
        raise undetermined
    # the direction's σ from the solve's own normal matrix, under the rule of every gravity estimate: refused above 5°,
    # a doubt above 1°
    sigma = float(np.sqrt(max(np.trace(Cd), 0.0)))
    doubt = gravity_sigma_doubt(sigma, "camera-IMU alignment", f"the {K} camera poses of the start-up window")
    if est_ba:
        ba = xr[3 * K + 2 :]
    x = xr
    return CameraImuAlignment(
        gravity=G * u,
        gravity_estimated=g_est,
        gravity_sigma_deg=math.degrees(sigma),
        velocity=x[: 3 * K].reshape(K, 3),
        velocity_sigma=float(np.sqrt(np.trace(C[:3, :3]) / 3.0)),
        gyro_bias=bg,
        accel_bias=ba,
        accel_bias_sigma=ba_sigma,
        residual_rms=float(np.sqrt(float(res @ res) / len(yr))),
        doubt=doubt,
    )
