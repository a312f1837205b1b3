"""Hand–eye calibration ``A_i X = X B_i`` with dual quaternions (Daniilidis, IJRR 18(3), 1999).

Frames: ``A_i`` are motions of the gripper (hand) expressed in the gripper frame, ``B_i`` the corresponding motions
of the camera (eye) in the camera frame, and ``X`` is the camera pose in the gripper frame (OpenCV's
``cam2gripper``: ``p_gripper = X p_camera``).  From absolute poses: ``A = G_i⁻¹ G_j`` (gripper-to-base poses ``G``)
and ``B = C_i C_j⁻¹`` (target-to-camera poses ``C``) — :func:`hand_eye_motions` builds them.  Dual quaternions are
``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose.algebra import _agreement

__all__ = ["HandEyeResult", "HandEyeWarning", "calibrate_hand_eye", "hand_eye_motions"]


class HandEyeWarning(UserWarning):
    """Hand–eye data that leave part of ``X`` unobservable or contain inconsistent motion pairs."""


@dataclass(frozen=True)
class HandEyeResult:
    """Result of :func:`calibrate_hand_eye`.

    Attributes
    ----------
    dualquat : ndarray (8,)
        ``X`` as a unit dual quaternion (``w >= 0``).
    quat : ndarray (4,), translation : ndarray (3,), matrix : ndarray (4, 4)
        ``X`` as rotation (xyzw), translation and homogeneous matrix.
    rotation_residuals : ndarray (n,)
        Angle (rad) of ``(A_i X)⁻¹ X B_i`` per motion pair.
    translation_residuals : ndarray (n,)
        Norm of its translation (units of the input).
    singular_values : ndarray (8,)
        Of the stacked ``6n x 8`` Daniilidis matrix (two near-zero values for consistent, non-degenerate data).
    incongruent_pairs : ndarray of int
        Pairs whose screw invariants differ: ``|θ_A − θ_B| > angle_tol`` or ``|d_A − d_B| > distance_tol``
        (rotation angle and translation along the axis must match for ``AX = XB`` to hold).
    parallel_axes : bool
        True when all rotation axes are (nearly) parallel: the rotation about them is still found but the
        translation of ``X`` along the common axis is unobservable.
    covariance : ndarray (6, 6)
        First-order covariance of ``[δθ, δt]`` (``X_true = exp([δθ, ·]) X̂`` with ``δt`` added to the translation)
        from the residual scatter: ``σ̂² (JᵀJ)⁻¹`` with ``σ̂² = ‖r‖² / (6n − 6)`` over the stacked twist residuals
        ``log((A_i X)⁻¹ X B_i)``.  The translation rows and columns are ``inf`` when ``parallel_axes``.
    """

    dualquat: np.ndarray
    quat: np.ndarray
    translation: np.ndarray
    matrix: np.ndarray
    rotation_residuals: np.ndarray
    translation_residuals: np.ndarray
    singular_values: np.ndarray
    incongruent_pairs: np.ndarray
    parallel_axes: bool
    covariance: np.ndarray

    def __post_init__(self) -> None:
        """The four forms of ``X`` repeat one pose: refused when they disagree
        (:func:`~dualpose.algebra._agreement.check_pose_agrees`)."""
        _agreement.check_pose_agrees(self.quat, self.translation, self.dualquat, self.matrix)


def _as_dualquats(m: ArrayLike, name: str) -> NDArray[np.float64]:
    import dualpose as dp

    arr = np.asarray(m, dtype=np.float64)
    if arr.ndim == 3 and arr.shape[1:] == (4, 4):
        return dp.dualquat_from_matrix(arr)
    if arr.ndim == 2 and arr.shape[1] == 8:
        return dp.dualquat_normalize(arr)
    raise ValueError(f"{name} must have shape (n, 4, 4) (homogeneous matrices) or (n, 8) (dual quaternions); "
                     f"got {arr.shape}")  # fmt: skip


def checked_motion_pairs(A_motions: ArrayLike, B_motions: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``A_motions`` and ``B_motions`` as unit dual quaternions (n, 8) after the checks every hand–eye solver needs:
    shapes ``(n, 4, 4)`` or ``(n, 8)``, equal counts, ``n >= 2``, finite values (ValueError naming the argument)."""
    a = _as_dualquats(A_motions, "A_motions")
    b = _as_dualquats(B_motions, "B_motions")
    if a.shape != b.shape:
        raise ValueError(f"A_motions and B_motions must have the same count; got {len(a)} and {len(b)}")
    if len(a) < 2:
        raise ValueError(f"need at least 2 motion pairs with non-parallel rotation axes; got {len(a)}")
    if not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ValueError("A_motions and B_motions must be finite")
    return a, b


