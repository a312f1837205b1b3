"""Measurement models with analytic Jacobians for the error-state filter (Solà 2017) and Hol's 22-state filter.

Error-state models (nominal ``x`` (16,) = :data:`~dualpose.estimation.state.ESKF_STATE`; error ``δx`` (15,) =
:data:`~dualpose.estimation.state.ESKF_ERROR`, ``q = q̂ ⊗ Exp(δθ)``, see :func:`boxplus`): each returns the residual
``r = y − h(x̂)`` (in the measurement's tangent space for orientations) and ``H = ∂h(x̂ ⊞ δx)/∂δx`` at δx = 0.

Camera: we use the **reprojection form** ``y = π(R_bcᵀ(R_wbᵀ(z_w − p) − p_bc)) + e`` with ``π(X, Y, Z) =
(fx X/Z + cx, fy Y/Z + cy)`` and pixel noise ``e``.  Hol's eq. 11c is the algebraically equivalent implicit form
``0 = [−f I₂, zⁱ] z^c + e`` (no division, the measured pixel enters the model): it is exact for the projective
constraint, but its noise is the pixel noise scaled by the unknown depth Z and multiplied into the measurement,
so the Gaussian noise assumption is only approximate and the NIS of a point depends on its depth.  The reprojection
form has homoscedastic pixel noise (the χ² gate and NIS report are then meaningful per correspondence) at the cost
of a 1/Z, which is harmless for points in front of the camera.  The 22-state Hol filter uses eq. 11c as written
(:func:`hol_camera_implicit`); the error-state filter uses the reprojection form.

Hol 22-state layout (eq. 8): :data:`~dualpose.estimation.state.HOL22_STATE`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose import _native
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE, HOL22_STATE

__all__ = [
    "boxplus",
    "camera_reprojection",
    "position_model",
    "pose_model",
    "magnetometer_model",
    "hol_accelerometer",
    "hol_gyroscope",
    "hol_camera_implicit",
]


def _state(x: np.ndarray) -> np.ndarray:
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.shape != (ESKF_STATE.dim,):
        raise ValueError(f"x must be an error-state nominal vector of shape ({ESKF_STATE.dim},); got {x.shape}")
    return x


def _vec(v: ArrayLike) -> NDArray[np.float64]:
    return np.ascontiguousarray(v, dtype=np.float64)


def boxplus(x: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """``x ⊞ δx``: add ``δx`` (15,) to the nominal state ``x`` (16,) with ``q ← q ⊗ Exp(δθ)``."""
    x = _state(x)
    out = np.copy(x, order="C")
    for block in ("position", "velocity", "gyro_bias", "accel_bias"):
        ESKF_STATE.get(out, block)[:] += ESKF_ERROR.get(dx, block)
    dq = dp.quat_from_rotvec(ESKF_ERROR.get(dx, "attitude"))
    ESKF_STATE.get(out, "quat")[:] = dp.quat_mul(ESKF_STATE.get(x, "quat"), dq)
    return out


def camera_reprojection(
    x: np.ndarray,
    pixels: np.ndarray,
    points: np.ndarray,
    intrinsics: tuple[float, float, float, float],
    q_bc: np.ndarray,
    p_bc: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reprojection residuals and Jacobians of point correspondences.

    Parameters
    ----------
    x : (16,) nominal state.  pixels : (M, 2) measured pixels.  points : (M, 3) landmarks, world frame, metres.
    intrinsics : (fx, fy, cx, cy) pixels.  q_bc : (4,) camera→body rotation xyzw.  p_bc : (3,) camera centre in b.

    Returns
    -------
    r : (M, 2) pixel residuals ``y − h(x̂)``.  H : (M, 2, 15) ``∂h/∂δx``.  depth : (M,) camera-frame Z, metres.
    """
    x = _state(x)
    pixels = np.ascontiguousarray(pixels, dtype=np.float64).reshape(-1, 2)
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pixels) != len(points):
        raise ValueError(f"pixels (M, 2) and points (M, 3) must have the same M; got {len(pixels)} and {len(points)}")
    m = len(pixels)
    r, H, depth = np.empty((m, 2)), np.empty((m, 2, ESKF_ERROR.dim)), np.empty(m)
    _native.eskf_camera_batch(x, _vec(intrinsics), _vec(q_bc), _vec(p_bc), pixels, points, r, H, depth)
    return r, H, depth


def position_model(x: np.ndarray, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Position fix ``y = p + e``: residual (3,) and H (3, 15)."""
    x = _state(x)
    H = np.zeros((3, ESKF_ERROR.dim))
    H[:, ESKF_ERROR.slice("position")] = np.eye(3)
    return np.asarray(position, float) - ESKF_STATE.get(x, "position"), H


def pose_model(x: np.ndarray, position: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Full pose ``(p, q_wb)`` measurement: residual ``[p_m − p̂, Log(q̂* ⊗ q_m)]`` (6,) and H (6, 15).

    With the right attitude error, ``Log(Exp(−δθ) ⊗ Exp(r_θ)) ≈ r_θ − J_l⁻¹(r_θ) δθ``, so
    ``H = [[I, 0, 0, 0, 0], [0, 0, J_l⁻¹(r_θ), 0, 0]]`` (the identity when the residual is small).
    """
    x = _state(x)
    r_theta = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(ESKF_STATE.get(x, "quat")), quat))
    r = np.concatenate([np.asarray(position, float) - ESKF_STATE.get(x, "position"), r_theta])
    H = np.zeros((6, ESKF_ERROR.dim))
    H[0:3, ESKF_ERROR.slice("position")] = np.eye(3)
    H[3:6, ESKF_ERROR.slice("attitude")] = dp.so3_left_jacobian_inv(r_theta)
    return r, H


