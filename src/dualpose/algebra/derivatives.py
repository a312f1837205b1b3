"""Quaternion calculus: angular velocity and acceleration, derivatives of exp and log, rotation-vector rates.

Layouts: quaternions and their time derivatives are ``(..., 4)`` arrays xyzw (Hamilton; per second for ``q̇``,
per second² for ``q̈``); angular velocities ``ω`` are ``(..., 3)`` in rad/s, accelerations ``ω̇`` in rad/s²;
rotation vectors ``(..., 3)`` in radians.  Vectors enter products as pure quaternions ``[ω, 0]``.

Frames (as :func:`~dualpose.algebra.quat.quat_integrate`): ``q`` maps body to world coordinates.

* ``frame="space"``: ``ω`` is expressed in the world (space) frame and ``q̇ = ½ ω (x) q`` (Dantam 2014 eq. (46)).
* ``frame="body"``: ``ω`` is expressed in the body frame (a gyroscope reading) and ``q̇ = ½ q (x) ω``.
  ``ω_space = R(q) ω_body``.

Jacobians are ``(..., 4, 4)`` with ``J[..., i, j] = ∂out_i / ∂q_j``, rows and columns in xyzw order.

Every function broadcasts over leading axes, accepts array-likes and returns float64.  Removable singularities
(the identity, tiny angles down to 1e-300) use the guarded series of :mod:`dualpose.algebra.series`; no NaN is
produced at the identity.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose._validation import as_array, call_kernel, raise_if_zero_norm
from dualpose.algebra._fastpath import fast_path

__all__ = [
    "quat_derivative",
    "omega_from_quat_derivative",
    "quat_second_derivative",
    "angular_acceleration_from_quat",
    "quat_exp_derivative",
    "quat_exp_jacobian",
    "quat_log_jacobian",
    "quat_log_derivative",
    "quat_derivative_from_rotvec_rate",
    "omega_from_rotvec_rate",
    "rotvec_rate_from_omega",
]


Frame = Literal["space", "body"]


def _body_flag(frame: str) -> float:
    if frame == "space":
        return 0.0
    if frame == "body":
        return 1.0
    raise ValueError(f"frame must be 'space' or 'body'; got {frame!r}")


@fast_path(_native.quat_derivative, fixed=(0.0,))
def quat_derivative(q: ArrayLike, omega: ArrayLike, frame: Frame = "space") -> NDArray[np.float64]:
    """Quaternion time derivative of a rotating frame: ``q̇ = ½ ω (x) q`` (space) or ``½ q (x) ω`` (body).

    Dantam 2014 eq. (46) (space frame); the body-frame form follows from ``ω_space = q (x) ω_body (x) q*``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Orientation (body -> world), xyzw.  Used as given (a non-unit ``q`` scales ``q̇``).
    omega : array_like, shape (..., 3)
        Angular velocity, rad/s, expressed in ``frame``.
    frame : {"space", "body"}

    Returns
    -------
    ndarray, shape (..., 4)
        ``q̇``, xyzw per second; tangent to the unit sphere (``q·q̇ = 0``).
    """
    q = as_array(q, "q", 4)
    omega = as_array(omega, "omega", 3)
    return call_kernel(_native.quat_derivative, (q, omega, _body_flag(frame)), ("q", "omega"))


@fast_path(_native.omega_from_quat_derivative, nan_declines=True, fixed=(0.0,))
def omega_from_quat_derivative(q: ArrayLike, qdot: ArrayLike, frame: Frame = "space") -> NDArray[np.float64]:
    """Angular velocity from a quaternion derivative: ``ω = 2 vec(q̇ (x) q*) / |q|²`` (space) or
    ``2 vec(q* (x) q̇) / |q|²`` (body).

    Dantam 2014 eq. (47) for unit ``q``.  Dividing by ``|q|²`` makes it the angular velocity of ``q/|q|`` for
    any nonzero ``q`` (a radial component of ``q̇`` only changes the scalar part, which is dropped).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Orientation, xyzw (zero raises ``ValueError``).
    qdot : array_like, shape (..., 4)
        Its time derivative, xyzw per second.
    frame : {"space", "body"}
        Frame in which ``ω`` is expressed.

    Returns
    -------
    ndarray, shape (..., 3)
        ``ω``, rad/s.
    """
    q = as_array(q, "q", 4)
    qdot = as_array(qdot, "qdot", 4)
    out = call_kernel(_native.omega_from_quat_derivative, (q, qdot, _body_flag(frame)), ("q", "qdot"))
    raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.quat_second_derivative, fixed=(0.0,))
def quat_second_derivative(
    q: ArrayLike, omega: ArrayLike, omega_dot: ArrayLike, frame: Frame = "space"
) -> NDArray[np.float64]:
    """Second time derivative ``q̈ = ½ (ω̇ (x) q + ω (x) q̇)`` with ``q̇ = ½ ω (x) q`` (Dantam 2014 eq. (48)).

    In the body frame ``q̈ = ½ (q̇ (x) ω + q (x) ω̇)`` with ``q̇ = ½ q (x) ω``.  Both equal
    ``½ ω̇ ⊗ q − ¼ |ω|² q`` (resp. ``½ q ⊗ ω̇ − ¼ |ω|² q``).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Orientation, xyzw (used as given).
    omega : array_like, shape (..., 3)
        Angular velocity, rad/s, in ``frame``.
    omega_dot : array_like, shape (..., 3)
        Angular acceleration, rad/s², in ``frame`` (the time derivative of the components of ``omega`` in that
        frame; ``ω̇_space = R ω̇_body``).
    frame : {"space", "body"}

    Returns
    -------
    ndarray, shape (..., 4)
        ``q̈``, xyzw per second².
    """
    q = as_array(q, "q", 4)
    omega = as_array(omega, "omega", 3)
    omega_dot = as_array(omega_dot, "omega_dot", 3)
    return call_kernel(
        _native.quat_second_derivative, (q, omega, omega_dot, _body_flag(frame)), ("q", "omega", "omega_dot")
    )


@fast_path(_native.angular_acceleration_from_quat, nan_declines=True, fixed=(0.0,))
def angular_acceleration_from_quat(
    q: ArrayLike, qdot: ArrayLike, qddot: ArrayLike, frame: Frame = "space"
) -> NDArray[np.float64]:
    """Angular acceleration from ``q, q̇, q̈``: the time derivative of :func:`omega_from_quat_derivative`.

    For unit ``q`` this is Dantam 2014 eq. (49), ``ω̇ = 2 (q̈ (x) q* + q̇ (x) q̇*)`` (whose second term is the real
    scalar ``|q̇|²``, so ``ω̇ = 2 vec(q̈ (x) q*)``; the printed "½ ω̇ =" is a typo).  In general
    ``ω̇ = (2/|q|²) [vec(q̈ (x) q*) − (2 q·q̇/|q|²) vec(q̇ (x) q*)]`` (space), and the same with ``q* (x) ·`` for
    the body frame.

    Parameters
    ----------
    q, qdot, qddot : array_like, shape (..., 4)
        Orientation (xyzw, zero raises ``ValueError``) and its first and second time derivatives.
    frame : {"space", "body"}
        Frame in which ``ω̇`` is expressed.

    Returns
    -------
    ndarray, shape (..., 3)
        ``ω̇``, rad/s².
    """
    q = as_array(q, "q", 4)
    qdot = as_array(qdot, "qdot", 4)
    qddot = as_array(qddot, "qddot", 4)
    out = call_kernel(
        _native.angular_acceleration_from_quat, (q, qdot, qddot, _body_flag(frame)), ("q", "qdot", "qddot")
    )
    raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.quat_exp_derivative)
def quat_exp_derivative(q: ArrayLike, qdot: ArrayLike) -> NDArray[np.float64]:
    """Time derivative of the exponential of a general quaternion, ``d/dt exp(q(t))``.

    With ``q = [v, w]`` and ``φ = |v|`` (Dantam 2014 eqs. (32)-(37) for the pure part, times ``e^w``)::

        d/dt e^q = ẇ e^q + e^w [ sinc(φ) v̇ + dsinc(φ) (v·v̇) v ,  −(v·v̇) sinc(φ) ]

    where ``dsinc(φ) = (φ cos φ − sin φ)/φ³`` is eq. (37)'s guarded series.  Note that this is *not*
    ``q̇ (x) e^q`` (eq. (31)).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Exponent, xyzw (any quaternion).
    qdot : array_like, shape (..., 4)
        Its time derivative.

    Returns
    -------
    ndarray, shape (..., 4)
        ``d/dt exp(q)``, xyzw; equal to ``quat_exp_jacobian(q) @ qdot``.
    """
    q = as_array(q, "q", 4)
    qdot = as_array(qdot, "qdot", 4)
    return call_kernel(_native.quat_exp_derivative, (q, qdot), ("q", "qdot"))


@fast_path(_native.quat_exp_jacobian)
def quat_exp_jacobian(q: ArrayLike) -> NDArray[np.float64]:
    """Jacobian of the quaternion exponential (Dantam 2014 eq. (22)) at ``q = [v, w]``.

    In block form::

        ∂e^q/∂q = e^w [[sinc(φ) I + dsinc(φ) v vᵀ,  sinc(φ) v],
                       [−sinc(φ) vᵀ,                cos φ   ]],     φ = |v|

    Parameters
    ----------
    q : array_like, shape (..., 4)
        xyzw.

    Returns
    -------
    ndarray, shape (..., 4, 4)
        ``J[..., i, j] = ∂(e^q)_i/∂q_j`` (xyzw rows and columns).
    """
    q = as_array(q, "q", 4)
    result: NDArray[np.float64] = _native.quat_exp_jacobian(q)
    return result


@fast_path(_native.quat_log_jacobian, nan_declines=True)
def quat_log_jacobian(q: ArrayLike) -> NDArray[np.float64]:
    """Jacobian of the principal quaternion logarithm (Dantam 2014 eq. (26)) at a general nonzero ``q``.

    With ``q = [v, w]``, ``n = |q|``, ``s = |v|``, ``φ = atan2(s, w)``, ``ln q = [g v, ln n]`` where
    ``g = φ/s`` (:func:`~dualpose.algebra.series.atan2c`).  Differentiating (``∂φ/∂s = w/n²``, ``∂φ/∂w = −s/n²``)::

        ∂ ln q/∂q = [[g I + (A/n³) v vᵀ,  −v/n²],
                     [vᵀ/n²,               w/n²]],     A = (cos φ sin φ − φ)/sin³ φ

    ``A`` is :func:`~dualpose.algebra.series.dqalpha` (−2/3 at the identity; pole at φ = π).  On the negative
    real axis (``v = 0, w < 0``) the logarithm is discontinuous and the result is NaN; approaching it the entries
    grow like ``1/sin³φ``.  For ``w <= 0``, ``A`` is evaluated as ``(ŵ ŝ − φ)/ŝ³`` with ``ŝ = s/n``, ``ŵ = w/n``
    (no cancellation there, and no loss through ``sin(φ)`` near π).

    Relation to Dantam 2014 eq. (41): Dantam's 3x4 matrix differentiates ``acos(w)/|v| · v`` (the unit-log
    formula of eq. (29), treating ``φ = acos(w)`` as a function of ``w`` only), which differs from the rows above
    off the unit sphere.  For ``|q| = 1`` and a tangent direction (``v·v̇ + w ẇ = 0``) the two give the same
    vector part, and the scalar row above gives 0 (``ln|q|`` stays 0); eq. (41)'s entries ``φ/sin³φ`` and
    ``1/sin²φ`` are singular at the identity, while these are not.  Equivalently, for unit ``q`` the vector part
    is eqs. (38)-(39): ``g v̇ + dlogc(φ) ẇ v``.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        xyzw; zero raises ``ValueError``.

    Returns
    -------
    ndarray, shape (..., 4, 4)
        ``J[..., i, j] = ∂(ln q)_i/∂q_j`` (xyzw rows and columns).
    """
    q = as_array(q, "q", 4)
    out = _native.quat_log_jacobian(q)
    raise_if_zero_norm(out, q, "q")
    value: NDArray[np.float64] = out
    return value


@fast_path(_native.quat_log_derivative, nan_declines=True)
def quat_log_derivative(q: ArrayLike, qdot: ArrayLike) -> NDArray[np.float64]:
    """Time derivative of the principal logarithm, ``d/dt ln q(t) = quat_log_jacobian(q) @ q̇``.

    Dantam 2014 eqs. (38)-(40) for unit ``q`` (see :func:`quat_log_jacobian` for the general form and its
    relation to eq. (41)); no singularity at the identity.

    Parameters
    ----------
    q : array_like, shape (..., 4)
        xyzw; zero raises ``ValueError``.
    qdot : array_like, shape (..., 4)
        Its time derivative.

    Returns
    -------
    ndarray, shape (..., 4)
        ``d/dt ln q``, xyzw (the scalar part is ``d/dt ln|q| = q·q̇/|q|²``).
    """
    q = as_array(q, "q", 4)
    qdot = as_array(qdot, "qdot", 4)
    out = call_kernel(_native.quat_log_derivative, (q, qdot), ("q", "qdot"))
    raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.quat_derivative_from_rotvec_rate)
def quat_derivative_from_rotvec_rate(rotvec: ArrayLike, rotvec_dot: ArrayLike) -> NDArray[np.float64]:
    """``q̇`` of ``q = exp(v/2)`` (:func:`~dualpose.algebra.quat.quat_from_rotvec`) given ``v`` and ``v̇``.

    Dantam 2014 eqs. (54)-(57), with ``y = v/2``, ``ẏ = v̇/2``, ``φ = |y|``::

        q̇_v = sinc(φ) ẏ + dsinc(φ) (y·ẏ) y ,   q̇_w = −(y·ẏ) sinc(φ)

    (eq. (55) as printed has the sign of the right-hand side flipped; ``q̇_w = −φ̇ sin φ`` is the correct
    middle term).

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vectors, radians.
    rotvec_dot : array_like, shape (..., 3)
        Their time derivatives, rad/s.

    Returns
    -------
    ndarray, shape (..., 4)
        ``q̇``, xyzw per second.
    """
    v = as_array(rotvec, "rotvec", 3)
    vd = as_array(rotvec_dot, "rotvec_dot", 3)
    return call_kernel(_native.quat_derivative_from_rotvec_rate, (v, vd), ("rotvec", "rotvec_dot"))


@fast_path(_native.so3_jacobian_apply, fixed=(1.0, 0.0))
def omega_from_rotvec_rate(rotvec: ArrayLike, rotvec_dot: ArrayLike, frame: Frame = "space") -> NDArray[np.float64]:
    """Angular velocity of ``R(t) = exp(v(t)×)``: ``ω_space = J_l(v) v̇``, ``ω_body = J_r(v) v̇``.

    ``J_l``/``J_r`` are the SO(3) Jacobians of :mod:`dualpose.algebra.lie`; this equals
    ``omega_from_quat_derivative(quat_from_rotvec(v), quat_derivative_from_rotvec_rate(v, v̇), frame)``.

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vectors ``v``, radians.
    rotvec_dot : array_like, shape (..., 3)
        ``v̇``, rad/s.
    frame : {"space", "body"}

    Returns
    -------
    ndarray, shape (..., 3)
        ``ω``, rad/s, in ``frame``.
    """
    v = as_array(rotvec, "rotvec", 3)
    vd = as_array(rotvec_dot, "rotvec_dot", 3)
    sgn = 1.0 - 2.0 * _body_flag(frame)
    return call_kernel(_native.so3_jacobian_apply, (v, vd, sgn, 0.0), ("rotvec", "rotvec_dot"))


@fast_path(_native.so3_jacobian_apply, fixed=(1.0, 1.0))
def rotvec_rate_from_omega(rotvec: ArrayLike, omega: ArrayLike, frame: Frame = "space") -> NDArray[np.float64]:
    """Rotation-vector rate ``v̇ = J_l(v)⁻¹ ω_space = J_r(v)⁻¹ ω_body`` (inverse of :func:`omega_from_rotvec_rate`).

    Singular at ``|v| = 2π k`` (k ≥ 1) only; regular on the principal ball ``|v| <= π`` and at ``v = 0``.

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vectors ``v``, radians.
    omega : array_like, shape (..., 3)
        Angular velocity, rad/s, in ``frame``.
    frame : {"space", "body"}

    Returns
    -------
    ndarray, shape (..., 3)
        ``v̇``, rad/s.
    """
    v = as_array(rotvec, "rotvec", 3)
    w = as_array(omega, "omega", 3)
    sgn = 1.0 - 2.0 * _body_flag(frame)
    return call_kernel(_native.so3_jacobian_apply, (v, w, sgn, 1.0), ("rotvec", "omega"))
