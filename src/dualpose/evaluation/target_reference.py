"""Per-frame camera poses against a calibration target, the reference trajectory made from them, and the scoring of
a tracked trajectory against it (docs/fusion.md, "Tracking on EuRoC imu_april").

Frames: target ``t`` (the world of the tracker), camera ``c``, IMU body ``b``; poses ``q_wc`` / ``q_wb`` xyzw
(camera / body -> target), positions in metres.  Each frame's pose is a robust PnP on the undistorted ("ideal")
pixels (:func:`dualpose.registration.pnp.solve_pnp_batch`: batched DLT, Gauss–Newton, one outlier pass) refined by
Gauss–Newton on the reprojection error of the *measured* (distorted) pixels through the camera model
(``camera.project_jacobian``), so the lens model is used exactly, not through its linearisation.  The reprojection
RMS is per coordinate (``sqrt(Σ r² / 2n)``, pixels of the measured image).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose.registration.pnp import solve_pnp_batch
from dualpose.types import Trajectory
from dualpose.types.camera_models import DistortedCamera
from dualpose.types.target import TargetDetections

__all__ = [
    "CameraPoses", "camera_poses", "body_trajectory", "reference_trajectory", "errors_against", "ErrorsAgainst",
    "three_cornered_hat",
]

#: outlier threshold of the PnP (ideal pixels) and of the refinement (measured pixels), px
OUTLIER_PX = 3.0
#: Gauss–Newton iterations of the distorted-model refinement
REFINE_ITERATIONS = 5


@dataclass
class CameraPoses:
    """Per-frame PnP poses of one camera (only the frames with enough corners).

    ``frame`` (P,) int: the detection frame index of each pose; ``stamps_ns`` (P,) int64 and ``t`` (P,) s (camera
    clock); ``q_wc`` (P, 4) xyzw camera -> target; ``c_w`` (P, 3) camera centre in the target frame, m;
    ``covariance`` (P, 6, 6) over ``[δθ_c, δc]`` (camera-frame rotation error, target-frame centre error) for the
    fitted pixel noise (``rms_px``); ``rms_px`` (P,) the per-coordinate reprojection RMS of the inliers in measured
    pixels; ``n_inliers`` (P,) int.
    """

    frame: np.ndarray
    stamps_ns: np.ndarray
    t: np.ndarray
    q_wc: np.ndarray
    c_w: np.ndarray
    covariance: np.ndarray
    rms_px: np.ndarray
    n_inliers: np.ndarray


def _padded(det: TargetDetections, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    counts = det.counts[frames]
    m = int(counts.max())
    rows = det.offsets[frames][:, None] + np.arange(m)[None, :]
    valid = np.arange(m)[None, :] < counts[:, None]
    rows = np.where(valid, rows, det.offsets[frames][:, None])
    return det.pixels[rows], det.points[rows], valid


def camera_poses(det: TargetDetections, camera: DistortedCamera, min_corners: int = 6) -> CameraPoses:
    """The pose of the camera at every frame of ``det`` with at least ``min_corners`` corners (module docstring).

    Parameters
    ----------
    det : TargetDetections
        Measured (distorted) pixels and target-frame points.
    camera : RadTanCamera or EquidistantCamera
        The lens model (``ideal_pixels``, ``project_jacobian``, ``pinhole``).
    min_corners : int
        At least 6.
    """
    if min_corners < 6:
        raise ValueError(f"min_corners must be >= 6 (PnP needs 6 correspondences); got {min_corners}")
    frames = np.flatnonzero(det.counts >= min_corners)
    if len(frames) == 0:
        raise ValueError(f"{det.path or 'detections'}: no frame has >= {min_corners} corners")
    raw, pts, valid = _padded(det, frames)
    ideal, ok = camera.ideal_pixels(raw, return_valid=True)
    valid = valid & ok
    keep = valid.sum(axis=1) >= 6
    frames, raw, pts, valid, ideal = frames[keep], raw[keep], pts[keep], valid[keep], ideal[keep]
    ideal = np.where(valid[..., None], ideal, 0.0)
    K = camera.pinhole().matrix
    first = solve_pnp_batch(ideal, pts, valid, K, threshold_px=OUTLIER_PX)
    R = dp.matrix_from_quat(first.q_wc).swapaxes(1, 2)  # R_cw
    tr = -np.einsum("bij,bj->bi", R, first.c_w)
    w = first.inliers.astype(np.float64)
    for _ in range(REFINE_ITERATIONS):
        rx = np.einsum("bij,bmj->bmi", R, pts)
        pc = rx + tr[:, None, :]
        pc[..., 2] = np.where(w > 0, pc[..., 2], 1.0)  # outliers/padding: any projectable point (weight 0)
        uv, Jp = camera.project_jacobian(pc)
        r = raw - uv
        J = np.empty(pc.shape[:2] + (2, 6))
        J[..., 0:3] = -np.einsum("bmij,bmjk->bmik", Jp, dp.so3_hat(rx))  # ∂π/∂δφ, R <- Exp(δφ) R
        J[..., 3:6] = Jp
        J = J.reshape(len(R), -1, 6)
        Jw = J * np.repeat(w, 2, axis=1)[:, :, None]
        JtJ = Jw.swapaxes(1, 2) @ J
        step = np.linalg.solve(JtJ, Jw.swapaxes(1, 2) @ r.reshape(len(R), -1, 1))[..., 0]
        R = dp.matrix_from_quat(dp.quat_from_rotvec(step[:, :3])) @ R
        tr = tr + step[:, 3:]
    pc = np.einsum("bij,bmj->bmi", R, pts) + tr[:, None, :]
    pc[..., 2] = np.where(w > 0, pc[..., 2], 1.0)
    r = raw - camera.project(pc)
    n = w.sum(axis=1)
    rms = np.sqrt(np.einsum("bm,bma->b", w, r**2) / (2 * n))
    # covariance of [δφ, δt] (left, world->camera) for the fitted noise, mapped to [δθ_c, δc] as solve_pnp does
    cov_lt = np.linalg.inv(JtJ) * (rms**2)[:, None, None]
    Rt = R.swapaxes(1, 2)
    Jc = np.zeros((len(R), 6, 6))
    Jc[:, 0:3, 0:3] = -np.eye(3)
    Jc[:, 3:6, 0:3] = -Rt @ dp.so3_hat(tr)
    Jc[:, 3:6, 3:6] = -Rt
    cov = Jc @ cov_lt @ Jc.swapaxes(1, 2)
    return CameraPoses(
        frame=frames, stamps_ns=det.stamps_ns[frames], t=det.t[frames], q_wc=dp.quat_from_matrix(Rt),
        c_w=-np.einsum("bij,bj->bi", Rt, tr), covariance=0.5 * (cov + cov.swapaxes(1, 2)), rms_px=rms,
        n_inliers=n.astype(np.int64),
    )  # fmt: skip


def body_trajectory(
    poses: CameraPoses, q_bc: np.ndarray, p_bc: np.ndarray, time_offset: float = 0.0, mask: np.ndarray | None = None,
    name: str = "",
) -> Trajectory:
    """The body (IMU) poses of camera poses through the extrinsic ``(q_bc, p_bc)`` (camera axes and centre in the
    body frame): ``R_wb = R_wc R_bcᵀ``, ``p_wb = c_w − R_wb p_bc``, at ``t + time_offset`` (IMU clock), optionally only
    the poses where ``mask`` (P,) is true."""
    sel = np.ones(len(poses.t), bool) if mask is None else np.asarray(mask, bool)
    q_wb = dp.quat_mul(poses.q_wc[sel], dp.quat_conj(np.asarray(q_bc, dtype=np.float64)))
    p_wb = poses.c_w[sel] - dp.quat_rotate(q_wb, np.asarray(p_bc, dtype=np.float64))
    ns = poses.stamps_ns[sel] + int(round(time_offset * 1e9))
    return Trajectory(poses.t[sel] + time_offset, p_wb, q_wb, ns, name=name)


def reference_trajectory(
    det: TargetDetections, camera: DistortedCamera, q_bc: np.ndarray, p_bc: np.ndarray, max_rms_px: float = 0.7,
    min_corners: int = 30, time_offset: float = 0.0,
) -> tuple[Trajectory, CameraPoses]:
    """The reference: body poses from the camera's per-frame PnP on the frames with a reprojection RMS below
    ``max_rms_px`` and at least ``min_corners`` inlier corners.  Returns the trajectory and the kept poses."""
    poses = camera_poses(det, camera, min_corners)
    keep = (poses.rms_px < max_rms_px) & (poses.n_inliers >= min_corners)
    kept = CameraPoses(*(getattr(poses, f)[keep] for f in CameraPoses.__dataclass_fields__))
    return body_trajectory(kept, q_bc, p_bc, time_offset, name="reference"), kept


@dataclass
class ErrorsAgainst:
    """Errors of an estimate at the reference times it covers.

    ``index`` (K,) rows of the reference that were matched; ``position`` (K, 3) estimate − reference, m (target
    frame, no alignment); ``rotation_deg`` (K,) angle between the attitudes; ``estimate`` the estimate at those
    times (a :class:`Trajectory`); ``position_rmse_m``, ``rotation_rmse_deg``.
    """

    index: np.ndarray
    position: np.ndarray
    rotation_deg: np.ndarray
    estimate: Trajectory

    @property
    def position_rmse_m(self) -> float:
        return float(np.sqrt(np.mean(np.sum(self.position**2, axis=1)))) if len(self.index) else float("nan")

    @property
    def rotation_rmse_deg(self) -> float:
        return float(np.sqrt(np.mean(self.rotation_deg**2))) if len(self.index) else float("nan")

    def within(self, mask: np.ndarray) -> ErrorsAgainst:
        """The errors at the matched rows where ``mask`` (K,) is true."""
        m = np.asarray(mask, bool)
        est = self.estimate.take(np.flatnonzero(m))
        return ErrorsAgainst(self.index[m], self.position[m], self.rotation_deg[m], est)


def errors_against(reference: Trajectory, estimate: Trajectory, max_gap: float | None = None) -> ErrorsAgainst:
    """Errors of ``estimate`` at the times of ``reference`` (same frame; no alignment).

    An estimate sample within 1 µs of a reference time is used as it is; otherwise the estimate is interpolated
    (position linearly, attitude by SLERP) between the samples around it, if they are at most ``max_gap`` apart
    (default 1.5 × the estimate's median step); reference times not covered are left out.
    """
    te, tr = estimate.stamps, reference.stamps
    if max_gap is None:
        max_gap = 1.5 * float(np.median(np.diff(te))) if len(te) > 1 else 0.0
    j = np.clip(np.searchsorted(te, tr), 1, max(len(te) - 1, 1))
    lo, hi = te[j - 1], te[j]
    exact_hi = np.abs(hi - tr) <= 1e-6
    exact_lo = np.abs(lo - tr) <= 1e-6
    inside = (lo <= tr) & (tr <= hi) & (hi - lo <= max_gap)
    ok = exact_hi | exact_lo | inside
    idx = np.flatnonzero(ok)
    jj = j[idx]
    frac = (tr[idx] - lo[idx]) / np.maximum(hi[idx] - lo[idx], 1e-300)
    a = np.where(exact_lo[idx], 0.0, np.where(exact_hi[idx], 1.0, frac))
    p = (1 - a)[:, None] * estimate.positions[jj - 1] + a[:, None] * estimate.positions[jj]
    q = dp.quat_slerp(estimate.quats[jj - 1], estimate.quats[jj], a) if len(idx) else np.zeros((0, 4))
    q = q.reshape(-1, 4)
    ref = reference.take(idx)
    est = Trajectory(tr[idx], p, q, reference.stamps_ns[idx] if reference.stamps_ns is not None else None,
                     name=estimate.name)  # fmt: skip
    return ErrorsAgainst(idx, p - ref.positions, np.degrees(dp.quat_angle(q, ref.quats)), est)


def three_cornered_hat(
    d_ab: ArrayLike, d_ac: ArrayLike, d_bc: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Error variances of three instruments a, b, c from the differences of their readings of the same quantity
    (the "three-cornered hat", Gray & Allan 1974).

    With mutually independent, zero-mean errors ``e_a, e_b, e_c``, the mean squares of the differences are
    ``M_ab = σ_a² + σ_b²``, ``M_ac = σ_a² + σ_c²``, ``M_bc = σ_b² + σ_c²``, so ``σ_a² = (M_ab + M_ac − M_bc) / 2`` and
    alike.  The mean squares are taken about zero (a common bias of one instrument counts as its error).  An error
    shared by two instruments is attributed to the third, and a negative result says the errors are correlated (it is
    returned as it is, not clipped).

    Parameters
    ----------
    d_ab, d_ac, d_bc : (K,) or (K, D)
        The differences ``a − b``, ``a − c``, ``b − c`` over the same K samples (each component on the last axis
        separately, e.g. the rotation-vector components of relative-rotation differences in a common frame).

    Returns
    -------
    (var_a, var_b, var_c) : each () or (D,), the estimated error variances (units of the input squared).
    """
    arrays = []
    for name, d in (("d_ab", d_ab), ("d_ac", d_ac), ("d_bc", d_bc)):
        a = np.asarray(d, dtype=np.float64)
        if a.ndim not in (1, 2) or a.shape[0] < 2:
            raise ValueError(f"{name} must have shape (K,) or (K, D) with K >= 2; got shape {a.shape}")
        if not np.isfinite(a).all():
            raise ValueError(f"{name} must be finite")
        arrays.append(a)
    if not arrays[0].shape == arrays[1].shape == arrays[2].shape:
        raise ValueError(f"d_ab, d_ac, d_bc must have the same shape; got {[a.shape for a in arrays]}")
    m_ab, m_ac, m_bc = (np.mean(a * a, axis=0) for a in arrays)
    return 0.5 * (m_ab + m_ac - m_bc), 0.5 * (m_ab + m_bc - m_ac), 0.5 * (m_ac + m_bc - m_ab)
