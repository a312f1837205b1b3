"""IMU preintegration between keyframes, vectorised over all intervals (Forster et al. 2017).

C. Forster, L. Carlone, F. Dellaert, D. Scaramuzza, "On-manifold preintegration for real-time visual-inertial
odometry", IEEE Trans. Robotics 33(1), 2017: eqs. (33)–(35) (preintegrated measurements), (44) (bias correction to
first order), (45) (residuals) and the supplementary material's Jacobians; noise propagation eq. (63).

Frames: the body (IMU) frame ``b`` and the target frame ``w``; ``R`` (…, 3, 3) is ``R_wb``, positions and
velocities are target-frame, metres and m/s; gravity ``g`` (3,) m/s² in the target frame.  Interval ``i`` runs
from node time ``s[i]`` to ``s[i+1]`` (IMU clock, seconds).  The IMU signals are taken as linear between samples
and integrated with the mid-point rule (the specific force rotated by the mid-point attitude of each
sub-step, not Forster's start-of-step attitude, whose error is ``½ |ω| h |f|`` per step) on sub-steps split at every
sample time, so the interval ends need not be
sample times.  Noise: white densities ``σ_g`` (rad/s/√Hz), ``σ_a`` (m/s²/√Hz) (continuous time; a sub-step of
length ``dt`` gets covariance ``σ² / dt`` per axis for its mean measurement).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import dualpose as dp

__all__ = ["Preintegrated", "gyro_axes_matrix", "accel_axes_matrix", "imu_factors", "preintegrate",
           "size_effect_jacobian"]

#: parameters of the axis models: a symmetric 3 × 3 perturbation of the gyro (xx, yy, zz, xy, xz, yz) and a full
#: 3 × 3 one of the accelerometer (row-major)
N_GYRO_AXES = 6
N_ACCEL_AXES = 9
#: parameters of the size effect: the positions of the y and the z accelerometer axes in the body frame (m), the x
#: axis at the body origin (Rehder et al. 2016)
N_SIZE_EFFECT = 6


def gyro_axes_matrix(theta: np.ndarray) -> np.ndarray:
    """Symmetric ``Δ`` (3, 3) of the gyro parameters ``θ = (xx, yy, zz, xy, xz, yz)``."""
    xx, yy, zz, xy, xz, yz = theta
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def accel_axes_matrix(theta: np.ndarray) -> np.ndarray:
    """``Δ`` (3, 3) of the accelerometer parameters (row-major)."""
    return np.asarray(theta, dtype=np.float64).reshape(3, 3)


def _gyro_axes_jacobian(w: np.ndarray) -> np.ndarray:
    """``∂(Δ w)/∂θ`` (…, 3, 6) for the symmetric gyro ``Δ``."""
    G = np.zeros(w.shape[:-1] + (3, 6))
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    G[..., 0, 0], G[..., 0, 3], G[..., 0, 4] = x, y, z
    G[..., 1, 1], G[..., 1, 3], G[..., 1, 5] = y, x, z
    G[..., 2, 2], G[..., 2, 4], G[..., 2, 5] = z, x, y
    return G


def _accel_axes_jacobian(f: np.ndarray) -> np.ndarray:
    """``∂(Δ f)/∂θ`` (…, 3, 9) for the row-major accelerometer ``Δ``."""
    A = np.zeros(f.shape[:-1] + (3, 9))
    for r in range(3):
        A[..., r, 3 * r : 3 * r + 3] = f
    return A


def size_effect_jacobian(w: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``∂s/∂r`` (…, 3, 6) of the accelerometer size effect, ``r = (r_y, r_z)``.

    J. Rehder, J. Nikolic, T. Schneider, T. Hinzmann, R. Siegwart, "Extending kalibr: calibrating the extrinsics of
    multiple IMUs and of individual axes", ICRA 2016: accelerometer axis ``i`` sits at ``r_i`` in the body frame
    (``r_x = 0``: the body origin is the x axis' position) and measures ``e_iᵀ f(r_i)`` with the specific force of a
    point at ``r``, ``f(r) = f(0) + α × r + ω × (ω × r)`` (``ω`` rad/s, ``α`` rad/s², body frame, (…, 3) each).  The
    measured specific force minus the origin's is ``s = [0, e_yᵀ K r_y, e_zᵀ K r_z]`` with ``K = [α]× + [ω]×²``,
    linear in ``r``.
    """
    K = dp.so3_hat(alpha) + dp.so3_hat(w) @ dp.so3_hat(w)
    S = np.zeros(K.shape[:-2] + (3, 6))
    S[..., 1, 0:3] = K[..., 1, :]
    S[..., 2, 3:6] = K[..., 2, :]
    return S


