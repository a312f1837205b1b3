"""Scene gravity alignment: the earth-frame gravity direction expressed in a scene model's frame, from periods at
rest (Hol 2008, §gravity alignment: "the gravity vector can be determined by averaging the accelerometer readings
over some time, while the camera is stationary in a known pose").

At rest the mean specific force is ``f_b = −R_wbᵀ g_w``, and the camera pose in the scene (PnP) with the known
extrinsic gives ``R_wb = R_wc R_bcᵀ``, so the scene-frame "up" is ``u_w = R_wc R_bcᵀ f_b / ‖f_b‖`` and gravity
points along ``−u_w``.  First-order errors (all tangent to ``u_w``):

* PnP attitude ``δθ_c`` (``R_wc,true = R̂_wc Exp(δθ_c)``): ``δu_w = −R_wc [v_c]× δθ_c``, ``v_c = R_bcᵀ f̂``;
* extrinsic ``ε`` (``R̂_bc = Exp(ε) R_bc,true``): ``δu_w = −R_wb [f̂]× ε``;
* accelerometer noise / uncalibrated bias ``δf``: ``δu_w = R_wb P δf / ‖f‖`` (``P = I − f̂ f̂ᵀ``).

Several periods are averaged with weights ``2 / tr C_k``; the extrinsic and bias terms are common to all periods
and are added as correlated terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp
from dualpose.calibration.static import checked_covariance3, checked_static_inputs
from dualpose.types._inputs import Doubt, gravity_sigma_doubt

__all__ = ["SceneGravity", "scene_gravity"]


@dataclass
class SceneGravity:
    """Result of :func:`scene_gravity`.

    Attributes
    ----------
    direction : ndarray (3,)
        Unit gravity direction (pointing down) in the scene frame.
    gravity : ndarray (3,)
        ``magnitude · direction``, m/s² — pass it as ``ErrorStateEKF(gravity=...)``.
    magnitude : float
        The ``magnitude`` argument, or the weighted mean ‖f_b‖ when it is None, m/s².
    covariance : ndarray (3, 3)
        Covariance of ``direction`` (rank 2, tangent plane), unit²  (≈ rad² per tangent axis).
    sigma_deg : float
        ``√tr(covariance)`` in degrees: the RMS angular error of the direction.
    tilt_deg : float
        Angle between ``direction`` and ``nominal_down``, degrees (the scene model's misalignment).
    q_level : ndarray (4,)
        Smallest rotation (xyzw) taking ``direction`` onto ``nominal_down``: apply it to the scene model
        (``x' = q_level x q_level*``) to level it.
    per_period : ndarray (K, 3)
        The direction from each period alone.
    doubt : Doubt or None
        ``"gravity_sigma"`` when ``sigma_deg`` exceeds 1° (the rule of every gravity estimate,
        ``dualpose.types._inputs.gravity_sigma_doubt``; above 5° :func:`scene_gravity` refuses).
    """

    direction: np.ndarray
    gravity: np.ndarray
    magnitude: float
    covariance: np.ndarray
    sigma_deg: float
    tilt_deg: float
    q_level: np.ndarray
    per_period: np.ndarray
    doubt: Doubt | None = None


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), float(a @ b))))


def scene_gravity(
    specific_force: np.ndarray,
    q_wc: np.ndarray,
    q_bc: np.ndarray,
    specific_force_covariance: np.ndarray | None = None,
    attitude_covariance: np.ndarray | None = None,
    extrinsic_covariance: np.ndarray | None = None,
    accel_bias_covariance: np.ndarray | None = None,
    nominal_down: ArrayLike = (0.0, 0.0, -1.0),
    magnitude: float | None = None,
) -> SceneGravity:
    """Gravity direction in the scene frame from ``K >= 1`` static periods, with its covariance.

    Parameters
    ----------
    specific_force : (K, 3) or (3,)
        Mean accelerometer reading at rest, body frame, m/s².
    q_wc : (K, 4) or (4,)
        Camera→scene orientation during each period (PnP), xyzw.
    q_bc : (4,)
        Camera→body rotation (extrinsic), xyzw.
    specific_force_covariance : (K, 3, 3) or (3, 3), optional
        White-noise covariance of each mean specific force, m²/s⁴.
    attitude_covariance : (K, 3, 3) or (3, 3), optional
        PnP camera-frame attitude covariance of each period, rad².
    extrinsic_covariance : (3, 3), optional
        ``Cov(ε)`` of ``q_bc`` (e.g. the ``covariance`` of :class:`ExtrinsicRotation`), rad².
    accel_bias_covariance : (3, 3), optional
        Uncertainty of the accelerometer bias left in ``specific_force``, m²/s⁴ (common to all periods).
    nominal_down : (3,)
        The scene model's assumed gravity direction (for ``tilt_deg`` and ``q_level``).
    magnitude : float, optional
        Gravity magnitude for ``gravity`` (default: measured).

    Raises
    ------
    ValueError
        The periods do not determine the direction: its σ (``sigma_deg``) above 5° (docs/refusals.md, "Gravity
        direction"); above 1° the result carries the ``doubt``.
    """
    f, q, cf, ca = checked_static_inputs(specific_force, q_wc, specific_force_covariance, attitude_covariance, 1)
    q_bc = np.asarray(q_bc, dtype=np.float64)
    if q_bc.shape != (4,) or not np.isfinite(q_bc).all():
        raise ValueError(f"q_bc must be a finite array of shape (4,); got {np.shape(q_bc)}")
    down_n = np.asarray(nominal_down, dtype=np.float64)
    if down_n.shape != (3,) or np.linalg.norm(down_n) == 0:
        raise ValueError(f"nominal_down must be a nonzero vector of shape (3,); got {np.shape(nominal_down)}")
    down_n = down_n / np.linalg.norm(down_n)
    nf = np.linalg.norm(f, axis=1)
    fh = f / nf[:, None]
    R_bc = dp.matrix_from_quat(q_bc)
    R_wc = dp.matrix_from_quat(q)  # (K, 3, 3)
    R_wb = R_wc @ R_bc.T
    u_w = np.einsum("kij,kj->ki", R_wb, fh)  # (K, 3) scene-frame up per period
    v_c = fh @ R_bc  # R_bcᵀ f̂, (K, 3)
    j_att = -np.einsum("kij,kjl->kil", R_wc, dp.so3_hat(v_c))
    proj = np.eye(3) - np.einsum("ki,kj->kij", fh, fh)
    j_f = np.einsum("kij,kjl->kil", R_wb, proj) / nf[:, None, None]
    c_ind = np.einsum("kij,kjl,kml->kim", j_att, ca, j_att) + np.einsum("kij,kjl,kml->kim", j_f, cf, j_f)
    tr = np.trace(c_ind, axis1=1, axis2=2)
    w = 2.0 / np.maximum(tr, 1e-300) if np.any(tr > 0) else np.ones(len(f))
    w = w / w.sum()
    m = w @ u_w
    up = m / np.linalg.norm(m)
    # the normalized weighted mean: δup = P_up Σ w_k δu_k / ‖m‖
    p_up = (np.eye(3) - np.outer(up, up)) / np.linalg.norm(m)
    cov = p_up @ np.einsum("k,kij->ij", w**2, c_ind) @ p_up.T
    if extrinsic_covariance is not None:
        se = checked_covariance3(extrinsic_covariance, "extrinsic_covariance")
        a = p_up @ np.einsum("k,kij,kjl->il", w, -R_wb, dp.so3_hat(fh))
        cov = cov + a @ se @ a.T
    if accel_bias_covariance is not None:
        sb = checked_covariance3(accel_bias_covariance, "accel_bias_covariance")
        a = p_up @ np.einsum("k,kij->ij", w, j_f)
        cov = cov + a @ sb @ a.T
    cov = 0.5 * (cov + cov.T)
    sigma = float(np.sqrt(max(np.trace(cov), 0.0)))
    doubt = gravity_sigma_doubt(sigma, "scene gravity", f"{len(f)} static period(s) and their camera poses")
    down = -up
    axis = np.cross(down, down_n)
    rotvec = axis / max(np.linalg.norm(axis), 1e-300) * np.radians(_angle(down, down_n))
    mag = float(w @ nf) if magnitude is None else float(magnitude)
    return SceneGravity(
        direction=down, gravity=mag * down, magnitude=mag, covariance=cov,
        sigma_deg=math.degrees(sigma), tilt_deg=_angle(down, down_n),
        q_level=dp.quat_from_rotvec(rotvec), per_period=-u_w, doubt=doubt,
    )  # fmt: skip
