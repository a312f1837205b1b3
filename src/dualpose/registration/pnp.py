"""Camera pose from 2-D–3-D point correspondences (PnP): normalized DLT + Gauss–Newton reprojection refinement.

Conventions: the result is the camera pose in the world, ``q_wc`` (4,) xyzw (camera→world, active) and the camera
centre ``c_w`` (3,) metres; internally the world→camera map ``X_c = R_cw X_w + t`` is estimated.  Pixels ``(M, 2)``,
points ``(M, 3)`` world frame, intrinsic matrix ``K`` (3, 3) without distortion.

The linear stage is the classic 12-unknown DLT on normalized image coordinates (Hartley & Zisserman §7.1) with
Hartley normalization of the 3-D points; it needs ≥ 6 non-coplanar points (the two-plane scene is fine).  The
rotation block is projected onto SO(3) (SVD) and the scale fixed from it; Gauss–Newton then minimises the pixel
reprojection error over ``(δφ, δt)`` with the left perturbation ``R ← Exp(δφ) R``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp

__all__ = ["PnPBatch", "PnPResult", "pnp_dlt", "pnp_dlt_batch", "pnp_refine", "solve_pnp", "solve_pnp_batch",
           "solve_pnp_ransac", "PNP_UNDETERMINED_ROTATION_RAD"]

#: a PnP pose whose rotation standard deviation (largest axis) exceeds this is refused (radians, ~11.5 deg: a pose
#: that loose is of no use, and a solve on nearly collinear points can stop at a wrong pose whose own σ is smaller
#: than the true one)
PNP_UNDETERMINED_ROTATION_RAD = 0.2


@dataclass
class PnPResult:
    """Camera pose ``q_wc`` (4,) xyzw, centre ``c_w`` (3,) m; ``covariance`` (6, 6) of the world-frame
    ``[δθ_c, δc]`` (camera rotation error in the camera frame, centre error in the world frame) from the
    Gauss–Newton normal matrix and ``pixel_sigma``; ``rms_px`` the final reprojection RMS; ``iterations``."""

    q_wc: np.ndarray
    c_w: np.ndarray
    covariance: np.ndarray
    rms_px: float
    iterations: int


def _check(
    pixels: ArrayLike, points: ArrayLike, K: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    pixels = np.asarray(pixels, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    K = np.asarray(K, dtype=np.float64)
    if pixels.ndim != 2 or pixels.shape[1] != 2:
        raise ValueError(f"pixels must have shape (M, 2); got {pixels.shape}")
    if points.shape != (len(pixels), 3):
        raise ValueError(f"points must have shape ({len(pixels)}, 3) to match pixels; got {points.shape}")
    if K.shape != (3, 3):
        raise ValueError(f"K must have shape (3, 3); got {K.shape}")
    if len(pixels) < 6:
        raise ValueError(f"PnP (DLT) needs at least 6 correspondences; got {len(pixels)}")
    if not (np.isfinite(pixels).all() and np.isfinite(points).all()):
        raise ValueError("pixels and points must be finite")
    return pixels, points, K


def _normalised(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """``(points − mu) / r`` with the centroid ``mu`` and the largest coordinate spread ``r``, and ``mu``, ``r``:
    the projection does not change with the scale of the scene, so PnP is solved on points of spread ~1 (no
    overflow for 1e200 m, no underflow for 1e-200 m).  ``ValueError`` for points all at one place or on one line
    (the pose is then undetermined)."""
    mu = points.mean(axis=0)
    d = points - mu
    r = float(np.abs(d).max())
    if not r > 0.0:
        raise ValueError("points: every correspondence has the same world point; PnP needs points spread in space")
    d = d / r
    sv = np.linalg.svd(d, compute_uv=False)
    if not sv[1] > 1e-9 * sv[0]:
        raise ValueError("points: the world points lie on one line; the rotation about it is undetermined")
    return d, mu, r


def pnp_dlt(pixels: ArrayLike, points: ArrayLike, K: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Linear PnP: returns ``(R_cw (3, 3), t (3,))`` with ``X_c = R_cw X_w + t``.

    Non-coplanar points: 12-unknown DLT.  When the points are close to a plane (smallest/largest spread < 0.2,
    e.g. a frame seeing mostly one of two walls) the plane-homography solution is computed as well and the
    candidate with the lower reprojection error is returned; exactly coplanar points use the homography only.
    """
    pixels, world, K = _check(pixels, points, K)
    R, t = pnp_dlt_batch(pixels[None], world[None], np.ones((1, len(pixels)), dtype=bool), K)
    return R[0], t[0]


