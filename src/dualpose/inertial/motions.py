"""Exact rigid motions for validating the inertial update algorithms (docs/inertial.md §3).

Every motion gives the pose ``q̂(t) = q(t) + ε ½ t^i(t) (x) q(t)`` (``(..., 8)``, ``q = q_b^i`` xyzw), the twist
(``(..., 6)`` = ``[ω, v]``) and the increments ``∫ [ω, v] dt`` over consecutive sub-intervals:

* ``frame="body"``: ``ω^b`` and ``v^b = q* ṫ^i q`` (``q̂̇ = ½ q̂ (x) [ω^b, v^b]``);
* ``frame="space"``: ``ω^i = q ω^b q*`` and ``v_s = ṫ^i − ω^i × t^i`` (``q̂̇ = ½ [ω^i, v_s] (x) q̂``).

:class:`Coning` has closed-form increments; :class:`Trajectory` integrates any smooth twist by Gauss–Legendre
quadrature (``nodes`` points per sub-interval, exact for polynomials of degree ``2·nodes − 1``).
"""

from __future__ import annotations

import abc
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp

__all__ = ["Motion", "Coning", "ConstantTwist", "SmoothTrajectory", "sample_times", "coning_drift"]

#: ρ_N of the coning drift ``ρ_N a² Ω (ΩT)^{2N}`` of the N-sample coning-optimal algorithm (docs/inertial.md §3)
CONING_RHO = {1: 1 / 12, 2: 1 / 960, 3: 1 / 204120, 4: 1 / 82575360}

Frame = Literal["body", "space"]
#: an ``(M, 3)`` table of parameters as nested tuples (one row per harmonic)
_Rows = tuple[tuple[float, float, float], ...]


def sample_times(t0: float, h: float, n: int) -> NDArray[np.float64]:
    """Boundaries ``t0 + j h``, j = 0..n (shape (n+1,)), of n sub-intervals of length h (seconds)."""
    if not (h > 0 and math.isfinite(h)):
        raise ValueError(f"h must be a positive finite step in seconds; got {h!r}")
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or n < 1:
        raise ValueError(f"n must be a positive integer number of sub-intervals; got {n!r}")
    return t0 + h * np.arange(n + 1, dtype=np.float64)


def coning_drift(a: float, Omega: float, T: float, samples: int) -> float:
    """Predicted drift rate (rad/s, about the cone axis) of the N-sample coning-optimal algorithm.

    ``ε_N = ρ_N a² Ω (ΩT)^{2N}`` (docs/inertial.md §3; Ignagni 1990), the leading term for small ``a`` and ``ΩT``; the
    dual-part drift of dual coning is its ``d ∂/∂a``, ``2 a d ρ_N Ω (ΩT)^{2N}`` (m/s).
    """
    return CONING_RHO[samples] * a * a * Omega * (Omega * T) ** (2 * samples)


def _check_frame(frame: str) -> bool:
    if frame not in ("body", "space"):
        raise ValueError(f"frame must be 'body' or 'space'; got {frame!r}")
    return frame == "body"


class Motion(abc.ABC):
    """Base class: subclasses give ``pose(t)`` and ``twist(t)``; increments come from quadrature."""

    nodes: int = 8

    @abc.abstractmethod
    def pose(self, t: ArrayLike) -> NDArray[np.float64]:
        """Pose dual quaternion at times ``t`` (seconds), shape ``t.shape + (8,)``."""

    @abc.abstractmethod
    def twist(self, t: ArrayLike, frame: Frame = "body") -> NDArray[np.float64]:
        """Twist ``[ω, v]`` (rad/s, m/s) at times ``t``, shape ``t.shape + (6,)``, in ``frame`` (module doc)."""

    def attitude(self, t: ArrayLike) -> NDArray[np.float64]:
        """Attitude ``q_b^i`` (xyzw) at times ``t``, shape ``t.shape + (4,)``."""
        return self.pose(t)[..., :4]

    def position(self, t: ArrayLike) -> NDArray[np.float64]:
        """Origin position ``t^i`` (metres) at times ``t``, shape ``t.shape + (3,)``."""
        return dp.qt_from_dualquat(self.pose(t))[1]

    def dual_increments(self, t0: float, h: float, n: int, frame: Frame = "body") -> NDArray[np.float64]:
        """``∫ [ω, v] dt`` over ``[t0 + j h, t0 + (j+1) h]``, j = 0..n−1: shape (n, 6) (rad, m).

        Gauss–Legendre quadrature with ``nodes`` points per sub-interval.
        """
        edges = sample_times(t0, h, n)
        x, w = np.polynomial.legendre.leggauss(self.nodes)
        mid = 0.5 * (edges[:-1] + edges[1:])
        t = mid[:, None] + 0.5 * h * x[None, :]
        result: NDArray[np.float64] = 0.5 * h * np.einsum("m,nmk->nk", w, self.twist(t, frame))
        return result

    def increments(self, t0: float, h: float, n: int, frame: Frame = "body") -> NDArray[np.float64]:
        """Angle increments ``∫ ω dt`` (rad), shape (n, 3): the first three columns of :meth:`dual_increments`."""
        return self.dual_increments(t0, h, n, frame)[:, :3]


