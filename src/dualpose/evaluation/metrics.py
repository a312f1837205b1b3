"""Trajectory accuracy: timestamp association, alignment, ATE, RPE and orientation error.

Definitions follow Sturm et al. 2012 (TUM RGB-D benchmark, ATE eq. 3 and RPE eq. 1) and the conventions of the
``evo`` package, whose numbers these functions reproduce (see ``docs/metrics.md`` and the tests):

- association: each pose of the *shorter* trajectory is paired with the nearest-in-time pose of the longer one
  when ``|dt| <= max_diff`` (``offset`` is added to the estimate's stamps first); optionally the longer one is then
  interpolated at the matched stamps (linear + slerp);
- alignment: Umeyama SE(3) / Sim(3) (or scale only) of the estimated positions onto the reference ones, or the
  first poses made equal (:mod:`dualpose.evaluation.align`), applied to every matched estimate pose;
- ATE: ``|p_ref_i - (s R p_est_i + t)|`` per matched pose (metres);
- orientation error: the angle of ``q_ref_i^-1 (x) q_R (x) q_est_i`` (degrees);
- RPE: for index pairs (i, j) taken on the estimate, the error of the relative motion
  ``E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)``: its translation norm (metres) and rotation angle (degrees).

Layouts: stamps ``(N,)`` seconds, positions ``(N, 3)`` metres, quaternions ``(N, 4)`` xyzw body -> world (need not be
unit: they are normalized here).  Every function is vectorised over the poses.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose.evaluation.align import Alignment, AlignMethod, Undetermined, align_positions, origin_alignment
from dualpose.types.trajectory import Trajectory, as_positions, as_quats, check_same_length, interpolate_poses

__all__ = [
    "associate",
    "ErrorStatistics",
    "error_statistics",
    "ate_errors",
    "orientation_errors_deg",
    "rpe_pairs",
    "rpe_errors",
    "Evaluation",
    "evaluate",
    "prepare_trajectory",
    "crop_trajectory",
    "MAX_COORDINATE",
]

#: largest accepted ``|position coordinate|``, metres: squared distances of larger ones overflow float64 (~1.8e308)
MAX_COORDINATE = 1e150
#: largest fraction of poses that may share their stamp with a different pose (warned about) before it is refused
MAX_SHARED_STAMPS = 0.05

RpeUnit = Literal["frames", "m"]
_RPE_CHUNK = 1 << 18
SyncMethod = Literal["nearest", "interpolate"]


# ------------------------------------------------------------------------------------------------ input checks


def prepare_trajectory(trajectory: Trajectory, name: str) -> Trajectory:
    """``trajectory`` in time order with exact duplicate poses dropped, ready for association and RPE.

    - Stamps out of order are sorted (stable) with a ``UserWarning``: RPE pairs are consecutive poses, so an
      unsorted file would pair poses far apart in time (evo assumes sorted input).
    - Exact duplicate rows (same stamp, position and quaternion) are dropped with a ``UserWarning``: they would
      count zero-length RPE pairs.
    - The same stamp with different poses is warned about, naming the stamp, and kept (the association sees
      them all, as evo does): real files have a few (stamps printed to 1 ms: TUM's ``fr2_desk`` ground truth has
      one, the EuRoC V1_02 estimate four).  When more than ``MAX_SHARED_STAMPS`` (5 %) of the poses share a
      stamp with a different pose, or every stamp is the same, the stamps do not identify the poses and it raises
      ``ValueError`` naming the first such stamp.
    - Coordinates beyond :data:`MAX_COORDINATE` (1e150 m) raise ``ValueError`` (their squares overflow).

    ``name`` labels the trajectory in the messages (with ``trajectory.name``, usually the path).
    """
    label = f"{name} ({trajectory.name})" if trajectory.name else name
    n = len(trajectory)
    if n == 0:
        raise ValueError(f"{label} has no poses")
    big = float(np.abs(trajectory.positions).max())
    if big > MAX_COORDINATE:
        raise ValueError(
            f"{label}: position coordinates up to {big:.3g} m; |coordinates| above {MAX_COORDINATE:g} m overflow "
            "squared distances in float64 (rescale the file)"
        )
    t = trajectory.stamps
    if np.any(t[1:] < t[:-1]):
        order = np.argsort(t, kind="stable")
        warnings.warn(f"{label}: timestamps are not in increasing order; sorted them", UserWarning, stacklevel=3)
        trajectory = trajectory.take(order)
        t = trajectory.stamps
    same = np.flatnonzero(t[1:] == t[:-1])
    if same.size:
        p, q = trajectory.positions, trajectory.quats
        differ = np.any(p[same] != p[same + 1], axis=1) | np.any(q[same] != q[same + 1], axis=1)
        if differ.any():
            k = int(same[np.argmax(differ)])
            n_differ = int(np.count_nonzero(differ))
            what = (
                f"{label}: stamp {float(t[k])!r} s has different poses (position {p[k].tolist()} vs "
                f"{p[k + 1].tolist()})"
            )
            if n_differ > MAX_SHARED_STAMPS * n or t[0] == t[-1]:
                raise ValueError(
                    f"{what}, and {n_differ} of {n} poses share a stamp with a different pose: the stamps do not "
                    "identify the poses (one pose per stamp is needed)"
                )
            warnings.warn(
                f"{what}; {n_differ} such stamp(s), all poses kept (as evo does)", UserWarning, stacklevel=3
            )
            same = same[~differ]
        if same.size == 0:
            return trajectory
        warnings.warn(
            f"{label}: dropped {same.size} exact duplicate pose(s) (first at stamp {float(t[same[0]])!r} s)",
            UserWarning,
            stacklevel=3,
        )
        keep = np.ones(n, dtype=bool)
        keep[same + 1] = False
        trajectory = trajectory.take(np.flatnonzero(keep))
    return trajectory


def crop_trajectory(trajectory: Trajectory, t_start: float | None, t_end: float | None, name: str,
                    offset: float = 0.0) -> Trajectory:
    """The poses with ``t_start <= stamp + offset <= t_end`` (seconds; None = unbounded), like evo's ``--t_start``,
    ``--t_end``.  Raises ``ValueError`` when ``t_start >= t_end`` or no pose is left."""
    if t_start is None and t_end is None:
        return trajectory
    lo = -np.inf if t_start is None else float(t_start)
    hi = np.inf if t_end is None else float(t_end)
    if np.isnan(lo) or np.isnan(hi) or lo >= hi:
        raise ValueError(f"t_start must be < t_end; got t_start = {t_start!r}, t_end = {t_end!r}")
    t = trajectory.stamps + offset
    keep = np.flatnonzero((t >= lo) & (t <= hi))
    if keep.size == 0:
        label = f"{name} ({trajectory.name})" if trajectory.name else name
        raise ValueError(
            f"{label} has no pose in [t_start, t_end] = [{lo}, {hi}] s (its stamps span "
            f"[{t.min():.6f}, {t.max():.6f}] s)"
        )
    return trajectory if keep.size == len(trajectory) else trajectory.take(keep)


# ------------------------------------------------------------------------------------------------ association


def _nearest_within(s1: np.ndarray, s2: np.ndarray, max_diff: float) -> tuple[np.ndarray, np.ndarray]:
    """For each stamp of ``s1`` the index of the nearest stamp of the sorted ``s2`` if within ``max_diff``.

    Ties go to the earlier stamp of ``s2``.  Returns (indices into s1, indices into s2), ascending in s1.
    """
    m = s2.shape[0]
    idx = np.minimum(np.searchsorted(s2, s1, side="right"), m - 1)
    diff_up = s2[idx] - s1  # negative only past the end, where idx = m - 1 is the nearest
    diff_low = np.where(idx > 0, s1 - s2[np.maximum(idx - 1, 0)], np.inf)
    take_up = (diff_up <= max_diff) & (diff_up < diff_low)
    take_low = ~take_up & (diff_low <= max_diff) & (diff_low <= diff_up)
    inside = (s1 >= s2[0] - max_diff) & (s1 <= s2[-1] + max_diff)
    keep = inside & (take_up | take_low)
    best = np.where(take_up, idx, idx - 1)
    return np.flatnonzero(keep), best[keep]


def associate(
    stamps_ref: ArrayLike, stamps_est: ArrayLike, max_diff: float = 0.01, offset: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Pair reference and estimate poses by nearest timestamp.

    Every stamp of the trajectory with fewer poses (the estimate when both have equally many) is matched to the
    nearest stamp of the other one, and kept when the difference is at most ``max_diff``; a pose of the longer
    trajectory may be used twice.  This is ``evo``'s ``associate_trajectories`` (nearest-time method).

    Parameters
    ----------
    stamps_ref, stamps_est : array_like, shape (N,) and (M,)
        Seconds.  Need not be sorted (the longer one is sorted internally).
    max_diff : float
        Largest accepted time difference, seconds (>= 0).
    offset : float
        Seconds added to the estimate's stamps before matching (``t_ref = t_est + offset``).

    Returns
    -------
    idx_ref, idx_est : ndarray of intp, shape (K,)
        Matched indices, in the order of the shorter trajectory.

    Raises
    ------
    ValueError
        For non-1-D or non-finite stamps, a negative ``max_diff``, or when no pair matches.
    """
    ref = np.asarray(stamps_ref, dtype=np.float64)
    est = np.asarray(stamps_est, dtype=np.float64)
    for name, s in (("stamps_ref", ref), ("stamps_est", est)):
        if s.ndim != 1 or s.shape[0] == 0:
            raise ValueError(f"{name} must have shape (N,) with N >= 1; got shape {s.shape}")
        if not np.isfinite(s).all():
            raise ValueError(f"{name} must be finite")
    if not (max_diff >= 0.0 and np.isfinite(max_diff)):
        raise ValueError(f"max_diff must be a finite number >= 0; got {max_diff!r}")
    est_longer = est.shape[0] > ref.shape[0]
    short, long = (ref, est + offset) if est_longer else (est, ref - offset)
    order = None
    if np.any(np.diff(long) < 0):
        order = np.argsort(long, kind="stable")
        long = long[order]
    i_short, i_long = _nearest_within(short, long, float(max_diff))
    if order is not None:
        i_long = order[i_long]
    if i_short.size == 0:
        raise ValueError(
            f"no matching timestamps within max_diff = {max_diff} s (offset {offset} s): reference spans "
            f"[{ref.min():.6f}, {ref.max():.6f}] s, estimate [{est.min():.6f}, {est.max():.6f}] s"
        )
    return (i_short, i_long) if est_longer else (i_long, i_short)