def pnp_dlt_batch(
    pixels: ArrayLike, points: ArrayLike, valid: ArrayLike, K: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`pnp_dlt` of ``B`` problems at once: ``pixels`` (B, M, 2), world ``points`` (B, M, 3), ``valid``
    (B, M) bool (the rows that are real; at least 6 a problem), ``K`` (3, 3); returns ``R_cw`` (B, 3, 3) and ``t``
    (B, 3).  Each problem follows the same steps as :func:`pnp_dlt` (its points normalised to spread ~1, the
    12-unknown DLT unless the points are nearly coplanar, the homography when they are close to a plane, the
    candidate with the lower reprojection error), the singular-value decompositions batched over the problems;
    padding rows enter as zero rows of the design matrices.  ``ValueError`` names the first problem whose points
    are all at one place or on one line.
    """
    pixels = np.asarray(pixels, dtype=np.float64)
    world = np.asarray(points, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool)
    K = np.asarray(K, dtype=np.float64)
    b, m = valid.shape
    w = valid.astype(np.float64)
    n = w.sum(axis=1)
    # normalisation of the world points (as _normalised): centroid and largest coordinate spread per problem
    mu_w = np.einsum("bm,bmi->bi", w, world) / n[:, None]
    d = (world - mu_w[:, None, :]) * w[..., None]
    r_w = np.abs(d).max(axis=(1, 2))
    where = " (problem {})" if b > 1 else ""
    bad = np.flatnonzero(~(r_w > 0.0))
    if len(bad):
        raise ValueError("points: every correspondence has the same world point; PnP needs points spread in space"
                         + where.format(int(bad[0])))  # fmt: skip
    pts = d / r_w[:, None, None]
    sv = np.linalg.svd(pts, compute_uv=False)
    bad = np.flatnonzero(~(sv[:, 1] > 1e-9 * sv[:, 0]))
    if len(bad):
        raise ValueError("points: the world points lie on one line; the rotation about it is undetermined"
                         + where.format(int(bad[0])))  # fmt: skip
    xn = np.concatenate([pixels, np.ones((b, m, 1))], axis=2) @ np.linalg.inv(K).T
    xn = xn[..., :2]
    mu = np.einsum("bm,bmi->bi", w, pts) / n[:, None]
    c = (pts - mu[:, None, :]) * w[..., None]  # centred, zero on padding rows
    _, sv_pts, vt_pts = np.linalg.svd(c, full_matrices=False)
    flatness = sv_pts[:, 2] / sv_pts[:, 0]
    R = np.full((b, 3, 3), np.nan)
    t = np.full((b, 3), np.nan)
    cost = np.full(b, np.inf)
    general = np.flatnonzero(flatness > 1e-3)
    if len(general):
        Rg, tg, ok = _general_dlt_batch(xn[general], c[general], mu[general], w[general])
        cg = _dlt_cost(Rg, tg, pixels[general], pts[general], w[general], K)
        keep = ok & np.isfinite(cg)
        R[general[keep]], t[general[keep]], cost[general[keep]] = Rg[keep], tg[keep], cg[keep]
    planar = np.flatnonzero((flatness < 0.2) | ~np.isfinite(cost))
    if len(planar):
        Rp, tp = _planar_dlt_batch(xn[planar], c[planar], mu[planar], vt_pts[planar], w[planar])
        cp = _dlt_cost(Rp, tp, pixels[planar], pts[planar], w[planar], K)
        better = (cp < cost[planar]) | ~np.isfinite(cost[planar])  # the general DLT wins ties (pnp_dlt's order)
        sel = planar[better]
        R[sel], t[sel] = Rp[better], tp[better]
    # X_c = R X_w + t with X_w = r_w X_n + mu_w
    return R, r_w[:, None] * t - np.einsum("bij,bj->bi", R, mu_w)


def _dlt_cost(
    R: NDArray[np.float64], t: NDArray[np.float64], pixels: NDArray[np.float64], points: NDArray[np.float64],
    w: NDArray[np.float64], K: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Sum of squared reprojection residuals (B,) of the rows weighted by ``w`` (B, M), as :func:`_residuals`."""
    pc = points @ np.swapaxes(R, 1, 2) + t[:, None, :]
    z = np.where(np.abs(pc[..., 2]) > 1e-12, pc[..., 2], 1e-12)
    ru = pixels[..., 0] - (K[0, 0] * pc[..., 0] / z + K[0, 2])
    rv = pixels[..., 1] - (K[1, 1] * pc[..., 1] / z + K[1, 2])
    out: NDArray[np.float64] = np.einsum("bm,bm->b", w, ru**2 + rv**2)
    return out


def _dlt_design(xn: np.ndarray, X: np.ndarray) -> NDArray[np.float64]:
    """DLT design matrices (..., 2m, 3k) of ``x ~ M X`` for normalized image points ``xn`` (..., m, 2) and
    homogeneous ``X`` (..., m, k): rows ``[Xᵀ, 0, −u Xᵀ]`` and ``[0, Xᵀ, −v Xᵀ]`` (k = 4: the 3x4 projection, k = 3:
    a homography); rows whose ``X`` is zero are zero."""
    *lead, m, k = X.shape
    A = np.zeros((*lead, 2 * m, 3 * k))
    A[..., 0::2, 0:k] = X
    A[..., 0::2, 2 * k :] = -xn[..., :1] * X
    A[..., 1::2, k : 2 * k] = X
    A[..., 1::2, 2 * k :] = -xn[..., 1:2] * X
    return A


def _general_dlt_batch(
    xn: np.ndarray, c: np.ndarray, mu: np.ndarray, w: np.ndarray,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """12-unknown DLT of each problem on its centred points ``c`` (B, M, 3) (zero on padding) with centroid ``mu``
    (B, 3); returns ``R`` (B, 3, 3), ``t`` (B, 3) and whether the rotation is proper (B,) (a reflection means
    degenerate or inconsistent correspondences)."""
    n = w.sum(axis=1)
    s = np.sqrt(3.0) * n / np.linalg.norm(c, axis=2).sum(axis=1)
    Xh = np.concatenate([c * s[:, None, None], w[..., None]], axis=2)
    Pm = np.linalg.svd(_dlt_design(xn, Xh), full_matrices=False)[2][:, -1].reshape(-1, 3, 4)
    flip = np.einsum("bmi,bi->b", Xh, Pm[:, 2]) < 0  # P is defined up to sign: the points in front of the camera
    Pm[flip] *= -1
    # undo the point normalization: X' = s (X − mu)
    M = Pm[:, :, :3] * s[:, None, None]
    t = Pm[:, :, 3] - np.einsum("bij,bj->bi", M, mu)
    u, sv, vt2 = np.linalg.svd(M)
    R = u @ vt2
    return R, t / sv.mean(axis=1, keepdims=True), np.linalg.det(R) > 0


def _planar_dlt_batch(
    xn: np.ndarray, c: np.ndarray, mu: np.ndarray, vt: np.ndarray, w: np.ndarray,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Pose of each problem from a plane-to-image homography (Zhang 2000 §2-3): ``H ∝ [r1 r2 t]`` in plane
    coordinates; ``c`` (B, M, 3) the centred points (zero on padding), ``mu`` (B, 3) their centroid, ``vt``
    (B, 3, 3) their principal axes (rows)."""
    B = np.swapaxes(vt, 1, 2).copy()  # columns: in-plane axes e1, e2 and the normal
    B[:, :, 2] = np.cross(B[:, :, 0], B[:, :, 1])
    uv = c @ B[:, :, :2]
    sc = np.sqrt(2.0) * w.sum(axis=1) / np.linalg.norm(uv, axis=2).sum(axis=1)
    U = np.concatenate([uv * sc[:, None, None], w[..., None]], axis=2)
    Hm = np.linalg.svd(_dlt_design(xn, U), full_matrices=False)[2][:, -1].reshape(-1, 3, 3)
    Hm = Hm * np.stack([sc, sc, np.ones_like(sc)], axis=1)[:, None, :]
    lam = 2.0 / (np.linalg.norm(Hm[:, :, 0], axis=1) + np.linalg.norm(Hm[:, :, 1], axis=1))
    lam = np.where(Hm[:, 2, 2] * lam < 0, -lam, lam)  # the plane origin must be in front of the camera
    r1, r2, tp = lam[:, None] * Hm[:, :, 0], lam[:, None] * Hm[:, :, 1], lam[:, None] * Hm[:, :, 2]
    u, _, vt2 = np.linalg.svd(np.stack([r1, r2, np.cross(r1, r2)], axis=2))
    D = np.zeros((len(u), 3, 3))
    D[:, 0, 0] = D[:, 1, 1] = 1.0
    D[:, 2, 2] = np.linalg.det(u @ vt2)
    Rp = u @ D @ vt2
    R = Rp @ np.swapaxes(B, 1, 2)
    return R, tp - np.einsum("bij,bj->bi", R, mu)


def _residuals(
    R: NDArray[np.float64], t: NDArray[np.float64], pixels: NDArray[np.float64], points: NDArray[np.float64],
    K: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Reprojection residuals ``(M, 2)`` px and camera-frame points ``(M, 3)`` of the pose ``(R, t)``."""
    pc = points @ R.T + t
    z = np.where(np.abs(pc[:, 2]) > 1e-12, pc[:, 2], 1e-12)  # RANSAC candidates may put a point on the plane Z = 0
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    pred = np.column_stack([fx * pc[:, 0] / z + cx, fy * pc[:, 1] / z + cy])
    return pixels - pred, pc


def pnp_refine(
    R: np.ndarray,
    t: np.ndarray,
    pixels: np.ndarray,
    points: np.ndarray,
    K: np.ndarray,
    iterations: int = 10,
    tol: float = 1e-10,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], int]:
    """Gauss–Newton on the reprojection error; returns ``(R_cw, t, JᵀJ (6, 6), iterations used)``.

    Parameters ``[δφ, δt]`` update ``R ← Exp(δφ) R`` and ``t ← t + δt``;
    ``∂X_c/∂δφ = −[R X_w]×``, ``∂X_c/∂δt = I``.
    """
    pixels, points, K = _check(pixels, points, K)
    fx, fy = K[0, 0], K[1, 1]
    R = np.array(R, dtype=np.float64)
    t = np.array(t, dtype=np.float64)
    JtJ = np.eye(6)
    it = 0
    for it in range(1, iterations + 1):  # noqa: B007
        r, pc = _residuals(R, t, pixels, points, K)
        X, Y, Z = pc.T
        Jp = np.zeros((len(pc), 2, 3))
        Jp[:, 0, 0] = fx / Z
        Jp[:, 0, 2] = -fx * X / Z**2
        Jp[:, 1, 1] = fy / Z
        Jp[:, 1, 2] = -fy * Y / Z**2
        rx = pc - t
        J: NDArray[np.float64] = np.empty((len(pc), 2, 6))  # ∂π/∂[δφ, δt]
        J[:, :, 0:3] = -np.einsum("mij,mjk->mik", Jp, dp.so3_hat(rx))
        J[:, :, 3:6] = Jp
        J = J.reshape(-1, 6)
        JtJ = J.T @ J
        step = np.linalg.solve(JtJ, J.T @ r.reshape(-1))
        R = dp.matrix_from_quat(dp.quat_from_rotvec(step[:3])) @ R
        t = t + step[3:]
        if np.linalg.norm(step) < tol:
            break
    return R, t, JtJ, it


def solve_pnp(
    pixels: np.ndarray, points: np.ndarray, K: np.ndarray, pixel_sigma: float = 1.0, iterations: int = 10
) -> PnPResult:
    """DLT initial guess + Gauss–Newton refinement; the camera pose in the world with its covariance.

    Solved on the points normalised to spread ~1 (the pose and its covariance mapped back), so the scene's scale
    does not matter.  Raises ``ValueError`` for points all at one place or on one line, and whenever the pose is not
    determined: the Gauss–Newton normal matrix singular to float64 precision (smallest eigenvalue at most ``1e-13``
    times the largest), or a rotation standard deviation above ``PNP_UNDETERMINED_ROTATION_RAD`` (0.2 rad, 11.5°) at
    ``pixel_sigma`` (points nearly collinear, or a tiny target far away) -- the numbers would be fitted to the pixel
    noise.
    """
    pixels, world, K = _check(pixels, points, K)
    points, mu_w, r_w = _normalised(world)
    try:
        R, t = pnp_dlt(pixels, points, K)
        R, t, JtJ, its = pnp_refine(R, t, pixels, points, K, iterations=iterations)
    except np.linalg.LinAlgError:
        raise ValueError("PnP pose is not determined: a normal matrix is singular (the points are collinear or "
                         "coincident)") from None  # fmt: skip
    r, _ = _residuals(R, t, pixels, points, K)
    lam = np.linalg.eigvalsh(0.5 * (JtJ + JtJ.T))
    if not lam[0] > 1e-13 * lam[-1]:
        raise ValueError("PnP pose is not determined: the normal matrix is singular to float64 precision (eigenvalues "
                         f"{lam[0]:.3g} .. {lam[-1]:.3g}); the points are collinear or coincident")  # fmt: skip
    cov_lt = np.linalg.inv(JtJ) * pixel_sigma**2  # over [δφ (world→camera, left), δt], normalised points
    rot_std = float(np.sqrt(max(np.linalg.eigvalsh(cov_lt[:3, :3])[-1], 0.0)))
    if rot_std > PNP_UNDETERMINED_ROTATION_RAD:
        raise ValueError(f"PnP pose is not determined: its rotation has a standard deviation of "
                         f"{np.degrees(rot_std):.3g} deg at pixel_sigma {pixel_sigma:g} px (points nearly collinear, "
                         "or too small in the image)")  # fmt: skip
    # R_wc = Rᵀ ← Rᵀ Exp(−δφ): camera-frame rotation error δθ_c = −δφ;
    # c = −Rᵀ t ← −(Exp(δφ) R)ᵀ (t + δt) ≈ c − Rᵀ δt − Rᵀ [t]× δφ
    Jc = np.zeros((6, 6))
    Jc[0:3, 0:3] = -np.eye(3)
    Jc[3:6, 0:3] = -R.T @ dp.so3_hat(t)
    Jc[3:6, 3:6] = -R.T
    Jc[3:6] *= r_w  # the centre in the world: c_w = r_w c_n + mu_w
    with np.errstate(over="ignore", invalid="ignore"):  # checked just below
        cov = Jc @ cov_lt @ Jc.T
    if not np.isfinite(cov).all():
        raise ValueError(f"points: spread {r_w:.3g} (world units): the pose covariance overflows float64 at this "
                         "scale; express the points in larger units")  # fmt: skip
    return PnPResult(
        q_wc=dp.quat_from_matrix(R.T),
        c_w=-r_w * (R.T @ t) + mu_w,
        covariance=0.5 * (cov + cov.T),
        rms_px=float(np.sqrt(np.mean(r**2))),
        iterations=its,
    )


def solve_pnp_ransac(
    pixels: np.ndarray,
    points: np.ndarray,
    K: np.ndarray,
    pixel_sigma: float = 1.0,
    threshold_px: float = 6.0,
    iterations: int = 200,
    seed: int = 0,
) -> tuple[PnPResult, NDArray[np.float64]]:
    """Robust PnP: RANSAC over minimal 6-point DLT samples (seeded), then :func:`solve_pnp` on the largest consensus
    set (reprojection error < ``threshold_px``).  Returns the result and the inlier mask (M,)."""
    pixels, points, K = _check(pixels, points, K)
    rng = np.random.default_rng(seed)
    m = len(pixels)
    best = np.zeros(m, bool)
    for _ in range(iterations):
        idx = rng.choice(m, 6, replace=False)
        try:
            R, t = pnp_dlt(pixels[idx], points[idx], K)
        except (ValueError, np.linalg.LinAlgError):
            continue
        r, pc = _residuals(R, t, pixels, points, K)
        inl = (np.linalg.norm(r, axis=1) < threshold_px) & (pc[:, 2] > 0)
        if inl.sum() > best.sum():
            best = inl
            if best.all():
                break
    if best.sum() < 6:
        raise ValueError(f"RANSAC found no consensus of >= 6 correspondences (best {int(best.sum())} of {m})")
    res = solve_pnp(pixels[best], points[best], K, pixel_sigma=pixel_sigma)
    R = dp.matrix_from_quat(res.q_wc).T
    r, _ = _residuals(R, -R @ res.c_w, pixels, points, K)
    inliers = np.linalg.norm(r, axis=1) < threshold_px
    if inliers.sum() > best.sum():
        res = solve_pnp(pixels[inliers], points[inliers], K, pixel_sigma=pixel_sigma)
    return res, inliers


@dataclass
class PnPBatch:
    """Result of :func:`solve_pnp_batch`: ``B`` camera poses as in :class:`PnPResult`, stacked.

    ``q_wc`` (B, 4), ``c_w`` (B, 3), ``covariance`` (B, 6, 6), ``rms_px`` (B,) over the inliers, ``inliers``
    (B, M) bool."""

    q_wc: np.ndarray
    c_w: np.ndarray
    covariance: np.ndarray
    rms_px: np.ndarray
    inliers: np.ndarray


def _gauss_newton_batch(
    R: NDArray[np.float64], t: NDArray[np.float64], pixels: NDArray[np.float64], points: NDArray[np.float64],
    w: NDArray[np.float64], K: NDArray[np.float64], iterations: int, tol: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Batched :func:`pnp_refine` over rows weighted by ``w`` (B, M) (0 / 1); returns ``(R, t, JᵀJ, r, Z)``.

    Each problem stops after the iteration whose step has no component above ``tol`` (JᵀJ and r are those of its
    last iterate: changes of O(tol)); only the problems still moving are computed in the next iteration."""
    R, t = R.copy(), t.copy()
    points = np.ascontiguousarray(points)
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    b, m = w.shape
    JtJ_all, r_all, Z_all = np.zeros((b, 6, 6)), np.zeros((b, m, 2)), np.zeros((b, m))
    act = np.arange(b)
    for _ in range(iterations):
        Ra, X = R[act], points[act]
        rx = X @ np.swapaxes(Ra, 1, 2)
        pc = rx + t[act][:, None, :]
        Z = np.where(np.abs(pc[..., 2]) > 1e-12, pc[..., 2], 1e-12)
        r = pixels[act] - np.stack([fx * pc[..., 0] / Z + cx, fy * pc[..., 1] / Z + cy], axis=-1)
        # ∂π/∂X_c rows (A, 0, C) and (0, D, E); ∂π/∂δφ = −Jp [R X]×, row a = (R X) × Jp_a; ∂π/∂δt = Jp
        A, C = fx / Z, -fx * pc[..., 0] / Z**2
        D, E = fy / Z, -fy * pc[..., 1] / Z**2
        p, q, s = rx[..., 0], rx[..., 1], rx[..., 2]
        J: NDArray[np.float64] = np.zeros(pc.shape[:2] + (2, 6))
        J[..., 0, 0], J[..., 0, 1], J[..., 0, 2] = q * C, s * A - p * C, -q * A
        J[..., 1, 0], J[..., 1, 1], J[..., 1, 2] = q * E - s * D, -p * E, p * D
        J[..., 0, 3], J[..., 0, 5], J[..., 1, 4], J[..., 1, 5] = A, C, D, E
        J = J.reshape(len(act), -1, 6)  # (B, 2M, 6)
        Jw = J * np.repeat(w[act], 2, axis=1)[:, :, None]
        JtJ = np.swapaxes(Jw, 1, 2) @ J
        step = np.linalg.solve(JtJ, np.swapaxes(Jw, 1, 2) @ r.reshape(len(act), -1, 1))[..., 0]
        R[act] = dp.matrix_from_quat(dp.quat_from_rotvec(step[:, :3])) @ Ra
        t[act] = t[act] + step[:, 3:]
        JtJ_all[act], r_all[act], Z_all[act] = JtJ, r, Z
        act = act[np.abs(step).max(axis=1) >= tol]
        if not len(act):
            break
    return R, t, JtJ_all, r_all, Z_all


def solve_pnp_batch(
    pixels: np.ndarray,
    points: np.ndarray,
    valid: np.ndarray,
    K: np.ndarray,
    pixel_sigma: float = 1.0,
    threshold_px: float = 6.0,
    iterations: int = 10,
    failed: str = "raise",
) -> PnPBatch:
    """``B`` independent PnP problems at once: :func:`solve_pnp` vectorised over the batch axis.

    Parameters
    ----------
    pixels : (B, M, 2), points : (B, M, 3)
        Correspondences of each problem (pixels, world points in metres); ``valid`` (B, M) bool marks the rows
        that are real (the rest is padding).  At least 6 valid rows per problem.
    K : (3, 3) intrinsics shared by all problems, px.

    failed : ``"raise"`` (default) or ``"nan"``
        A problem left with fewer than 6 correspondences within ``threshold_px`` of its fit raises ``ValueError``,
        or (``"nan"``) gets NaN pose, covariance and RMS and no inliers while the others are solved.

    The linear start is the 12-unknown DLT of :func:`pnp_dlt` (normal equations, batched eigen-solve); problems
    whose points are close to a plane take :func:`pnp_dlt_batch` (the steps of :func:`pnp_dlt`, batched).
    Gauss–Newton then refines all problems together; correspondences with a reprojection error above
    ``threshold_px`` are dropped and the problems that lost any are refined again (one robust pass; for heavy
    outlier rates use :func:`solve_pnp_ransac`).  Each problem's Gauss–Newton stops when its step has no component
    above 1e-8 (rad, m); covariances as :func:`solve_pnp`.
    """
    if failed not in ("raise", "nan"):
        raise ValueError(f"failed must be 'raise' or 'nan'; got {failed!r}")
    pixels = np.asarray(pixels, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    valid = np.asarray(valid, dtype=bool)
    K = np.asarray(K, dtype=np.float64)
    if pixels.ndim != 3 or pixels.shape[2] != 2:
        raise ValueError(f"pixels must have shape (B, M, 2); got {pixels.shape}")
    b, m = pixels.shape[:2]
    if points.shape != (b, m, 3) or valid.shape != (b, m) or K.shape != (3, 3):
        raise ValueError(f"points, valid and K must have shapes ({b}, {m}, 3), ({b}, {m}), (3, 3); got "
                         f"{points.shape}, {valid.shape}, {K.shape}")  # fmt: skip
    w = valid.astype(np.float64)
    n = w.sum(axis=1)
    if np.any(n < 6):
        raise ValueError(f"PnP (DLT) needs at least 6 correspondences; problem {int(np.argmin(n))} has {int(n.min())}")
    xn = np.linalg.solve(K, np.concatenate([pixels, np.ones((b, m, 1))], axis=2).reshape(-1, 3).T).T
    xn = xn.reshape(b, m, 3)[..., :2]
    mu = np.einsum("bm,bmi->bi", w, points) / n[:, None]
    d = (points - mu[:, None, :]) * w[..., None]
    lam = np.linalg.eigvalsh(np.swapaxes(d, 1, 2) @ d)
    flat = np.sqrt(np.maximum(lam[:, 0], 0.0) / np.maximum(lam[:, 2], 1e-300))
    s = np.sqrt(3.0) * n / np.maximum(np.linalg.norm(d, axis=2).sum(axis=1), 1e-300)
    Xh = np.concatenate([d * s[:, None, None], np.ones((b, m, 1))], axis=2)
    z4 = np.zeros_like(Xh)
    a1 = np.concatenate([Xh, z4, -xn[..., :1] * Xh], axis=2)
    a2 = np.concatenate([z4, Xh, -xn[..., 1:] * Xh], axis=2)
    N = np.swapaxes(a1 * w[..., None], 1, 2) @ a1 + np.swapaxes(a2 * w[..., None], 1, 2) @ a2
    Pm = np.linalg.eigh(N)[1][:, :, 0].reshape(b, 3, 4)
    flip = np.einsum("bm,bmi,bi->b", w, Xh, Pm[:, 2]) < 0  # put the points in front of the camera
    Pm[flip] *= -1
    Mx = Pm[:, :, :3] * s[:, None, None]
    t = Pm[:, :, 3] - np.einsum("bij,bj->bi", Mx, mu)
    u, sv, vt = np.linalg.svd(Mx)
    R = u @ vt
    t = t / sv.mean(axis=1, keepdims=True)
    near = np.flatnonzero((np.linalg.det(R) < 0) | (flat < 0.2))  # near-planar: pnp_dlt's steps, batched
    if len(near):
        R[near], t[near] = pnp_dlt_batch(pixels[near], points[near], valid[near], K)
    R, t, JtJ, r, Z = _gauss_newton_batch(R, t, pixels, points, w, K, iterations, 1e-8)
    inl = valid & (np.linalg.norm(r, axis=2) < threshold_px) & (Z > 0)
    redo = np.flatnonzero(np.any(inl != valid, axis=1))
    lost = redo[inl[redo].sum(axis=1) < 6]
    if len(lost):
        if failed == "raise":
            raise ValueError("PnP: fewer than 6 correspondences within threshold_px of the fit in some problem")
        redo = np.setdiff1d(redo, lost)
        inl[lost] = False
        JtJ[lost] = np.eye(6)
    if len(redo):
        out = _gauss_newton_batch(R[redo], t[redo], pixels[redo], points[redo], inl[redo].astype(float), K,
                                  iterations, 1e-8)  # fmt: skip
        R[redo], t[redo], JtJ[redo], r[redo] = out[:4]
    cov_lt = np.linalg.inv(JtJ) * pixel_sigma**2
    Jc = np.zeros((b, 6, 6))
    Jc[:, 0:3, 0:3] = -np.eye(3)
    Rt = np.swapaxes(R, 1, 2)
    Jc[:, 3:6, 0:3] = -Rt @ dp.so3_hat(t)
    Jc[:, 3:6, 3:6] = -Rt
    cov = Jc @ cov_lt @ np.swapaxes(Jc, 1, 2)
    with np.errstate(invalid="ignore"):  # the lost problems (no inliers): NaN below
        rms = np.sqrt(np.einsum("bm,bma->b", inl.astype(float), r**2) / (2 * inl.sum(axis=1)))
    q_wc = np.full((b, 4), np.nan)
    ok = np.ones(b, dtype=bool)
    ok[lost] = False
    q_wc[ok] = dp.quat_from_matrix(Rt[ok])
    c_w = -np.einsum("bij,bj->bi", Rt, t)
    c_w[lost], cov[lost], rms[lost] = np.nan, np.nan, np.nan
    return PnPBatch(
        q_wc=q_wc, c_w=c_w,
        covariance=0.5 * (cov + np.swapaxes(cov, 1, 2)), rms_px=rms, inliers=inl,
    )  # fmt: skip
