"""Named state blocks: the layouts of every estimator's state vector and covariance, defined once.

A :class:`StateLayout` names contiguous blocks of a vector (and of the rows/columns of its covariance).  Code outside
this module reaches a block by name (``ESKF_STATE.get(x, "quat")``, ``ESKF_ERROR.cov(P, "attitude")``), never by a
literal index.  The native kernels name the same offsets in their layout headers (``src/native/estimation/
*_layout.hpp``), export them as module constants (``dualpose._native.ESKF_QUAT``, ...), and the tests check that
they equal the plain integers below (``ESKF_QUAT`` = the offset of ``"quat"`` in :data:`ESKF_STATE`, ...).

Layouts (quaternions xyzw; ``q_wb`` rotates body vectors into the world frame, Hol's ``q^{be}`` is its conjugate):

==========================  ==========================================================================================
:data:`ESKF_STATE` (16)     ``position`` (3) m, ``velocity`` (3) m/s, ``quat`` (4) ``q_wb``, ``gyro_bias`` (3) rad/s,
                            ``accel_bias`` (3) m/s² (Solà 2017 §5.1)
:data:`ESKF_ERROR` (15)     ``position``, ``velocity``, ``attitude`` (3, local: ``q = q̂ ⊗ Exp(δθ)``), ``gyro_bias``,
                            ``accel_bias`` (Solà 2017 §5.3)
:data:`HOL22_STATE` (22)    ``position`` (3) m, ``velocity`` (3), ``acceleration`` (3) m/s², ``quat_be`` (4) ``q^{be}``,
                            ``angular_velocity`` (3) rad/s (body), ``gyro_bias`` (3), ``accel_bias`` (3) (Hol 2008
                            eq. 8); the covariance has the same layout
:data:`AHRS_STATE` (7)      ``quat`` (4) ``q_wb`` (earth frame ENU), ``gyro_bias`` (3) rad/s
:data:`AHRS_ERROR` (6)      ``attitude`` (3, global: ``q = Exp(δθ) ⊗ q̂``), ``gyro_bias`` (3)
==========================  ==========================================================================================
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "StateLayout",
    "ESKF_STATE",
    "ESKF_ERROR",
    "HOL22_STATE",
    "AHRS_STATE",
    "AHRS_ERROR",
    "MSCKF_CLONE",
    "MSCKF_CLONE_ERROR",
]


class StateLayout:
    """Contiguous named blocks of a vector of length ``dim``.

    Parameters
    ----------
    name : str
        What the vector is (used in error messages).
    blocks : sequence of (str, int)
        Block names and sizes, in order.
    """

    def __init__(self, name: str, blocks: tuple[tuple[str, int], ...]) -> None:
        self.name = name
        self._slices: dict[str, slice] = {}
        start = 0
        for block, size in blocks:
            if block in self._slices or size <= 0:
                raise ValueError(f"{name}: block {block!r} repeated or of size {size}")
            self._slices[block] = slice(start, start + size)
            start += size
        self.dim = start

    def __repr__(self) -> str:
        inner = ", ".join(f"{k}={s.start}:{s.stop}" for k, s in self._slices.items())
        return f"StateLayout({self.name!r}: {inner})"

    @property
    def names(self) -> tuple[str, ...]:
        """Block names in order."""
        return tuple(self._slices)

    @property
    def slices(self) -> Mapping[str, slice]:
        """``{name: slice}`` of every block."""
        return dict(self._slices)

    def slice(self, block: str) -> slice:
        """The slice of ``block``; ``KeyError`` naming the known blocks otherwise."""
        try:
            return self._slices[block]
        except KeyError:
            raise KeyError(f"{self.name} has no block {block!r}; blocks: {', '.join(self._slices)}") from None

    def offset(self, block: str) -> int:
        """First index of ``block``."""
        return int(self.slice(block).start)

    def size(self, block: str) -> int:
        """Length of ``block``."""
        s = self.slice(block)
        return int(s.stop - s.start)

    def get(self, x: ArrayLike, block: str) -> np.ndarray:
        """``x[..., block]`` (a view when ``x`` is an array) of vectors ``x`` of shape ``(..., dim)``."""
        x = np.asarray(x)
        if x.shape[-1:] != (self.dim,):
            raise ValueError(f"{self.name} vectors must have shape (..., {self.dim}); got {x.shape}")
        return x[..., self.slice(block)]

    def cov(self, P: ArrayLike, block: str, other: str | None = None) -> np.ndarray:
        """The ``(block, other)`` sub-matrix (default ``other = block``) of covariances ``P`` ``(..., dim, dim)``."""
        P = np.asarray(P)
        if P.shape[-2:] != (self.dim, self.dim):
            raise ValueError(f"{self.name} covariances must have shape (..., {self.dim}, {self.dim}); got {P.shape}")
        return P[..., self.slice(block), self.slice(block if other is None else other)]

    def assemble(self, **blocks: ArrayLike) -> np.ndarray:
        """A vector ``(dim,)`` from every block given by name (each of its block's size)."""
        missing = set(self._slices) - set(blocks)
        extra = set(blocks) - set(self._slices)
        if missing or extra:
            raise ValueError(f"{self.name}: missing blocks {sorted(missing)}, unknown blocks {sorted(extra)}")
        x = np.empty(self.dim)
        for block, value in blocks.items():
            v = np.asarray(value, dtype=np.float64)
            if v.shape != (self.size(block),):
                raise ValueError(f"{block} must have shape ({self.size(block)},); got {v.shape}")
            x[self.slice(block)] = v
        return x


ESKF_STATE = StateLayout(
    "error-state filter nominal state",
    (("position", 3), ("velocity", 3), ("quat", 4), ("gyro_bias", 3), ("accel_bias", 3)),
)
ESKF_ERROR = StateLayout(
    "error-state filter error state",
    (("position", 3), ("velocity", 3), ("attitude", 3), ("gyro_bias", 3), ("accel_bias", 3)),
)
HOL22_STATE = StateLayout(
    "Hol 22-state",
    (
        ("position", 3),
        ("velocity", 3),
        ("acceleration", 3),
        ("quat_be", 4),
        ("angular_velocity", 3),
        ("gyro_bias", 3),
        ("accel_bias", 3),
    ),
)
AHRS_STATE = StateLayout("AHRS nominal state", (("quat", 4), ("gyro_bias", 3)))
AHRS_ERROR = StateLayout("AHRS error state", (("attitude", 3), ("gyro_bias", 3)))

# ---------------------------------------------------------------------------------------- offsets for the kernels
ESKF_DIM = ESKF_STATE.dim
ESKF_ERROR_DIM = ESKF_ERROR.dim
ESKF_POSITION = ESKF_STATE.offset("position")
ESKF_VELOCITY = ESKF_STATE.offset("velocity")
ESKF_QUAT = ESKF_STATE.offset("quat")
ESKF_GYRO_BIAS = ESKF_STATE.offset("gyro_bias")
ESKF_ACCEL_BIAS = ESKF_STATE.offset("accel_bias")
ESKF_D_POSITION = ESKF_ERROR.offset("position")
ESKF_D_VELOCITY = ESKF_ERROR.offset("velocity")
ESKF_D_ATTITUDE = ESKF_ERROR.offset("attitude")
ESKF_D_GYRO_BIAS = ESKF_ERROR.offset("gyro_bias")
ESKF_D_ACCEL_BIAS = ESKF_ERROR.offset("accel_bias")

HOL22_DIM = HOL22_STATE.dim
HOL22_POSITION = HOL22_STATE.offset("position")
HOL22_VELOCITY = HOL22_STATE.offset("velocity")
HOL22_ACCELERATION = HOL22_STATE.offset("acceleration")
HOL22_QUAT_BE = HOL22_STATE.offset("quat_be")
HOL22_ANGULAR_VELOCITY = HOL22_STATE.offset("angular_velocity")
HOL22_GYRO_BIAS = HOL22_STATE.offset("gyro_bias")
HOL22_ACCEL_BIAS = HOL22_STATE.offset("accel_bias")

AHRS_ERROR_DIM = AHRS_ERROR.dim
AHRS_D_ATTITUDE = AHRS_ERROR.offset("attitude")
AHRS_D_GYRO_BIAS = AHRS_ERROR.offset("gyro_bias")

#: a clone of the IMU pose in the MSCKF window (:mod:`dualpose.estimation.msckf`): ``position`` p_wb (3) m, ``quat``
#: q_wb (4) xyzw, and its error (local attitude error, as :data:`ESKF_ERROR`)
MSCKF_CLONE = StateLayout("MSCKF clone", (("position", 3), ("quat", 4)))
MSCKF_CLONE_ERROR = StateLayout("MSCKF clone error", (("position", 3), ("attitude", 3)))