# ------------------------------------------------------------------------------------------------ statistics


@dataclass(frozen=True)
class ErrorStatistics:
    """Summary of a set of non-negative errors (``std`` is the population standard deviation, like evo)."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    sse: float
    n: int

    def as_dict(self) -> dict[str, float | int]:
        return {k: getattr(self, k) for k in ("rmse", "mean", "median", "std", "min", "max", "sse", "n")}


def error_statistics(errors: ArrayLike) -> ErrorStatistics:
    """rmse, mean, median, std, min, max, sum of squares and count of ``errors`` (shape (K,), K >= 1)."""
    e = np.asarray(errors, dtype=np.float64)
    if e.ndim != 1 or e.shape[0] == 0:
        raise ValueError(f"errors must have shape (K,) with K >= 1; got shape {e.shape}")
    if not np.isfinite(e).all():
        raise ValueError("errors must be finite")
    sq = e * e
    return ErrorStatistics(
        rmse=float(np.sqrt(np.mean(sq))),
        mean=float(np.mean(e)),
        median=float(np.median(e)),
        std=float(np.std(e)),
        min=float(np.min(e)),
        max=float(np.max(e)),
        sse=float(np.sum(sq)),
        n=int(e.shape[0]),
    )


# ------------------------------------------------------------------------------------------------ per-pose errors


def ate_errors(positions_ref: ArrayLike, positions_est: ArrayLike) -> np.ndarray:
    """Absolute trajectory (translation) error ``|p_ref_i - p_est_i|`` of matched, aligned poses.

    ``positions_ref``, ``positions_est``: (N, 3) metres.  Returns (N,) metres (Sturm 2012 eq. 3 before the RMSE).
    """
    a, b = as_positions(positions_ref, "positions_ref"), as_positions(positions_est, "positions_est")
    check_same_length(positions_ref=a, positions_est=b)
    err: NDArray[np.float64] = np.linalg.norm(a - b, axis=1)
    return err


def orientation_errors_deg(quats_ref: ArrayLike, quats_est: ArrayLike) -> np.ndarray:
    """Rotation angle between matched orientations, ``angle(q_ref_i^-1 (x) q_est_i)``, degrees in [0, 180].

    ``quats_ref``, ``quats_est``: (N, 4) xyzw (normalized here; sign-invariant).  Uses :func:`dualpose.quat_angle`
    (atan2 form, accurate for tiny angles).  Returns (N,).
    """
    a, b = as_quats(quats_ref, "quats_ref"), as_quats(quats_est, "quats_est")
    check_same_length(quats_ref=a, quats_est=b)
    deg: NDArray[np.float64] = np.degrees(dp.quat_angle(a, b))
    return deg


def _chain(nxt: np.ndarray) -> np.ndarray:
    """The sequence 0, nxt[0], nxt[nxt[0]], ... up to (excluding) the sentinel ``len(nxt)``, by pointer doubling.

    ``nxt`` (n,) must satisfy ``i < nxt[i] <= n``.  O(n log n) numpy work, no per-element Python loop.
    """
    n = nxt.shape[0]
    jump = np.append(nxt, n)  # jump = next^L with L = len(chain); sentinel maps to itself
    chain = np.zeros(1, dtype=np.intp)
    while chain[-1] != n:
        chain = np.concatenate([chain, jump[chain]])
        jump = jump[jump]
    out: NDArray[np.intp] = chain[chain < n]
    return out


def rpe_pairs(
    positions: ArrayLike, delta: float, unit: RpeUnit = "frames", all_pairs: bool = False, rel_tol: float = 0.1
) -> np.ndarray:
    """Index pairs (i, j) for the relative pose error, chosen on one trajectory (evo uses the estimate's).

    Parameters
    ----------
    positions : array_like, shape (N, 3)
        Positions (metres) along which path lengths are measured (``unit="m"``).
    delta : float
        Step: a whole number of poses (``unit="frames"``, >= 1) or a path length in metres (``unit="m"``, > 0).
    unit : {"frames", "m"}
    all_pairs : bool
        False (default): consecutive pairs ``(i_0, i_1), (i_1, i_2), ...`` with ``i_0 = 0`` -- every ``delta``-th
        pose, or each next pose once the travelled path since the previous one reaches ``delta`` metres.
        True: a pair starting at every pose -- ``(i, i + delta)``, or the ``j > i`` whose path length from ``i``
        is nearest to ``delta`` metres, kept when within ``rel_tol * delta`` of it.

    Returns
    -------
    ndarray of intp, shape (K, 2)
        Possibly empty.
    """
    p = as_positions(positions, "positions")
    n = p.shape[0]
    if unit == "frames":
        if not (float(delta).is_integer() and delta >= 1):
            raise ValueError(f"delta must be a whole number of frames >= 1 for unit='frames'; got {delta!r}")
        d = int(delta)
        if all_pairs:
            i = np.arange(max(n - d, 0), dtype=np.intp)
            return np.stack([i, i + d], axis=1)
        ids = np.arange(0, n, d, dtype=np.intp)
        return np.stack([ids[:-1], ids[1:]], axis=1)
    if unit != "m":
        raise ValueError(f"unit must be 'frames' or 'm'; got {unit!r}")
    if not (delta > 0 and np.isfinite(delta)):
        raise ValueError(f"delta must be a positive number of metres for unit='m'; got {delta!r}")
    dist = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    target = dist + delta
    # first j with dist[j] >= dist[i] + delta; j > i even where delta is below the float resolution of dist[i]
    up = np.maximum(np.searchsorted(dist, target, side="left"), np.arange(1, n + 1))
    if not all_pairs:
        chain = _chain(up)
        return np.stack([chain[:-1], chain[1:]], axis=1)
    i = np.arange(n - 1, dtype=np.intp)
    up, tgt = up[:-1], target[:-1]
    low = up - 1  # dist[low] < target; the earliest pose with that distance wins ties (like argmin)
    low_first = np.maximum(np.searchsorted(dist, dist[low], side="left"), i + 1)
    err_up = np.where(up < n, np.abs(dist[np.minimum(up, n - 1)] - tgt), np.inf)
    err_low = np.where(low > i, np.abs(dist[low] - tgt), np.inf)
    use_low = err_low <= err_up
    j = np.where(use_low, low_first, up)
    err = np.where(use_low, err_low, err_up)
    keep = err <= rel_tol * delta
    return np.stack([i[keep], j[keep]], axis=1)


def rpe_errors(
    positions_ref: ArrayLike,
    quats_ref: ArrayLike,
    positions_est: ArrayLike,
    quats_est: ArrayLike,
    pairs: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """Relative pose error of index pairs (Sturm 2012 eq. 1): ``E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j)``.

    Parameters
    ----------
    positions_ref, positions_est : array_like, shape (N, 3)
        Matched positions, metres (reference Q, estimate P).
    quats_ref, quats_est : array_like, shape (N, 4)
        Matched orientations body -> world, xyzw.
    pairs : array_like of int, shape (K, 2)
        Index pairs (i, j), e.g. from :func:`rpe_pairs`.

    Returns
    -------
    translation : ndarray, shape (K,)
        ``|trans(E)| = |R_Pi^T (p_Pj - p_Pi) - R_Qi^T (p_Qj - p_Qi)|``, metres.
    rotation_deg : ndarray, shape (K,)
        ``angle(rot(E))``, degrees.
    """
    pq, pp = as_positions(positions_ref, "positions_ref"), as_positions(positions_est, "positions_est")
    qq, qp = as_quats(quats_ref, "quats_ref"), as_quats(quats_est, "quats_est")
    check_same_length(positions_ref=pq, quats_ref=qq, positions_est=pp, quats_est=qp)
    ij = np.asarray(pairs)
    if ij.ndim != 2 or ij.shape[1] != 2 or ij.dtype.kind not in "iu":
        raise ValueError(f"pairs must be an integer array of shape (K, 2); got {ij.dtype} {ij.shape}")
    if ij.size and (ij.min() < 0 or ij.max() >= pq.shape[0]):
        raise ValueError(f"pairs must index 0..{pq.shape[0] - 1}; got range [{ij.min()}, {ij.max()}]")
    k = ij.shape[0]
    translation, rotation = np.empty(k), np.empty(k)
    for a in range(0, k, _RPE_CHUNK):  # chunks of pairs bound the temporaries (~20 per pair) for millions of poses
        i, j = ij[a : a + _RPE_CHUNK, 0], ij[a : a + _RPE_CHUNK, 1]
        qq_i_inv, qp_i_inv = dp.quat_conj(qq[i]), dp.quat_conj(qp[i])
        t_ref = dp.quat_rotate(qq_i_inv, pq[j] - pq[i])
        t_est = dp.quat_rotate(qp_i_inv, pp[j] - pp[i])
        rel_ref = dp.quat_mul(qq_i_inv, qq[j])
        rel_est = dp.quat_mul(qp_i_inv, qp[j])
        translation[a : a + _RPE_CHUNK] = np.linalg.norm(t_est - t_ref, axis=1)
        rotation[a : a + _RPE_CHUNK] = np.degrees(dp.quat_angle(rel_ref, rel_est))
    return translation, rotation


# ------------------------------------------------------------------------------------------------ all together


@dataclass(frozen=True)
class Evaluation:
    """Result of :func:`evaluate`.

    Attributes
    ----------
    idx_ref, idx_est : ndarray of intp, shape (K,)
        Matched pose indices (with ``sync="interpolate"``, those of the longer trajectory are the nearest poses
        to the interpolated times).
    stamps : ndarray, shape (K,)
        The matched times in the reference's clock, seconds.
    positions_ref, quats_ref : ndarray, shapes (K, 3), (K, 4)
        Matched (or interpolated) reference poses (quaternions normalized).
    positions_est, quats_est : ndarray, shapes (K, 3), (K, 4)
        Matched estimate poses after the alignment.
    alignment : Alignment
    ate : ndarray, shape (K,)
        Translation error per matched pose, metres.
    orientation_deg : ndarray, shape (K,)
        Orientation error per matched pose, degrees.
    rpe_pairs : ndarray of intp, shape (L, 2)
        Index pairs into the matched arrays.
    rpe_translation, rpe_rotation_deg : ndarray, shape (L,)
        Relative pose error per pair, metres and degrees.
    settings : dict
        The arguments used.
    """

    idx_ref: np.ndarray
    idx_est: np.ndarray
    stamps: np.ndarray
    positions_ref: np.ndarray
    quats_ref: np.ndarray
    positions_est: np.ndarray
    quats_est: np.ndarray
    alignment: Alignment
    ate: np.ndarray
    orientation_deg: np.ndarray
    rpe_pairs: np.ndarray
    rpe_translation: np.ndarray
    rpe_rotation_deg: np.ndarray
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def ate_stats(self) -> ErrorStatistics:
        return error_statistics(self.ate)

    @property
    def orientation_stats(self) -> ErrorStatistics:
        return error_statistics(self.orientation_deg)

    @property
    def rpe_translation_stats(self) -> ErrorStatistics:
        return error_statistics(self.rpe_translation)

    @property
    def rpe_rotation_stats(self) -> ErrorStatistics:
        return error_statistics(self.rpe_rotation_deg)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary: headline numbers (``ate_rmse_m``, ``orientation_rmse_deg``, ``rpe_rmse_m``,
        ``rpe_rotation_rmse_deg``) plus the full statistics, the alignment and the settings."""
        ate, ori = self.ate_stats, self.orientation_stats
        rpe_t, rpe_r = self.rpe_translation_stats, self.rpe_rotation_stats
        return {
            "ate_rmse_m": ate.rmse,
            "orientation_rmse_deg": ori.rmse,
            "rpe_rmse_m": rpe_t.rmse,
            "rpe_rotation_rmse_deg": rpe_r.rmse,
            "matched_poses": int(self.idx_ref.shape[0]),
            "rpe_pairs": int(self.rpe_pairs.shape[0]),
            "ate_m": ate.as_dict(),
            "orientation_deg": ori.as_dict(),
            "rpe_translation_m": rpe_t.as_dict(),
            "rpe_rotation_deg": rpe_r.as_dict(),
            "alignment": self.alignment.as_dict(),
            "settings": dict(self.settings),
        }


