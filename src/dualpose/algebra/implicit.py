"""Implicit dual quaternions (Dantam 2014 §V): a rigid transform stored as a pair ``(q, t)``.

Layout: ``q`` is a unit quaternion ``(..., 4)`` xyzw (Hamilton, active) and ``t`` a translation ``(..., 3)``; the pair
maps body coordinates to world coordinates, ``p ↦ R(q) p + t`` (eq. (106)), and is the same transform as the
dual quaternion ``[q, ½ t (x) q]`` (Dantam eq. (103); ``dualquat_from_qt``).  Twists are ``(..., 6)`` arrays
``[ω, v]`` with ``exp([[ω×, v], [0, 0]]) = (exp(ω/2), J_l(ω) v)`` (scipy's ``RigidTransform`` exponential
coordinates).

Every function broadcasts over leading axes (``q`` and ``t`` broadcast against each other too), accepts
array-likes and returns float64; a function returning a pair gives both arrays the common batch shape of all its
inputs.  Rotations of vectors use ``q/|q|`` (the ``2/|q|²`` scaling of
:func:`~dualpose.algebra.quat.quat_rotate`); quaternion products keep the norm they are given.  A zero quaternion
where a rotation is needed raises ``ValueError``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose._validation import as_array, call_kernel, call_kernel_pair, raise_if_zero_norm
from dualpose.algebra._fastpath import fast_path

__all__ = [
    "qt_mul",
    "qt_transform",
    "qt_conj",
    "qt_from_twist",
    "twist_from_qt",
    "qt_mul_derivative",
]



@fast_path(_native.qt_mul, nan_declines=True)
def qt_mul(
    q1: ArrayLike, t1: ArrayLike, q2: ArrayLike, t2: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Compose implicit dual quaternions: ``(q1, t1)(q2, t2) = (q1 (x) q2, rot(q1, t2) + t1)``.

    Dantam 2014 eqs. (104)-(105): the same as the dual-quaternion product of eq. (79) and as the 4x4 product
    ``T1 @ T2`` (eq. (111)); ``(q2, t2)`` is applied first.

    Parameters
    ----------
    q1, t1 : array_like, shapes (..., 4) and (..., 3)
        Left transform (e.g. ``T_world_b``), xyzw and translation.
    q2, t2 : array_like, shapes (..., 4) and (..., 3)
        Right transform (e.g. ``T_b_c``).

    Returns
    -------
    q : ndarray, shape (..., 4)
        ``q1 (x) q2`` (signs kept; no canonicalisation).
    t : ndarray, shape (..., 3)
        ``R(q1) t2 + t1``.
    """
    q1 = as_array(q1, "q1", 4)
    t1 = as_array(t1, "t1", 3)
    q2 = as_array(q2, "q2", 4)
    t2 = as_array(t2, "t2", 3)
    q, t = call_kernel_pair(_native.qt_mul, (q1, t1, q2, t2), ("q1", "t1", "q2", "t2"))
    raise_if_zero_norm(t, q1, "q1")
    return q, t


@fast_path(_native.qt_transform, nan_declines=True)
def qt_transform(q: ArrayLike, t: ArrayLike, points: ArrayLike) -> NDArray[np.float64]:
    """Transform points: ``p' = rot(q, p) + t`` (Dantam 2014 eq. (106)).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Rotation, xyzw (normalized inside; zero raises ``ValueError``).
    t : array_like, shape (..., 3)
        Translation.
    points : array_like, shape (..., 3)
        Points in the body (child) frame.

    Returns
    -------
    ndarray, shape (..., 3)
        The points in the world (parent) frame.
    """
    q = as_array(q, "q", 4)
    t = as_array(t, "t", 3)
    p = as_array(points, "points", 3)
    out = call_kernel(_native.qt_transform, (q, t, p), ("q", "t", "points"))
    raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.qt_conj, nan_declines=True)
