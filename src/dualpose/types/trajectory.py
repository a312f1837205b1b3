"""A timestamped pose sequence: the container the readers return and the metrics consume.

Layout: ``stamps`` ``(N,)`` float64 seconds; ``positions`` ``(N, 3)`` metres (the body origin in the world frame);
``quats`` ``(N, 4)`` xyzw Hamilton, the active rotation body -> world (``v_world = q v_body q*``).  When the source
stored integer nanoseconds (EuRoC), ``stamps_ns`` keeps them exactly and ``stamps`` is derived from them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose.types import _inputs

__all__ = ["Trajectory", "seconds_from_ns", "interpolate_poses", "as_positions", "as_quats", "check_same_length"]


def seconds_from_ns(stamps_ns: ArrayLike) -> NDArray[np.float64]:
    """Integer nanoseconds ``(N,)`` int64 -> float64 seconds ``(N,)``.

    The whole seconds and the nanosecond remainder are converted separately, so the only rounding is the final
    float64 sum (float64 has ~0.24 µs resolution at 1.4e9 s); ``ns / 1e9`` would round the 19-digit integer first.
    """
    ns = np.asarray(stamps_ns)
    if ns.dtype.kind not in "iu":
        raise TypeError(f"stamps_ns must be an integer array; got dtype {ns.dtype}")
    ns = ns.astype(np.int64, copy=False)
    whole, frac = np.divmod(ns, 1_000_000_000)
    return whole.astype(np.float64) + frac.astype(np.float64) * 1e-9


@dataclass(frozen=True)
class Trajectory:
    """Timestamped poses.

    Attributes
    ----------
    stamps : ndarray, shape (N,)
        Seconds (float64).
    positions : ndarray, shape (N, 3)
        Positions of the body in the world frame, metres.
    quats : ndarray, shape (N, 4)
        Orientations body -> world, xyzw, Hamilton.  Stored as given (files often round them to a few digits, so
        they need not be exactly unit); the metrics normalize them.  Never zero.
    stamps_ns : ndarray of int64, shape (N,), optional
        Exact integer nanoseconds when the source had them; ``stamps`` then equals ``seconds_from_ns(stamps_ns)``
        (refused when not, to half a nanosecond plus the float's rounding: the two repeat one time).
    name : str
        A label (usually the file path).
    extra : mapping of str -> ndarray with leading dimension N
        Further per-pose columns a format carries (EuRoC ground truth: ``velocity``, ``gyro_bias``,
        ``accel_bias``, each (N, 3)).
    """

    stamps: np.ndarray
    positions: np.ndarray
    quats: np.ndarray
    stamps_ns: np.ndarray | None = None
    name: str = ""
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        stamps = np.asarray(self.stamps, dtype=np.float64)
        positions = np.asarray(self.positions, dtype=np.float64)
        quats = np.asarray(self.quats, dtype=np.float64)
        if stamps.ndim != 1:
            raise ValueError(f"stamps must have shape (N,); got shape {stamps.shape}")
        n = stamps.shape[0]
        if positions.shape != (n, 3):
            raise ValueError(f"positions must have shape (N, 3) = ({n}, 3); got shape {positions.shape}")
        if quats.shape != (n, 4):
            raise ValueError(f"quats must have shape (N, 4) = ({n}, 4) (xyzw); got shape {quats.shape}")
        for name, arr in (("stamps", stamps), ("positions", positions), ("quats", quats)):
            if not np.isfinite(arr).all():  # n = 0 is allowed
                finite = np.isfinite(arr).reshape(n, -1).all(axis=1)
                raise ValueError(f"{name} must be finite; first bad pose index {int(np.argmin(finite))}")
        if n and not np.einsum("ij,ij->i", quats, quats).all():  # |q|^2 of a finite nonzero q can underflow to 0 only
            zero = ~(quats != 0.0).any(axis=1)  # below 1e-154; check the components then
            if zero.any():
                raise ValueError(f"quats must be nonzero; pose index {int(np.argmax(zero))} is [0, 0, 0, 0]")
        object.__setattr__(self, "stamps", stamps)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "quats", quats)
        if self.stamps_ns is not None:
            ns = np.asarray(self.stamps_ns)
            if ns.dtype.kind not in "iu" or ns.shape != (n,):
                raise ValueError(f"stamps_ns must be an integer array of shape ({n},); got {ns.dtype} {ns.shape}")
            object.__setattr__(self, "stamps_ns", ns.astype(np.int64, copy=False))
            _inputs.check_stamps_agree(stamps, self.stamps_ns)  # two fields, one time (docs/refusals.md)
        extra = {}
        for key, arr in dict(self.extra).items():
            arr = np.asarray(arr)
            if arr.shape[:1] != (n,):
                raise ValueError(f"extra[{key!r}] must have leading dimension N = {n}; got shape {arr.shape}")
            extra[key] = arr
        object.__setattr__(self, "extra", extra)

    def __len__(self) -> int:
        return int(self.stamps.shape[0])

    def take(self, indices: ArrayLike) -> Trajectory:
        """The poses at ``indices`` (integer array, repeats allowed), as a new trajectory."""
        idx = np.asarray(indices, dtype=np.intp)
        return Trajectory(
            self.stamps[idx],
            self.positions[idx],
            self.quats[idx],
            None if self.stamps_ns is None else self.stamps_ns[idx],
            self.name,
            {k: v[idx] for k, v in self.extra.items()},
        )


def as_positions(x: ArrayLike, name: str) -> NDArray[np.float64]:
    """``x`` as finite float64 positions (N, 3), metres; errors name ``name``."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3); got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite")
    return a


