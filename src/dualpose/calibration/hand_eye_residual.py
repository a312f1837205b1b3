"""Motion pairs and the hand–eye loop residual shared by the estimator, its tests and the benchmark.

Frames: camera poses ``A_i`` (camera in target), body poses ``B(t)`` (marker in motion capture, or hand in robot
base), ``X`` the camera pose in the body frame.  For a pair of camera stamps ``(t_i, t_j)`` and a time offset ``τ``
(camera time ``t`` ↔ body time ``t + τ``) the relative motions are ``A_ij = A_i⁻¹ A_j`` (camera frame) and
``B_ij = B(t_i + τ)⁻¹ B(t_j + τ)`` (body frame; SLERP + linear interpolation), and ``B_ij X = X A_ij`` holds for
the true ``X`` and ``τ``.  The loop residual of a pair is ``E_ij = (B_ij X)⁻¹ (X A_ij)``: its rotation angle
(rotation residual) and the norm of its translation (translation residual).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

import dualpose as dp
from dualpose.calibration.hand_eye_streams import PoseStream, interpolate_stream

__all__ = [
    "LoopResidual",
    "select_pairs",
    "pair_motions",
    "pair_residuals",
    "squared_pair_residuals",
    "fit_hand_eye",
    "loop_residual",
]


def select_pairs(
    camera: PoseStream, *, min_angle: float = np.deg2rad(10.0), max_dt: float = 2.0
) -> tuple[np.ndarray, np.ndarray]:
    """Camera index pairs ``(i, j)``: for each ``i`` the first ``j > i`` that rotated by at least ``min_angle``.

    Parameters
    ----------
    camera : PoseStream
    min_angle : float
        Smallest rotation angle of ``A_i⁻¹ A_j`` (rad; default 10°): pairs that rotate little determine the
        rotation axis poorly.
    max_dt : float
        Largest ``t_j − t_i`` (s); an ``i`` without such a partner forms no pair.

    Returns
    -------
    i, j : ndarray of int, shape (m,)
    """
    t, q = camera.stamps, camera.quats
    n = len(t)
    reach = np.searchsorted(t, t + max_dt, side="right") - 1 - np.arange(n)
    j = np.full(n, -1)
    for d in range(1, int(reach.max(initial=0)) + 1):
        cand = np.flatnonzero((j < 0) & (reach >= d))
        if cand.size == 0:
            break
        ang = dp.quat_angle(q[cand], q[cand + d])
        hit = cand[ang >= min_angle]
        j[hit] = hit + d
    i = np.flatnonzero(j >= 0)
    return i, j[i]


def pair_motions(
    camera: PoseStream, body: PoseStream, i: np.ndarray, j: np.ndarray, tau: float, max_gap: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Relative motions of the pairs: ``A_ij`` from the camera samples, ``B_ij`` from the body at ``t + τ``.

    Returns
    -------
    qa, ta : ndarray, shapes (m, 4), (m, 3)
        ``A_ij`` (camera frame at ``t_i``; metres).
    qb, tb : ndarray, shapes (m, 4), (m, 3)
        ``B_ij`` (body frame at ``t_i + τ``; metres).
    valid : ndarray of bool, shape (m,)
        Both body poses interpolated inside the stream and not across a gap longer than ``max_gap``.
    """
    pb, qb, ok = interpolate_stream(body, np.concatenate([camera.stamps[i], camera.stamps[j]]) + tau, max_gap)
    m = len(i)
    qbi, tbi = dp.qt_conj(qb[:m], pb[:m])
    qbij, tbij = dp.qt_mul(qbi, tbi, qb[m:], pb[m:])
    qai, tai = dp.qt_conj(camera.quats[i], camera.positions[i])
    qaij, taij = dp.qt_mul(qai, tai, camera.quats[j], camera.positions[j])
    return qaij, taij, qbij, tbij, ok[:m] & ok[m:]