def magnetometer_model(x: np.ndarray, measurement: np.ndarray, field_w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Magnetometer ``y = R_wbᵀ m_w + e``: residual (3,) and H (3, 15) with ``∂/∂δθ = [R̂ᵀ m_w]×``."""
    x = _state(x)
    m_b = dp.quat_rotate(dp.quat_conj(ESKF_STATE.get(x, "quat")), field_w)
    H = np.zeros((3, ESKF_ERROR.dim))
    H[:, ESKF_ERROR.slice("attitude")] = dp.so3_hat(m_b)
    return np.asarray(measurement, float) - m_b, H


# ----------------------------------------------------------------------------------------------------------------
# Hol's 22-state model (eq. 8, 11a-c).  Jacobians with respect to the full 22-vector (quaternion as 4 numbers).
# ----------------------------------------------------------------------------------------------------------------


def _rot_be_and_derivs(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``R^{be}(q^{be})`` (xyzw) as the quadratic form (a rotation for unit q) and ``∂R/∂q_i`` (4, 3, 3)."""
    x, y, z, w = q
    R = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    dR = 2.0 * np.array(
        [
            [[0, y, z], [y, -2 * x, -w], [z, w, -2 * x]],
            [[-2 * y, x, w], [x, 0, z], [-w, z, -2 * y]],
            [[-2 * z, -w, x], [w, -2 * z, y], [x, y, 0]],
            [[0, -z, y], [z, 0, -x], [-y, x, 0]],
        ]
    )
    return R, dR


def hol_accelerometer(x: np.ndarray, gravity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hol eq. 11a: ``h = R^{be}(b̈ − g^e) + δ_a``; returns h (3,) and ∂h/∂x (3, 22)."""
    L = HOL22_STATE
    R, dR = _rot_be_and_derivs(L.get(x, "quat_be"))
    d = L.get(x, "acceleration") - gravity
    H = np.zeros((3, L.dim))
    H[:, L.slice("acceleration")] = R
    H[:, L.slice("quat_be")] = np.einsum("kij,j->ik", dR, d)
    H[:, L.slice("accel_bias")] = np.eye(3)
    return R @ d + L.get(x, "accel_bias"), H


def hol_gyroscope(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hol eq. 11b: ``h = ω^b_{eb} + δ_ω``; returns h (3,) and ∂h/∂x (3, 22)."""
    L = HOL22_STATE
    H = np.zeros((3, L.dim))
    H[:, L.slice("angular_velocity")] = np.eye(3)
    H[:, L.slice("gyro_bias")] = np.eye(3)
    return L.get(x, "angular_velocity") + L.get(x, "gyro_bias"), H


def hol_camera_implicit(
    x: np.ndarray,
    pixels: np.ndarray,
    points: np.ndarray,
    intrinsics: tuple[float, float, float, float],
    q_bc: np.ndarray,
    p_bc: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hol eq. 11c: ``h = [−f I₂, zⁱ] R^{cb}(R^{be}(z^e − b^e) − c^b)`` per correspondence (measured value 0).

    ``zⁱ`` is the measured pixel relative to the principal point, ``f`` in pixels (fx, fy separately).  Returns
    h (M, 2), ∂h/∂x (M, 2, 22) and the camera-frame depth (M,) (the noise of h is the pixel noise times the depth).
    """
    fx, fy, cx, cy = intrinsics
    R, dR = _rot_be_and_derivs(HOL22_STATE.get(x, "quat_be"))
    Rcb = dp.matrix_from_quat(dp.quat_conj(q_bc))
    d = np.asarray(points, float) - HOL22_STATE.get(x, "position")  # (M, 3)
    zb = d @ R.T - p_bc
    zc = zb @ Rcb.T
    zi = np.asarray(pixels, float) - [cx, cy]
    A = np.zeros((len(d), 2, 3))
    A[:, 0, 0] = -fx
    A[:, 1, 1] = -fy
    A[:, :, 2] = zi
    h = np.einsum("mij,mj->mi", A, zc)
    AR = np.einsum("mij,jk->mik", A, Rcb)  # ∂h/∂z^b
    H = np.zeros((len(d), 2, HOL22_STATE.dim))
    H[:, :, HOL22_STATE.slice("position")] = -np.einsum("mik,kl->mil", AR, R)
    H[:, :, HOL22_STATE.slice("quat_be")] = np.einsum("mik,qkl,ml->miq", AR, dR, d)
    return h, H, zc[:, 2]
