"""Robust pose from point correspondences with gross outliers: RANSAC (Fischler & Bolles 1981) and IRLS (Huber, Cauchy).

Frames and layouts as :func:`~dualpose.registration.register_pose`: the pose maps model points to measured points,
``p̃ ≈ R p⁰ + t``; quaternions xyzw.  Points only (directions have no minimal-sample model here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose.registration._inputs import method_code, prepare_single
from dualpose.registration.batch import register_pose_batch
from dualpose.registration.estimate import PoseEstimate, register_pose

__all__ = ["RobustEstimate", "register_pose_ransac", "register_pose_irls", "ransac_iterations"]

_LOSSES = ("huber", "cauchy")


@dataclass(frozen=True)
class RobustEstimate:
    """Result of :func:`register_pose_ransac` / :func:`register_pose_irls`.

    Attributes
    ----------
    pose : PoseEstimate
        The final weighted least-squares fit (on the inliers for RANSAC; with the last IRLS weights for IRLS).
    inlier_mask : ndarray (n,) of bool
        Correspondences whose residual under ``pose`` is at most the threshold (IRLS: ``c`` times 3).
    weights : ndarray (n,)
        The point weights of the final fit (0/1 inlier weights times the user's weights for RANSAC, robust weights
        for IRLS).
    iterations : int
        RANSAC hypotheses drawn, or IRLS iterations.
    threshold : float
        The inlier threshold (RANSAC) or the loss scale ``c`` (IRLS).
    """

    pose: PoseEstimate
    inlier_mask: np.ndarray
    weights: np.ndarray
    iterations: int
    threshold: float

    @property
    def inlier_ratio(self) -> float:
        return float(self.inlier_mask.mean())


def ransac_iterations(inlier_ratio: float, confidence: float, sample_size: int = 3) -> int:
    """Hypotheses needed so that with probability ``confidence`` one minimal sample is outlier-free:
    ``N = log(1 - confidence) / log(1 - w^s)`` (Fischler & Bolles 1981), ``w`` the inlier ratio."""
    w = min(max(inlier_ratio, 0.0), 1.0)
    ws = w**sample_size
    if ws >= 1.0:
        return 1
    if ws <= 0.0:
        return np.iinfo(np.int64).max
    return int(math.ceil(math.log(1.0 - confidence) / math.log1p(-ws)))


def _residual_norms(quat: np.ndarray, trans: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> NDArray[np.float64]:
    """‖R_h p0_i + t_h − p1_i‖ for hypotheses h (H, 4)/(H, 3) and points i: shape (H, n)."""
    import dualpose as dp

    r = dp.matrix_from_quat(quat)  # (H, 3, 3)
    pred = np.einsum("hij,nj->hni", r, p0) + trans[:, None, :]
    return _norms(pred - p1[None])


def _norms(d: NDArray[np.float64]) -> NDArray[np.float64]:
    """Euclidean norms over the last axis (3) without underflow or overflow of the squares (hypot), so that
    residuals of points at 1e-200 or 1e200 compare with a threshold in the same units."""
    return np.asarray(np.hypot(np.hypot(d[..., 0], d[..., 1]), d[..., 2]), dtype=np.float64)


def register_pose_ransac(
    model_points: ArrayLike,
    measured_points: ArrayLike,
    *,
    threshold: float,
    confidence: float = 0.999,
    max_iterations: int = 10_000,
    point_weights: ArrayLike | None = None,
    method: str = "dq",
    irls: str | None = None,
    seed: int | np.random.Generator | None = None,
    batch_size: int = 256,
) -> RobustEstimate:
    """Minimal-sample RANSAC for the rigid pose model -> measured, then a least-squares refit on the inliers.

    Hypotheses come from random triples of correspondences, solved in batches of ``batch_size`` by
    :func:`register_pose_batch`; triples whose rotation is not unique (collinear, coincident) are discarded.  A
    correspondence is an inlier of a hypothesis when its residual ``‖R p⁰ + t − p̃‖ <= threshold``.  The number of
    hypotheses adapts to the best inlier ratio ``w`` seen: ``N = log(1 − confidence) / log(1 − w³)``, capped by
    ``max_iterations``.  The best hypothesis (most inliers; ties broken by the smaller inlier residual sum) is
    refit on its inliers; the inlier set is recomputed with the refit and refit once more if it changed.

    Parameters
    ----------
    model_points, measured_points : array_like, shape (n, 3), n >= 3
    threshold : float
        Inlier distance in measured units (e.g. 3 σ of the noise).
    confidence : float in (0, 1)
        Probability of drawing at least one outlier-free triple.
    max_iterations : int
        Cap on the hypotheses drawn.
    point_weights : array_like (n,), optional
        Weights for the refit (sampling is uniform).
    method : {"dq", "horn", "svd"}
        Solver of the hypotheses and of the refit.
    irls : {"huber", "cauchy"} or None
        Follow the inlier refit by :func:`register_pose_irls` on all points with this loss and ``c = threshold / 3``.
    seed : int or numpy Generator, optional
        Random source (seed it for reproducible results).
    batch_size : int
        Hypotheses solved per batch.

    Returns
    -------
    RobustEstimate

    Raises
    ------
    ValueError
        Bad shapes or values; no triple with a unique rotation; fewer than 3 inliers for the best hypothesis.
    """
    method_code(method)
    p0, p1, beta, _, _, _ = prepare_single(model_points, measured_points, None, None, point_weights, None)
    if not (threshold > 0 and math.isfinite(threshold)):
        raise ValueError(f"threshold must be a positive finite distance; got {threshold!r}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1); got {confidence!r}")
    if irls is not None and irls not in _LOSSES:
        raise ValueError(f"irls must be one of {_LOSSES} or None; got {irls!r}")
    if not np.isfinite(p0).all() or not np.isfinite(p1).all():
        raise ValueError("model_points and measured_points must be finite")
    rng = np.random.default_rng(seed)
    n = p0.shape[0]
    if n < 3:
        raise ValueError(f"RANSAC draws triples of correspondences: needs at least 3 points; got {n}")
    best_count, best_sum, best = -1, np.inf, None
    needed, drawn = max_iterations, 0
    while drawn < min(needed, max_iterations):
        h = min(batch_size, min(needed, max_iterations) - drawn)
        # distinct triples: the first 3 of a random key's argsort per row (vectorised sampling without replacement)
        idx = np.argpartition(rng.random((h, n)), 2, axis=1)[:, :3]  # kth=2: the 3 smallest keys come first
        hyp = register_pose_batch(p0[idx], p1[idx], method=method)
        drawn += h
        res = _residual_norms(hyp.quat, hyp.translation, p0, p1)
        inl = res <= threshold
        count = np.where(hyp.rotation_unique, inl.sum(axis=1), -1)
        rsum = np.where(inl, res, 0.0).sum(axis=1)
        order = np.lexsort((rsum, -count))
        k = order[0]
        if count[k] > best_count or (count[k] == best_count and rsum[k] < best_sum):
            best_count, best_sum = int(count[k]), float(rsum[k])
            best = (hyp.quat[k].copy(), hyp.translation[k].copy())
            needed = ransac_iterations(best_count / n, confidence)
    if best is None or best_count < 0:
        raise ValueError("RANSAC found no triple of correspondences with a unique rotation (degenerate data)")
    if best_count < 3:
        raise ValueError(f"RANSAC: the best hypothesis has {best_count} inlier(s) at threshold {threshold}; need 3")
    mask = _residual_norms(best[0][None], best[1][None], p0, p1)[0] <= threshold
    pose = register_pose(p0[mask], p1[mask], point_weights=beta[mask], method=method)
    for _ in range(2):  # re-derive the inliers from the refit; refit while they change
        new = _norms(p0 @ pose.rotation_matrix.T + pose.translation - p1) <= threshold
        if new.sum() < 3 or np.array_equal(new, mask):
            break
        mask = new
        pose = register_pose(p0[mask], p1[mask], point_weights=beta[mask], method=method)
    if irls is not None:
        rob = register_pose_irls(
            p0, p1, loss=irls, c=threshold / 3.0, point_weights=beta, method=method, initial=pose
        )
        return RobustEstimate(rob.pose, rob.inlier_mask, rob.weights, drawn, threshold)
    # the refit was on the inlier subset; re-express it over all points (zero weight for the outliers)
    weights = np.where(mask, beta, 0.0)
    pose = register_pose(p0, p1, point_weights=weights, method=method)
    return RobustEstimate(pose, mask, weights, drawn, threshold)


def _robust_weights(r: np.ndarray, loss: str, c: float) -> NDArray[np.float64]:
    """IRLS weights ``ψ(r)/r``: Huber ``min(1, c/r)``, Cauchy ``1 / (1 + (r/c)²)``."""
    if loss == "huber":
        result: NDArray[np.float64] = np.minimum(1.0, c / np.maximum(r, 1e-300))
        return result
    return 1.0 / (1.0 + (r / c) ** 2)


def register_pose_irls(
    model_points: ArrayLike,
    measured_points: ArrayLike,
    *,
    loss: str = "huber",
    c: float | None = None,
    point_weights: ArrayLike | None = None,
    method: str = "dq",
    initial: PoseEstimate | None = None,
    max_iterations: int = 50,
    tol: float = 1e-12,
) -> RobustEstimate:
    """Iteratively reweighted least squares with a Huber or Cauchy loss on the point residual norms.

    Each iteration solves the weighted problem in closed form with weights ``β_i · w(‖r_i‖)`` from the previous
    pose (Huber: ``w = min(1, c/r)``; Cauchy: ``w = 1/(1 + (r/c)²)``) until the pose changes by less than ``tol``
    (rotation angle in radians plus translation in units of ``c``).  IRLS converges to a local minimum of the
    robust cost: with many gross outliers start it from RANSAC (``initial=``, or ``register_pose_ransac(irls=)``).

    Parameters
    ----------
    loss : {"huber", "cauchy"}
    c : float, optional
        Loss scale in measured units; default ``1.345 × 1.4826 × median(‖r_i‖)`` of the initial fit (Huber's 95%
        efficiency constant on a MAD scale estimate; for Cauchy ``2.385`` replaces ``1.345``).
    initial : PoseEstimate, optional
        Starting pose (default: the unweighted least-squares fit).

    Returns
    -------
    RobustEstimate
        ``inlier_mask`` marks residuals ``<= 3 c``; ``weights`` the final IRLS weights.
    """
    if loss not in _LOSSES:
        raise ValueError(f"loss must be one of {_LOSSES}; got {loss!r}")
    method_code(method)
    p0, p1, beta, _, _, _ = prepare_single(model_points, measured_points, None, None, point_weights, None)
    pose = initial if initial is not None else register_pose(p0, p1, point_weights=beta, method=method)

    def resid(est: PoseEstimate) -> NDArray[np.float64]:
        return _norms(p0 @ est.rotation_matrix.T + est.translation - p1)

    r = resid(pose)
    if c is None:
        k = 1.345 if loss == "huber" else 2.385
        c = k * 1.4826 * float(np.median(r))
        if not c > 0:
            c = 1e-12 * max(float(np.abs(p1).max()), 1.0)
    if not (c > 0 and math.isfinite(c)):
        raise ValueError(f"c must be a positive finite scale; got {c!r}")
    it = 0
    w = beta * _robust_weights(r, loss, c)
    for it in range(1, max_iterations + 1):  # noqa: B007
        w = beta * _robust_weights(r, loss, c)
        if np.count_nonzero(w) < 3:
            break
        new = register_pose(p0, p1, point_weights=w, method=method)
        import dualpose as dp

        step = float(dp.quat_angle(new.quat, pose.quat)) + float(np.abs(new.translation - pose.translation).max()) / c
        pose = new
        r = resid(pose)
        if step <= tol:
            break
    return RobustEstimate(pose, r <= 3.0 * c, w, it, float(c))