def as_quats(x: ArrayLike, name: str) -> NDArray[np.float64]:
    """``x`` as finite quaternions (N, 4) xyzw, normalized to unit length; errors name ``name``."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 4:
        raise ValueError(f"{name} must have shape (N, 4) (xyzw); got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite")
    return dp.quat_normalize(a)


def check_same_length(**arrays: np.ndarray) -> None:
    """Raise a ValueError naming the arrays when their leading lengths differ."""
    sizes = {k: v.shape[0] for k, v in arrays.items()}
    if len(set(sizes.values())) != 1:
        raise ValueError(f"matched arrays must have the same length N; got {sizes}")


def interpolate_poses(
    stamps: ArrayLike, positions: ArrayLike, quats: ArrayLike, at: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Poses of a trajectory at other times: linear in position, slerp in orientation.

    Parameters
    ----------
    stamps : array_like, shape (N,)
        Seconds, non-decreasing, N >= 2.
    positions : array_like, shape (N, 3)
    quats : array_like, shape (N, 4)
        xyzw.
    at : array_like, shape (K,)
        Query times, seconds.  Times outside ``[stamps[0], stamps[-1]]`` get the first / last pose (no
        extrapolation); between two equal stamps the earlier pose is used.

    Returns
    -------
    positions : ndarray, shape (K, 3)
    quats : ndarray, shape (K, 4)
        Unit, xyzw (:func:`dualpose.quat_slerp` on the shorter arc).
    """
    t = np.asarray(stamps, dtype=np.float64)
    p = as_positions(positions, "positions")
    q = as_quats(quats, "quats")
    x = np.asarray(at, dtype=np.float64)
    if t.ndim != 1 or t.shape[0] < 2:
        raise ValueError(f"stamps must have shape (N,) with N >= 2; got shape {t.shape}")
    check_same_length(stamps=t, positions=p, quats=q)
    if np.any(np.diff(t) < 0):
        raise ValueError("stamps must be sorted (non-decreasing) to interpolate")
    if x.ndim != 1 or not np.isfinite(x).all():
        raise ValueError(f"at must be a finite array of shape (K,); got shape {x.shape}")
    k = np.clip(np.searchsorted(t, x, side="left"), 1, t.shape[0] - 1)
    dt = t[k] - t[k - 1]
    frac = np.where(dt > 0.0, (x - t[k - 1]) / np.where(dt > 0.0, dt, 1.0), 0.0)
    frac = np.clip(frac, 0.0, 1.0)
    pos = p[k - 1] + frac[:, None] * (p[k] - p[k - 1])
    return pos, dp.quat_slerp(q[k - 1], q[k], frac)
