"""The classical closed-form solutions of the hand–eye equation ``A_i X = X B_i``.

Frames and inputs as in :mod:`dualpose.registration.hand_eye`: ``A_i`` the gripper (hand, body) motions in the gripper
frame, ``B_i`` the camera (eye) motions in the camera frame, ``X`` the camera pose in the gripper frame
(``p_gripper = X p_camera``).  With ``A = (R_A, t_A)``, ``B = (R_B, t_B)``, ``X = (R_X, t_X)`` the equation splits into
``R_A R_X = R_X R_B`` and ``(R_A − I) t_X = R_X t_B − t_A``.

* :func:`hand_eye_tsai_lenz` — Tsai & Lenz, "A new technique for fully autonomous and efficient 3D robotics hand/eye
  calibration", IEEE T-RA 5(3), 1989: linear least squares in the modified Rodrigues vectors
  ``P = 2 sin(θ/2) n``: ``[P_A + P_B]× P' = P_B − P_A`` with ``P'`` the Gibbs vector ``tan(θ_X/2) n_X``; then the
  translation by linear least squares.
* :func:`hand_eye_park_martin` — Park & Martin, "Robot sensor calibration: solving AX = XB on the Euclidean group",
  IEEE T-RA 10(5), 1994: ``α_i = log R_A_i = R_X β_i``, ``M = Σ β_i α_iᵀ``, ``R_X = (MᵀM)^(-1/2) Mᵀ``; translation as
  Tsai–Lenz.
* :func:`hand_eye_horaud_dornaika` — Horaud & Dornaika, "Hand-eye calibration", IJRR 14(3), 1995, linear rotation:
  ``R_A R_X = R_X R_B`` as ``q_A r = r q_B`` (unit quaternions, signs with ``w >= 0``), the unit ``r`` minimising
  ``Σ |(Q(q_A) − W(q_B)) r|²`` — the eigenvector of the smallest eigenvalue of a 4×4 matrix; translation as
  Tsai–Lenz.
* :func:`hand_eye_andreff` — Andreff, Horaud & Espiau, "On-line hand-eye calibration", 3DIM 1999: the linear system
  ``[[I₉ − R_A ⊗ R_B, 0], [I₃ ⊗ t_Bᵀ, I₃ − R_A]] [vec R_X; t_X] = [0; t_A]`` (row-major ``vec``) in least squares,
  the rotation block then projected on SO(3) (scale and sign from its determinant, orthogonal polar factor).
* :func:`hand_eye_daniilidis` — Daniilidis, "Hand-eye calibration using dual quaternions", IJRR 18(3), 1999
  (:func:`~dualpose.registration.calibrate_hand_eye`).

:data:`HAND_EYE_CLOSED_FORMS` maps their names to the functions.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose.registration.hand_eye import HandEyeWarning, calibrate_hand_eye, checked_motion_pairs

__all__ = [
    "HAND_EYE_CLOSED_FORMS",
    "hand_eye_andreff",
    "hand_eye_daniilidis",
    "hand_eye_horaud_dornaika",
    "hand_eye_park_martin",
    "hand_eye_translation",
    "hand_eye_tsai_lenz",
]


def _motions(
    A_motions: ArrayLike, B_motions: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Rotations (canonical quaternions, ``w >= 0``) and translations of the motions, after the shape checks."""
    a, b = checked_motion_pairs(A_motions, B_motions)
    qa, ta = dp.qt_from_dualquat(a)
    qb, tb = dp.qt_from_dualquat(b)
    return dp.quat_canonical(qa), ta, dp.quat_canonical(qb), tb


def hand_eye_translation(A_motions: ArrayLike, B_motions: ArrayLike, quat: ArrayLike) -> NDArray[np.float64]:
    """Translation of ``X`` (input units) for a given rotation: least squares of ``(R_A − I) t_X = R_X t_B − t_A``.

    This is the second step of Tsai & Lenz (1989); ``|(R_A − I) t_X − R_X t_B + t_A|`` is also the norm of the
    translation of the loop residual ``(A X)⁻¹ X B``, so the result minimises that residual's RMS for the rotation.

    Parameters
    ----------
    A_motions, B_motions : array_like, shape (n, 4, 4) or (n, 8)
        Gripper and camera motions (homogeneous matrices or dual quaternions ``[real xyzw, dual xyzw]``).
    quat : array_like, shape (4,)
        Rotation of ``X``, xyzw.

    Returns
    -------
    ndarray, shape (3,)
    """
    qa, ta, _, tb = _motions(A_motions, B_motions)
    return _translation(qa, ta, tb, np.asarray(quat, dtype=np.float64))


def _translation(qa: np.ndarray, ta: np.ndarray, tb: np.ndarray, qx: np.ndarray) -> NDArray[np.float64]:
    lhs = dp.matrix_from_quat(qa) - np.eye(3)
    rhs = dp.quat_rotate(qx, tb) - ta
    result: NDArray[np.float64] = np.linalg.lstsq(lhs.reshape(-1, 3), rhs.reshape(-1), rcond=None)[0]
    return result