def qt_conj(q: ArrayLike, t: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Conjugate ``(q*, −rot(q*, t))`` (Dantam 2014 §V-C); the inverse transform for a unit ``q``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Rotation, xyzw (zero raises ``ValueError``).
    t : array_like, shape (..., 3)
        Translation.

    Returns
    -------
    q_conj : ndarray, shape (..., 4)
        ``q* = [−x, −y, −z, w]``.
    t_conj : ndarray, shape (..., 3)
        ``−R(q)ᵀ t``: ``qt_mul(q, t, *qt_conj(q, t))`` is the identity.
    """
    q = as_array(q, "q", 4)
    t = as_array(t, "t", 3)
    qc, tc = call_kernel_pair(_native.qt_conj, (q, t), ("q", "t"))
    raise_if_zero_norm(tc, q, "q")
    return qc, tc


@fast_path(_native.qt_from_twist)
def qt_from_twist(xi: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Exponential of twists as implicit dual quaternions: ``q = exp(ω/2)``, ``t = J_l(ω) v``.

    The pair is ``exp([[ω×, v], [0, 0]])`` (scipy's ``RigidTransform.from_exp_coords``), equivalently the
    dual-quaternion exponential of the pure dual quaternion ``½ (ω + ε v)`` (Dantam 2014 eqs. (50), (85)).

    Parameters
    ----------
    xi : array_like, shape (..., 6)
        Twists ``[ω, v]``: ω in radians (any magnitude), v in length units.

    Returns
    -------
    q : ndarray, shape (..., 4)
        Unit quaternion, xyzw (``w = cos(|ω|/2)``, negative for ``|ω| > π``).
    t : ndarray, shape (..., 3)
        Translation, using the guarded left Jacobian (:func:`~dualpose.algebra.lie.so3_left_jacobian`).
    """
    xi = as_array(xi, "xi", 6)
    result: tuple[NDArray[np.float64], NDArray[np.float64]] = _native.qt_from_twist(xi)
    return result


@fast_path(_native.twist_from_qt, nan_declines=True)
def twist_from_qt(q: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Principal twist ``[ω, v]`` of ``(q, t)``: ``ω = 2 ln(±q)`` with ``|ω| <= π``, ``v = J_l(ω)⁻¹ t``.

    Inverse of :func:`qt_from_twist` on ``|ω| < π`` (scipy's ``RigidTransform.as_exp_coords``).  The sign of
    ``q`` does not matter (``q`` and ``−q`` give the same twist); non-unit ``q`` is treated as ``q/|q|``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Rotation, xyzw (zero raises ``ValueError``).
    t : array_like, shape (..., 3)
        Translation.

    Returns
    -------
    ndarray, shape (..., 6)
        ``[ω, v]``; ω in radians with the atan2 angle of Dantam 2014 eq. (51).
    """
    q = as_array(q, "q", 4)
    t = as_array(t, "t", 3)
    out = call_kernel(_native.twist_from_qt, (q, t), ("q", "t"))
    raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.qt_mul_derivative, nan_declines=True)
def qt_mul_derivative(
    q1: ArrayLike,
    t1: ArrayLike,
    q1dot: ArrayLike,
    t1dot: ArrayLike,
    q2: ArrayLike,
    t2: ArrayLike,
    q2dot: ArrayLike,
    t2dot: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Time derivative of :func:`qt_mul` (Dantam 2014 eq. (107)).

    ``d/dt (q1 (x) q2) = q̇1 (x) q2 + q1 (x) q̇2`` and
    ``d/dt (rot(q1, t2) + t1) = ṫ1 + q̇1 (x) t2 (x) q1* + q1 (x) ṫ2 (x) q1* + q1 (x) t2 (x) q̇1*``.

    The translation part is evaluated on the normalized rotation ``u = q1/|q1|`` with
    ``u̇ = (q̇1 − (u·q̇1) u)/|q1|``, so it is the exact derivative of what :func:`qt_mul` computes for any nonzero
    ``q1``; for a unit ``q1`` with a tangent ``q̇1`` (``q1·q̇1 = 0``, as for ``q̇1 = ½ ω (x) q1``) it is eq. (107)
    literally.

    Parameters
    ----------
    q1, t1, q1dot, t1dot : array_like, shapes (..., 4), (..., 3), (..., 4), (..., 3)
        Left transform and its time derivative (xyzw per second, length per second).
    q2, t2, q2dot, t2dot : array_like, shapes (..., 4), (..., 3), (..., 4), (..., 3)
        Right transform and its time derivative.

    Returns
    -------
    qdot : ndarray, shape (..., 4)
        Derivative of the composed quaternion.
    tdot : ndarray, shape (..., 3)
        Derivative of the composed translation.
    """
    names = ("q1", "t1", "q1dot", "t1dot", "q2", "t2", "q2dot", "t2dot")
    args = tuple(
        as_array(a, n, s)
        for a, n, s in zip((q1, t1, q1dot, t1dot, q2, t2, q2dot, t2dot), names, (4, 3) * 4, strict=True)
    )
    qd, td = call_kernel_pair(_native.qt_mul_derivative, args, names)
    raise_if_zero_norm(td, args[0], "q1")
    return qd, td
