"""Hand–eye calibration with time offset from two unsynchronised pose streams.

Pipeline (:func:`calibrate_hand_eye_streams`): (1) coarse ``τ`` from the angular-rate correlation
(:mod:`~dualpose.calibration.hand_eye_time`); (2) motion pairs of camera samples
(:func:`~dualpose.calibration.hand_eye_residual.select_pairs`) with the body interpolated at ``t + τ``; (3) ``X``
from Daniilidis' dual-quaternion solution (Daniilidis, IJRR 1999) inside a least-median-of-squares sampler
(outlier-robust, as ETH's RANSAC stage: Furrer et al., FSR 2017); (4) joint nonlinear least squares of ``X`` and
``τ`` on the rotation and translation loop residuals, each scaled by a robust estimate of its noise, alternated with
χ² outlier rejection until the inlier set settles; (5) on the settled pairs, the five classical closed forms
(:mod:`~dualpose.registration.hand_eye_closed_form`) scored with the reported loop residuals, a grid scan of ``τ``
(the residual has local minima in ``τ`` when the clocks tick at commensurate rates), and a final joint refinement of
``X`` and ``τ`` started from the best closed form that by construction ends no worse than it on either reported
residual.  Uncertainties are first order, ``s² (JᵀJ)⁻¹`` at the solution.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import OptimizeResult, least_squares, minimize

import dualpose as dp
from dualpose.calibration.hand_eye_residual import pair_motions, pair_residuals, select_pairs, squared_pair_residuals
from dualpose.calibration.hand_eye_streams import (
    CleaningReport,
    PoseStream,
    interpolate_stream,
    rotation_noise,
    shift_stamps,
)
from dualpose.calibration.hand_eye_time import coarse_time_offset
from dualpose.registration import HandEyeWarning, calibrate_hand_eye
from dualpose.registration.hand_eye_closed_form import HAND_EYE_CLOSED_FORMS, hand_eye_translation
from dualpose.types import _inputs

__all__ = ["HandEyeStreamResult", "calibrate_hand_eye_streams", "NOT_CREDIBLE_RATIO", "DOUBTFUL_RATIO",
           "DOUBTFUL_CORRELATION"]

#: rotation loop residual RMS over the one the streams' own noise predicts above which the match is refused as not
#: credible, and above which it is doubtful (docs/refusals.md, "The thresholds on real data": true pairs of the shared
#: recordings, whole and in halves and thirds, 0.87-1.76; their windows against another window or another recording,
#: 3.45-55, the lowest a third of one recording against the other recording, which a refusal above 5 let through)
NOT_CREDIBLE_RATIO = 3.0
DOUBTFUL_RATIO = 2.5
#: coarse rate correlation below which the match is doubtful (unrelated recordings: 0.27-0.40; true pairs: 0.92-0.97)
DOUBTFUL_CORRELATION = 0.6

#: a float64 array (the shapes are in the docstrings)
_Arr = NDArray[np.float64]
_CHI2_3_MEDIAN = 2.365974  # median of χ²(3): robust scale of a 3-vector residual
_CHI2_6_999 = 22.457744  # 0.999 quantile of χ²(6): inlier gate of the normalized 6-vector residual
_CHI2_6_9999 = 27.855876  # 0.9999 quantile of χ²(6): gate of the per-pose target consistency
_X_SCALE: NDArray[np.float64] = np.r_[[1e-2] * 6, 1e-3]  # typical sizes of [δθ (rad), t (m), dτ (s)] for the optimisers
_DIFF_STEP = np.array(1e-6)  # relative finite-difference step of least_squares (a 0-d array: scipy's array_like)


def _consistent_poses(camera: PoseStream, body: PoseStream, qx: _Arr, tx: _Arr, tau: float,
                      max_gap: float | None) -> NDArray[np.bool_]:  # fmt: skip
    """Camera samples whose target pose ``Y_k = B(t_k + τ) X A_k⁻¹`` agrees with the others (the target is fixed).

    An outlier detection spoils every pair it is part of, and, being a jump, is often chosen as the partner of the
    samples before it; removing such samples before forming pairs keeps the good pairs.  Samples without a valid body
    pose are kept (the pair stage drops them).
    """
    pb, qb, ok = interpolate_stream(body, camera.stamps + tau, max_gap)
    qy, ty = dp.qt_mul(*dp.qt_mul(qb, pb, qx, tx), *dp.qt_conj(camera.quats, camera.positions))
    keep = np.ones(len(camera), bool)
    if ok.sum() < 10:
        return keep
    use = ok.copy()
    for _ in range(2):
        q0, t0 = dp.quat_mean(qy[use]), np.median(ty[use], axis=0)
        th2 = dp.quat_angle(qy, q0) ** 2
        d2 = np.einsum("ij,ij->i", ty - t0, ty - t0)
        s2r, s2t = _robust_scales(th2[ok], d2[ok])
        use = ok & (th2 / s2r + d2 / s2t <= _CHI2_6_9999)
    keep[ok] = use[ok]
    return keep


@dataclass(frozen=True)
class HandEyeStreamResult:
    """Result of :func:`calibrate_hand_eye_streams`.

    Attributes
    ----------
    quat : ndarray (4,)
        Rotation of ``X`` (camera frame -> body frame), xyzw, ``w >= 0``.
    translation : ndarray (3,)
        Camera origin in the body frame (m).
    dualquat : ndarray (8,), matrix : ndarray (4, 4)
        ``X`` as unit dual quaternion and homogeneous matrix.
    time_offset : float
        ``τ`` (s): camera time ``t`` ↔ body time ``t + τ``.
    coarse_time_offset, coarse_correlation : float
        ``τ`` of the rate correlation and its normalized correlation peak.
    rotation_rmse_deg, translation_rmse_m : float
        RMS loop residuals over the inlier pairs (rotation angle in deg, translation norm in m).
    pairs : ndarray of int, shape (m, 2)
        Camera-sample indices of the inlier pairs (used in the final fit).
    pairs_total : int
        Pairs with valid body poses at ``τ`` before outlier rejection.
    sigma_rotation, sigma_translation : float
        Per-component scales of the residuals (rad, m), the weights of the final cost: the RMS rotation angle and
        translation norm of the best closed form on each, divided by ``√3``.
    start_method : str
        The closed form the final refinement started from (a key of
        :data:`~dualpose.registration.hand_eye_closed_form.HAND_EYE_CLOSED_FORMS`), or ``"joint"`` when none of
        them could be computed.
    start_rotation_rmse_deg, start_translation_rmse_m, start_time_offset : float
        That start's RMS loop residuals on ``pairs`` (deg, m) at its time offset (s, same clock as
        ``time_offset``); by construction ``rotation_rmse_deg <= start_rotation_rmse_deg`` and
        ``translation_rmse_m <= start_translation_rmse_m``.
    covariance : ndarray (7, 7)
        First-order covariance of ``[δθ (rad, left perturbation of the rotation), t (m), τ (s)]``.
    rotation_sigma_deg : ndarray (3,), translation_sigma_m : ndarray (3,), time_offset_sigma : float
        Square roots of its diagonal (deg, m, s).
    expected_rotation_rmse_deg : float
        The rotation loop residual RMS the streams' own orientation noise predicts:
        ``sqrt(6 (σ_camera² + σ_body²))`` (two samples of each stream per pair, three components) with the σ of
        :func:`~dualpose.calibration.hand_eye_streams.rotation_noise` (deg; NaN when a stream is too short).
    residual_to_noise : float
        ``rotation_rmse_deg / expected_rotation_rmse_deg``: about 1 for a true pair; far above for streams whose
        motions do not match (different recordings, a wrong time offset).
    credible : bool
        False when ``residual_to_noise > NOT_CREDIBLE_RATIO``: the streams do not record the same motion.
    credibility : str
        ``"credible"``, ``"doubtful"`` (``residual_to_noise > DOUBTFUL_RATIO`` or a coarse correlation below
        ``DOUBTFUL_CORRELATION``) or ``"not credible"``, with the reason after a colon when not credible.
    camera_report, body_report : CleaningReport or None
        Filled in by callers that cleaned the streams (the CLI).
    """

    quat: np.ndarray
    translation: np.ndarray
    dualquat: np.ndarray
    matrix: np.ndarray
    time_offset: float
    coarse_time_offset: float
    coarse_correlation: float
    rotation_rmse_deg: float
    translation_rmse_m: float
    pairs: np.ndarray
    pairs_total: int
    sigma_rotation: float
    sigma_translation: float
    covariance: np.ndarray
    rotation_sigma_deg: np.ndarray
    translation_sigma_m: np.ndarray
    time_offset_sigma: float
    start_method: str
    start_rotation_rmse_deg: float
    start_translation_rmse_m: float
    start_time_offset: float
    expected_rotation_rmse_deg: float = float("nan")
    residual_to_noise: float = float("nan")
    credible: bool = True
    credibility: str = "credible"
    camera_report: CleaningReport | None = field(default=None)
    body_report: CleaningReport | None = field(default=None)

    def __post_init__(self) -> None:
        """``quat``, ``translation``, ``dualquat`` and ``matrix`` repeat one ``X``: refused when they disagree
        (:func:`~dualpose.types._inputs.check_pose_agrees`)."""
        _inputs.check_pose_agrees(self.quat, self.translation, self.dualquat, self.matrix)

    @property
    def pairs_used(self) -> int:
        return len(self.pairs)


def _lmeds_daniilidis(qa: _Arr, ta: _Arr, qb: _Arr, tb: _Arr, rng: np.random.Generator,
                      iterations: int) -> tuple[_Arr, _Arr]:  # fmt: skip
    """Least-median-of-squares over Daniilidis solutions of random 3-pair samples, then a fit on the inliers."""
    # calibrate_hand_eye solves A X = X B with A the body motions
    a_dq, b_dq = dp.dualquat_from_qt(qb, tb), dp.dualquat_from_qt(qa, ta)
    m = len(qa)
    cands = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HandEyeWarning)
        for _ in range(iterations):
            s = rng.choice(m, 3, replace=False)
            try:
                r = calibrate_hand_eye(a_dq[s], b_dq[s])
            except ValueError:
                continue
            if r.parallel_axes:
                continue
            cands.append((r.quat, r.translation, *squared_pair_residuals(qa, ta, qb, tb, r.quat, r.translation)))
    if not cands:
        raise ValueError("no sample of motion pairs gave a hand-eye solution (rotation axes all parallel?)")
    best = min(cands, key=lambda c: np.median(c[2]))  # rotation first: the translation depends on it
    s2r, s2t = _robust_scales(best[2], best[3])
    best = min(cands, key=lambda c: np.median(c[2] / s2r + c[3] / s2t))
    s2r, s2t = _robust_scales(best[2], best[3])
    inl = best[2] / s2r + best[3] / s2t <= _CHI2_6_999
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HandEyeWarning)
        r = calibrate_hand_eye(a_dq[inl], b_dq[inl])
    return r.quat, r.translation


def _robust_scales(th2: np.ndarray, t2: np.ndarray) -> tuple[float, float]:
    """Per-component variances of the rotation and translation residuals from their median squared norms."""
    return max(float(np.median(th2)) / _CHI2_3_MEDIAN, 1e-20), max(float(np.median(t2)) / _CHI2_3_MEDIAN, 1e-20)


def calibrate_hand_eye_streams(
    camera: PoseStream, body: PoseStream, *, time_offset: float | None = None, fix_time_offset: bool = False,
    min_pair_angle: float = np.deg2rad(10.0), max_pair_dt: float = 2.0, max_gap: float | None = None,
    margin: float = 0.05, iterations: int = 300, seed: int = 0, max_rounds: int = 6, gate: float = _CHI2_6_999,
) -> HandEyeStreamResult:  # fmt: skip
    """Estimate ``X`` (camera pose in the body frame) and the time offset ``τ`` from two pose streams.

    Parameters
    ----------
    camera : PoseStream
        Camera poses in the target frame (cleaned, see :func:`~dualpose.calibration.clean_pose_stream`).
    body : PoseStream
        Body (marker or hand) poses in its reference frame, in its own clock.
    time_offset : float, optional
        Start value of ``τ`` (s); default: the angular-rate correlation.
    fix_time_offset : bool
        Keep ``τ = time_offset`` (requires ``time_offset``).
    min_pair_angle, max_pair_dt : float
        Pair selection (rad, s), see :func:`~dualpose.calibration.hand_eye_residual.select_pairs`.
    max_gap : float, optional
        Longest body-stream gap bridged by interpolation (s); default 5 median sampling intervals.
    margin : float
        A pair is used only if its body poses stay valid for ``τ ± margin`` (s), so that the pair set does not
        change during the refinement.
    iterations : int
        Random 3-pair samples of the robust initial solution.
    seed : int
        Seed of the sampler.
    max_rounds : int
        Most refinement / outlier-rejection rounds.

    Raises
    ------
    ValueError
        No overlap of the streams after ``τ``, fewer than 3 usable pairs, or degenerate motion.

    Warns
    -----
    HandEyeWarning
        When the match is doubtful or not credible (``credibility``): the rotation loop residual far above the one
        the streams' own noise predicts, or a weak coarse rate correlation.
    """
    if fix_time_offset and time_offset is None:
        raise ValueError("fix_time_offset needs a time_offset")
    coarse_corr = float("nan")
    if time_offset is None:
        coarse = coarse_time_offset(camera, body, max_gap_body=max_gap)
        tau0, coarse_corr = coarse.offset, coarse.correlation
    else:
        tau0 = float(time_offset)
    lo, hi = max(camera.stamps[0] + tau0, body.stamps[0]), min(camera.stamps[-1] + tau0, body.stamps[-1])
    if lo >= hi:
        raise ValueError(f"no overlap in time after the time offset τ = {tau0:.6f} s: camera spans "
                         f"[{camera.stamps[0]:.3f}, {camera.stamps[-1]:.3f}] s + τ, body spans "
                         f"[{body.stamps[0]:.3f}, {body.stamps[-1]:.3f}] s")  # fmt: skip
    i_all, j_all = select_pairs(camera, min_angle=min_pair_angle, max_dt=max_pair_dt)
    # work with stamps near zero: τ = τ' + shift with camera' = camera − c0, body' = body − b0
    shift = float(body.stamps[0] - camera.stamps[0])
    camera, body = shift_stamps(camera, camera.stamps[0]), shift_stamps(body, body.stamps[0])
    tau0 -= shift

    def usable(tau: float) -> np.ndarray:
        ok = pair_motions(camera, body, i_all, j_all, tau, max_gap)[4]
        for d in (-margin, margin):
            ok &= pair_motions(camera, body, i_all, j_all, tau + d, max_gap)[4]
        return ok

    ok = usable(tau0)
    if ok.sum() < 3:
        raise ValueError(f"only {int(ok.sum())} motion pair(s) with body poses at camera time + τ (τ = {tau0:.6f} s);"
                         " need at least 3 (too little overlap, or too little rotation)")  # fmt: skip
    qa, ta, qb, tb, _ = pair_motions(camera, body, i_all[ok], j_all[ok], tau0, max_gap)
    qx, tx = _lmeds_daniilidis(qa, ta, qb, tb, np.random.default_rng(seed), iterations)
    # drop inconsistent camera samples, then form the pairs again from the rest (indices kept in the input's terms)
    kept = np.flatnonzero(_consistent_poses(camera, body, qx, tx, tau0, max_gap))
    camera = PoseStream(camera.stamps[kept], camera.positions[kept], camera.quats[kept], camera.name)
    i_all, j_all = select_pairs(camera, min_angle=min_pair_angle, max_dt=max_pair_dt)
    tau = tau0
    inliers = None
    for _ in range(max_rounds):
        ok = usable(tau)
        qa, ta, qb, tb, _ = pair_motions(camera, body, i_all[ok], j_all[ok], tau, max_gap)
        th2, t2 = squared_pair_residuals(qa, ta, qb, tb, qx, tx)
        s2r, s2t = _robust_scales(th2, t2)
        new = np.flatnonzero(ok)[th2 / s2r + t2 / s2t <= gate]
        if inliers is not None and np.array_equal(new, inliers):
            break
        inliers = new
        if len(inliers) < 3:
            raise ValueError(f"only {len(inliers)} consistent motion pair(s); need at least 3")
        qx, tx, tau = _joint_fit(camera, body, i_all[inliers], j_all[inliers], qx, tx, tau, np.sqrt(s2r),
                                 np.sqrt(s2t), fix_time_offset, max_gap)  # fmt: skip
    i, j = i_all[inliers], j_all[inliers]
    half_width = min(max(0.02, float(np.median(np.diff(body.stamps)))), margin)
    qx, tx, tau, sol, sr, st, (start, ms0, tau_start), (ms_r, ms_t) = _refine_from_closed_form(
        camera, body, i, j, qx, tx, tau, fix_time_offset, max_gap, half_width
    )
    noise = np.hypot(rotation_noise(camera), rotation_noise(body, max_gap))
    expected_deg = float(np.degrees(np.sqrt(6.0) * noise))
    rmse_deg = float(np.degrees(np.sqrt(ms_r)))
    credible, credibility = _credibility(rmse_deg, expected_deg, coarse_corr)
    cov = _covariance(sol, fix_time_offset)
    sd = np.sqrt(np.diag(cov))
    x = dp.dualquat_canonical(dp.dualquat_from_qt(qx, tx))
    pairs_total = int(usable(tau).sum())
    tau = float(time_offset) if fix_time_offset and time_offset is not None else tau + shift
    tau0 += shift
    return HandEyeStreamResult(
        quat=qx, translation=tx, dualquat=x, matrix=dp.matrix_from_dualquat(x), time_offset=float(tau),
        coarse_time_offset=float(tau0), coarse_correlation=coarse_corr,
        rotation_rmse_deg=float(np.degrees(np.sqrt(ms_r))), translation_rmse_m=float(np.sqrt(ms_t)),
        pairs=np.column_stack([kept[i], kept[j]]), pairs_total=pairs_total, sigma_rotation=sr, sigma_translation=st,
        covariance=cov, rotation_sigma_deg=np.degrees(sd[:3]), translation_sigma_m=sd[3:6],
        time_offset_sigma=float(sd[6]), start_method=start, start_rotation_rmse_deg=float(np.degrees(np.sqrt(ms0[0]))),
        start_translation_rmse_m=float(np.sqrt(ms0[1])),
        start_time_offset=float(time_offset) if fix_time_offset and time_offset is not None else tau_start + shift,
        expected_rotation_rmse_deg=expected_deg, residual_to_noise=rmse_deg / expected_deg if expected_deg > 0 else
        float("nan"), credible=credible, credibility=credibility,
    )  # fmt: skip


def _credibility(rmse_deg: float, expected_deg: float, correlation: float) -> tuple[bool, str]:
    """``(credible, credibility)`` of a hand–eye match (see :class:`HandEyeStreamResult`); warns unless credible."""
    ratio = rmse_deg / expected_deg if expected_deg > 0 else float("nan")
    text = (f"rotation loop residual {rmse_deg:.3g} deg is {ratio:.3g} x the {expected_deg:.3g} deg the streams' "
            "own noise predicts")  # fmt: skip
    corr = "" if np.isnan(correlation) else f", coarse rate correlation {correlation:.2f}"
    if ratio > NOT_CREDIBLE_RATIO:
        verdict = (False, f"not credible: {text}{corr}; the two streams do not record the same motion (different "
                   "recordings, or a wrong time offset)")  # fmt: skip
    elif ratio > DOUBTFUL_RATIO or correlation < DOUBTFUL_CORRELATION:
        verdict = (True, f"doubtful: {text}{corr}")
    else:
        return True, "credible"
    warnings.warn(f"hand-eye match {verdict[1]}", HandEyeWarning, stacklevel=3)
    return verdict


#: a residual vector as a function of the parameters ``z = [δθ, t, dτ]``
_Residuals = Callable[[_Arr], _Arr]


def _pair_residual_fun(camera: PoseStream, body: PoseStream, i: NDArray[np.intp], j: NDArray[np.intp], qx0: _Arr,
                       tau0: float, sr: float, st: float, fix_tau: bool, max_gap: float | None) -> _Residuals:
    """Residual vector ``[θ_ij/σ_r, t_ij/σ_t]`` (flattened) of the pairs as a function of ``z = [δθ, t, dτ]``."""
    qa, ta, _, _, _ = pair_motions(camera, body, i, j, tau0, max_gap)

    def fun(z: np.ndarray) -> np.ndarray:
        q = dp.quat_mul(dp.quat_from_rotvec(z[:3]), qx0)
        tau = tau0 + (0.0 if fix_tau else z[6])
        _, _, qb, tb, _ = pair_motions(camera, body, i, j, tau, max_gap)
        rv, te = pair_residuals(qa, ta, qb, tb, q, z[3:6])
        r: _Arr = np.hstack([rv / sr, te / st]).ravel()
        return r

    return fun


def _joint_fit(camera: PoseStream, body: PoseStream, i: NDArray[np.intp], j: NDArray[np.intp], qx0: _Arr, tx0: _Arr,
               tau0: float, sr: float, st: float, fix_tau: bool,
               max_gap: float | None) -> tuple[_Arr, _Arr, float]:  # fmt: skip
    """Least squares of ``[δθ, t, dτ]`` on the normalized residuals ``[θ_ij/σ_r, t_ij/σ_t]`` of the pairs."""
    fun = _pair_residual_fun(camera, body, i, j, qx0, tau0, sr, st, fix_tau, max_gap)
    sol = least_squares(fun, np.r_[0.0, 0.0, 0.0, tx0, 0.0], method="trf", x_scale=_X_SCALE, diff_step=_DIFF_STEP,
                        xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=100)  # fmt: skip
    q = dp.quat_canonical(dp.quat_mul(dp.quat_from_rotvec(sol.x[:3]), qx0))
    return q, np.array(sol.x[3:6]), tau0 + (0.0 if fix_tau else float(sol.x[6]))


def _closed_form_start(camera: PoseStream, body: PoseStream, i: NDArray[np.intp], j: NDArray[np.intp],
                       qx_joint: _Arr, tx_joint: _Arr, tau: float,
                       max_gap: float | None) -> tuple[str, _Arr, _Arr, float, float]:  # fmt: skip
    """The five closed forms on the pairs at ``τ`` scored with the reported residuals: ``(name, q, t, σ_r, σ_t)``.

    Each translation is re-solved by least squares for its rotation (the optimum of the translation residual for that
    rotation).  ``σ = RMS / √3`` per component from the best RMS of each residual over the closed forms; the start is
    the closed form whose worse residual is nearest its best: least ``max(RMS_r/best_r, RMS_t/best_t)``.
    """
    qa, ta, qb, tb, _ = pair_motions(camera, body, i, j, tau, max_gap)
    a_dq, b_dq = dp.dualquat_from_qt(qb, tb), dp.dualquat_from_qt(qa, ta)  # A X = X B with A the body motions
    cands: dict[str, tuple[_Arr, _Arr]] = {}
    for name, solve in HAND_EYE_CLOSED_FORMS.items():
        try:
            q, _ = solve(a_dq, b_dq)
        except (ValueError, np.linalg.LinAlgError):
            continue
        cands[name] = (q, hand_eye_translation(a_dq, b_dq, q))
    if not cands:
        cands["joint"] = (qx_joint, tx_joint)
    ms = {k: [float(np.mean(v)) for v in squared_pair_residuals(qa, ta, qb, tb, *c)] for k, c in cands.items()}
    sr = max(float(np.sqrt(min(m[0] for m in ms.values()) / 3.0)), 1e-12)
    st = max(float(np.sqrt(min(m[1] for m in ms.values()) / 3.0)), 1e-12)
    start = min(ms, key=lambda k: (max(ms[k][0] / sr**2, ms[k][1] / st**2), ms[k][0] / sr**2 + ms[k][1] / st**2))
    return start, *cands[start], sr, st


def _scan_time_offset(camera: PoseStream, body: PoseStream, i: NDArray[np.intp], j: NDArray[np.intp], qx: _Arr,
                      tx: _Arr, tau0: float, sr: float, st: float, half_width: float,
                      max_gap: float | None) -> float:  # fmt: skip
    """``τ`` of least cost on a grid ``τ₀ ± half_width`` at fixed ``X`` (0.25 ms steps).

    With linear/SLERP interpolation of the body the cost is piecewise smooth in ``τ``, with a kink whenever a camera
    stamp + ``τ`` crosses a body sample; when the two clocks tick at commensurate rates the kinks line up and the
    cost has local minima one body interval apart, which a local refinement cannot leave.
    """
    qa, ta, _, _, _ = pair_motions(camera, body, i, j, tau0, max_gap)
    grid = tau0 + np.arange(-half_width, half_width + 1e-9, 2.5e-4)
    cost = np.full(len(grid), np.inf)
    for k, tau in enumerate(grid):
        _, _, qb, tb, ok = pair_motions(camera, body, i, j, tau, max_gap)
        if ok.all():
            th2, t2 = squared_pair_residuals(qa, ta, qb, tb, qx, tx)
            cost[k] = float(np.mean(th2 / sr**2 + t2 / st**2))
    return float(grid[int(np.argmin(cost))]) if np.isfinite(cost).any() else tau0


def _refine_from_closed_form(
    camera: PoseStream, body: PoseStream, i: NDArray[np.intp], j: NDArray[np.intp], qx_joint: _Arr, tx_joint: _Arr,
    tau0: float, fix_tau: bool, max_gap: float | None, half_width: float,
) -> tuple[
    _Arr, _Arr, float, OptimizeResult, float, float, tuple[str, tuple[float, float], float], tuple[float, float]
]:
    """Final ``X`` and ``τ`` on the settled pairs, never worse than the closed form it starts from.

    (1) The best closed form at ``τ₀`` (:func:`_closed_form_start`); (2) unless ``τ`` is fixed, a grid scan of ``τ``
    at that ``X`` (:func:`_scan_time_offset`) moves ``τ₀`` to the deepest minimum nearby, and the closed forms are
    recomputed there; (3) ``[δθ, t, dτ]`` refined from the start on ``mean_ij(|θ_ij|²/σ_r² + |t_ij|²/σ_t²)`` (free),
    and the worse of the two residuals brought as near its best closed form as possible without worsening either
    residual of the start (:func:`_minimax_refinement`); (4) of the start and these two, among those that worsen
    neither residual of the start (the start itself at worst), the one whose worse residual is nearest its best closed
    form, with both residuals checked by the same computation that reports them.  Returns ``qx, tx, τ, sol, σ_r,
    σ_t``, the start ``(name, (mean squared angle rad², mean squared translation m²), τ)`` and the final mean
    squares.
    """
    start, q0, t0, sr, st = _closed_form_start(camera, body, i, j, qx_joint, tx_joint, tau0, max_gap)
    if not fix_tau:
        tau_scan = _scan_time_offset(camera, body, i, j, q0, t0, tau0, sr, st, half_width, max_gap)
        if tau_scan != tau0:
            tau0 = tau_scan
            start, q0, t0, sr, st = _closed_form_start(camera, body, i, j, q0, t0, tau0, max_gap)
    fun = _pair_residual_fun(camera, body, i, j, q0, tau0, sr, st, fix_tau, max_gap)
    qa, ta, _, _, _ = pair_motions(camera, body, i, j, tau0, max_gap)

    def mean_squares(z: np.ndarray) -> tuple[float, float]:  # the reported residuals, computed as reported
        q = dp.quat_canonical(dp.quat_mul(dp.quat_from_rotvec(z[:3]), q0))
        _, _, qb, tb, ok = pair_motions(camera, body, i, j, tau0 + (0.0 if fix_tau else float(z[6])), max_gap)
        if not ok.all():  # a τ that leaves a body gap or the body stream is never chosen
            return np.inf, np.inf
        th2, t2 = squared_pair_residuals(qa, ta, qb, tb, q, z[3:6])
        return float(np.mean(th2)), float(np.mean(t2))

    z0 = np.r_[0.0, 0.0, 0.0, t0, 0.0]
    ms0 = mean_squares(z0)
    ideal = _residual_optima(fun, mean_squares, z0, (3.0 * sr**2, 3.0 * st**2), fix_tau)

    def key(ms: tuple[float, float]) -> tuple[float, float]:  # worst ratio to the optima, then the cost
        return max(ms[0] / ideal[0], ms[1] / ideal[1]), ms[0] / ideal[0] + ms[1] / ideal[1]

    sol = least_squares(fun, z0, method="trf", x_scale=_X_SCALE, diff_step=_DIFF_STEP, xtol=1e-12, ftol=1e-12,
                        gtol=1e-12, max_nfev=200)  # fmt: skip
    cands = [sol.x, _minimax_refinement(mean_squares, z0, ms0, ideal, fix_tau)]
    best_z, best_ms = z0, ms0
    for z in cands:
        ms = mean_squares(z)
        if ms[0] <= ms0[0] and ms[1] <= ms0[1] and key(ms) < key(best_ms):
            best_z, best_ms = z, ms
    q = dp.quat_canonical(dp.quat_mul(dp.quat_from_rotvec(best_z[:3]), q0))
    tau = tau0 + (0.0 if fix_tau else float(best_z[6]))
    if best_z is not sol.x:  # the covariance at the point returned
        sol.fun, sol.jac = fun(best_z), _jacobian(fun, best_z)
    sol.x = best_z.copy()
    sol.x[:3] = 0.0
    return q, np.array(best_z[3:6]), tau, sol, float(sr), float(st), (start, ms0, tau0), best_ms


def _residual_optima(fun: _Residuals, mean_squares: Callable[[_Arr], tuple[float, float]], z0: _Arr,
                     closed_form_best: tuple[float, float], fix_tau: bool) -> tuple[float, float]:  # fmt: skip
    """The least mean square of each residual alone over ``[δθ, t, dτ]`` (and that of the closed forms if lower).

    The rotation residual does not depend on ``t``: it is minimised over ``[δθ, dτ]``, the translation residual over
    all.  The two optima may lie at different ``τ`` and ``X``; no single solution need reach both.
    """
    n = 6 if fix_tau else 7
    free = {"rotation": [0, 1, 2] + ([6] if n == 7 else []), "translation": list(range(n))}
    out = list(closed_form_best)
    for k, (name, idx) in enumerate(free.items()):
        cols = slice(0, 3) if name == "rotation" else slice(3, 6)

        def part(u: _Arr, idx: list[int] = idx, cols: slice = cols) -> _Arr:
            z = z0.copy()
            z[idx] = u
            r: _Arr = fun(z).reshape(-1, 6)[:, cols].ravel()
            return r

        sol = least_squares(part, z0[idx], method="trf", x_scale=_X_SCALE[idx], diff_step=_DIFF_STEP,
                            max_nfev=100)
        z = z0.copy()
        z[idx] = sol.x
        out[k] = min(out[k], mean_squares(z)[k])
    return out[0], out[1]


def _minimax_refinement(mean_squares: Callable[[_Arr], tuple[float, float]], z0: _Arr, ms0: tuple[float, float],
                        ideal: tuple[float, float], fix_tau: bool) -> _Arr:  # fmt: skip
    """``z`` of least ``s`` with ``ms_r <= s·ideal_r``, ``ms_t <= s·ideal_t`` (the worse residual as near its optimum
    as it can be), ``ms_r <= ms_r(z0)`` and ``ms_t <= ms_t(z0)`` (never worse than the start).

    SLSQP (Kraft 1988) on ``[z / x_scale, s]`` from ``[0, s(z0)]``, which is feasible; ``z0`` if it fails.  A margin
    of 1e-9 keeps SLSQP's slight infeasibility at active constraints (~1e-14) inside the feasible set; the caller
    checks the result again with the reported residuals.
    """
    n = 6 if fix_tau else 7
    scale = _X_SCALE[:n]
    cache: dict[bytes, tuple[float, float]] = {}

    def ev(v: np.ndarray) -> tuple[float, float]:
        k = v[:n].tobytes()
        if k not in cache:
            z = z0.copy()
            z[:n] += v[:n] * scale
            cache[k] = mean_squares(z)
        return cache[k]

    m = 1.0 - 1e-9
    v0 = np.r_[np.zeros(n), max(ms0[0] / ideal[0], ms0[1] / ideal[1])]

    def objective(v: _Arr) -> float:
        return float(v[n])

    # scipy-stubs' constraint TypedDict matches no dict literal with python_version 3.10 (it does with 3.11)
    res = minimize(objective, v0, method="SLSQP",  # type: ignore[call-overload, unused-ignore]
                   constraints=[{"type": "ineq", "fun": lambda v: m * v[n] - ev(v)[0] / ideal[0]},
                                {"type": "ineq", "fun": lambda v: m * v[n] - ev(v)[1] / ideal[1]},
                                {"type": "ineq", "fun": lambda v: m - ev(v)[0] / ms0[0]},
                                {"type": "ineq", "fun": lambda v: m - ev(v)[1] / ms0[1]}],
                   options={"maxiter": 60, "ftol": 1e-10, "eps": 1e-6})  # fmt: skip
    z: _Arr = z0.copy()
    z[:n] += res.x[:n] * scale
    return z


def _jacobian(fun: _Residuals, z: _Arr, h: float = 1e-6) -> _Arr:
    """Central-difference Jacobian of ``fun`` at ``z``."""
    cols = []
    for k in range(len(z)):
        e = np.zeros(len(z))
        e[k] = h
        cols.append((fun(z + e) - fun(z - e)) / (2 * h))
    return np.column_stack(cols)


def _covariance(sol: OptimizeResult, fix_tau: bool) -> _Arr:
    """``s² (JᵀJ)⁻¹`` with ``s² = ‖r‖² / (n − p)`` over the normalized residuals; τ row/column 0 when fixed."""
    jac = np.asarray(sol.jac)
    if fix_tau:
        jac = jac[:, :6]
    dof = max(jac.shape[0] - jac.shape[1], 1)
    s2 = float(sol.fun @ sol.fun) / dof
    cov = s2 * np.linalg.pinv(jac.T @ jac)
    out: _Arr = np.pad(cov, ((0, 1), (0, 1))) if fix_tau else cov
    return out
