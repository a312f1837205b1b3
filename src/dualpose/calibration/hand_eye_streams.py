"""Pose streams for hand–eye calibration: cleaning of real recordings and interpolation (SLERP + linear).

A pose stream is a sequence of timestamped poses of one sensor or body in its reference frame (``p_ref = R(q) p +
t``): a camera in a calibration target, a motion-capture marker in the capture frame, a robot hand in the robot base.
Real files are sorted here, rid of repeated rows, and merged where one time stamp carries different poses; the
interpolation never bridges a gap longer than a threshold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp

__all__ = ["PoseStream", "CleaningReport", "clean_pose_stream", "default_max_gap", "interpolate_stream", "shift_stamps",
           "rotation_noise"]


@dataclass(frozen=True)
class PoseStream:
    """Cleaned timestamped poses: strictly increasing stamps, unit quaternions with continuous signs.

    Attributes
    ----------
    stamps : ndarray, shape (N,)
        Seconds, strictly increasing.
    positions : ndarray, shape (N, 3)
        Origin of the sensor/body frame in the reference frame, metres.
    quats : ndarray, shape (N, 4)
        Orientation sensor/body -> reference, xyzw, unit, ``q_k · q_(k-1) >= 0``.
    name : str
        A label used in error messages (usually the file path).
    """

    stamps: np.ndarray
    positions: np.ndarray
    quats: np.ndarray
    name: str = ""

    def __len__(self) -> int:
        return len(self.stamps)


@dataclass(frozen=True)
class CleaningReport:
    """What :func:`clean_pose_stream` changed.

    Attributes
    ----------
    rows_in, rows_out : int
        Rows before and after cleaning.
    was_sorted : bool
        Whether the input stamps were already non-decreasing.
    exact_duplicates : int
        Rows dropped because an identical row (same stamp and pose, ``q`` and ``-q`` equal) came before.
    merged_stamps : int
        Time stamps that carried two or more different poses; each group was replaced by its average (mean
        position, Markley mean orientation).
    """

    rows_in: int
    rows_out: int
    was_sorted: bool
    exact_duplicates: int
    merged_stamps: int


def clean_pose_stream(
    stamps: ArrayLike, positions: ArrayLike, quats: ArrayLike, name: str = "", *, min_rows: int = 2
) -> tuple[PoseStream, CleaningReport]:
    """Sort a pose stream, drop repeated rows and merge time stamps that carry different poses.

    Rules, in order: (1) quaternions are normalized (zero raises); (2) rows are sorted by stamp (stable: rows with
    equal stamps keep their file order); (3) rows equal to an earlier row with the same stamp (position and
    orientation, ``q ≡ -q``) are dropped; (4) the different poses that remain at one stamp are averaged — the
    mean position and the Markley mean orientation (:func:`dualpose.quat_mean`) — so that the result does not
    depend on their file order; (5) quaternion signs are flipped to make consecutive quaternions have a
    non-negative dot product.

    Parameters
    ----------
    stamps : array_like, shape (N,)
        Seconds.
    positions : array_like, shape (N, 3)
        Metres.
    quats : array_like, shape (N, 4)
        xyzw, any nonzero norm.
    name : str
        Label for error messages.
    min_rows : int
        Fewest rows the cleaned stream may have.

    Returns
    -------
    PoseStream, CleaningReport

    Raises
    ------
    ValueError
        Shapes, non-finite values, zero quaternions, or fewer than ``min_rows`` distinct stamps.
    """
    label = f"{name}: " if name else ""
    t = np.asarray(stamps, dtype=np.float64)
    p = np.asarray(positions, dtype=np.float64)
    q = np.asarray(quats, dtype=np.float64)
    n = t.shape[0] if t.ndim == 1 else -1
    if n < 0 or p.shape != (n, 3) or q.shape != (n, 4):
        raise ValueError(f"{label}stamps (N,), positions (N, 3), quats (N, 4) expected; got {t.shape}, {p.shape}, "
                         f"{q.shape}")  # fmt: skip
    if not (np.isfinite(t).all() and np.isfinite(p).all() and np.isfinite(q).all()):
        raise ValueError(f"{label}non-finite stamp, position or quaternion")
    norm = np.linalg.norm(q, axis=1)
    if (norm == 0).any():
        raise ValueError(f"{label}zero quaternion at row {int(np.argmax(norm == 0))}")
    q = dp.quat_canonical(q / norm[:, None])  # one sign per rotation for the duplicate test
    was_sorted = bool(np.all(np.diff(t) >= 0))
    order = np.argsort(t, kind="stable")
    t, p, q = t[order], p[order], q[order]
    rows = np.hstack([t[:, None], p, q])
    keep = np.ones(len(t), bool)
    same_stamp = np.flatnonzero(np.diff(t) == 0)
    exact = 0
    for k in same_stamp:  # drop rows equal to an earlier row with the same stamp
        start = k
        while start > 0 and t[start - 1] == t[k + 1]:
            start -= 1
        if any(keep[m] and np.array_equal(rows[m], rows[k + 1]) for m in range(start, k + 1)):
            keep[k + 1] = False
            exact += 1
    t, p, q = t[keep], p[keep], q[keep]
    uniq, first, counts = np.unique(t, return_index=True, return_counts=True)
    merged = int(np.count_nonzero(counts > 1))
    if merged:
        p_out = p[first].copy()
        q_out = q[first].copy()
        for g in np.flatnonzero(counts > 1):
            sl = slice(first[g], first[g] + counts[g])
            p_out[g] = p[sl].mean(axis=0)
            q_out[g] = dp.quat_mean(q[sl])
        t, p, q = uniq, p_out, q_out
    if len(t) < min_rows:
        raise ValueError(f"{label}{len(t)} distinct time stamp(s); need at least {min_rows}")
    q = _continuous_signs(q)
    report = CleaningReport(int(n), int(len(t)), was_sorted, exact, merged)
    return PoseStream(t, p, q, name), report


def _continuous_signs(q: np.ndarray) -> np.ndarray:
    """Flip signs so that ``q_k · q_(k-1) >= 0`` along the sequence."""
    dots = np.einsum("ij,ij->i", q[1:], q[:-1])
    flips = np.concatenate([[False], dots < 0])
    sign = np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)
    return q * sign[:, None]


def default_max_gap(stream: PoseStream) -> float:
    """Longest interval interpolated across by default: 5 times the median sampling interval (s)."""
    return 5.0 * float(np.median(np.diff(stream.stamps)))


def interpolate_stream(
    stream: PoseStream, times: ArrayLike, max_gap: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Poses at ``times``: SLERP of the orientation and linear interpolation of the position.

    Parameters
    ----------
    stream : PoseStream
    times : array_like, shape (M,)
        Seconds, in the stream's clock, any order.
    max_gap : float, optional
        Longest interval between neighbouring samples that may be bridged (s); default
        :func:`default_max_gap`.

    Returns
    -------
    positions : ndarray, shape (M, 3)
    quats : ndarray, shape (M, 4)
    valid : ndarray of bool, shape (M,)
        False outside ``[stamps[0], stamps[-1]]`` or inside (not at the ends of) a gap longer than ``max_gap``.
        Invalid entries are extrapolated from the nearest sample interval (finite, but not to be trusted).
    """
    if max_gap is None:
        max_gap = default_max_gap(stream)
    s = stream.stamps
    x = np.asarray(times, dtype=np.float64)
    i = np.clip(np.searchsorted(s, x, side="right") - 1, 0, len(s) - 2)
    span = s[i + 1] - s[i]
    u = (x - s[i]) / span
    valid = (x >= s[0]) & (x <= s[-1]) & ((span <= max_gap) | (x == s[i]) | (x == s[i + 1]))
    pos = stream.positions[i] + u[:, None] * (stream.positions[i + 1] - stream.positions[i])
    quat = dp.quat_slerp(stream.quats[i], stream.quats[i + 1], u)
    return pos, quat, valid