@dataclass(frozen=True)
class Coning(Motion):
    """Classical (``d = 0``) or dual coning about x: half-angle ``a`` (rad), rate ``Omega`` (rad/s), radius ``d`` (m).

    ``q(t) = (0, sin(a/2) cos Ωt, sin(a/2) sin Ωt, cos(a/2))`` (xyzw) and, with the dual angle ``a + εd``,
    ``q̂(t) = q(a) + ε d ∂q/∂a``: the origin moves on the circle ``t^i = d (0, cos Ωt, sin Ωt)`` (docs/inertial.md §3).
    Body rate ``ω^b = Ω (−2 sin²(a/2), −sin a sin Ωt, sin a cos Ωt)``; inertial rate
    ``ω^i = Ω (2 sin²(a/2), −sin a sin Ωt, sin a cos Ωt)``; the velocities are the dual parts,
    ``v = d ∂ω/∂a`` (principle of transference).  Increments are in closed form.
    """

    a: float
    Omega: float
    d: float = 0.0

    def pose(self, t: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        s, c = math.sin(0.5 * self.a), math.cos(0.5 * self.a)
        ct, st = np.cos(self.Omega * t), np.sin(self.Omega * t)
        z = np.zeros_like(t)
        real = np.stack([z, s * ct, s * st, c + z], axis=-1)
        hd = 0.5 * self.d
        dual = np.stack([z, hd * c * ct, hd * c * st, -hd * s + z], axis=-1)
        return np.concatenate([real, dual], axis=-1)

    def _terms(self, frame: Frame) -> tuple[float, float, float, float]:
        """(x-rate, its a-derivative, yz amplitude, its a-derivative), each without the factor Ω."""
        sx = -1.0 if _check_frame(frame) else 1.0
        return sx * 2.0 * math.sin(0.5 * self.a) ** 2, sx * math.sin(self.a), math.sin(self.a), math.cos(self.a)

    def twist(self, t: ArrayLike, frame: Frame = "body") -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        x, dx, yz, dyz = self._terms(frame)
        om, d = self.Omega, self.d
        ct, st = np.cos(om * t), np.sin(om * t)
        one = np.ones_like(t)
        return om * np.stack([x * one, -yz * st, yz * ct, d * dx * one, -d * dyz * st, d * dyz * ct], axis=-1)

    def dual_increments(self, t0: float, h: float, n: int, frame: Frame = "body") -> NDArray[np.float64]:
        """Exact: ``(x Ωh, −2 A sin(Ωh/2) sin Ω(t+h/2), 2 A sin(Ωh/2) cos Ω(t+h/2))`` and its d ∂/∂a."""
        edges = sample_times(t0, h, n)
        mid = edges[:-1] + 0.5 * h
        x, dx, yz, dyz = self._terms(frame)
        om, d = self.Omega, self.d
        g = 2.0 * math.sin(0.5 * om * h)
        sm, cm = np.sin(om * mid), np.cos(om * mid)
        one = np.ones_like(mid)
        return np.stack(
            [x * om * h * one, -g * yz * sm, g * yz * cm, d * dx * om * h * one, -g * d * dyz * sm, g * d * dyz * cm],
            axis=-1,
        )


@dataclass(frozen=True)
class ConstantTwist(Motion):
    """Constant twist ``[ω, v]`` from ``dq0``: ``q̂(t) = q̂0 (x) exp(t ω̂/2)`` (body) or ``exp(t ω̂/2) (x) q̂0``.

    ``twist`` is ``(6,)`` (rad/s, m/s); ``dq0`` is ``(8,)``; every N-sample algorithm is exact for it.
    """

    twist_vector: tuple[float, float, float, float, float, float]
    dq0: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0)
    frame: Frame = "body"

    def pose(self, t: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        step = dp.dualquat_from_twist(t[..., None] * np.asarray(self.twist_vector))
        dq0 = np.asarray(self.dq0, dtype=float)
        return dp.dualquat_mul(dq0, step) if _check_frame(self.frame) else dp.dualquat_mul(step, dq0)

    def twist(self, t: ArrayLike, frame: Frame = "body") -> NDArray[np.float64]:
        if frame != self.frame:
            raise ValueError(f"this ConstantTwist is constant in the {self.frame!r} frame; got frame={frame!r}")
        t = np.asarray(t, dtype=float)
        result: NDArray[np.float64] = np.broadcast_to(np.asarray(self.twist_vector, dtype=float), (*t.shape, 6)).copy()
        return result

    def dual_increments(self, t0: float, h: float, n: int, frame: Frame = "body") -> NDArray[np.float64]:
        """Exact: every row is ``h [ω, v]``."""
        sample_times(t0, h, n)
        return self.twist(np.zeros(n), frame) * h


@dataclass(frozen=True)
class SmoothTrajectory(Motion):
    """General smooth motion: rotation vector and position are sums of sinusoids (no closed-form increments).

    ``r(t) = Σ_m A_m sin(f_m t + p_m)`` (per axis, rad; keep ``|r| < π``) gives ``q(t) = exp(r(t)/2)`` and
    ``t^i(t) = Σ_m B_m sin(g_m t + c_m)`` (m).  Rates come from the exact derivatives
    (:func:`dualpose.quat_derivative_from_rotvec_rate`); increments use Gauss–Legendre quadrature.

    Parameters are ``(M, 3)`` arrays given as nested tuples: ``rot_amp``, ``rot_freq`` (rad/s), ``rot_phase`` and
    ``pos_amp``, ``pos_freq``, ``pos_phase``.
    """

    rot_amp: _Rows = ((0.6, 0.4, 0.5), (0.2, 0.3, 0.1))
    rot_freq: _Rows = ((0.7, 1.1, 0.9), (2.3, 1.9, 2.9))
    rot_phase: _Rows = ((0.1, 0.5, 1.0), (0.3, 0.2, 0.7))
    pos_amp: _Rows = ((2.0, 1.5, 0.5), (0.3, 0.2, 0.4))
    pos_freq: _Rows = ((0.5, 0.8, 1.3), (2.1, 1.7, 2.5))
    pos_phase: _Rows = ((0.0, 1.0, 0.4), (0.9, 0.1, 0.6))
    nodes: int = 8

    @staticmethod
    def _series(
        t: np.ndarray, amp: _Rows, freq: _Rows, phase: _Rows,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        a, f, p = (np.asarray(x, dtype=float) for x in (amp, freq, phase))
        arg = t[..., None, None] * f + p
        return (a * np.sin(arg)).sum(axis=-2), (a * f * np.cos(arg)).sum(axis=-2)

    def pose(self, t: ArrayLike) -> NDArray[np.float64]:
        t = np.asarray(t, dtype=float)
        r, _ = self._series(t, self.rot_amp, self.rot_freq, self.rot_phase)
        p, _ = self._series(t, self.pos_amp, self.pos_freq, self.pos_phase)
        return dp.dualquat_from_qt(dp.quat_from_rotvec(r), p)

    def twist(self, t: ArrayLike, frame: Frame = "body") -> NDArray[np.float64]:
        body = _check_frame(frame)
        t = np.asarray(t, dtype=float)
        r, rdot = self._series(t, self.rot_amp, self.rot_freq, self.rot_phase)
        p, pdot = self._series(t, self.pos_amp, self.pos_freq, self.pos_phase)
        q = dp.quat_from_rotvec(r)
        qdot = dp.quat_derivative_from_rotvec_rate(r, rdot)
        if body:
            w = 2.0 * dp.quat_mul(dp.quat_conj(q), qdot)[..., :3]
            v = dp.quat_rotate(dp.quat_conj(q), pdot)
        else:
            w = 2.0 * dp.quat_mul(qdot, dp.quat_conj(q))[..., :3]
            v = pdot - np.cross(w, p)
        return np.concatenate([w, v], axis=-1)
