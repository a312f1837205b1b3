"""Least-squares similarity / rigid alignment of two point sets (Umeyama 1991), used to align trajectories.

Umeyama, "Least-squares estimation of transformation parameters between two point patterns", IEEE PAMI 13(4),
1991: the (s, R, t) minimising ``sum_i |y_i - (s R x_i + t)|^2`` (eq. 1) in closed form from the SVD of the
cross-covariance (eqs. 38-43), with the reflection correction ``S`` that keeps ``det R = +1``.  That solve is
:func:`dualpose.registration.register_pose` with ``method="svd"`` (and ``scale=True`` for Sim(3)); this module adds
the trajectory-specific checks and the other alignments evo offers.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp
from dualpose.registration import register_pose

__all__ = ["Alignment", "umeyama_alignment", "align_positions", "origin_alignment", "posyaw_alignment",
           "AlignMethod", "check_alignment_rank"]

AlignMethod = Literal["se3", "sim3", "scale", "origin", "posyaw", "none"]

#: a point set is degenerate when its second principal spread is at most
#: max(SPREAD_REL_MAGNITUDE * largest |coordinate|, SPREAD_REL_FIRST * first principal spread)
SPREAD_REL_MAGNITUDE = 1e-12
SPREAD_REL_FIRST = 1e-8


def check_alignment_rank(source: np.ndarray, target: np.ndarray, names: tuple[str, str] = ("source", "target")) -> None:
    """Refuse point sets for which the Umeyama rotation (and the Sim(3) scale) is not determined.

    For each set, with ``sigma_0 >= sigma_1`` the two largest principal standard deviations (square roots of the
    eigenvalues of its 3x3 covariance) and ``M`` its largest absolute coordinate, the set is degenerate when
    ``sigma_1 <= max(1e-12 M, 1e-8 sigma_0)``: all points coincide to the precision their coordinates carry
    (``sigma_0`` at rounding level, e.g. a trajectory that stands still) or lie on one line (rank < 2), so a rotation
    about that line -- or any rotation, and the scale -- fits equally well.  The test is scale-aware: a relative
    test on the cross-covariance alone accepts rounding noise as structure (Umeyama 1991 requires rank >= 2 of
    the cross-covariance, eq. 39; ``docs/metrics.md``, "Alignment").

    ``source``, ``target``: float64 (N, 3); ``names`` label them in the message.  Raises ``ValueError``.
    """
    for name, pts in zip(names, (source, target), strict=True):
        n = pts.shape[0]
        magnitude = float(np.abs(pts).max(initial=0.0))
        centred = pts - pts.mean(axis=0)
        cov = centred.T @ centred / n
        sigma = np.sqrt(np.clip(np.linalg.eigvalsh(cov)[::-1], 0.0, None))
        if sigma[0] <= SPREAD_REL_MAGNITUDE * magnitude or sigma[0] == 0.0:
            raise ValueError(
                f"alignment is degenerate: the {name} positions do not move (spread {sigma[0]:.3g} m over {n} "
                f"points at coordinates up to {magnitude:.3g} m); use --align none or origin"
            )
        if sigma[1] <= max(SPREAD_REL_MAGNITUDE * magnitude, SPREAD_REL_FIRST * sigma[0]):
            raise ValueError(
                f"alignment is degenerate: the {name} positions lie on a line (principal spreads "
                f"{sigma[0]:.3g} m and {sigma[1]:.3g} m), so the rotation about it is not determined; "
                "use --align none or origin"
            )


@dataclass(frozen=True)
class Alignment:
    """A similarity transform ``x -> scale * rotation @ x + translation`` applied to an estimated trajectory.

    Attributes
    ----------
    rotation : ndarray, shape (3, 3)
        Proper rotation matrix (det +1).
    translation : ndarray, shape (3,)
        Metres.
    scale : float
        1 except for ``"sim3"`` and ``"scale"``.
    method : {"se3", "sim3", "scale", "origin", "none"}
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float
    method: str

    @property
    def quat(self) -> np.ndarray:
        """The rotation as a unit quaternion, shape (4,), xyzw."""
        return dp.quat_from_matrix(self.rotation)

    @property
    def matrix(self) -> np.ndarray:
        """The 4x4 homogeneous matrix ``[[s R, t], [0, 1]]``."""
        m = np.eye(4)
        m[:3, :3] = self.scale * self.rotation
        m[:3, 3] = self.translation
        return m

    def apply(self, positions: ArrayLike, quats: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Transform poses: ``p' = s R p + t`` and ``q' = q_R (x) q``.

        ``positions`` (..., 3) metres, ``quats`` (..., 4) xyzw (norm kept).  Returns the new arrays.
        """
        p = np.asarray(positions, dtype=np.float64)
        q = np.asarray(quats, dtype=np.float64)
        return self.scale * (p @ self.rotation.T) + self.translation, dp.quat_mul(self.quat, q)

    def as_dict(self) -> dict[str, Any]:
        return {
            "method": self.method,
            "scale": float(self.scale),
            "rotation": self.rotation.tolist(),
            "translation": self.translation.tolist(),
        }


def umeyama_alignment(source: ArrayLike, target: ArrayLike, with_scale: bool = False) -> Alignment:
    """The similarity (or rigid, ``with_scale=False``) transform taking ``source`` onto ``target`` in least squares.

    Parameters
    ----------
    source, target : array_like, shape (N, 3)
        Corresponding points (e.g. estimated and reference positions at matched times), N >= 3.
    with_scale : bool
        Estimate the scale too (Sim(3), Umeyama eq. 42); otherwise scale = 1 (SE(3)).

    Returns
    -------
    Alignment
        Minimiser of ``sum |target_i - (s R source_i + t)|^2``: ``R = U S V^T`` (eq. 40), ``s = tr(D S) / sigma_x^2``
        (eq. 42), ``t = mu_y - s R mu_x`` (eq. 41), as solved by ``register_pose(source, target, method="svd")``.

    Raises
    ------
    ValueError
        For shapes other than (N, 3) with matching N, N < 3, non-finite input, or a degenerate configuration
        (:func:`check_alignment_rank`: either point set standing still or collinear to its coordinates'
        precision, or a cross-covariance of rank < 2, so the rotation is not unique).
    """
    return _umeyama(source, target, with_scale, ("source", "target"))


def _umeyama(source: ArrayLike, target: ArrayLike, with_scale: bool, names: tuple[str, str]) -> Alignment:
    """:func:`umeyama_alignment`; ``names`` label the point sets in the degeneracy messages."""
    x = np.asarray(source, dtype=np.float64)
    y = np.asarray(target, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"source must have shape (N, 3); got shape {x.shape}")
    if y.shape != x.shape:
        raise ValueError(f"target must have the same shape as source {x.shape}; got shape {y.shape}")
    n = x.shape[0]
    if n < 3:
        raise ValueError(f"alignment needs at least 3 corresponding points; got {n}")
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("source and target must be finite")
    check_alignment_rank(x, y, names)
    fit = register_pose(x, y, method="svd", scale=with_scale)
    d = fit.singular_values
    assert d is not None  # method="svd" reports them
    if d[1] <= max(d[0], 1e-300) * 1e-12:
        raise ValueError(
            f"alignment is degenerate: the cross-covariance has rank < 2 (singular values {(d / n).tolist()}); "
            "the points are (nearly) collinear or coincident"
        )
    rotation, translation, scale = dp.matrix_from_quat(fit.quat), fit.translation.copy(), fit.scale
    return Alignment(rotation, translation, scale, "sim3" if with_scale else "se3")


def align_positions(reference: ArrayLike, estimate: ArrayLike, method: AlignMethod = "se3") -> Alignment:
    """The alignment of ``estimate`` (N, 3) onto ``reference`` (N, 3) from positions alone.

    ``method``: ``"se3"`` (Umeyama, rigid), ``"posyaw"`` (4-DoF: translation and a rotation about the world z
    axis, :func:`posyaw_alignment`), ``"sim3"`` (Umeyama with scale), ``"scale"`` (only the Umeyama Sim(3)
    scale is applied, rotation and translation are left alone -- evo's ``--correct_scale`` without ``--align``) or
    ``"none"`` (identity).  ``"origin"`` needs orientations: use :func:`origin_alignment`.
    """
    if method == "none":
        return Alignment(np.eye(3), np.zeros(3), 1.0, "none")
    names = ("estimate", "reference")  # the degeneracy messages name them rather than source / target
    if method == "scale":
        return Alignment(np.eye(3), np.zeros(3), _umeyama(estimate, reference, True, names).scale, "scale")
    if method == "posyaw":
        return posyaw_alignment(reference, estimate)
    if method not in ("se3", "sim3"):
        raise ValueError(f"method must be 'se3', 'sim3', 'scale', 'posyaw' or 'none'; got {method!r}")
    return _umeyama(estimate, reference, method == "sim3", names)


def origin_alignment(
    position_ref: ArrayLike, quat_ref: ArrayLike, position_est: ArrayLike, quat_est: ArrayLike
) -> Alignment:
    """The rigid transform that puts the estimate's first pose onto the reference's: ``T = T_ref,0 T_est,0^-1``.

    Parameters
    ----------
    position_ref, position_est : array_like, shape (3,)
        Metres.
    quat_ref, quat_est : array_like, shape (4,)
        xyzw, normalized here.

    Returns
    -------
    Alignment
        ``method="origin"``, scale 1: ``R = R_ref,0 R_est,0^T``, ``t = p_ref,0 - R p_est,0``.
    """
    p_ref, p_est = np.asarray(position_ref, dtype=np.float64), np.asarray(position_est, dtype=np.float64)
    if p_ref.shape != (3,) or p_est.shape != (3,):
        raise ValueError(f"positions must have shape (3,); got {p_ref.shape} and {p_est.shape}")
    q = dp.quat_mul(dp.quat_normalize(quat_ref), dp.quat_conj(dp.quat_normalize(quat_est)))
    rotation = dp.matrix_from_quat(q)
    return Alignment(rotation, p_ref - rotation @ p_est, 1.0, "origin")


def posyaw_alignment(reference: ArrayLike, estimate: ArrayLike) -> Alignment:
    """The 4-DoF alignment (translation and yaw about the world z axis) of ``estimate`` (N, 3) onto ``reference``
    (N, 3), least squares over the positions -- the alignment rpg_trajectory_evaluation uses for visual–inertial
    odometry (Zhang & Scaramuzza, "A tutorial on quantitative trajectory evaluation for visual(-inertial)
    odometry", IROS 2018, §IV-B), whose roll and pitch are observable through gravity and must not be fitted.

    Both frames must have z along gravity (up or down alike).  With centred points ``x`` (estimate) and ``y``
    (reference), the yaw maximising ``Σ yᵀ R_z(ψ) x`` is ``ψ = atan2(Σ (x_x y_y − x_y y_x), Σ (x_x y_x + x_y y_y))``;
    the translation is ``ȳ − R_z(ψ) x̄``.
    """
    y = np.asarray(reference, dtype=np.float64)
    x = np.asarray(estimate, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3 or y.shape != x.shape or len(x) < 2:
        raise ValueError(f"reference and estimate must both have shape (N >= 2, 3); got {y.shape} and {x.shape}")
    if not (np.isfinite(x).all() and np.isfinite(y).all()):
        raise ValueError("positions must be finite")
    xm, ym = x.mean(axis=0), y.mean(axis=0)
    xc, yc = x - xm, y - ym
    if np.hypot(xc[:, 0], xc[:, 1]).max() == 0.0 or np.hypot(yc[:, 0], yc[:, 1]).max() == 0.0:
        raise ValueError("alignment is degenerate: the positions do not move horizontally, so the yaw is not "
                         "determined; use --align none or origin")  # fmt: skip
    cross = np.sum(xc[:, 0] * yc[:, 1] - xc[:, 1] * yc[:, 0])
    psi = np.arctan2(cross, np.sum(xc[:, 0] * yc[:, 0] + xc[:, 1] * yc[:, 1]))
    c, s = np.cos(psi), np.sin(psi)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Alignment(R, ym - R @ xm, 1.0, "posyaw")