def shift_stamps(stream: PoseStream, origin: float) -> PoseStream:
    """The same stream with ``origin`` (s) subtracted from its stamps.

    Unix-epoch stamps (~1.5e9 s) have a float64 resolution of 0.24 µs; a refinement that perturbs the time offset
    by microseconds needs stamps near zero.
    """
    return PoseStream(stream.stamps - origin, stream.positions, stream.quats, stream.name)


#: median of the χ distribution with 3 degrees of freedom: the median angle of an isotropic 3-D error of unit σ
_CHI3_MEDIAN = 1.5381728


def rotation_noise(stream: PoseStream, max_gap: float | None = None) -> float:
    """Per-component standard deviation (rad) of the orientation noise of a stream, from its own samples.

    Each sample is compared with the SLERP of its two neighbours at its stamp: for white noise of ``σ`` per
    component that deviation has ``1.5 σ²`` per component (the sample's own plus half of its neighbours'), and its
    angle is χ-distributed with 3 degrees of freedom; the median makes the estimate robust to outlier poses, and
    smooth motion adds only its curvature over two sample intervals.  Triples spanning more than ``max_gap``
    (default :func:`default_max_gap`) are skipped.  Returns NaN for fewer than 3 usable triples.
    """
    if max_gap is None:
        max_gap = default_max_gap(stream)
    t, q = stream.stamps, stream.quats
    if len(t) < 3:
        return float("nan")
    ok = (t[2:] - t[:-2]) <= 2.0 * max_gap
    if ok.sum() < 3:
        return float("nan")
    u = (t[1:-1] - t[:-2]) / (t[2:] - t[:-2])
    mid = dp.quat_slerp(q[:-2][ok], q[2:][ok], u[ok])
    return float(np.median(dp.quat_angle(q[1:-1][ok], mid)) / (_CHI3_MEDIAN * np.sqrt(1.5)))
