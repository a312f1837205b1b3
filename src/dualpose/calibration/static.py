"""Static periods: the mean specific force and the camera pose (PnP over all frames of the period) with their
uncertainties — the raw material of the static calibrations (:mod:`.extrinsic`, :mod:`.gravity`).

Frames as in :mod:`dualpose.estimation`: world/scene ``w`` (the calibration pattern's or scene model's frame), body
``b`` (IMU), camera ``c``.  ``q_wc`` (4,) xyzw is the camera→world rotation; its error is the camera-frame
``δθ_c`` of :class:`dualpose.registration.pnp.PnPResult` (``R_wc,true = R̂_wc Exp(δθ_c)``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, TypedDict

import numpy as np
from numpy.typing import NDArray

from dualpose.types.camera import FrameCorrespondences, PinholeModel
from dualpose.types.imu import ImuNoise

__all__ = [
    "StaticArrays", "StaticPeriod", "static_period", "static_period_from_run", "static_periods", "stack_static_periods"
]


class StaticArrays(TypedDict):
    """``K`` periods at rest stacked (:func:`stack_static_periods`, :func:`static_periods`): the keyword arrays of
    :func:`~dualpose.calibration.extrinsic.camera_imu_rotation` and :func:`~dualpose.calibration.gravity.scene_gravity`.

    ``specific_force`` (K, 3) m/s² body frame, ``q_wc`` (K, 4) xyzw camera → target, ``specific_force_covariance``
    and ``attitude_covariance`` (K, 3, 3) (m/s²)², rad².
    """

    specific_force: NDArray[np.float64]
    q_wc: NDArray[np.float64]
    specific_force_covariance: NDArray[np.float64]
    attitude_covariance: NDArray[np.float64]


@dataclass
class StaticPeriod:
    """One period at rest.

    Attributes
    ----------
    specific_force : ndarray (3,)
        Mean accelerometer reading, body frame, m/s² (at rest ``f_b = −R_wbᵀ g_w``: it points "up").
    specific_force_covariance : ndarray (3, 3)
        Covariance of that mean from the white noise, ``σ_a² / T`` per axis (``σ_a`` the noise density in
        m/s²/√Hz, ``T`` the averaging time in s).  Accelerometer bias is *not* in it (see the calibration functions).
    q_wc : ndarray (4,)
        Camera→world orientation, xyzw, from PnP over all correspondences of the period.
    c_w : ndarray (3,)
        Camera centre in the world frame, m.
    attitude_covariance : ndarray (3, 3)
        Covariance of the camera-frame attitude error ``δθ_c`` of ``q_wc``, rad².
    n_samples, n_frames, n_correspondences : int
    """

    specific_force: np.ndarray
    specific_force_covariance: np.ndarray
    q_wc: np.ndarray
    c_w: np.ndarray
    attitude_covariance: np.ndarray
    n_samples: int
    n_frames: int
    n_correspondences: int


def static_period(
    accel: np.ndarray,
    pixels: np.ndarray,
    points: np.ndarray,
    K: np.ndarray,
    accelerometer_noise_density: float,
    rate: float,
    pixel_sigma: float = 1.0,
    n_frames: int = 1,
) -> StaticPeriod:
    """Summarise a period at rest.

    Parameters
    ----------
    accel : (N, 3) accelerometer samples at rest, body frame, m/s².
    pixels : (M, 2), points : (M, 3)
        All 2-D–3-D correspondences of the frames taken during the period (the camera does not move, so they are
        solved together: one robust PnP, :func:`dualpose.registration.pnp.solve_pnp_ransac`).
    K : (3, 3) camera intrinsics, px.
    accelerometer_noise_density : float, m/s²/√Hz.  rate : float, IMU rate, Hz.  pixel_sigma : float, px.
    n_frames : int, for the record.
    """
    from dualpose.registration.pnp import solve_pnp_ransac

    accel = np.asarray(accel, dtype=np.float64)
    if accel.ndim != 2 or accel.shape[1] != 3 or len(accel) < 1:
        raise ValueError(f"accel must have shape (N, 3) with N >= 1; got {accel.shape}")
    if not (accelerometer_noise_density >= 0 and rate > 0):
        raise ValueError("accelerometer_noise_density must be >= 0 and rate > 0")
    pnp, inliers = solve_pnp_ransac(pixels, points, K, pixel_sigma=pixel_sigma)
    t_avg = len(accel) / rate
    return StaticPeriod(
        specific_force=accel.mean(axis=0),
        specific_force_covariance=np.eye(3) * accelerometer_noise_density**2 / t_avg,
        q_wc=pnp.q_wc,
        c_w=pnp.c_w,
        attitude_covariance=pnp.covariance[:3, :3].copy(),
        n_samples=len(accel),
        n_frames=int(n_frames),
        n_correspondences=int(inliers.sum()),
    )


class _StaticRun(Protocol):
    """The fields of a :class:`~dualpose.sim.SimulatedRun` that :func:`static_period_from_run` reads."""

    @property
    def t(self) -> np.ndarray: ...
    @property
    def accel(self) -> np.ndarray: ...
    @property
    def frames(self) -> FrameCorrespondences: ...
    @property
    def camera(self) -> PinholeModel: ...
    @property
    def imu_noise(self) -> ImuNoise: ...
    @property
    def pixel_sigma(self) -> float: ...


def static_period_from_run(run: _StaticRun, t_start: float | None = None, t_end: float | None = None) -> StaticPeriod:
    """:func:`static_period` over ``[t_start, t_end]`` (s; default the whole run) of a
    :class:`~dualpose.sim.SimulatedRun` (or any object with its fields): the IMU samples and the camera
    frames stamped in the window.  The two clocks differ by the (unknown) time offset, so keep the window a few
    tens of ms inside the period at rest; the true offset is not used.
    """
    t0 = run.t[0] if t_start is None else t_start
    t1 = run.t[-1] if t_end is None else t_end
    sel = (run.t >= t0) & (run.t <= t1)
    f = run.frames
    ks = np.flatnonzero((f.t >= t0) & (f.t <= t1))
    if len(ks) == 0:
        raise ValueError(f"no camera frame in the static window [{t0}, {t1}] s")
    rows = np.concatenate([np.arange(f.offsets[k], f.offsets[k + 1]) for k in ks])
    n = run.imu_noise
    return static_period(
        run.accel[sel], f.pixels[rows], f.points[rows], run.camera.matrix, n.accelerometer_noise_density,
        n.update_rate, pixel_sigma=max(run.pixel_sigma, 1e-3), n_frames=len(ks),
    )  # fmt: skip


def static_periods(
    accel: np.ndarray,
    pixels: np.ndarray,
    points: np.ndarray,
    valid: np.ndarray,
    K: np.ndarray,
    accelerometer_noise_density: float,
    rate: float,
    pixel_sigma: float = 1.0,
) -> StaticArrays:
    """:func:`static_period` for ``P`` periods at once, straight into the arrays of :func:`stack_static_periods`.

    Parameters
    ----------
    accel : (P, N, 3) accelerometer samples at rest of each period, body frame, m/s².
    pixels : (P, M, 2), points : (P, M, 3), valid : (P, M) bool
        The correspondences of each period (padding rows have ``valid`` False); solved together per period by
        :func:`dualpose.registration.pnp.solve_pnp_batch` (one robust pass, no RANSAC).
    K, accelerometer_noise_density, rate, pixel_sigma : as :func:`static_period`.

    Returns
    -------
    dict
        ``specific_force`` (P, 3), ``q_wc`` (P, 4), ``specific_force_covariance`` (P, 3, 3),
        ``attitude_covariance`` (P, 3, 3).
    """
    from dualpose.registration.pnp import solve_pnp_batch

    accel = np.asarray(accel, dtype=np.float64)
    if accel.ndim != 3 or accel.shape[2] != 3 or accel.shape[1] < 1:
        raise ValueError(f"accel must have shape (P, N, 3) with N >= 1; got {accel.shape}")
    if not (accelerometer_noise_density >= 0 and rate > 0):
        raise ValueError("accelerometer_noise_density must be >= 0 and rate > 0")
    pnp = solve_pnp_batch(pixels, points, valid, K, pixel_sigma=pixel_sigma)
    p, n = accel.shape[:2]
    return StaticArrays(
        specific_force=accel.mean(axis=1),
        q_wc=pnp.q_wc,
        specific_force_covariance=np.broadcast_to(np.eye(3) * accelerometer_noise_density**2 * rate / n,
                                                  (p, 3, 3)).copy(),  # fmt: skip
        attitude_covariance=np.ascontiguousarray(pnp.covariance[:, :3, :3]),
    )


def stack_static_periods(periods: list[StaticPeriod]) -> StaticArrays:
    """Keyword arrays for :func:`~.extrinsic.camera_imu_rotation` / :func:`~.gravity.scene_gravity` from
    ``K`` periods: ``specific_force`` (K, 3), ``q_wc`` (K, 4), ``specific_force_covariance`` (K, 3, 3),
    ``attitude_covariance`` (K, 3, 3)."""
    if len(periods) == 0:
        raise ValueError("periods must hold at least one StaticPeriod")
    return StaticArrays(
        specific_force=np.stack([p.specific_force for p in periods]),
        q_wc=np.stack([p.q_wc for p in periods]),
        specific_force_covariance=np.stack([p.specific_force_covariance for p in periods]),
        attitude_covariance=np.stack([p.attitude_covariance for p in periods]),
    )


def _stack_cov(c: np.ndarray | None, name: str, k: int) -> np.ndarray:
    if c is None:
        return np.zeros((k, 3, 3))
    a = np.asarray(c, dtype=np.float64)
    if a.shape == (3, 3):
        a = np.broadcast_to(a, (k, 3, 3))
    if a.shape != (k, 3, 3) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite array of shape ({k}, 3, 3) or (3, 3); got {a.shape}")
    return np.array(a)


def checked_covariance3(c: object, name: str) -> np.ndarray:
    """``c`` as a finite (3, 3) float64 array; ValueError naming ``name`` otherwise."""
    a = np.asarray(c, dtype=np.float64)
    if a.shape != (3, 3) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite array of shape (3, 3); got {a.shape}")
    return a


def checked_static_inputs(
    specific_force: np.ndarray,
    q_wc: np.ndarray,
    specific_force_covariance: np.ndarray | None,
    attitude_covariance: np.ndarray | None,
    minimum: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Validated ``(f (K, 3), q_wc (K, 4) unit, Σ_f (K, 3, 3), Σ_θ (K, 3, 3))``; ``None`` covariances are zeros."""
    f = np.asarray(specific_force, dtype=np.float64)
    if f.ndim == 1:
        f = f[None]
    if f.ndim != 2 or f.shape[1] != 3 or len(f) < minimum:
        raise ValueError(f"specific_force must have shape (K, 3) with K >= {minimum}; got {np.shape(specific_force)}")
    k = len(f)
    q = np.asarray(q_wc, dtype=np.float64)
    if q.ndim == 1:
        q = q[None]
    if q.shape != (k, 4):
        raise ValueError(f"q_wc must have shape ({k}, 4) to match specific_force; got {np.shape(q_wc)}")
    if not (np.isfinite(f).all() and np.isfinite(q).all()):
        raise ValueError("specific_force and q_wc must be finite")
    norm_f = np.linalg.norm(f, axis=1)
    if np.any(norm_f < 1e-6):
        raise ValueError("specific_force must be nonzero (the mean accelerometer reading at rest, m/s²)")
    nq = np.linalg.norm(q, axis=1)
    if np.any(nq < 1e-12):
        raise ValueError("q_wc must hold nonzero quaternions")
    cf = _stack_cov(specific_force_covariance, "specific_force_covariance", k)
    ca = _stack_cov(attitude_covariance, "attitude_covariance", k)
    return f, q / nq[:, None], cf, ca
