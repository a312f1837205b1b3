"""Camera–IMU time offset from gyro rates vs rotation rates of per-frame vision poses, refined in the filter.

Clock convention (the simulator's, Kalibr's ``timeshift_cam_imu`` and ``ErrorStateEKF.camera_time_offset``):
``t_imu = t_cam + offset``.  A frame stamped ``t_cam`` by the camera was taken at IMU time ``t_cam + offset``;
a positive offset means the camera stamps are *early* (too small) by ``offset`` seconds.

Stage 1 (:func:`estimate_time_offset`): consecutive camera poses ``q_wc`` (4,) xyzw give the mean camera-frame
angular rate over each frame interval, ``ω̄_c,k = Log(R_wc,kᵀ R_wc,k+1) / (t_k+1 − t_k)``.  The gyro (body frame,
rad/s, linear between samples) is integrated exactly over the shifted interval ``[t_k + d, t_k+1 + d]`` and rotated
into the camera frame with the extrinsic (``ω_c = R_bcᵀ ω_b``).  The cost

    C(d) = min_b Σ_k ‖ω̄_c,k − R_bcᵀ (ω̄_gyro,k(d) − b)‖²

(the gyro bias ``b`` is solved in closed form for every ``d``) is evaluated on a grid (the coarse
cross-correlation), the best grid point is refined with a parabola through its neighbours and then by a bounded
1-D minimisation of the continuous ``C(d)``.  Without an extrinsic, ``R_bc`` is estimated with the offset
(the rate vectors are registered for every candidate: ``ω̄_c = R_cb ω̄_gyro − R_cb b``).

Stage 2 (:func:`refine_time_offset_in_filter`): the error-state filter is re-run with ``camera_time_offset = d``
and the mean gated NIS of the camera correspondences is minimised over ``d`` in a small bracket around the
stage-1 estimate (bounded Brent search).  Only the filter's public API is used.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar

import dualpose as dp

__all__ = [
    "TimeOffsetEstimate",
    "FilterTimeOffsetEstimate",
    "vision_rotation_rates",
    "gyro_mean_rates",
    "estimate_time_offset",
    "refine_time_offset_in_filter",
    "frame_poses",
]


@dataclass
class TimeOffsetEstimate:
    """Stage-1 result.

    Attributes
    ----------
    offset : float
        ``t_imu = t_cam + offset``, seconds.
    sigma : float
        First-order standard deviation of ``offset`` (s) from the Gauss–Newton curvature and the residual scatter.
    coarse_offset : float
        Best grid point (s) before the sub-sample refinement.
    gyro_bias : ndarray (3,)
        Gyro bias (body frame, rad/s) solved with the offset.
    q_bc : ndarray (4,)
        Camera→body rotation used (the given one) or estimated from the rates (registration mode), xyzw.
    rms_residual : float
        RMS rate residual at the optimum, rad/s.
    grid, cost : ndarray (G,)
        Candidate offsets (s) and ``C(d)`` on them (the coarse correlation curve).
    n_intervals : int
        Frame intervals used.
    mode : str
        ``"extrinsic"`` (``q_bc`` given) or ``"registration"`` (rotation estimated with the offset).
    """

    offset: float
    sigma: float
    coarse_offset: float
    gyro_bias: np.ndarray
    rms_residual: float
    grid: np.ndarray
    cost: np.ndarray
    n_intervals: int
    q_bc: np.ndarray
    mode: str


@dataclass
class FilterTimeOffsetEstimate:
    """Stage-2 result: ``offset`` (s) minimising ``mean_nis`` (the filter's mean gated camera NIS, 2 dof) within
    ``bounds``; ``evaluations`` the offsets tried and ``scores`` their mean NIS."""

    offset: float
    mean_nis: float
    bounds: tuple[float, float]
    evaluations: np.ndarray
    scores: np.ndarray


def _as_n3(x: np.ndarray, name: str, n: int | None = None) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3 or (n is not None and a.shape[0] != n):
        want = "(N, 3)" if n is None else f"({n}, 3)"
        raise ValueError(f"{name} must have shape {want}; got {a.shape}")
    return a


def _as_times(t: np.ndarray, name: str, minimum: int) -> np.ndarray:
    a = np.asarray(t, dtype=np.float64)
    if a.ndim != 1 or len(a) < minimum:
        raise ValueError(f"{name} must have shape (N,) with N >= {minimum}; got {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
        raise ValueError(f"{name} must be finite and strictly increasing")
    return a


def frame_poses(
    frame_t: np.ndarray,
    offsets: np.ndarray,
    pixels: np.ndarray,
    points: np.ndarray,
    K: np.ndarray,
    pixel_sigma: float = 1.0,
    min_points: int = 6,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame camera orientations from robust PnP (:func:`dualpose.registration.pnp.solve_pnp_ransac`).

    ``offsets`` (F + 1,) int: frame k owns rows ``offsets[k]:offsets[k+1]`` of ``pixels`` (M, 2) and ``points``
    (M, 3) (the layout of :class:`dualpose.sim.CameraFrames`).  Returns ``q_wc`` (F, 4) xyzw and the
    camera-frame attitude covariance (F, 3, 3) rad² of each (NaN rows where PnP is impossible).
    """
    from dualpose.registration.pnp import solve_pnp_ransac

    offsets = np.asarray(offsets, dtype=np.int64)
    n = len(np.asarray(frame_t))
    if offsets.shape != (n + 1,):
        raise ValueError(f"offsets must have shape ({n + 1},) (one more than frame_t); got {offsets.shape}")
    q = np.full((n, 4), np.nan)
    cov = np.full((n, 3, 3), np.nan)
    for k in range(n):  # one PnP per frame: the per-frame solve is the unit of work
        a, b = offsets[k], offsets[k + 1]
        if b - a < min_points:
            continue
        try:
            res, _ = solve_pnp_ransac(pixels[a:b], points[a:b], K, pixel_sigma=pixel_sigma)
        except (ValueError, np.linalg.LinAlgError):
            continue
        q[k] = res.q_wc
        cov[k] = res.covariance[:3, :3]
    return q, cov


def _rates_with_frames(
    frame_t: np.ndarray, q_wc: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    t = _as_times(frame_t, "frame_t", 2)
    q = np.asarray(q_wc, dtype=np.float64)
    if q.shape != (len(t), 4):
        raise ValueError(f"q_wc must have shape ({len(t)}, 4); got {q.shape}")
    ok = np.all(np.isfinite(q), axis=1)
    k = np.flatnonzero(ok[:-1] & ok[1:])
    rel = dp.quat_mul(dp.quat_conj(q[k]), q[k + 1])
    return t[k], t[k + 1], dp.rotvec_from_quat(rel) / (t[k + 1] - t[k])[:, None], k, rel


def vision_rotation_rates(frame_t: np.ndarray, q_wc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean camera-frame angular rate over each pair of consecutive frames.

    Parameters
    ----------
    frame_t : (F,) camera stamps, s.  q_wc : (F, 4) camera→world orientations xyzw (NaN rows are skipped).

    Returns
    -------
    t0, t1 : (P,) interval ends (camera clock), omega_c : (P, 3) ``Log(R_wc,kᵀ R_wc,k+1) / Δt`` rad/s.
    """
    return _rates_with_frames(frame_t, q_wc)[:3]


def _offset_sigma(r: np.ndarray, dr: np.ndarray, k: np.ndarray, dt: np.ndarray, n_params: int) -> float:
    """First-order σ of the offset from the residual scatter (no attitude covariances given).

    ``r_k = (n_k+1 − n_k) / Δt_k`` with i.i.d. isotropic attitude errors ``n`` (σ_θ per axis), so neighbouring
    residuals are anti-correlated; the offset error ``δd = −Σ dr·r / Σ dr²`` then has variance
    ``σ_θ² ‖Dᵀ dr‖² / (Σ dr²)²`` (``D`` the differencing operator), and σ_θ² is estimated from the residuals.
    PnP attitude noise is anisotropic (rotation about the optical axis is much better determined), so this is
    only indicative; give the covariances for the weighted estimator and its model-based σ.
    """
    w = 1.0 / dt[:, None]
    s2_theta = float(np.sum(r**2)) / max(float(np.sum(2.0 * w**2)) * r.shape[1] - n_params, 1.0)
    back = np.zeros((int(k.max()) + 2, r.shape[1]))
    np.add.at(back, k + 1, dr * w)
    np.add.at(back, k, -dr * w)
    curv = float(np.sum(dr**2))
    return float(np.sqrt(s2_theta * float(np.sum(back**2)) / max(curv, 1e-300) ** 2))


def _offset_sigma_weighted(
    dr: np.ndarray,
    W: np.ndarray,
    k: np.ndarray,
    dt: np.ndarray,
    R_rel: np.ndarray,
    cov: np.ndarray,
    c_gyro: np.ndarray,
) -> float:
    """First-order σ of the weighted estimate: ``δd = −Σ drᵀ W r / Σ drᵀ W dr`` with
    ``r_k = (n_k+1 − R_rel,kᵀ n_k) / Δt_k + e_k``, ``Cov(n_j) = cov[j]`` (every frame's error enters two
    intervals) and independent gyro-mean noise ``Cov(e_k) = c_gyro[k]``."""
    wd = np.einsum("kij,kj->ki", W, dr) / dt[:, None]  # W_k dr_k / Δt_k
    g = np.zeros((len(cov), 3))
    np.add.at(g, k + 1, wd)
    np.add.at(g, k, -np.einsum("kij,kj->ki", R_rel, wd))
    used = np.zeros(len(cov), bool)
    used[k] = used[k + 1] = True
    var = float(np.einsum("ji,jil,jl->", g[used], cov[used], g[used]))
    wdr = wd * dt[:, None]
    var += float(np.einsum("ki,kij,kj->", wdr, c_gyro, wdr))
    curv = float(np.einsum("ki,kij,kj->", dr, W, dr))
    return float(np.sqrt(var) / max(curv, 1e-300))


def _gyro_integral(t: np.ndarray, gyro: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cumulative integral of the piecewise-linear gyro signal at the sample times, and the slopes."""
    h = np.diff(t)
    cum = np.zeros_like(gyro)
    cum[1:] = np.cumsum(0.5 * (gyro[1:] + gyro[:-1]) * h[:, None], axis=0)
    slope: NDArray[np.float64] = np.diff(gyro, axis=0) / h[:, None]
    return cum, slope


def _integral_at(t: np.ndarray, gyro: np.ndarray, cum: np.ndarray, slope: np.ndarray, x: np.ndarray) -> np.ndarray:
    i = np.clip(np.searchsorted(t, x, side="right") - 1, 0, len(t) - 2)
    tau = x - t[i]
    out: NDArray[np.float64] = cum[i] + gyro[i] * tau[:, None] + 0.5 * slope[i] * tau[:, None] ** 2
    return out


def gyro_mean_rates(t: np.ndarray, gyro: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Exact mean ``(1/(b−a)) ∫_a^b ω dt`` (P, 3) of the gyro taken as linear between its samples.

    ``t`` (N,) IMU times, ``gyro`` (N, 3) rad/s, interval ends ``a``, ``b`` (P,) inside ``[t[0], t[-1]]``.
    """
    t = _as_times(t, "t", 2)
    gyro = _as_n3(gyro, "gyro", len(t))
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    cum, slope = _gyro_integral(t, gyro)
    ia = _integral_at(t, gyro, cum, slope, a)
    ib = _integral_at(t, gyro, cum, slope, b)
    rates: NDArray[np.float64] = (ib - ia) / (b - a)[:, None]
    return rates


class _RateCost:
    """``C(d)`` of the module docstring for fixed data (given rotation, or registered per candidate)."""

    def __init__(self, t: NDArray[np.float64], gyro: NDArray[np.float64], t0: NDArray[np.float64],
                 t1: NDArray[np.float64], omega_c: NDArray[np.float64], R_cb: NDArray[np.float64] | None,
                 W: NDArray[np.float64] | None) -> None:  # fmt: skip
        self.t, self.gyro = t, gyro
        self.cum, self.slope = _gyro_integral(t, gyro)
        self.t0, self.t1, self.omega_c, self.R_cb, self.W = t0, t1, omega_c, R_cb, W

    def valid(self, d: float) -> NDArray[np.bool_]:
        ok: NDArray[np.bool_] = (self.t0 + d >= self.t[0]) & (self.t1 + d <= self.t[-1])
        return ok

    def residuals(self, d: float, keep: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centred rate residuals (P, 3), the gyro bias (3,) body frame and ``R_cb`` (3, 3) at offset ``d``."""
        a, b = self.t0[keep] + d, self.t1[keep] + d
        ia = _integral_at(self.t, self.gyro, self.cum, self.slope, a)
        ib = _integral_at(self.t, self.gyro, self.cum, self.slope, b)
        g = (ib - ia) / (b - a)[:, None]
        R_cb = self.R_cb
        if R_cb is None:  # ω_c = R_cb ω_gyro + t (t = −R_cb b): a point registration of the rate vectors
            from dualpose.registration import register_pose

            R_cb = register_pose(np.ascontiguousarray(g), np.ascontiguousarray(self.omega_c[keep])).rotation_matrix
        r = g @ R_cb.T - self.omega_c[keep]
        if self.W is None:
            bias_c = r.mean(axis=0)
        else:  # weighted mean
            W = self.W[keep]
            bias_c = np.linalg.solve(W.sum(axis=0), np.einsum("kij,kj->i", W, r))
        return r - bias_c, R_cb.T @ bias_c, R_cb

    def __call__(self, d: float, keep: np.ndarray) -> float:
        r = self.residuals(d, keep)[0]
        if self.W is None:
            return float(np.sum(r**2))
        return float(np.einsum("ki,kij,kj->", r, self.W[keep], r))


def estimate_time_offset(
    t: np.ndarray,
    gyro: np.ndarray,
    frame_t: np.ndarray,
    q_wc: np.ndarray,
    q_bc: np.ndarray | None = None,
    attitude_covariance: np.ndarray | None = None,
    gyroscope_noise_density: float = 0.0,
    max_offset: float = 0.1,
    grid_step: float | None = None,
    gauss_newton_iterations: int = 10,
    weighted: bool = False,
) -> TimeOffsetEstimate:
    """Camera–IMU time offset ``t_imu = t_cam + offset`` from gyro rates and vision rotation rates (stage 1).

    Parameters
    ----------
    t : (N,) IMU times, s.  gyro : (N, 3) body-frame rates, rad/s.
    frame_t : (F,) camera stamps (camera clock), s.  q_wc : (F, 4) per-frame camera orientation xyzw (e.g. from
        :func:`frame_poses`; NaN rows are skipped).
    q_bc : (4,) xyzw, optional
        Camera→body rotation (camera axes in the body frame), used to rotate the gyro rates into the camera frame.
        Without it the rotation is estimated for every candidate offset by registering the rate vectors
        (:func:`dualpose.registration.register_pose`, points = rates, translation = bias), at some cost in
        precision.
    attitude_covariance : (F, 3, 3), optional
        Camera-frame attitude covariance of each ``q_wc`` (rad², from :func:`frame_poses`).  With it ``sigma`` is
        the model-based first-order σ (sandwich over the interval covariances ``(Σ_k+1 + R_relᵀ Σ_k R_rel) / Δt²``
        plus gyro noise); without it ``sigma`` comes from the residual scatter (isotropic-noise approximation,
        optimistic by ~1.2× on the eight because PnP attitude noise is strongly anisotropic).
    gyroscope_noise_density : float
        rad/s/√Hz; with ``attitude_covariance``, the white gyro noise of each interval mean (``σ_g² / Δt`` per
        axis) is added to the interval covariance.
    max_offset : float
        Search ``|offset| <= max_offset`` s.
    grid_step : float, optional
        Coarse grid spacing, s (default: the IMU sample period).
    gauss_newton_iterations : int
        Final Gauss–Newton steps with the slope averaged over ±¼ frame interval (0: stop at the Brent minimum).
    weighted : bool
        With ``attitude_covariance``, weight each interval by the inverse of its covariance.  Off by default: on
        the simulated eight it did not reduce the error (4.2 vs 3.4 ms RMS over 60 runs) — the first-order PnP
        covariances of frames with few points are not trusted enough to be used as weights.

    Raises
    ------
    ValueError
        Bad shapes, or fewer than 8 usable frame intervals, or no rotation (the cost is flat).
    """
    t = _as_times(t, "t", 3)
    gyro = _as_n3(gyro, "gyro", len(t))
    t0, t1, omega_c, frame_index, rel = _rates_with_frames(frame_t, q_wc)
    if len(t0) < 8:
        raise ValueError(f"need at least 8 consecutive pairs of valid frame poses; got {len(t0)}")
    W: NDArray[np.float64] | None = None
    cov: NDArray[np.float64] | None = None
    R_rel: NDArray[np.float64] | None = None
    c_gyro: NDArray[np.float64] | None = None
    if attitude_covariance is not None:
        cov = np.asarray(attitude_covariance, dtype=np.float64)
        if cov.shape != (len(frame_t), 3, 3):
            raise ValueError(f"attitude_covariance must have shape ({len(frame_t)}, 3, 3); got {cov.shape}")
        R_rel = dp.matrix_from_quat(rel)
        c_int = cov[frame_index + 1] + np.einsum("kji,kjl,klm->kim", R_rel, cov[frame_index], R_rel)
        c_int /= ((t1 - t0) ** 2)[:, None, None]
        c_gyro = np.eye(3) * gyroscope_noise_density**2 / (t1 - t0)[:, None, None]
        c_int += c_gyro
        if not np.isfinite(c_int).all():
            raise ValueError("attitude_covariance must be finite wherever q_wc is")
        W = np.linalg.inv(c_int) if weighted else np.broadcast_to(np.eye(3), c_int.shape).copy()
    R_cb = None
    if q_bc is not None:
        q_bc = np.asarray(q_bc, dtype=np.float64)
        if q_bc.shape != (4,):
            raise ValueError(f"q_bc must have shape (4,); got {q_bc.shape}")
        R_cb = dp.matrix_from_quat(q_bc).T
    if not max_offset > 0:
        raise ValueError(f"max_offset must be > 0; got {max_offset}")
    step = float(np.median(np.diff(t))) if grid_step is None else float(grid_step)
    cost = _RateCost(t, gyro, t0, t1, omega_c, R_cb, W)
    h = 0.25 * float(np.median(t1 - t0))  # half-width of the smoothed slope below
    keep = cost.valid(-max_offset - h) & cost.valid(max_offset + h)  # the same intervals for every candidate
    if keep.sum() < 8:
        raise ValueError(f"only {int(keep.sum())} frame intervals lie inside the IMU record for |offset| <= "
                         f"{max_offset} s; need 8")  # fmt: skip
    grid = np.arange(-max_offset, max_offset + 0.5 * step, step)
    values = np.array([cost(d, keep) for d in grid])
    if np.ptp(values) <= 1e-12 * max(values.max(), 1e-300):
        raise ValueError("the rate-matching cost is flat: the recording has no rotation to correlate")
    j = int(np.argmin(values))
    coarse = float(grid[j])
    d0 = coarse
    if 0 < j < len(grid) - 1:  # parabola through the best grid point and its neighbours
        cm, c0, cp = values[j - 1], values[j], values[j + 1]
        den = cm - 2 * c0 + cp
        if den > 0:
            d0 = coarse + 0.5 * step * (cm - cp) / den
    lo, hi = max(d0 - step, -max_offset), min(d0 + step, max_offset)
    res = minimize_scalar(lambda d: cost(d, keep), bounds=(lo, hi), method="bounded", options={"xatol": 1e-6})
    d = float(res.x)
    # Gauss–Newton with a smoothed slope: ∂r/∂d by a central difference over ±¼ frame interval.  The exact slope
    # (ω(b + d) − ω(a + d)) / (b − a) depends on single gyro samples, so the cost is rough at the sample scale and
    # its minimiser jitters; the estimating equation Σ drᵀ W r = 0 with the averaged slope does not.
    wk = np.broadcast_to(np.eye(3), (int(keep.sum()), 3, 3)) if W is None else W[keep]
    for _ in range(gauss_newton_iterations):
        r = cost.residuals(d, keep)[0]
        dr = (cost.residuals(d + h, keep)[0] - cost.residuals(d - h, keep)[0]) / (2 * h)
        delta = -float(np.einsum("ki,kij,kj->", dr, wk, r)) / float(np.einsum("ki,kij,kj->", dr, wk, dr))
        d = float(np.clip(d + delta, -max_offset, max_offset))
        if abs(delta) < 1e-7:
            break
    r, bias, R_cb_used = cost.residuals(d, keep)
    dr = (cost.residuals(d + h, keep)[0] - cost.residuals(d - h, keep)[0]) / (2 * h)
    if W is None:
        sigma = _offset_sigma(r, dr, frame_index[keep], (t1 - t0)[keep], 4 if R_cb is not None else 7)
    else:
        assert cov is not None and R_rel is not None and c_gyro is not None  # set together with W above
        sigma = _offset_sigma_weighted(dr, W[keep], frame_index[keep], (t1 - t0)[keep], R_rel[keep], cov, c_gyro[keep])
    return TimeOffsetEstimate(
        offset=d, sigma=sigma, coarse_offset=coarse, gyro_bias=bias, rms_residual=float(np.sqrt(np.mean(r**2))),
        grid=grid, cost=values, n_intervals=int(keep.sum()), q_bc=dp.quat_from_matrix(R_cb_used.T),
        mode="extrinsic" if R_cb is not None else "registration",
    )  # fmt: skip


class _FilterInnovations(Protocol):
    @property
    def nis(self) -> NDArray[np.float64]: ...
    @property
    def gate(self) -> float: ...


class _FilterRun(Protocol):
    @property
    def innovation(self) -> _FilterInnovations: ...


class _OffsetFilter(Protocol):
    """What :func:`refine_time_offset_in_filter` needs of a filter (:class:`~dualpose.estimation.eskf.ErrorStateEKF`
    is one): a settable ``camera_time_offset`` and ``run`` over a recording."""

    camera_time_offset: float

    def run(self, t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, frame_t: np.ndarray, offsets: np.ndarray,
            pixels: np.ndarray, points: np.ndarray) -> _FilterRun: ...  # fmt: skip


def refine_time_offset_in_filter(
    make_filter: Callable[[], _OffsetFilter],
    t: np.ndarray,
    gyro: np.ndarray,
    accel: np.ndarray,
    frame_t: np.ndarray,
    offsets: np.ndarray,
    pixels: np.ndarray,
    points: np.ndarray,
    initial_offset: float,
    half_width: float = 0.006,
    xatol: float = 1e-4,
) -> FilterTimeOffsetEstimate:
    """Refine the offset by minimising the error-state filter's mean gated camera NIS (stage 2).

    For each candidate ``d`` a fresh filter ``make_filter()`` (an :class:`~dualpose.estimation.eskf.ErrorStateEKF`
    already at its initial state) gets ``camera_time_offset = d`` and filters the recording with ``run``; the score
    is ``mean(min(NIS_i, gate))`` over every correspondence (2 dof; rejected correspondences count as the gate, so
    the score is continuous in ``d`` as gating decisions flip).  A bounded Brent search over
    ``[initial_offset ± half_width]`` returns the minimiser.

    Parameters
    ----------
    make_filter : callable () -> ErrorStateEKF
    t, gyro, accel, frame_t, offsets, pixels, points
        As for ``ErrorStateEKF.run`` (IMU times (N,), rates (N, 3) rad/s, specific force (N, 3) m/s², camera stamps
        (F,), frame offsets (F + 1,), pixels (M, 2), world points (M, 3)).
    initial_offset : float
        Stage-1 estimate, s.  half_width : float, s.  xatol : float, s (Brent's absolute tolerance).
    """
    if not half_width > 0:
        raise ValueError(f"half_width must be > 0; got {half_width}")
    tried: list[float] = []
    scores: list[float] = []

    def score(d: float) -> float:
        filt = make_filter()
        filt.camera_time_offset = float(d)
        res = filt.run(t, gyro, accel, frame_t, offsets, pixels, points)
        nis = np.asarray(res.innovation.nis, dtype=np.float64)
        gate = float(res.innovation.gate)
        val = float(np.mean(np.minimum(np.where(np.isfinite(nis), nis, gate), gate))) if len(nis) else np.inf
        tried.append(float(d))
        scores.append(val)
        return val

    bounds = (float(initial_offset - half_width), float(initial_offset + half_width))
    res = minimize_scalar(score, bounds=bounds, method="bounded", options={"xatol": xatol})
    return FilterTimeOffsetEstimate(
        offset=float(res.x), mean_nis=float(res.fun), bounds=bounds, evaluations=np.array(tried),
        scores=np.array(scores),
    )  # fmt: skip
