"""Coarse time offset between two pose streams from the cross-correlation of their angular-rate magnitudes.

The rate magnitude ``|ω(t)|`` of a rigid rig is the same for every sensor on it (the hand–eye rotation does not change
it), so the offset ``τ`` (camera time ``t`` ↔ body time ``t + τ``) maximises the normalized cross-correlation of the
two rate signals (as in Furrer et al., FSR 2017: filtered angular-velocity norms, cross-correlated).  Each stream is
resampled on its own grid starting at its own first stamp, so an offset of hours between unrelated clocks costs
nothing more than one of milliseconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, signal

import dualpose as dp
from dualpose.calibration.hand_eye_streams import PoseStream, interpolate_stream

__all__ = ["CoarseOffset", "angular_rate_signal", "coarse_time_offset"]


@dataclass(frozen=True)
class CoarseOffset:
    """Result of :func:`coarse_time_offset`.

    Attributes
    ----------
    offset : float
        ``τ`` (s): camera time ``t`` corresponds to body time ``t + τ``.
    correlation : float
        Normalized cross-correlation at the peak, in [-1, 1].
    overlap : float
        Length of the overlap of the two valid rate signals at the peak (s).
    """

    offset: float
    correlation: float
    overlap: float


def angular_rate_signal(
    stream: PoseStream, dt: float, *, max_gap: float | None = None, baseline: float = 0.2,
    median_window: float = 0.15, smooth_window: float = 0.1, clip_percentile: float = 99.5,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Filtered angular-rate magnitude of ``stream`` on the grid ``stamps[0] + k dt``.

    The orientation is interpolated on the grid (SLERP, not across gaps longer than ``max_gap``) and the rate at
    sample ``k`` is ``angle(q_k, q_(k+s)) / (s dt)`` (rad/s) with ``s dt ≈ baseline``: a difference over a
    baseline longer than the sampling interval keeps the rate of a noisy camera pose from being dominated by its
    noise (per-sample differences of noisy orientations add up to a large positive bias).  Then a running median
    over ``median_window`` seconds (removes the spikes of isolated outlier poses), clipping at the
    ``clip_percentile`` percentile and a running mean over ``smooth_window`` seconds.  Both streams must use the
    same ``dt`` and ``baseline`` (the rate is then delayed by the same ``baseline / 2`` in both).

    Returns
    -------
    rate : ndarray, shape (K,)
        rad/s; 0 where invalid.
    valid : ndarray of bool, shape (K,)
        The whole baseline window is interpolated without crossing a gap.
    """
    k = int(np.floor((stream.stamps[-1] - stream.stamps[0]) / dt)) + 1
    s = max(1, int(round(baseline / dt)))
    if k <= s + 1:
        return np.zeros(max(k, 1)), np.zeros(max(k, 1), bool)
    grid = stream.stamps[0] + dt * np.arange(k)
    _, q, ok = interpolate_stream(stream, grid, max_gap)
    bad = np.concatenate([[0], np.cumsum(~ok)])
    valid = np.zeros(k, bool)
    valid[: k - s] = bad[s + 1 :] - bad[: k - s] == 0
    rate = np.zeros(k)
    rate[: k - s] = dp.quat_angle(q[: k - s], q[s:]) / (s * dt)
    rate = np.where(valid, rate, 0.0)
    med = max(1, int(round(median_window / dt)) | 1)
    rate = ndimage.median_filter(rate, size=med, mode="nearest")
    if valid.any():
        rate = np.minimum(rate, np.percentile(rate[valid], clip_percentile))
    box = max(1, int(round(smooth_window / dt)))
    weight = ndimage.uniform_filter1d(valid.astype(float), box, mode="constant")
    rate = ndimage.uniform_filter1d(np.where(valid, rate, 0.0), box, mode="constant")
    rate = np.where(valid & (weight > 0), rate / np.maximum(weight, 1e-12), 0.0)
    return rate, valid


def coarse_time_offset(
    camera: PoseStream, body: PoseStream, *, dt: float = 0.01, max_gap_camera: float | None = None,
    max_gap_body: float | None = None, min_overlap_fraction: float = 0.3, max_offset: float | None = None,
) -> CoarseOffset:  # fmt: skip
    """Time offset maximising the normalized cross-correlation of the angular-rate magnitudes.

    For lag ``L`` (camera grid sample ``k`` ↔ body grid sample ``k + L``) the score is
    ``Σ a_k b_(k+L) / sqrt(Σ a_k² m^b_(k+L) · Σ m^a_k b_(k+L)²)`` over the samples valid in both (``a``, ``b`` the
    rate signals with their valid-sample means removed, ``m`` the validity masks), computed for every lag at once with
    FFTs.  Lags whose overlap is shorter than ``min_overlap_fraction`` of the shorter valid signal are not
    considered.  The peak is refined by a parabola through its neighbours (sub-sample resolution).

    Parameters
    ----------
    camera, body : PoseStream
    dt : float
        Grid spacing (s).
    max_gap_camera, max_gap_body : float, optional
        Interpolation gap limits (s); default 5 median sampling intervals.
    min_overlap_fraction : float
        See above.
    max_offset : float, optional
        Search only ``|τ| <= max_offset`` (s).

    Raises
    ------
    ValueError
        When the streams are too short or never overlap enough.
    """
    a, ma = angular_rate_signal(camera, dt, max_gap=max_gap_camera)
    b, mb = angular_rate_signal(body, dt, max_gap=max_gap_body)
    if ma.sum() < 10 or mb.sum() < 10:
        raise ValueError("too few valid samples for the time-offset correlation (need >= 10 per stream)")
    a = np.where(ma, a - a[ma].mean(), 0.0)
    b = np.where(mb, b - b[mb].mean(), 0.0)
    fa, fb = ma.astype(float), mb.astype(float)
    cab = signal.correlate(b, a, mode="full", method="fft")
    saa = signal.correlate(fb, a * a, mode="full", method="fft")
    sbb = signal.correlate(b * b, fa, mode="full", method="fft")
    nov = signal.correlate(fb, fa, mode="full", method="fft")
    lags = np.arange(-(len(a) - 1), len(b))
    base = body.stamps[0] - camera.stamps[0]
    ok = (nov > min_overlap_fraction * min(fa.sum(), fb.sum()) - 0.5) & (saa > 1e-12) & (sbb > 1e-12)
    if max_offset is not None:
        ok &= np.abs(base + lags * dt) <= max_offset
    if not ok.any():
        raise ValueError("the two streams never overlap enough for the time-offset correlation")
    score = np.full(len(lags), -np.inf)
    score[ok] = cab[ok] / np.sqrt(saa[ok] * sbb[ok])
    k = int(np.argmax(score))
    frac = 0.0
    if 0 < k < len(score) - 1 and np.isfinite(score[k - 1]) and np.isfinite(score[k + 1]):
        den = score[k - 1] - 2 * score[k] + score[k + 1]
        if den < 0:
            frac = float(np.clip(0.5 * (score[k - 1] - score[k + 1]) / den, -0.5, 0.5))
    return CoarseOffset(float(base + (lags[k] + frac) * dt), float(score[k]), float(nov[k] * dt))
