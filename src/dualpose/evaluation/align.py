"""Least-squares similarity / rigid alignment of two point sets (Umeyama 1991), used to align trajectories.

Umeyama, "Least-squares estimation of transformation parameters between two point patterns", IEEE PAMI 13(4),
1991: the (s, R, t) minimising ``sum_i |y_i - (s R x_i + t)|^2`` (eq. 1) in closed form from the SVD of the
cross-covariance (eqs. 38-43), with the reflection correction ``S`` that keeps ``det R = +1``.  That solve is
:func:`dualpose.registration.register_pose` with ``method="svd"`` (and ``scale=True`` for Sim(3)); this module adds
the trajectory-specific checks and the other alignments evo offers.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp
from dualpose.registration import register_pose
from dualpose.types import _inputs

__all__ = ["Alignment", "AlignmentConditioning", "umeyama_alignment", "align_positions", "origin_alignment",
           "posyaw_alignment", "AlignMethod", "Undetermined", "check_alignment_rank", "alignment_conditioning"]

AlignMethod = Literal["se3", "sim3", "scale", "origin", "posyaw", "none"]
#: what an alignment the data do not determine does: refuse (ValueError) or warn and flag it
Undetermined = Literal["raise", "warn"]

#: a point set is degenerate when its second principal spread is at most
#: max(SPREAD_REL_MAGNITUDE * largest |coordinate|, SPREAD_REL_FIRST * first principal spread)
SPREAD_REL_MAGNITUDE = 1e-12
SPREAD_REL_FIRST = 1e-8

#: an alignment whose rotation standard deviation (worst axis) exceeds this, radians (~29 deg), or whose Sim(3)
#: scale has a relative standard deviation above UNDETERMINED_SCALE_REL, is refused: it is fitted to noise
UNDETERMINED_ROTATION_RAD = 0.5
UNDETERMINED_SCALE_REL = 0.3
#: above these (~2.9 deg, 5 %) the alignment is kept with a warning and ``well_determined`` False
POORLY_DETERMINED_ROTATION_RAD = 0.05
POORLY_DETERMINED_SCALE_REL = 0.05


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
class AlignmentConditioning:
    """How well the data determine an alignment: first-order standard deviations from the fit's own residual.

    Attributes
    ----------
    noise_m : float
        Residual standard deviation per coordinate, ``sqrt(Σ|r_i|² / (3N - p))`` for ``p`` fitted parameters (6
        se3, 7 sim3 and scale, 4 posyaw), floored at the coordinates' rounding (``2.2e-16`` times the largest
        absolute coordinate), metres.
    rotation_std_rad : float
        Standard deviation of the rotation about its least determined axis, radians (``inf`` when no noise-free
        signal determines it).
    rotation_std_axis : tuple of float
        Per-axis standard deviations (radians) about the principal axes of the cross-covariance, largest last;
        posyaw: the yaw alone (one entry).
    translation_std_m : float
        Standard deviation of each translation component at the centroid of the matched reference positions.
    scale_std : float
        Standard deviation of the Sim(3) scale (0 when the scale is not fitted).
    well_determined : bool
        False when the rotation or scale standard deviation exceeds the warning bounds
        (``POORLY_DETERMINED_ROTATION_RAD``, ``POORLY_DETERMINED_SCALE_REL``).
    reason : str
        Why it is not well determined ("" otherwise).
    """

    noise_m: float
    rotation_std_rad: float
    rotation_std_axis: tuple[float, ...]
    translation_std_m: float
    scale_std: float
    well_determined: bool = True
    reason: str = ""

    def as_dict(self) -> dict[str, Any]:
        return {
            "noise_m": self.noise_m,
            "rotation_std_deg": float(np.degrees(self.rotation_std_rad)),
            "translation_std_m": self.translation_std_m,
            "scale_std": self.scale_std,
            "well_determined": self.well_determined,
            "reason": self.reason,
        }


def _std_ratio(num: float, den: float) -> float:
    """``num / den`` for standard deviations: ``inf`` when ``den`` is not positive (nothing determines it)."""
    return float(num / den) if den > 0.0 else (0.0 if num == 0.0 else float("inf"))


def alignment_conditioning(
    source: ArrayLike, target: ArrayLike, rotation: ArrayLike, scale: float, method: str
) -> AlignmentConditioning:
    """The first-order uncertainty of the alignment ``target ≈ scale · rotation @ source + t`` from its residual.

    The rotation is decided by the cross-covariance ``H = (1/N) Σ x'_i y'_iᵀ`` of the centred ``source`` ``x'``
    and ``target`` ``y'`` (Umeyama 1991 eq. 38; Horn 1987): with ``H = U D Vᵀ`` and Umeyama's reflection sign
    ``S = diag(1, 1, d)``, a small rotation about the axis pairing directions ``i, j`` moves by
    ``δθ_k = (δH̃_ij − δH̃_ji) / (d_i + S_j d_j)`` with ``H̃ = Uᵀ H V``.  Noise of standard deviation ``σ_y`` on the
    target and ``σ_x`` on the source perturbs ``H̃_ij`` with variance ``(λx_i σ_y² + λy_j σ_x²) / N``
    (``λx_i``, ``λy_j`` the mean squared centred coordinates along ``u_i``, ``v_j``).  Only the residual variance
    ``σ² = σ_y² + s² σ_x²`` is observed, so the bound ``σ² max(λx_i, λy_j / s²) / N`` is used: it holds whichever
    set carries the noise, and is what makes the test refuse an alignment fitted to noise (a reference standing
    still with 0.1 mm jitter against a noisy estimate has a cross-covariance at its own noise level).  The scale
    (Umeyama eq. 42) has variance ``σ² / (N Σ_k λx_k)``, to which the bound of its errors-in-variables bias,
    ``3σ² / Σ_k λx_k`` relative (noise on the source inflates its spread and shrinks the fitted scale by that
    fraction), is added in quadrature; the translation at the target centroid ``σ² / N``.  For
    ``method="posyaw"`` the yaw ``ψ = atan2(B, A)`` (``A + iB = Σ (x_h·y_h + i x_h×y_h)`` over the horizontal
    parts) has variance ``σ² max(Σ|x_h|², Σ|y_h|²/s²) / (A² + B²)``.

    Parameters
    ----------
    source, target : array_like, shape (N, 3)
        Matched points: estimate (source) and reference (target) positions, metres.
    rotation : array_like, shape (3, 3)
        The fitted rotation.
    scale : float
        The fitted scale (1 for rigid alignments).
    method : {"se3", "sim3", "scale", "posyaw"}
        Which parameters were fitted (sets the residual's degrees of freedom and the scale term).
    """
    x = np.asarray(source, dtype=np.float64)
    y = np.asarray(target, dtype=np.float64)
    r = np.asarray(rotation, dtype=np.float64)
    n = x.shape[0]
    n_par = {"se3": 6, "sim3": 7, "scale": 7, "posyaw": 4}[method]
    xc = x - x.mean(axis=0)
    yc = y - y.mean(axis=0)
    # work in units of the largest centred coordinate (no under/overflow of the squares at any magnitude)
    unit = float(max(np.abs(xc).max(initial=0.0) * abs(scale), np.abs(yc).max(initial=0.0)))
    floor = np.finfo(np.float64).eps * float(max(np.abs(x).max(initial=0.0) * abs(scale), np.abs(y).max(initial=0.0)))
    if unit == 0.0 or scale == 0.0:
        return AlignmentConditioning(floor, np.inf, (np.inf,), floor, np.inf if method == "sim3" else 0.0)
    xs = xc * (scale / unit)  # source in target units, scaled
    ys = yc / unit
    res = ys - xs @ r.T
    dof = max(3 * n - n_par, 1)
    sigma = float(max(np.sqrt(np.einsum("ij,ij->", res, res) / dof), floor / unit))
    trans_std = float(sigma / np.sqrt(n) * unit)
    if method == "posyaw":
        a = float(np.sum(xs[:, 0] * ys[:, 0] + xs[:, 1] * ys[:, 1]))
        b = float(np.sum(xs[:, 0] * ys[:, 1] - xs[:, 1] * ys[:, 0]))
        spread = max(float(np.sum(xs[:, :2] ** 2)), float(np.sum(ys[:, :2] ** 2)))
        yaw_std = _std_ratio(sigma * np.sqrt(spread), float(np.hypot(a, b)))
        return AlignmentConditioning(sigma * unit, yaw_std, (yaw_std,), trans_std, 0.0)
    h = xs.T @ ys / n
    u, d, vt = np.linalg.svd(h)
    v = vt.T
    refl = np.sign(np.linalg.det(v @ u.T)) or 1.0
    sgn = np.array([1.0, 1.0, refl])
    lam_x = np.mean((xs @ u) ** 2, axis=0)
    lam_y = np.mean((ys @ v) ** 2, axis=0)
    stds = []
    for i, j in ((1, 2), (0, 2), (0, 1)):  # the axis k pairs the other two directions
        var_ij = sigma**2 * max(lam_x[i], lam_y[j]) / n
        var_ji = sigma**2 * max(lam_x[j], lam_y[i]) / n
        stds.append(_std_ratio(np.sqrt(var_ij + var_ji), d[i] * sgn[i] + d[j] * sgn[j]))
    scale_std = 0.0
    if method in ("sim3", "scale"):
        # in scaled units xs = x' s / unit: var(s) = σ² s² / (N Σ|xs|²/N); plus the errors-in-variables bias: noise
        # on the source inflates its spread and shrinks the fitted scale by up to 3σ² / mean|xs|² (relative)
        spread2 = float(np.sum(xs**2))
        first_order = _std_ratio(sigma * abs(scale), float(np.sqrt(spread2)))
        bias = _std_ratio(3.0 * n * sigma**2 * abs(scale), spread2)
        scale_std = float(np.hypot(first_order, bias))
    return AlignmentConditioning(sigma * unit, max(stds), tuple(sorted(stds)), trans_std, scale_std)


def _judge(cond: AlignmentConditioning, scale: float, method: str, undetermined: Undetermined) -> AlignmentConditioning:
    """Refuse an undetermined alignment (``ValueError``; with ``undetermined="warn"`` a warning and the flag
    instead); warn about and flag a poorly determined one."""
    rot_deg = float(np.degrees(cond.rotation_std_rad))
    scale_rel = cond.scale_std / abs(scale) if scale else np.inf
    what = "yaw" if method == "posyaw" else "rotation"
    noise = f"residual noise {cond.noise_m:.3g} m"
    if cond.rotation_std_rad > UNDETERMINED_ROTATION_RAD or scale_rel > UNDETERMINED_SCALE_REL:
        if cond.rotation_std_rad > UNDETERMINED_ROTATION_RAD:
            reason = (
                f"alignment ({method}) is not determined by the data: its {what} has a standard deviation of "
                f"{rot_deg:.3g} deg ({noise}); the positions do not move enough against their noise (standing "
                "still, too few poses, a nearly straight path, or an estimate unrelated to the reference)"
            )
        else:
            reason = (
                f"alignment ({method}) is not determined by the data: its scale {scale:.6g} has a standard "
                f"deviation of {cond.scale_std:.3g} ({noise})"
            )
        if undetermined == "raise":
            raise ValueError(reason + "; use --align none or origin, or more poses")
    else:
        reasons = []
        if cond.rotation_std_rad > POORLY_DETERMINED_ROTATION_RAD:
            reasons.append(f"{what} standard deviation {rot_deg:.3g} deg")
        if scale_rel > POORLY_DETERMINED_SCALE_REL:
            reasons.append(f"scale standard deviation {100 * scale_rel:.3g} %")
        if not reasons:
            return cond
        reason = f"the {method} alignment is poorly determined ({', '.join(reasons)}; {noise})"
    warnings.warn(reason + "; errors include the alignment's own uncertainty", UserWarning, stacklevel=3)
    return AlignmentConditioning(cond.noise_m, cond.rotation_std_rad, cond.rotation_std_axis,
                                 cond.translation_std_m, cond.scale_std, False, reason)  # fmt: skip


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
    method : {"se3", "sim3", "scale", "posyaw", "origin", "none"}
    conditioning : AlignmentConditioning or None
        How well the data determine it (:func:`alignment_conditioning`); None for "origin" and "none".
    """

    rotation: np.ndarray
    translation: np.ndarray
    scale: float
    method: str
    conditioning: AlignmentConditioning | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        """The fields repeat one transform: the rotation must be one (orthonormal to 1e-6, det +1), the scale
        positive and finite, the translation a finite 3-vector."""
        r = _inputs.check_rotation_matrix(self.rotation, "rotation")
        t = np.asarray(self.translation, dtype=np.float64)
        if t.shape != (3,) or not np.isfinite(t).all():
            raise ValueError(f"translation must be a finite vector of shape (3,); got shape {t.shape}")
        if not (np.isfinite(self.scale) and self.scale > 0.0):
            raise ValueError(f"scale must be positive and finite; got {self.scale!r}")
        object.__setattr__(self, "rotation", r)
        object.__setattr__(self, "translation", t)

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
        out: dict[str, Any] = {
            "method": self.method,
            "scale": float(self.scale),
            "rotation": self.rotation.tolist(),
            "translation": self.translation.tolist(),
        }
        if self.conditioning is not None:
            out["conditioning"] = self.conditioning.as_dict()
        return out


def umeyama_alignment(
    source: ArrayLike, target: ArrayLike, with_scale: bool = False, undetermined: Undetermined = "raise"
) -> Alignment:
    """The similarity (or rigid, ``with_scale=False``) transform taking ``source`` onto ``target`` in least squares.

    Parameters
    ----------
    source, target : array_like, shape (N, 3)
        Corresponding points (e.g. estimated and reference positions at matched times), N >= 3.
    with_scale : bool
        Estimate the scale too (Sim(3), Umeyama eq. 42); otherwise scale = 1 (SE(3)).
    undetermined : {"raise", "warn"}
        What an alignment the data do not determine does (:func:`alignment_conditioning`: rotation standard
        deviation above ``UNDETERMINED_ROTATION_RAD`` or relative scale standard deviation above
        ``UNDETERMINED_SCALE_REL``): raise ``ValueError`` (default), or warn and return it flagged
        (``conditioning.well_determined`` False).  A poorly determined one always warns and is flagged.

    Returns
    -------
    Alignment
        Minimiser of ``sum |target_i - (s R source_i + t)|^2``: ``R = U S V^T`` (eq. 40), ``s = tr(D S) / sigma_x^2``
        (eq. 42), ``t = mu_y - s R mu_x`` (eq. 41), as solved by ``register_pose(source, target, method="svd")``,
        with its ``conditioning``.

    Raises
    ------
    ValueError
        For shapes other than (N, 3) with matching N, N < 3, non-finite input, a degenerate configuration
        (:func:`check_alignment_rank`: either point set standing still or collinear to its coordinates'
        precision, or a cross-covariance of rank < 2, so the rotation is not unique), or an alignment the data do
        not determine against their own noise (``undetermined="raise"``).
    """
    return _umeyama(source, target, with_scale, ("source", "target"), None, undetermined)


def _umeyama(
    source: ArrayLike,
    target: ArrayLike,
    with_scale: bool,
    names: tuple[str, str],
    method: str | None = None,
    undetermined: Undetermined = "raise",
) -> Alignment:
    """:func:`umeyama_alignment`; ``names`` label the point sets in the degeneracy messages, ``method`` (default
    se3 / sim3) the alignment in the conditioning messages."""
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
    method = method or ("sim3" if with_scale else "se3")
    cond = _judge(alignment_conditioning(x, y, rotation, scale, method), scale, method, undetermined)
    return Alignment(rotation, translation, scale, "sim3" if with_scale else "se3", cond)


def align_positions(
    reference: ArrayLike, estimate: ArrayLike, method: AlignMethod = "se3", undetermined: Undetermined = "raise"
) -> Alignment:
    """The alignment of ``estimate`` (N, 3) onto ``reference`` (N, 3) from positions alone.

    ``method``: ``"se3"`` (Umeyama, rigid), ``"posyaw"`` (4-DoF: translation and a rotation about the world z
    axis, :func:`posyaw_alignment`), ``"sim3"`` (Umeyama with scale), ``"scale"`` (only the Umeyama Sim(3)
    scale is applied, rotation and translation are left alone -- evo's ``--correct_scale`` without ``--align``) or
    ``"none"`` (identity).  ``"origin"`` needs orientations: use :func:`origin_alignment`.  ``undetermined`` as in
    :func:`umeyama_alignment`; the result carries its ``conditioning`` (not for "none").
    """
    if method == "none":
        return Alignment(np.eye(3), np.zeros(3), 1.0, "none")
    names = ("estimate", "reference")  # the degeneracy messages name them rather than source / target
    if method == "scale":
        sim3 = _umeyama(estimate, reference, True, names, "scale", undetermined)
        return Alignment(np.eye(3), np.zeros(3), sim3.scale, "scale", sim3.conditioning)
    if method == "posyaw":
        return posyaw_alignment(reference, estimate, undetermined)
    if method not in ("se3", "sim3"):
        raise ValueError(f"method must be 'se3', 'sim3', 'scale', 'posyaw' or 'none'; got {method!r}")
    return _umeyama(estimate, reference, method == "sim3", names, None, undetermined)


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


def posyaw_alignment(reference: ArrayLike, estimate: ArrayLike, undetermined: Undetermined = "raise") -> Alignment:
    """The 4-DoF alignment (translation and yaw about the world z axis) of ``estimate`` (N, 3) onto ``reference``
    (N, 3), least squares over the positions -- the alignment rpg_trajectory_evaluation uses for visual–inertial
    odometry (Zhang & Scaramuzza, "A tutorial on quantitative trajectory evaluation for visual(-inertial)
    odometry", IROS 2018, §IV-B), whose roll and pitch are observable through gravity and must not be fitted.

    Both frames must have z along gravity (up or down alike).  With centred points ``x`` (estimate) and ``y``
    (reference), the yaw maximising ``Σ yᵀ R_z(ψ) x`` is ``ψ = atan2(Σ (x_x y_y − x_y y_x), Σ (x_x y_x + x_y y_y))``;
    the translation is ``ȳ − R_z(ψ) x̄``.  ``undetermined`` and the ``conditioning`` as in :func:`umeyama_alignment`.
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
    cond = _judge(alignment_conditioning(x, y, R, 1.0, "posyaw"), 1.0, "posyaw", undetermined)
    return Alignment(R, ym - R @ xm, 1.0, "posyaw", cond)
