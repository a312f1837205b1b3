"""Closed-form smooth 6-DoF body motions for the simulator, with exact velocity, acceleration and angular rate.

Motions are trigonometric sums in a phase ``θ(t)``: position ``p(t) = p0 + Σ_k A_k (sin(n_k θ + ψ_k) − sin ψ_k)``
and orientation ``q(t) = q0 ⊗ Exp(φ(t))`` with ``φ`` of the same form.  They are C^∞ in θ, and θ(t) is either linear
(random generator) or a quintic smoothstep (Hol's eight: starts and stops at rest, C² at the junctions), so velocity,
acceleration and the body angular velocity ``ω_b = J_r(φ) φ̇`` are exact closed forms.

Frames: world ``w`` (z up), IMU body ``b``, camera ``c`` (z along the optical axis, x right, y down).  Orientations
are ``(..., 4)`` xyzw quaternions ``q_wb`` (body -> world, active).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp

__all__ = ["SmoothMotion", "eight_motion", "random_motion", "look_at_quat", "default_extrinsic", "SCENE_TARGET",
           "CAMERA_HOME"]


def _smoothstep(tau: np.ndarray) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Quintic smoothstep ``S = 10τ³ − 15τ⁴ + 6τ⁵`` clipped to [0, 1] and its first two derivatives."""
    inside = (tau > 0.0) & (tau < 1.0)
    t = np.clip(tau, 0.0, 1.0)
    s = t**3 * (10.0 + t * (-15.0 + 6.0 * t))
    ds = np.where(inside, 30.0 * t**2 * (1.0 - t) ** 2, 0.0)
    dds = np.where(inside, 60.0 * t * (1.0 - t) * (1.0 - 2.0 * t), 0.0)
    return s, ds, dds