def evaluate(
    reference: Trajectory,
    estimate: Trajectory,
    *,
    align: AlignMethod = "se3",
    align_first_n: int | None = None,
    max_diff: float = 0.01,
    offset: float = 0.0,
    sync: SyncMethod = "nearest",
    rpe_delta: float = 1,
    rpe_unit: RpeUnit = "frames",
    rpe_all_pairs: bool = False,
    rpe_pairs_from_reference: bool = False,
    t_start: float | None = None,
    t_end: float | None = None,
    undetermined: Undetermined = "raise",
) -> Evaluation:
    """Associate, align and compute ATE, orientation error and RPE of ``estimate`` against ``reference``.

    The steps and defaults are those of ``evo_ape`` / ``evo_rpe``: ``align`` "se3" = ``--align``, "sim3" =
    ``--align --correct_scale``, "scale" = ``--correct_scale`` alone, "origin" = ``--align_origin`` (first
    matched poses made equal), "none"; ``align_first_n`` = ``--n_to_align`` (estimate the se3/sim3/scale alignment
    from the first n matched poses only, apply it to all); ``max_diff`` = ``--t_max_diff``; ``offset`` =
    ``--t_offset``; ``sync="interpolate"`` = ``--sync_method interpolation`` (after the association, the trajectory
    with more poses is interpolated -- :func:`interpolate_poses` -- at the matched stamps of the other one instead
    of taking its nearest poses); ``rpe_delta``, ``rpe_unit`` = ``-d``, ``-u f|m``; ``rpe_all_pairs`` = ``--all_pairs``;
    ``rpe_pairs_from_reference`` = ``--pairs_from_reference`` (by default the pairs are chosen on the aligned
    estimate).  RPE is unchanged by a rigid alignment; "sim3"/"scale" rescale the estimate's translations first.
    ``t_start``, ``t_end`` = ``--t_start``, ``--t_end``: only poses with stamps (the estimate's plus ``offset``) in
    ``[t_start, t_end]`` are used.  ``undetermined``: what an alignment the data do not determine against their
    noise does (:func:`~dualpose.evaluation.align.umeyama_alignment`): "raise" or "warn" (flagged in
    ``alignment.conditioning``).

    Both trajectories first go through :func:`prepare_trajectory`: unsorted stamps are sorted and exact duplicate
    poses dropped (each with a ``UserWarning``); the same stamp with two different poses is refused.

    Raises
    ------
    ValueError
        No matching stamps, a degenerate or undetermined alignment
        (:func:`~dualpose.evaluation.align.check_alignment_rank`,
        :func:`~dualpose.evaluation.align.alignment_conditioning`), an
        RPE step that yields no pair, two poses at one stamp, or an empty crop window.
    """
    for name, t in (("reference", reference), ("estimate", estimate)):
        if not isinstance(t, Trajectory):
            raise TypeError(f"{name} must be a dualpose.io.Trajectory; got {type(t).__name__}")
    reference = crop_trajectory(prepare_trajectory(reference, "reference"), t_start, t_end, "reference")
    estimate = crop_trajectory(prepare_trajectory(estimate, "estimate"), t_start, t_end, "estimate", offset)
    idx_ref, idx_est = associate(reference.stamps, estimate.stamps, max_diff, offset)
    p_ref, q_ref = reference.positions[idx_ref], dp.quat_normalize(reference.quats[idx_ref])
    p_est, q_est = estimate.positions[idx_est], dp.quat_normalize(estimate.quats[idx_est])
    stamps = reference.stamps[idx_ref]
    if sync == "interpolate":
        if len(estimate) > len(reference):
            p_est, q_est = interpolate_poses(estimate.stamps, estimate.positions, estimate.quats, stamps - offset)
        else:
            stamps = estimate.stamps[idx_est] + offset
            p_ref, q_ref = interpolate_poses(reference.stamps, reference.positions, reference.quats, stamps)
    elif sync != "nearest":
        raise ValueError(f"sync must be 'nearest' or 'interpolate'; got {sync!r}")
    if align == "origin":
        alignment = origin_alignment(p_ref[0], q_ref[0], p_est[0], q_est[0])
    else:
        n = idx_ref.shape[0]
        if align_first_n is not None:
            if not (int(align_first_n) == align_first_n and align_first_n >= 1):
                raise ValueError(f"align_first_n must be a whole number >= 1 or None; got {align_first_n!r}")
            n = min(int(align_first_n), n)
        alignment = align_positions(p_ref[:n], p_est[:n], align, undetermined)
    p_est, q_est = alignment.apply(p_est, q_est)
    pairs = rpe_pairs(p_ref if rpe_pairs_from_reference else p_est, rpe_delta, rpe_unit, rpe_all_pairs)
    if pairs.shape[0] == 0:
        raise ValueError(
            f"rpe_delta = {rpe_delta} ({rpe_unit}) gives no pose pair among {idx_ref.shape[0]} matched poses; "
            "use a smaller step"
        )
    rpe_t, rpe_r = rpe_errors(p_ref, q_ref, p_est, q_est, pairs)
    settings = {
        "align": align,
        "align_first_n": align_first_n,
        "max_diff": max_diff,
        "offset": offset,
        "sync": sync,
        "rpe_delta": rpe_delta,
        "rpe_unit": rpe_unit,
        "rpe_all_pairs": rpe_all_pairs,
        "rpe_pairs_from_reference": rpe_pairs_from_reference,
        "t_start": t_start,
        "t_end": t_end,
        "reference": reference.name,
        "estimate": estimate.name,
    }
    return Evaluation(
        idx_ref=idx_ref,
        idx_est=idx_est,
        stamps=stamps,
        positions_ref=p_ref,
        quats_ref=q_ref,
        positions_est=p_est,
        quats_est=q_est,
        alignment=alignment,
        ate=ate_errors(p_ref, p_est),
        orientation_deg=orientation_errors_deg(q_ref, q_est),
        rpe_pairs=pairs,
        rpe_translation=rpe_t,
        rpe_rotation_deg=rpe_r,
        settings=settings,
    )