def hand_eye_motions(
    gripper_to_base: ArrayLike, target_to_camera: ArrayLike, pairs: str = "all"
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Relative motions ``A = G_i⁻¹ G_j``, ``B = C_i C_j⁻¹`` (dual quaternions (m, 8)) from absolute poses.

    ``gripper_to_base`` and ``target_to_camera``: (n, 4, 4) or (n, 8).  ``pairs``: ``"all"`` (i < j) or
    ``"consecutive"`` (j = i + 1).
    """
    import dualpose as dp

    g = _as_dualquats(gripper_to_base, "gripper_to_base")
    c = _as_dualquats(target_to_camera, "target_to_camera")
    if g.shape != c.shape:
        raise ValueError(f"gripper_to_base and target_to_camera must have the same count; got {len(g)} and {len(c)}")
    if pairs == "all":
        i, j = np.triu_indices(len(g), 1)
    elif pairs == "consecutive":
        i = np.arange(len(g) - 1)
        j = i + 1
    else:
        raise ValueError(f"pairs must be 'all' or 'consecutive'; got {pairs!r}")
    a = dp.dualquat_mul(dp.dualquat_conj(g[i]), g[j])
    b = dp.dualquat_mul(c[i], dp.dualquat_conj(c[j]))
    return a, b


def _residual_twists(a: np.ndarray, b: np.ndarray, x: np.ndarray) -> NDArray[np.float64]:
    import dualpose as dp

    lhs = dp.dualquat_mul(a, x)
    rhs = dp.dualquat_mul(x, b)
    return dp.twist_from_dualquat(dp.dualquat_mul(dp.dualquat_conj(lhs), rhs))


def calibrate_hand_eye(
    A_motions: ArrayLike,
    B_motions: ArrayLike,
    *,
    angle_tol: float = np.deg2rad(1.0),
    distance_tol: float | None = None,
    exclude_incongruent: bool = False,
) -> HandEyeResult:
    """Solve ``A_i X = X B_i`` for the rigid ``X`` (Daniilidis 1999 §5).

    Steps: (1) motions as unit dual quaternions; each ``B_i`` is sign-aligned with its ``A_i`` (the scalar parts
    of the real and dual quaternions must match: with a random sign the stacked system mixes ``X`` and a
    different solution, giving errors near 180°); (2) screw congruence check (equal rotation angles and
    translations along the axes, within ``angle_tol`` / ``distance_tol``); (3) for every pair the 6x8 block
    ``[[a − b, [a + b]×, 0, 0], [a' − b', [a' + b']×, a − b, [a + b]×]]`` (vector parts of the real ``a, b`` and dual
    ``a', b'`` parts; unknown ``[x₀, x, x'₀, x']``, scalar first) — Daniilidis eq. (31) — stacked and decomposed
    by SVD; (4) ``x̂ = λ₁ v₇ + λ₂ v₈`` from the right singular vectors of the two smallest singular values with
    ``λ₁, λ₂`` from ``x̂ᵀx̂ = 1`` and ``x̂ᵀx̂' = 0`` (the quadratic in ``s = λ₁/λ₂``, eqs. (34)-(35)).

    Parameters
    ----------
    A_motions, B_motions : array_like, shape (n, 4, 4) or (n, 8)
        Gripper motions (gripper frame) and camera motions (camera frame), n >= 2 with non-parallel axes.
    angle_tol : float
        Tolerance of the congruence check on rotation angles (rad, default 1°).
    distance_tol : float, optional
        Tolerance on the translations along the screw axes (default: 1% of the largest motion translation).
    exclude_incongruent : bool
        Leave incongruent pairs out of the solve (they are always reported).

    Returns
    -------
    HandEyeResult

    Warns
    -----
    HandEyeWarning
        When pairs are incongruent, or when every rotation axis is parallel (translation along it unobservable).

    Raises
    ------
    ValueError
        Shapes, fewer than 2 motion pairs, or (nearly) pure translations only.
    """
    import dualpose as dp

    a, b = checked_motion_pairs(A_motions, B_motions)
    # (1) signs: choose ±b so that its scalar parts match a's
    plus = np.abs(a[:, 3] - b[:, 3]) + np.abs(a[:, 7] - b[:, 7])
    minus = np.abs(a[:, 3] + b[:, 3]) + np.abs(a[:, 7] + b[:, 7])
    b = np.where((minus < plus)[:, None], -b, b)
    # (2) screw congruence
    axis_a, _, d_a, th_a = dp.screw_from_dualquat(a)
    _, _, d_b, th_b = dp.screw_from_dualquat(b)
    if distance_tol is None:
        _, ta = dp.qt_from_dualquat(a)
        distance_tol = 0.01 * max(float(np.abs(ta).max()), 1e-300)
    bad = np.flatnonzero((np.abs(th_a - th_b) > angle_tol) | (np.abs(d_a - d_b) > distance_tol))
    if bad.size:
        warnings.warn(
            f"{bad.size} of {len(a)} motion pair(s) fail the screw congruence check (angle/translation along the "
            f"axis of A and B differ): indices {bad[:10].tolist()}{'...' if bad.size > 10 else ''}",
            HandEyeWarning,
            stacklevel=2,
        )
    use = np.ones(len(a), bool)
    if exclude_incongruent:
        use[bad] = False
    rotating = th_a > 1e-6
    if np.count_nonzero(use & rotating) < 2:
        raise ValueError("need at least 2 usable motion pairs that rotate (pure translations do not determine X)")
    axes = axis_a[use & rotating]
    sv_axes = np.linalg.svd(axes, compute_uv=False)
    parallel = bool(sv_axes[1] <= 1e-3 * sv_axes[0])
    if parallel:
        warnings.warn(
            "all rotation axes are parallel: the translation of X along the common axis is unobservable",
            HandEyeWarning,
            stacklevel=2,
        )
    # (3) stacked 6x8 blocks, unknown [x0, x, x0', x'] (scalar first)
    au, bu = a[use], b[use]
    ar, ad, br, bd = au[:, :3], au[:, 4:7], bu[:, :3], bu[:, 4:7]
    m = len(au)
    t = np.zeros((m, 6, 8))
    t[:, :3, 0] = ar - br
    t[:, :3, 1:4] = dp.so3_hat(ar + br)
    t[:, 3:, 0] = ad - bd
    t[:, 3:, 1:4] = dp.so3_hat(ad + bd)
    t[:, 3:, 4] = ar - br
    t[:, 3:, 5:8] = dp.so3_hat(ar + br)
    _, sv, vt = np.linalg.svd(t.reshape(6 * m, 8), full_matrices=False)
    v7, v8 = vt[6], vt[7]
    u1, w1, u2, w2 = v7[:4], v7[4:], v8[:4], v8[4:]
    # (4) λ1 v7 + λ2 v8 with s = λ1/λ2: s² u1·w1 + s (u1·w2 + u2·w1) + u2·w2 = 0
    qa, qb, qc = u1 @ w1, u1 @ w2 + u2 @ w1, u2 @ w2
    if abs(qa) > 1e-12 * max(abs(qb), abs(qc), 1e-300):
        disc = max(qb * qb - 4 * qa * qc, 0.0)
        roots = [(-qb + np.sqrt(disc)) / (2 * qa), (-qb - np.sqrt(disc)) / (2 * qa)]
    else:
        roots = [-qc / qb] if qb != 0 else [0.0]
    best = max(roots, key=lambda s: s * s * (u1 @ u1) + 2 * s * (u1 @ u2) + u2 @ u2)
    norm2 = best * best * (u1 @ u1) + 2 * best * (u1 @ u2) + u2 @ u2
    lam2 = 1.0 / np.sqrt(norm2)
    xs = best * lam2 * v7 + lam2 * v8  # scalar-first [x0, x, x0', x']
    x = np.r_[xs[1:4], xs[0], xs[5:8], xs[4]]
    x = dp.dualquat_canonical(dp.dualquat_normalize(x))
    q, tr = dp.qt_from_dualquat(x)
    # residuals and covariance over all pairs
    res = _residual_twists(a, b, x)
    rot_res = np.linalg.norm(res[:, :3], axis=1)
    _, trans_res_vec = dp.qt_from_dualquat(
        dp.dualquat_mul(dp.dualquat_conj(dp.dualquat_mul(a, x)), dp.dualquat_mul(x, b))
    )
    cov = _covariance(a[use], b[use], x)
    if parallel:
        cov = cov.copy()
        cov[3:, :] = np.inf  # the translation along the common axis is unobservable
        cov[:, 3:] = np.inf
    return HandEyeResult(
        dualquat=x, quat=q, translation=tr, matrix=dp.matrix_from_dualquat(x), rotation_residuals=rot_res,
        translation_residuals=np.linalg.norm(trans_res_vec, axis=1), singular_values=sv, incongruent_pairs=bad,
        parallel_axes=parallel, covariance=cov,
    )  # fmt: skip


def _covariance(a: np.ndarray, b: np.ndarray, x: np.ndarray) -> NDArray[np.float64]:
    """``σ̂² (JᵀJ)⁻¹`` for the stacked twist residuals, with a central-difference Jacobian in ``[δθ, δt]``."""
    import dualpose as dp

    q0, t0 = dp.qt_from_dualquat(x)

    def perturbed(d: np.ndarray) -> NDArray[np.float64]:
        q = dp.quat_mul(dp.quat_from_rotvec(d[:3]), q0)
        return dp.dualquat_from_qt(q, t0 + d[3:])

    r0 = _residual_twists(a, b, x).ravel()
    jac = np.empty((r0.size, 6))
    h = 1e-6
    for k in range(6):
        e = np.zeros(6)
        e[k] = h
        jac[:, k] = (_residual_twists(a, b, perturbed(e)).ravel() - _residual_twists(a, b, perturbed(-e)).ravel()) / (
            2 * h
        )
    dof = max(r0.size - 6, 1)
    sigma2 = float(r0 @ r0) / dof
    jtj = jac.T @ jac
    try:
        return sigma2 * np.linalg.inv(jtj)
    except np.linalg.LinAlgError:
        return sigma2 * np.linalg.pinv(jtj)