def hand_eye_tsai_lenz(A_motions: ArrayLike, B_motions: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``X`` by Tsai & Lenz (1989).

    Parameters
    ----------
    A_motions, B_motions : array_like, shape (n, 4, 4) or (n, 8)
        Gripper motions (gripper frame) and camera motions (camera frame), n >= 2 with non-parallel axes.

    Returns
    -------
    quat : ndarray, shape (4,)
        Rotation of ``X``, xyzw, ``w >= 0``.
    translation : ndarray, shape (3,)
        Translation of ``X`` (input units).
    """
    qa, ta, qb, tb = _motions(A_motions, B_motions)
    pa, pb = 2.0 * qa[:, :3], 2.0 * qb[:, :3]  # 2 sin(θ/2) n, from w >= 0
    lhs = dp.so3_hat(pa + pb).reshape(-1, 3)
    gibbs = np.linalg.lstsq(lhs, (pb - pa).reshape(-1), rcond=None)[0]  # tan(θ_X/2) n_X
    qx = dp.quat_canonical(np.r_[gibbs, 1.0] / np.sqrt(1.0 + gibbs @ gibbs))
    return qx, _translation(qa, ta, tb, qx)


def hand_eye_park_martin(A_motions: ArrayLike, B_motions: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``X`` by Park & Martin (1994); parameters and returns as :func:`hand_eye_tsai_lenz`."""
    qa, ta, qb, tb = _motions(A_motions, B_motions)
    alpha, beta = dp.rotvec_from_quat(qa), dp.rotvec_from_quat(qb)
    m = np.einsum("ni,nj->ij", beta, alpha)
    lam, v = np.linalg.eigh(m.T @ m)
    if lam[0] <= 1e-12 * max(lam[-1], 1e-300):
        raise ValueError("the rotation axes of the motions are (nearly) parallel: MᵀM is singular")
    rx = (v / np.sqrt(lam)) @ v.T @ m.T
    qx = dp.quat_canonical(dp.quat_from_matrix(rx))
    return qx, _translation(qa, ta, tb, qx)


def hand_eye_horaud_dornaika(
    A_motions: ArrayLike, B_motions: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``X`` by Horaud & Dornaika (1995), linear rotation; parameters and returns as :func:`hand_eye_tsai_lenz`."""
    qa, ta, qb, tb = _motions(A_motions, B_motions)
    c = dp.quat_left_matrix(qa) - dp.quat_right_matrix(qb)
    _, v = np.linalg.eigh(np.einsum("nki,nkj->ij", c, c))
    qx = dp.quat_canonical(v[:, 0])
    return qx, _translation(qa, ta, tb, qx)


def hand_eye_andreff(A_motions: ArrayLike, B_motions: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``X`` by Andreff et al. (1999); parameters and returns as :func:`hand_eye_tsai_lenz`."""
    qa, ta, qb, tb = _motions(A_motions, B_motions)
    ra, rb = dp.matrix_from_quat(qa), dp.matrix_from_quat(qb)
    n = len(qa)
    lhs = np.zeros((n, 12, 12))
    lhs[:, :9, :9] = np.eye(9) - np.einsum("nij,nkl->nikjl", ra, rb).reshape(n, 9, 9)
    lhs[:, 9:, :9] = np.einsum("ij,nk->nijk", np.eye(3), tb).reshape(n, 3, 9)
    lhs[:, 9:, 9:] = np.eye(3) - ra
    rhs = np.zeros((n, 12))
    rhs[:, 9:] = ta
    z = np.linalg.lstsq(lhs.reshape(-1, 12), rhs.reshape(-1), rcond=None)[0]
    r = z[:9].reshape(3, 3)
    det = np.linalg.det(r)
    if not abs(det) > 1e-12:
        raise ValueError("the linear system of Andreff et al. is singular (parallel rotation axes?)")
    r = r * (np.sign(det) / np.cbrt(abs(det)))
    u, _, vt = np.linalg.svd(r)
    rx = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    return dp.quat_canonical(dp.quat_from_matrix(rx)), z[9:].copy()


def hand_eye_daniilidis(A_motions: ArrayLike, B_motions: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``X`` by Daniilidis (1999), :func:`~dualpose.registration.calibrate_hand_eye` without its warnings;
    parameters and returns as :func:`hand_eye_tsai_lenz`."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HandEyeWarning)
        r = calibrate_hand_eye(A_motions, B_motions)
    return r.quat, r.translation


HAND_EYE_CLOSED_FORMS: dict[str, Callable[[ArrayLike, ArrayLike], tuple[np.ndarray, np.ndarray]]] = {
    "tsai_lenz": hand_eye_tsai_lenz,
    "park_martin": hand_eye_park_martin,
    "horaud_dornaika": hand_eye_horaud_dornaika,
    "andreff": hand_eye_andreff,
    "daniilidis": hand_eye_daniilidis,
}