@dataclass(frozen=True)
class SmoothMotion:
    """Closed-form smooth 6-DoF body trajectory (see the module docstring for the form).

    Attributes
    ----------
    p0 : ndarray (3,)
        Body position at θ = 0, world frame, metres.
    q0 : ndarray (4,)
        Body orientation ``q_wb`` at θ = 0, xyzw.
    pos_amp, pos_phase : ndarray (K, 3); pos_harm : ndarray (K,)
        Position terms ``A_k``, ``ψ_k`` (per axis) and harmonic ``n_k``.
    rot_amp, rot_phase : ndarray (L, 3); rot_harm : ndarray (L,)
        Rotation-vector terms, radians.
    phase_kind : str
        ``"linear"`` (θ = Ω t) or ``"smoothstep"`` (θ = 2π S((t − t_start)/period), at rest outside).
    omega0 : float
        Ω for ``"linear"``, rad/s of phase.
    t_start, period : float
        Start and duration (s) of the smoothstep phase.
    duration : float
        Total length of the run, s.
    """

    p0: np.ndarray
    q0: np.ndarray
    pos_amp: np.ndarray
    pos_harm: np.ndarray
    pos_phase: np.ndarray
    rot_amp: np.ndarray
    rot_harm: np.ndarray
    rot_phase: np.ndarray
    phase_kind: str = "linear"
    omega0: float = 1.0
    t_start: float = 0.0
    period: float = 1.0
    duration: float = 1.0

    def phase(self, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """θ(t), θ'(t), θ''(t) for times ``t`` (s), each shaped like ``t``."""
        t = np.asarray(t, dtype=np.float64)
        if self.phase_kind == "linear":
            return self.omega0 * t, np.full_like(t, self.omega0), np.zeros_like(t)
        s, ds, dds = _smoothstep((t - self.t_start) / self.period)
        k = 2.0 * math.pi
        return k * s, k * ds / self.period, k * dds / self.period**2

    @staticmethod
    def _series(amp: np.ndarray, harm: np.ndarray, ph: np.ndarray, th: np.ndarray) -> tuple[NDArray[np.float64], ...]:
        arg = harm[:, None] * th[..., None, None] + ph  # (..., K, 3)
        s, c = np.sin(arg), np.cos(arg)
        f = np.sum(amp * (s - np.sin(ph)), axis=-2)
        df = np.sum(amp * harm[:, None] * c, axis=-2)
        ddf = -np.sum(amp * harm[:, None] ** 2 * s, axis=-2)
        return f, df, ddf

    def kinematics(self, t: np.ndarray) -> dict[str, NDArray[np.float64]]:
        """Exact ground truth at times ``t`` (shape (N,)).

        Returns
        -------
        dict
            ``position`` (N, 3) m, ``velocity`` (N, 3) m/s, ``acceleration`` (N, 3) m/s² (world frame),
            ``quat`` (N, 4) ``q_wb`` xyzw, ``omega`` (N, 3) rad/s body-frame angular velocity.
        """
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        th, dth, ddth = self.phase(t)
        f, df, ddf = self._series(self.pos_amp, self.pos_harm, self.pos_phase, th)
        pos = self.p0 + f
        vel = df * dth[:, None]
        acc = ddf * dth[:, None] ** 2 + df * ddth[:, None]
        phi, dphi, _ = self._series(self.rot_amp, self.rot_harm, self.rot_phase, th)
        q = dp.quat_mul(self.q0, dp.quat_from_rotvec(phi))
        omega = np.einsum("nij,nj->ni", dp.so3_right_jacobian(phi), dphi * dth[:, None])
        return {"position": pos, "velocity": vel, "acceleration": acc, "quat": q, "omega": omega}


def look_at_quat(eye: ArrayLike, target: ArrayLike, up: ArrayLike = (0.0, 0.0, 1.0)) -> NDArray[np.float64]:
    """``q_wc`` (xyzw) of a camera at ``eye`` looking at ``target`` (z forward, x right, y down, world ``up``);
    ``eye`` and ``target`` may be batches ``(..., 3)`` (then the result is ``(..., 4)``)."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z = z / np.linalg.norm(z, axis=-1, keepdims=True)
    x = np.cross(z, np.asarray(up, float))
    x = x / np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(z, x)
    return dp.quat_from_matrix(np.stack([x, y, z], axis=-1))


def default_extrinsic() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body→camera extrinsic ``(q_bc, p_bc)``: camera axes in the body frame (IMU x ≈ optical axis, z ≈ up,
    tilted by a few degrees) and the camera centre in the body frame (metres)."""
    r_nominal = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # columns: x_c, y_c, z_c in b
    q = dp.quat_mul(dp.quat_from_matrix(r_nominal), dp.quat_from_rotvec([0.03, -0.02, 0.04]))
    return q, np.array([0.03, -0.012, 0.021])


def extrinsic_arrays(
    extrinsic: tuple[np.ndarray, np.ndarray] | None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The extrinsic ``(q_bc (4,) xyzw, p_bc (3,) m)`` as float arrays; :func:`default_extrinsic` when None."""
    q_bc, p_bc = default_extrinsic() if extrinsic is None else extrinsic
    return np.asarray(q_bc, float), np.asarray(p_bc, float)


def body_from_camera(
    q_wc: np.ndarray, c_w: np.ndarray, q_bc: np.ndarray, p_bc: np.ndarray
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body poses ``(q_wb (..., 4) xyzw, p_wb (..., 3) m)`` of camera poses ``(q_wc (..., 4), c_w (..., 3))`` with
    the extrinsic ``(q_bc, p_bc)`` (camera axes and centre in the body frame)."""
    q_wb = dp.quat_mul(q_wc, dp.quat_conj(q_bc))
    return q_wb, c_w - dp.quat_rotate(q_wb, p_bc)


SCENE_TARGET = np.array([0.0, 0.35, 0.35])
CAMERA_HOME = np.array([0.0, 1.45, 0.85])


def _home_body_pose(extrinsic: tuple[np.ndarray, np.ndarray] | None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body pose ``(q_wb, p_wb)`` whose camera (extrinsic, default :func:`default_extrinsic`) sits at
    :data:`CAMERA_HOME` looking at :data:`SCENE_TARGET`: where the motions start."""
    q_bc, p_bc = default_extrinsic() if extrinsic is None else extrinsic
    return body_from_camera(look_at_quat(CAMERA_HOME, SCENE_TARGET), CAMERA_HOME, q_bc, p_bc)


def eight_motion(
    path_length: float = 2.6,
    period: float = 5.4,
    static_before: float = 1.0,
    static_after: float = 0.5,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
) -> SmoothMotion:
    """Hol's eight-shaped run: a figure eight of ``path_length`` metres traversed once in ``period`` seconds.

    The eight lies in the plane facing the wall (x lateral, z vertical) with a depth oscillation in y; the camera
    looks at the two-plane scene throughout while roll, pitch and yaw oscillate.  The phase is a quintic smoothstep,
    so the body is at rest for ``static_before`` s (for static alignment), then moves with peak acceleration
    ≈ 3.9 m/s² and peak angular rate ≈ 1 rad/s (Hol: up to 4 m/s², 1 rad/s), then rests for ``static_after`` s.
    """
    q_wb0, p0 = _home_body_pose(extrinsic)
    # shape: x = a sin θ, z = b sin 2θ, y = d (cos 2θ − 1); scaled to the requested path length
    shape = np.array([[1.0, 0.0, 0.0], [0.0, 0.12, 0.5]])
    harm = np.array([1.0, 2.0])
    phase = np.array([[0.0, 0.0, 0.0], [0.0, math.pi / 2, 0.0]])
    th = np.linspace(0.0, 2 * math.pi, 20001)
    arg = harm[:, None] * th[:, None, None] + phase
    d = np.sum(shape * harm[:, None] * np.cos(arg), axis=1)
    length = np.trapezoid(np.linalg.norm(d, axis=1), th)
    amp = shape * (path_length / length)
    rot_amp = np.array([[0.22, 0.0, 0.26], [0.0, 0.17, 0.0]])
    rot_phase = np.array([[0.3, 0.0, 1.1], [0.0, 0.7, 0.0]])
    return SmoothMotion(
        p0=p0,
        q0=q_wb0,
        pos_amp=amp,
        pos_harm=harm,
        pos_phase=phase,
        rot_amp=rot_amp,
        rot_harm=harm.copy(),
        rot_phase=rot_phase,
        phase_kind="smoothstep",
        t_start=static_before,
        period=period,
        duration=static_before + period + static_after,
    )


def random_motion(
    seed: int,
    duration: float = 10.0,
    n_terms: int = 4,
    position_amplitude: float = 0.15,
    rotation_amplitude: float = 0.08,
    max_frequency_hz: float = 0.6,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
) -> SmoothMotion:
    """Smooth (C^∞) random 6-DoF motion: ``n_terms`` random sinusoids per axis in position and rotation vector.

    Frequencies are uniform in (0.1, ``max_frequency_hz``) Hz; amplitudes are uniform up to ``position_amplitude``
    metres and ``rotation_amplitude`` radians per term; the camera stays near the default home pose, facing the scene.
    """
    rng = np.random.default_rng(seed)
    q_wb0, p0 = _home_body_pose(extrinsic)
    omega0 = 2 * math.pi * 0.1
    harm_p = rng.uniform(1.0, max_frequency_hz / 0.1, n_terms)
    harm_r = rng.uniform(1.0, max_frequency_hz / 0.1, n_terms)
    return SmoothMotion(
        p0=p0,
        q0=q_wb0,
        pos_amp=rng.uniform(-position_amplitude, position_amplitude, (n_terms, 3)),
        pos_harm=harm_p,
        pos_phase=rng.uniform(0, 2 * math.pi, (n_terms, 3)),
        rot_amp=rng.uniform(-rotation_amplitude, rotation_amplitude, (n_terms, 3)),
        rot_harm=harm_r,
        rot_phase=rng.uniform(0, 2 * math.pi, (n_terms, 3)),
        phase_kind="linear",
        omega0=omega0,
        duration=duration,
    )