def pair_residuals(
    qa: np.ndarray, ta: np.ndarray, qb: np.ndarray, tb: np.ndarray, qx: np.ndarray, tx: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Loop residuals ``E = (B X)⁻¹ (X A)``: rotation vectors (m, 3) in rad and translations (m, 3) in metres."""
    qbx, tbx = dp.qt_mul(qb, tb, qx, tx)
    qxa, txa = dp.qt_mul(qx, tx, qa, ta)
    qe, te = dp.qt_mul(*dp.qt_conj(qbx, tbx), qxa, txa)
    return dp.rotvec_from_quat(qe), te


def squared_pair_residuals(
    qa: np.ndarray, ta: np.ndarray, qb: np.ndarray, tb: np.ndarray, qx: np.ndarray, tx: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Squared rotation angles (m,) rad² and squared translation norms (m,) m² of the loop residuals
    (:func:`pair_residuals`)."""
    rv, te = pair_residuals(qa, ta, qb, tb, qx, tx)
    return np.einsum("ij,ij->i", rv, rv), np.einsum("ij,ij->i", te, te)


def fit_hand_eye(
    qa: np.ndarray, ta: np.ndarray, qb: np.ndarray, tb: np.ndarray, qx0: np.ndarray, tx0: np.ndarray,
    sigma_rotation: float, sigma_translation: float,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """``X`` minimising ``Σ |θ_ij|²/σ_r² + |t_ij|²/σ_t²`` at a fixed time offset, from the start ``(qx0, tx0)``.

    Returns the rotation (4,) xyzw and translation (3,) m of ``X``.
    """

    def fun(z: np.ndarray) -> np.ndarray:
        q = dp.quat_mul(dp.quat_from_rotvec(z[:3]), qx0)
        rv, te = pair_residuals(qa, ta, qb, tb, q, z[3:])
        return np.hstack([rv / sigma_rotation, te / sigma_translation]).ravel()

    sol = least_squares(fun, np.r_[0.0, 0.0, 0.0, tx0], method="lm", xtol=1e-12, ftol=1e-12)
    return dp.quat_canonical(dp.quat_mul(dp.quat_from_rotvec(sol.x[:3]), qx0)), sol.x[3:].copy()


@dataclass(frozen=True)
class LoopResidual:
    """The loop residual of a pair set at one time offset, with ``X`` re-fitted there (see :func:`loop_residual`).

    Attributes
    ----------
    time_offset : float
        ``τ`` (s).
    cost : float
        ``mean_ij (|θ_ij|²/σ_r² + |t_ij|²/σ_t²)`` (dimensionless).
    rotation_rmse_deg, translation_rmse_m : float
        RMS over the pairs of the rotation angle (deg) and translation norm (m) of ``E_ij``.
    quat, translation : ndarray, shapes (4,), (3,)
        ``X`` used.
    pairs : int
        Pairs with valid body poses at this ``τ``.
    """

    time_offset: float
    cost: float
    rotation_rmse_deg: float
    translation_rmse_m: float
    quat: np.ndarray
    translation: np.ndarray
    pairs: int


def loop_residual(
    camera: PoseStream, body: PoseStream, i: np.ndarray, j: np.ndarray, tau: float, quat: np.ndarray,
    translation: np.ndarray, sigma_rotation: float, sigma_translation: float, *, refit: bool = True,
    max_gap: float | None = None,
) -> LoopResidual:  # fmt: skip
    """Loop residual of the pairs ``(i, j)`` at time offset ``tau``.

    With ``refit`` (default) ``X`` is re-fitted at ``tau`` by :func:`fit_hand_eye` starting from ``(quat,
    translation)``, so that scanning ``tau`` traces the profile ``min_X cost(X, τ)`` whose minimum is the joint
    estimate of ``(X, τ)``; without it ``X`` stays fixed.  Pairs whose body poses are not valid at ``tau`` are left
    out (``pairs`` counts those kept).
    """
    qa, ta, qb, tb, ok = pair_motions(camera, body, i, j, tau, max_gap)
    qa, ta, qb, tb = qa[ok], ta[ok], qb[ok], tb[ok]
    if not ok.any():
        raise ValueError(f"no pair has valid body poses at time offset {tau:.6f} s")
    qx, tx = np.asarray(quat, float), np.asarray(translation, float)
    if refit:
        qx, tx = fit_hand_eye(qa, ta, qb, tb, qx, tx, sigma_rotation, sigma_translation)
    th2, t2 = squared_pair_residuals(qa, ta, qb, tb, qx, tx)
    cost = float(np.mean(th2 / sigma_rotation**2 + t2 / sigma_translation**2))
    return LoopResidual(float(tau), cost, float(np.degrees(np.sqrt(th2.mean()))), float(np.sqrt(t2.mean())), qx, tx,
                        int(ok.sum()))  # fmt: skip