@dataclass
class Preintegrated:
    """Preintegrated measurements of ``I`` intervals, linearised at the biases ``bias_gyro``, ``bias_accel`` (I, 3).

    ``dR`` (I, 3, 3), ``dv``, ``dp`` (I, 3), ``dt`` (I,) s; bias Jacobians ``R_bg``, ``v_bg``, ``v_ba``, ``p_bg``,
    ``p_ba`` (I, 3, 3); ``covariance`` (I, 9, 9) of ``[δφ, δv, δp]``.  With ``axes=True`` also the Jacobians with
    respect to the axis-model parameters (the measurements corrected as ``(I − Δ) y``): ``R_Mg``, ``v_Mg``,
    ``p_Mg`` (I, 3, 6), ``v_Ma``, ``p_Ma`` (I, 3, 9); None otherwise.  With ``size_effect`` also ``v_r``, ``p_r``
    (I, 3, 6) with respect to the accelerometer axis positions (``size_effect_jacobian``).
    """

    dR: np.ndarray
    dv: np.ndarray
    dp: np.ndarray
    dt: np.ndarray
    R_bg: np.ndarray
    v_bg: np.ndarray
    v_ba: np.ndarray
    p_bg: np.ndarray
    p_ba: np.ndarray
    covariance: np.ndarray
    bias_gyro: np.ndarray
    bias_accel: np.ndarray
    R_Mg: np.ndarray | None = None
    v_Mg: np.ndarray | None = None
    p_Mg: np.ndarray | None = None
    v_Ma: np.ndarray | None = None
    p_Ma: np.ndarray | None = None
    v_r: np.ndarray | None = None
    p_r: np.ndarray | None = None

    def axis_jacobians(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(R_Mg, v_Mg, p_Mg, v_Ma, p_Ma)``; ValueError when preintegrated without ``axes=True``."""
        if self.R_Mg is None or self.v_Mg is None or self.p_Mg is None or self.v_Ma is None or self.p_Ma is None:
            raise ValueError("the preintegration holds no axis-model Jacobians (preintegrate with axes=True)")
        return self.R_Mg, self.v_Mg, self.p_Mg, self.v_Ma, self.p_Ma

    def size_effect_jacobians(self) -> tuple[np.ndarray, np.ndarray]:
        """``(v_r, p_r)``; ValueError when preintegrated without ``size_effect``."""
        if self.v_r is None or self.p_r is None:
            raise ValueError("the preintegration holds no size-effect Jacobians (preintegrate with size_effect)")
        return self.v_r, self.p_r


def _substeps(imu_t: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Break points (I, n+1) of every interval ``[a, b]`` at the sample times inside it (padded with ``b``)."""
    ia = np.searchsorted(imu_t, a, side="right")
    ib = np.searchsorted(imu_t, b, side="left")
    n = np.maximum(ib - ia, 0) + 1
    j = np.arange(int(n.max()) + 1)
    idx = np.clip(ia[:, None] + j[None, :] - 1, 0, len(imu_t) - 1)
    bp = np.where(j[None, :] == 0, a[:, None], np.where(j[None, :] < n[:, None], imu_t[idx], b[:, None]))
    return bp, n


def _interp(imu_t: np.ndarray, x: np.ndarray, tq: np.ndarray) -> np.ndarray:
    flat = tq.ravel()
    return np.stack([np.interp(flat, imu_t, x[:, c]) for c in range(3)], axis=-1).reshape(tq.shape + (3,))


def preintegrate(
    imu_t: np.ndarray,
    gyro: np.ndarray,
    accel: np.ndarray,
    s: np.ndarray,
    bias_gyro: np.ndarray,
    bias_accel: np.ndarray,
    gyro_noise_density: float,
    accel_noise_density: float,
    axes: bool = False,
    size_effect: np.ndarray | None = None,
) -> Preintegrated:
    """Preintegrate the IMU over the ``I = len(s) − 1`` intervals between node times ``s`` (N,) s.

    ``imu_t`` (S,) s, ``gyro`` (S, 3) rad/s, ``accel`` (S, 3) m/s² (body frame); ``bias_gyro``, ``bias_accel``
    (I, 3) the linearisation biases of each interval.  The loop runs over the sub-step index (≈ samples per
    interval), vectorised over the intervals still active at that index.  ``axes``: also the Jacobians with
    respect to the gyro/accelerometer axis models (:class:`Preintegrated`).  ``size_effect`` (6,) m: the positions
    ``(r_y, r_z)`` of the y and z accelerometer axes (``size_effect_jacobian``); the specific force is then taken
    at the body origin, ``f − s(r)``, with ``ω`` the bias-corrected gyro and ``α`` its central difference over the
    samples, and the Jacobians with respect to ``r`` are returned as well.
    """
    a, b = s[:-1], s[1:]
    bp, n = _substeps(imu_t, a, b)
    tm = 0.5 * (bp[:, :-1] + bp[:, 1:])
    h = np.diff(bp, axis=1)
    w_all = _interp(imu_t, gyro, tm) - bias_gyro[:, None, :]
    f_all = _interp(imu_t, accel, tm) - bias_accel[:, None, :]
    f_meas = f_all  # before the size-effect correction (the accelerometer axis model acts on the measurement)
    if size_effect is not None:
        alpha = np.gradient(gyro, imu_t, axis=0)  # central differences (one-sided at the ends)
        S_all = size_effect_jacobian(w_all, _interp(imu_t, alpha, tm))
        f_all = f_all - S_all @ np.asarray(size_effect, dtype=np.float64)
        v_r, p_r = np.zeros((len(a), 3, N_SIZE_EFFECT)), np.zeros((len(a), 3, N_SIZE_EFFECT))
    m = len(a)
    dR = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
    dv = np.zeros((m, 3))
    dpos = np.zeros((m, 3))
    R_bg = np.zeros((m, 3, 3))
    v_bg = np.zeros((m, 3, 3))
    v_ba = np.zeros((m, 3, 3))
    p_bg = np.zeros((m, 3, 3))
    p_ba = np.zeros((m, 3, 3))
    cov = np.zeros((m, 9, 9))
    if axes:
        R_Mg, v_Mg, p_Mg = np.zeros((m, 3, 6)), np.zeros((m, 3, 6)), np.zeros((m, 3, 6))
        v_Ma, p_Ma = np.zeros((m, 3, 9)), np.zeros((m, 3, 9))
    eye = np.eye(3)
    sg2, sa2 = gyro_noise_density**2, accel_noise_density**2
    for j in range(h.shape[1]):  # sub-step index; vectorised over the intervals that have a j-th sub-step
        k = np.flatnonzero(n > j)
        dt = h[k, j][:, None, None]
        phi = w_all[k, j] * h[k, j][:, None]
        E = dp.so3_exp(phi)
        Jr = dp.so3_right_jacobian(phi)
        Rk = dR[k] @ dp.so3_exp(0.5 * phi)  # the rotation at the sub-step's mid-point (second-order accurate)
        fx = dp.so3_hat(f_all[k, j])
        Rf = np.einsum("kij,kj->ki", Rk, f_all[k, j])
        Rfx = Rk @ fx
        # noise propagation (eq. 63): A Σ Aᵀ + B Q Bᵀ over [δφ, δv, δp]
        A = np.zeros((len(k), 9, 9))
        A[:, 0:3, 0:3] = np.swapaxes(E, 1, 2)
        A[:, 3:6, 0:3] = -Rfx * dt
        A[:, 3:6, 3:6] = eye
        A[:, 6:9, 0:3] = -0.5 * Rfx * dt**2
        A[:, 6:9, 3:6] = eye * dt
        A[:, 6:9, 6:9] = eye
        c = A @ cov[k] @ np.swapaxes(A, 1, 2)
        hh = h[k, j][:, None, None]
        c[:, 0:3, 0:3] += sg2 * hh * (Jr @ np.swapaxes(Jr, 1, 2))
        c[:, 3:6, 3:6] += sa2 * hh * eye
        c[:, 3:6, 6:9] += sa2 * 0.5 * hh**2 * eye
        c[:, 6:9, 3:6] += sa2 * 0.5 * hh**2 * eye
        c[:, 6:9, 6:9] += sa2 * 0.25 * hh**3 * eye
        cov[k] = c
        # bias Jacobians (Forster supplementary, eq. (62)), with the values before this sub-step
        p_ba[k] += v_ba[k] * dt - 0.5 * Rk * dt**2
        p_bg[k] += v_bg[k] * dt - 0.5 * (Rfx @ R_bg[k]) * dt**2
        v_ba[k] -= Rk * dt
        v_bg[k] -= (Rfx @ R_bg[k]) * dt
        R_bg[k] = np.swapaxes(E, 1, 2) @ R_bg[k] - Jr * dt
        if axes:  # δω = −Δ_g ω̃, δf = −Δ_a f̃: biases with a per-step multiplier (ω̃, f̃ before the bias)
            Gk = _gyro_axes_jacobian(w_all[k, j] + bias_gyro[k])
            Ak = _accel_axes_jacobian(f_meas[k, j] + bias_accel[k])
            p_Ma[k] += v_Ma[k] * dt - 0.5 * (Rk @ Ak) * dt**2
            p_Mg[k] += v_Mg[k] * dt - 0.5 * (Rfx @ R_Mg[k]) * dt**2
            v_Ma[k] -= (Rk @ Ak) * dt
            v_Mg[k] -= (Rfx @ R_Mg[k]) * dt
            R_Mg[k] = np.swapaxes(E, 1, 2) @ R_Mg[k] - (Jr @ Gk) * dt
        if size_effect is not None:  # δf = −S δr: a known per-sample input, linear in r
            RS = Rk @ S_all[k, j]
            p_r[k] += v_r[k] * dt - 0.5 * RS * dt**2
            v_r[k] -= RS * dt
        # measurements (eq. 33–35)
        dpos[k] += dv[k] * h[k, j][:, None] + 0.5 * Rf * h[k, j][:, None] ** 2
        dv[k] += Rf * h[k, j][:, None]
        dR[k] = dR[k] @ E
    out = Preintegrated(dR, dv, dpos, b - a, R_bg, v_bg, v_ba, p_bg, p_ba, cov, bias_gyro.copy(), bias_accel.copy())
    if axes:
        out.R_Mg, out.v_Mg, out.p_Mg, out.v_Ma, out.p_Ma = R_Mg, v_Mg, p_Mg, v_Ma, p_Ma
    if size_effect is not None:
        out.v_r, out.p_r = v_r, p_r
    return out


def imu_factors(
    pre: Preintegrated,
    R_i: np.ndarray,
    p_i: np.ndarray,
    v_i: np.ndarray,
    R_j: np.ndarray,
    p_j: np.ndarray,
    v_j: np.ndarray,
    bias_gyro: np.ndarray,
    bias_accel: np.ndarray,
    gravity: np.ndarray,
    gravity_basis: np.ndarray,
    jacobians: bool = True,
    axes_gyro: np.ndarray | None = None,
    axes_accel: np.ndarray | None = None,
    size_effect: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Residuals ``[r_R, r_v, r_p]`` (I, 9) of eq. (45) with the first-order bias correction (eq. 44).

    State perturbations: ``R ← R Exp(δφ)``, ``p ← p + δp``, ``v ← v + δv`` (target frame), biases additive,
    gravity ``g ← Exp(B δg) g`` with ``B = gravity_basis`` (3, 2) orthogonal to ``g``.  Returns the residuals and
    (with ``jacobians``) the Jacobian (I, 9, 26) over ``[φ_i, p_i, v_i, φ_j, p_j, v_j, b_g, b_a, δg]``, or
    (I, 9, 41) with the axis-model deviations ``axes_gyro`` (6,), ``axes_accel`` (9,) from the linearisation point
    (then ``pre`` must hold the axis Jacobians) appended, and then 6 more columns with the size-effect deviation
    ``size_effect`` (6,) m from the linearisation point (``pre`` preintegrated with ``size_effect``).
    """
    dbg = bias_gyro - pre.bias_gyro
    dba = bias_accel - pre.bias_accel
    corr = np.einsum("kij,kj->ki", pre.R_bg, dbg)
    dvc = pre.dv + np.einsum("kij,kj->ki", pre.v_bg, dbg) + np.einsum("kij,kj->ki", pre.v_ba, dba)
    dpc = pre.dp + np.einsum("kij,kj->ki", pre.p_bg, dbg) + np.einsum("kij,kj->ki", pre.p_ba, dba)
    axes = axes_gyro is not None
    if axes_gyro is not None:
        if axes_accel is None:
            raise ValueError("axes_accel must be given with axes_gyro")
        R_Mg, v_Mg, p_Mg, v_Ma, p_Ma = pre.axis_jacobians()
        corr = corr + R_Mg @ axes_gyro
        dvc = dvc + v_Mg @ axes_gyro + v_Ma @ axes_accel
        dpc = dpc + p_Mg @ axes_gyro + p_Ma @ axes_accel
    if size_effect is not None:
        v_r, p_r = pre.size_effect_jacobians()
        dvc = dvc + v_r @ size_effect
        dpc = dpc + p_r @ size_effect
    dRc = pre.dR @ dp.so3_exp(corr)
    Rit = np.swapaxes(R_i, 1, 2)
    T = pre.dt[:, None]
    rel = Rit @ R_j
    rR = dp.so3_log(np.swapaxes(dRc, 1, 2) @ rel)
    yv = np.einsum("kij,kj->ki", Rit, v_j - v_i - gravity * T)
    yp = np.einsum("kij,kj->ki", Rit, p_j - p_i - v_i * T - 0.5 * gravity * T**2)
    r = np.concatenate([rR, yv - dvc, yp - dpc], axis=1)
    if not jacobians:
        return r, None
    n_axes = N_GYRO_AXES + N_ACCEL_AXES if axes else 0
    J = np.zeros((len(r), 9, 26 + n_axes + (N_SIZE_EFFECT if size_effect is not None else 0)))
    Jinv = dp.so3_right_jacobian_inv(rR)
    J[:, 0:3, 0:3] = -Jinv @ np.swapaxes(rel, 1, 2)
    J[:, 0:3, 9:12] = Jinv
    JrotB = -Jinv @ np.swapaxes(dp.so3_exp(rR), 1, 2) @ dp.so3_right_jacobian(corr)
    J[:, 0:3, 18:21] = JrotB @ pre.R_bg
    if axes:
        R_Mg, v_Mg, p_Mg, v_Ma, p_Ma = pre.axis_jacobians()
        J[:, 0:3, 26:32] = JrotB @ R_Mg
        J[:, 3:6, 26:32] = -v_Mg
        J[:, 3:6, 32:41] = -v_Ma
        J[:, 6:9, 26:32] = -p_Mg
        J[:, 6:9, 32:41] = -p_Ma
    if size_effect is not None:
        v_r, p_r = pre.size_effect_jacobians()
        J[:, 3:6, 26 + n_axes :] = -v_r
        J[:, 6:9, 26 + n_axes :] = -p_r
    J[:, 3:6, 0:3] = dp.so3_hat(yv)
    J[:, 3:6, 6:9] = -Rit
    J[:, 3:6, 15:18] = Rit
    J[:, 3:6, 18:21] = -pre.v_bg
    J[:, 3:6, 21:24] = -pre.v_ba
    G = -dp.so3_hat(gravity) @ gravity_basis  # ∂g/∂δg (3, 2)
    J[:, 3:6, 24:26] = -(Rit @ G) * T[:, :, None]
    J[:, 6:9, 0:3] = dp.so3_hat(yp)
    J[:, 6:9, 3:6] = -Rit
    J[:, 6:9, 6:9] = -Rit * T[:, :, None]
    J[:, 6:9, 12:15] = Rit
    J[:, 6:9, 18:21] = -pre.p_bg
    J[:, 6:9, 21:24] = -pre.p_ba
    J[:, 6:9, 24:26] = -0.5 * (Rit @ G) * (T**2)[:, :, None]
    return r, J
