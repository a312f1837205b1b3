"""Camera–IMU relative orientation from static poses (Hol 2008, §"Sensor pose calibration").

With the sensor at rest in ``K`` poses in front of a calibration pattern lying on a horizontal surface, the
accelerometer measures the body-frame "up" direction ``u_b,k = f_b,k / ‖f_b,k‖`` (Hol eq. 2 with ``b̈ = 0``:
``y_a = −g^b``), and the pattern's PnP pose gives the same vertical in the camera frame, ``u_c,k = R_wc,kᵀ u_w``
(``u_w`` the pattern's known up direction).  Both are the same physical direction, so

    u_b,k = R_bc u_c,k        (R_bc: camera→body, the columns are the camera axes in the body frame)

which is Wahba's problem, solved with the directions-only registration
(:func:`dualpose.registration.register_pose`, model = camera verticals, measured = body verticals).  Rotation about
the vertical is unobservable from a single gravity direction: at least two poses with different body-frame
gravity directions are needed (in practice tilt by tens of degrees about two axes).

Uncertainty (first order, :meth:`dualpose.registration.PoseEstimate.direction_influence`): each pair's residual
``R_bc u_c,k − u_b,k`` has the tangent-plane covariance ``C_k = R_bc Σ_uc,k R_bcᵀ + Σ_ub,k`` with
``Σ_ub = P Σ_f P / ‖f‖²`` (``P = I − u uᵀ``; white accelerometer noise of the averaged specific force) and
``Σ_uc = [u_c]× Σ_θ [u_c]×ᵀ`` (PnP attitude error ``δθ_c``: ``δu_c = [u_c]× δθ_c``).  Pairs are weighted with
``α_k = 2 / tr C_k`` and the sandwich ``Σ_k G_k C_k G_kᵀ`` is the covariance; errors shared by all poses — an
uncalibrated accelerometer bias ``b`` (``δu_b,k = P_k b / ‖f_k‖``) and a tilt of the pattern (``δu_c,k = R_wc,kᵀ
δu_w``) — are added as fully correlated terms ``(Σ_k G_k M_k) Σ (Σ_k G_k M_k)ᵀ``.

Error convention: ``R̂_bc = Exp(ε) R_bc,true`` (body frame); ``covariance`` is ``Cov(ε)`` (3, 3), rad².
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp
from dualpose.calibration.static import checked_covariance3, checked_static_inputs

__all__ = ["ExtrinsicRotation", "camera_imu_rotation", "unobservability_check"]


@dataclass
class ExtrinsicRotation:
    """Result of :func:`camera_imu_rotation`.

    Attributes
    ----------
    q_bc : ndarray (4,)
        Camera→body rotation, xyzw (the camera axes in the body frame; :func:`dualpose.sim.default_extrinsic`'s
        convention).
    covariance : ndarray (3, 3)
        ``Cov(ε)``, ``R̂_bc = Exp(ε) R_bc,true`` (body frame), rad².
    sigma_deg : ndarray (3,)
        Per-axis standard deviations (body x, y, z), degrees.
    residual_deg : ndarray (K,)
        Angle between ``R̂_bc u_c,k`` and ``u_b,k`` per pose, degrees.
    spread_deg : float
        Spread of the body-frame gravity directions (the angle whose tangent is ``√(λ₂/λ₁)`` of their scatter
        matrix); near 0 the rotation about the vertical is unobservable.
    weights : ndarray (K,)
        Direction weights used (``2 / tr C_k``; ones without noise information).
    noise_from_residuals : bool
        True when no noise information was given and the isotropic direction σ was estimated from the residuals.
    registration : PoseEstimate
        The directions-only registration result.
    """

    q_bc: np.ndarray
    covariance: np.ndarray
    sigma_deg: np.ndarray
    residual_deg: np.ndarray
    spread_deg: float
    weights: np.ndarray
    noise_from_residuals: bool
    registration: object


def _spread_deg(u: np.ndarray) -> float:
    lam = np.linalg.eigvalsh(u.T @ u / len(u))[::-1]
    return float(np.degrees(np.arctan2(np.sqrt(max(lam[1], 0.0)), np.sqrt(max(lam[0], 0.0)))))


def unobservability_check(up_b: np.ndarray, direction_sigma: float, name: str = "specific_force") -> float:
    """Spread (degrees) of the unit directions ``up_b`` (K, 3); raise ValueError when rotation about the vertical is
    unobservable: the spread is below 3× the per-direction noise ``direction_sigma`` (rad) or numerically zero."""
    spread = _spread_deg(up_b)
    floor = max(3.0 * np.degrees(direction_sigma), 1e-6)
    if spread < floor:
        raise ValueError(
            f"{name}: all {len(up_b)} body-frame gravity directions are parallel (spread {spread:.3g} deg, noise "
            f"floor {floor:.3g} deg), so the rotation about the vertical is unobservable; record static poses with "
            "the sensor tilted differently (at least two distinct gravity directions, ideally tens of degrees apart "
            "about two axes)"
        )
    return spread


def camera_imu_rotation(
    specific_force: np.ndarray,
    q_wc: np.ndarray,
    pattern_up_w: ArrayLike = (0.0, 0.0, 1.0),
    specific_force_covariance: np.ndarray | None = None,
    attitude_covariance: np.ndarray | None = None,
    accel_bias_covariance: np.ndarray | None = None,
    pattern_tilt_sigma: float = 0.0,
) -> ExtrinsicRotation:
    """Camera→body rotation ``R_bc`` from ``K`` static poses (Hol 2008), with its first-order covariance.

    Parameters
    ----------
    specific_force : (K, 3)
        Mean accelerometer reading at rest in each pose, body frame, m/s² (bias-corrected if the bias is known).
    q_wc : (K, 4)
        Camera→pattern orientation in each pose (PnP), xyzw.
    pattern_up_w : (3,)
        The pattern's "up" (minus gravity) direction in its own frame (default z: a pattern lying level).
    specific_force_covariance : (K, 3, 3) or (3, 3), optional
        Covariance of each mean specific force (white noise: ``σ_a² / T``), m²/s⁴.
    attitude_covariance : (K, 3, 3) or (3, 3), optional
        Covariance of each PnP camera-frame attitude error ``δθ_c``, rad².
    accel_bias_covariance : (3, 3), optional
        Uncertainty of the (common) accelerometer bias left in ``specific_force``, m²/s⁴: a correlated term.
    pattern_tilt_sigma : float
        Standard deviation (rad, per tangent axis) of the pattern's levelling: a correlated term.

    Without any noise information the direction σ is estimated from the residuals (needs K >= 3).

    Raises
    ------
    ValueError
        Bad shapes (naming the argument and the expected shape), fewer than 2 poses, or parallel body-frame gravity
        directions (rotation about the vertical unobservable, :func:`unobservability_check`).
    """
    from dualpose.registration import register_pose

    f, q, cf, ca = checked_static_inputs(specific_force, q_wc, specific_force_covariance, attitude_covariance, 2)
    k = len(f)
    up_w = np.asarray(pattern_up_w, dtype=np.float64)
    if up_w.shape != (3,) or not np.isfinite(up_w).all() or np.linalg.norm(up_w) == 0:
        raise ValueError(f"pattern_up_w must be a finite nonzero vector of shape (3,); got {np.shape(pattern_up_w)}")
    up_w = up_w / np.linalg.norm(up_w)
    nf = np.linalg.norm(f, axis=1)
    u_b = f / nf[:, None]
    R_wc = dp.matrix_from_quat(q)  # (K, 3, 3)
    u_c = np.einsum("kji,j->ki", R_wc, up_w)  # R_wcᵀ u_w
    proj = np.eye(3) - np.einsum("ki,kj->kij", u_b, u_b)
    cov_ub = np.einsum("kij,kjl,kml->kim", proj, cf, proj) / nf[:, None, None] ** 2
    hat_c = dp.so3_hat(u_c)
    cov_uc = np.einsum("kij,kjl,kml->kim", hat_c, ca, hat_c)
    has_noise = bool(np.any(cov_ub) or np.any(ca))
    sigma_floor = np.sqrt(np.mean(np.trace(cov_ub, axis1=1, axis2=2) + np.trace(cov_uc, axis1=1, axis2=2)) / 2)
    spread = unobservability_check(u_b, sigma_floor)

    weights = np.ones(k)
    est = register_pose(None, None, model_directions=u_c, measured_directions=u_b, direction_weights=weights)
    if has_noise:  # re-weight with the tangent-plane variances at the first solution, then solve again
        R = est.rotation_matrix
        cpair = np.einsum("ij,kjl,ml->kim", R, cov_uc, R) + cov_ub
        weights = 2.0 / np.maximum(np.trace(cpair, axis1=1, axis2=2), 1e-300)
        weights = weights / weights.max()
        est = register_pose(None, None, model_directions=u_c, measured_directions=u_b, direction_weights=weights)
    if not est.rotation_unique:
        raise ValueError(f"specific_force/q_wc: the rotation is not unique (degeneracy={est.degeneracy!r})")
    R = est.rotation_matrix
    noise_from_residuals = not has_noise
    if has_noise:
        cpair = np.einsum("ij,kjl,ml->kim", R, cov_uc, R) + cov_ub
        cov = est.rotation_covariance(direction_covariances=cpair)
    else:
        if k < 3:
            raise ValueError("specific_force: without noise information at least 3 poses are needed to estimate it")
        sigma_d = np.sqrt(float(np.sum(est.direction_residuals**2)) / (2 * k - 3))
        cov = est.rotation_covariance(sigma_directions=sigma_d)
    g = est.direction_influence()  # (K, 3, 3): ε = Σ G_k e_k, e_k the measured-direction (u_b) error
    if accel_bias_covariance is not None:
        sb = checked_covariance3(accel_bias_covariance, "accel_bias_covariance")
        a = np.einsum("kij,kjl->il", g, proj / nf[:, None, None])
        cov = cov + a @ sb @ a.T
    if pattern_tilt_sigma:
        if not (np.isfinite(pattern_tilt_sigma) and pattern_tilt_sigma > 0):
            raise ValueError(f"pattern_tilt_sigma must be finite and >= 0; got {pattern_tilt_sigma}")
        # a model (camera) direction error e⁰ acts as the measured error −R e⁰, with e⁰_k = R_wc,kᵀ δu_w
        a = -np.einsum("kij,jl,kml->im", g, R, R_wc)
        st = pattern_tilt_sigma**2 * (np.eye(3) - np.outer(up_w, up_w))
        cov = cov + a @ st @ a.T
    cov = 0.5 * (cov + cov.T)
    resid = np.degrees(np.arctan2(np.linalg.norm(np.cross(u_c @ R.T, u_b), axis=1), np.sum((u_c @ R.T) * u_b, axis=1)))
    return ExtrinsicRotation(
        q_bc=est.quat.copy(), covariance=cov, sigma_deg=np.degrees(np.sqrt(np.diag(cov))), residual_deg=resid,
        spread_deg=spread, weights=weights, noise_from_residuals=noise_from_residuals, registration=est,
    )  # fmt: skip
