"""A timestamped pose sequence: the container the readers return and the metrics consume.

Layout: ``stamps`` ``(N,)`` float64 seconds; ``positions`` ``(N, 3)`` metres (the body origin in the world frame);
``quats`` ``(N, 4)`` xyzw Hamilton, the active rotation body -> world (``v_world = q v_body q*``).  When the source
stored integer nanoseconds (EuRoC), ``stamps_ns`` keeps them exactly and ``stamps`` is derived from them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Trajectory", "seconds_from_ns"]


def seconds_from_ns(stamps_ns: ArrayLike) -> np.ndarray:
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
        they need not be exactly unit); the metrics normalise them.  Never zero.
    stamps_ns : ndarray of int64, shape (N,), optional
        Exact integer nanoseconds when the source had them; ``stamps`` then equals ``seconds_from_ns(stamps_ns)``.
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
            finite = np.isfinite(arr).reshape(n, -1).all(axis=1)
            if not finite.all():
                raise ValueError(f"{name} must be finite; first bad pose index {int(np.argmin(finite))}")
        zero = ~(np.abs(quats) > 0.0).any(axis=1)
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
