"""Dual-quaternion algebra and rigid transforms (Dantam 2014 §IV; Walker, Shao & Volz 1991 §2 and Appendix).

Layout: a dual quaternion is a float64 array of shape ``(..., 8)`` = ``[r_x, r_y, r_z, r_w, d_x, d_y, d_z, d_w]``:
the real part ``r`` then the dual part ``d``, each an xyzw quaternion (Hamilton product).  A unit dual quaternion
is the rigid transform ``p -> R(r) p + t`` with ``r`` the rotation and ``d = ½ t (x) r`` (Dantam eq. (77); Walker
``s = W(r) t``, eq. (25)); it maps body (child) coordinates to world (parent) coordinates, and ``a (x) b`` applies
``b`` first.  Translations are ``(..., 3)`` arrays in the caller's length unit; angles are radians.  Twists
(exponential coordinates) are ``(..., 6)`` = ``[ω, v]``, the se(3) element ``[[ω×, v], [0, 0]]`` whose exponential
is the transform (scipy's ``RigidTransform.as_exp_coords`` order).  Every function broadcasts over all leading axes
and accepts array-likes.

NaN in elementwise algebra propagates; a zero real part where a nonzero one is needed raises ``ValueError``;
``dualquat_from_matrix`` refuses non-finite input.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose._validation import (
    as_array,
    as_scalar_array,
    call_kernel,
    check_finite,
    identity_array,
    raise_if_zero_norm,
    try_flat_kernel,
)
from dualpose.algebra._fastpath import fast_path
from dualpose.algebra.quat import raise_not_rotation

__all__ = [
    "dualquat_mul",
    "dualquat_conj",
    "dualquat_inv",
    "dualquat_norm",
    "dualquat_normalize",
    "dualquat_canonical",
    "dualquat_identity",
    "dualquat_from_qt",
    "qt_from_dualquat",
    "dualquat_from_matrix",
    "matrix_from_dualquat",
    "dualquat_transform",
    "dualquat_exp",
    "dualquat_log",
    "dualquat_pow",
    "dualquat_from_twist",
    "twist_from_dualquat",
    "dualquat_sclerp",
    "dualquat_from_screw",
    "screw_from_dualquat",
    "dualquat_integrate",
]

#: the flat row loops (dualpose._validation.try_flat_kernel) by name; the tests substitute this look-up to count them
_FLAT = {"dualquat_mul": _native.flat_dualquat_mul, "dualquat_transform": _native.flat_dualquat_transform}
_fk = _FLAT.__getitem__
_CONJ = np.array([-1.0, -1.0, -1.0, 1.0, -1.0, -1.0, -1.0, 1.0], dtype=np.float64)
_BOTTOM = np.array([0.0, 0.0, 0.0, 1.0], dtype=np.float64)
_NONZERO = "a dual quaternion with a nonzero real part"


def _raise_zero(out: np.ndarray, s: np.ndarray, name: str) -> None:
    raise_if_zero_norm(out, s, name, _NONZERO)


def dualquat_identity(shape: int | tuple[int, ...] = ()) -> NDArray[np.float64]:
    """Identity dual quaternions ``[0, 0, 0, 1, 0, 0, 0, 0]`` of shape ``shape + (8,)``."""
    return identity_array(shape, 8)


@fast_path(_native.dualquat_mul, takes_out=True)
def dualquat_mul(a: ArrayLike, b: ArrayLike, out: np.ndarray | None = None) -> NDArray[np.float64]:
    """Dual-quaternion product ``a (x) b = (a_r b_r, a_r b_d + a_d b_r)`` (Dantam 2014 eq. (79)).

    Parameters
    ----------
    a, b : array_like, shape (..., 8)
        Dual quaternions ``[real xyzw, dual xyzw]``.  Leading axes broadcast.
    out : ndarray, shape (..., 8), optional
        Preallocated float64 array for the result (as for NumPy ufuncs).

    Returns
    -------
    ndarray, shape (..., 8)
        For unit inputs the composed transform: apply ``b`` first, then ``a`` (``T_world_c = T_world_b (x) T_b_c``).
    """
    a = as_array(a, "a", 8)
    b = as_array(b, "b", 8)
    flat = try_flat_kernel(_fk("dualquat_mul"), (a, b), out, 8)
    if flat is not None:
        return flat[0]  # the product needs no norm: never flagged
    return call_kernel(_native.dualquat_mul, (a, b), ("a", "b"), out)


@fast_path(_native.dualquat_conj)
def dualquat_conj(s: ArrayLike) -> NDArray[np.float64]:
    """Quaternion conjugate of both parts, ``(r*, d*)`` (Dantam 2014 eq. (81)); (..., 8) -> (..., 8).

    For a unit dual quaternion this is the inverse transform ``p -> Rᵀ (p − t)``.
    """
    s = as_array(s, "s", 8)
    return s * _CONJ


@fast_path(_native.dualquat_inv, nan_declines=True)
def dualquat_inv(s: ArrayLike) -> NDArray[np.float64]:
    """Multiplicative inverse ``(r⁻¹, −r⁻¹ d r⁻¹)`` of a dual quaternion with any nonzero real part.

    ``dualquat_mul(s, dualquat_inv(s))`` is the identity ``[0, 0, 0, 1, 0, 0, 0, 0]``; for unit ``s`` this equals
    :func:`dualquat_conj`.  Shape (..., 8) -> (..., 8).  A zero real part raises ``ValueError``.
    """
    s = as_array(s, "s", 8)
    out = _native.dualquat_inv(s)
    _raise_zero(out, s, "s")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.dualquat_norm, nan_declines=True)
def dualquat_norm(s: ArrayLike) -> NDArray[np.float64]:
    """Dual-number norm ``|S| = sqrt(S S*) = |r| + ε (r·d)/|r|`` as ``[|r|, r·d/|r|]``, shape (..., 8) -> (..., 2).

    A unit dual quaternion has norm ``[1, 0]`` (Walker 1991 eqs. (13)-(14)).  The dual component is undefined for
    a zero real part, which raises ``ValueError``.
    """
    s = as_array(s, "s", 8)
    out = _native.dualquat_norm(s)
    _raise_zero(out, s, "s")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.dualquat_normalize, nan_declines=True)
def dualquat_normalize(s: ArrayLike) -> NDArray[np.float64]:
    """The unit dual quaternion ``S / |S|`` (dual-number division), shape (..., 8) -> (..., 8).

    ``r' = r/|r|`` and ``d' = d/|r| − r' (r'·d)/|r|``, so ``|r'| = 1`` and ``r'·d' = 0`` (Walker 1991 eqs.
    (13)-(14)).  The rotation is that of ``r``; the translation ``2 vec(d' (x) r'*)`` equals that of
    :func:`qt_from_dualquat` on the input.  A zero real part raises ``ValueError``.
    """
    s = as_array(s, "s", 8)
    out = _native.dualquat_normalize(s)
    _raise_zero(out, s, "s")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.dualquat_canonical)
def dualquat_canonical(s: ArrayLike) -> NDArray[np.float64]:
    """The sign representative whose real part has ``w > 0`` (ties as :func:`~dualpose.algebra.quat.quat_canonical`).

    ``S`` and ``−S`` are the same rigid transform.  Both parts are negated together: the dual part is
    ``½ t (x) r``, so flipping only the real part would negate the translation.  Shape (..., 8) -> (..., 8).
    """
    s = as_array(s, "s", 8)
    result: NDArray[np.float64] = _native.dualquat_canonical(s)
    return result


@fast_path(_native.dualquat_from_qt, nan_declines=True)
def dualquat_from_qt(q: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Dual quaternion ``[r, ½ t (x) r]`` with ``r = q/|q|`` (Dantam 2014 eqs. (76)-(77)).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Rotations (body to world), xyzw; normalized here, sign kept.  A zero quaternion raises ``ValueError``.
    t : array_like, shape (..., 3)
        Translations: the body origin in world coordinates.

    Returns
    -------
    ndarray, shape (..., 8)
        Unit dual quaternions of ``p -> R(q) p + t``.

    Examples
    --------
    >>> import numpy as np, dualpose as dp
    >>> T = dp.dualquat_from_qt(dp.quat_from_rotvec([0.0, 0.0, np.pi / 2]), [1.0, 2.0, 3.0])
    >>> T.shape
    (8,)
    >>> q, t = dp.qt_from_dualquat(T)
    >>> t.round(12) + 0.0
    array([1., 2., 3.])
    """
    q = as_array(q, "q", 4)
    t = as_array(t, "t", 3)
    out = call_kernel(_native.dualquat_from_qt, (q, t), ("q", "t"))
    raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.qt_from_dualquat, nan_declines=True)
def qt_from_dualquat(s: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rotation and translation of dual quaternions (Dantam 2014 eq. (78); Walker 1991 eq. (19)).

    Parameters
    ----------
    s : array_like, shape (..., 8)
        Dual quaternions; any nonzero real part (zero raises ``ValueError``).

    Returns
    -------
    q : ndarray, shape (..., 4)
        The unit rotation ``r/|r|``, xyzw, sign kept.
    t : ndarray, shape (..., 3)
        ``t = 2 vec(d (x) r*) / |r|²``; invariant under scaling ``s`` by a nonzero real number.
    """
    s = as_array(s, "s", 8)
    q, t = _native.qt_from_dualquat(s)
    _raise_zero(q, s, "s")
    return q, t


def dualquat_from_matrix(matrix: ArrayLike) -> NDArray[np.float64]:
    """Unit dual quaternions of homogeneous transforms ``[[R, t], [0, 1]]`` (Walker 1991 §2.2.2).

    ``r`` is :func:`~dualpose.algebra.quat.quat_from_matrix` of ``R`` (Shepperd's method, ``w >= 0``) and the dual
    part is ``s = W(r) t`` with ``t = ½ [t; 0]`` (Walker eq. (25)), i.e. ``½ t (x) r``.

    Parameters
    ----------
    matrix : array_like, shape (..., 4, 4)
        Finite homogeneous transforms (body to world).  The bottom row must be ``[0, 0, 0, 1]`` within 1e-12.

    Returns
    -------
    ndarray, shape (..., 8)
        Real part with ``w >= 0``.

    Raises
    ------
    ValueError
        Non-finite input, a bottom row that is not ``[0, 0, 0, 1]``, or a rotation block that is not a rotation
        (as in :func:`~dualpose.algebra.quat.quat_from_matrix`: ``max |RᵀR − I| > 1e-5`` or ``det R <= 0``).
    """
    m = as_array(matrix, "matrix", (4, 4))
    check_finite(m, "matrix")
    if np.abs(m[..., 3, :] - _BOTTOM).max(initial=0.0) > 1e-12:
        raise ValueError("matrix must be homogeneous transforms [[R, t], [0, 1]]; a bottom row is not [0, 0, 0, 1]")
    r = _native.quat_from_matrix(m[..., :3, :3])
    if np.isnan(r).any():
        raise_not_rotation(r, m[..., :3, :3], "matrix")
    result: NDArray[np.float64] = _native.dualquat_from_rt(m, r)
    return result


@fast_path(_native.matrix_from_dualquat, nan_declines=True)
def matrix_from_dualquat(s: ArrayLike) -> NDArray[np.float64]:
    """Homogeneous transforms ``[[R, t], [0, 1]]`` of dual quaternions (Walker 1991 eqs. (17)-(19); Dantam (109)).

    ``s`` has shape (..., 8); a non-unit real part is normalized (``R`` uses ``2/|r|²``, ``t`` as in
    :func:`qt_from_dualquat`), zero raises ``ValueError``.  Returns (..., 4, 4) with ``T @ [p, 1] ==
    [dualquat_transform(s, p), 1]``.
    """
    s = as_array(s, "s", 8)
    out = _native.matrix_from_dualquat(s)
    _raise_zero(out, s, "s")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.dualquat_transform, nan_declines=True, takes_out=True)
def dualquat_transform(s: ArrayLike, points: ArrayLike, out: np.ndarray | None = None) -> NDArray[np.float64]:
    """Transform points: ``p' = R p + t`` (Dantam 2014 eq. (95), evaluated in the implicit form (106)).

    Parameters
    ----------
    s : array_like, shape (..., 8)
        Rigid transforms (body to world).  A non-unit real part is normalized (``2/|r|²`` scaling) and ``t`` is
        read as in :func:`qt_from_dualquat`; a zero real part raises ``ValueError``.
    points : array_like, shape (..., 3)
        Points in body coordinates.  Leading axes broadcast with those of ``s``.
    out : ndarray, shape (..., 3), optional
        Preallocated float64 array for the result (as for NumPy ufuncs).

    Returns
    -------
    ndarray, shape (..., 3)
        Points in world coordinates.

    Examples
    --------
    A quarter turn about z followed by the translation ``[1, 2, 3]``:

    >>> import numpy as np, dualpose as dp
    >>> T = dp.dualquat_from_qt(dp.quat_from_rotvec([0.0, 0.0, np.pi / 2]), [1.0, 2.0, 3.0])
    >>> dp.dualquat_transform(T, [1.0, 0.0, 0.0]).round(12) + 0.0
    array([1., 3., 3.])
    """
    s = as_array(s, "s", 8)
    p = as_array(points, "points", 3)
    flat = try_flat_kernel(_fk("dualquat_transform"), (s, p), out, 3)
    if flat is not None:
        res, flagged = flat
        if flagged:  # some |r| was zero or extreme: rows are right, but look for a zero
            _raise_zero(res[..., 0], s, "s")
        return res
    res = call_kernel(_native.dualquat_transform, (s, p), ("s", "points"), out)
    _raise_zero(res[..., 0], s, "s")  # a zero real part makes every component NaN; one column is enough
    return res


@fast_path(_native.dualquat_exp)
def dualquat_exp(s: ArrayLike) -> NDArray[np.float64]:
    """Exponential of a general dual quaternion (Dantam 2014 eqs. (82)-(85)).

    With ``φ = |r_v|`` and ``k = r_v·d_v``::

        e^S = e^(r_w + ε d_w) ( [sinc φ r_v, cos φ],  [sinc φ d_v + dsinc φ k r_v, −sinc φ k] )

    where ``e^(r_w + ε d_w) = e^(r_w) (1 + ε d_w)``, ``sinc φ = sin φ/φ`` and ``dsinc φ = (cos φ − sinc φ)/φ²``
    are the guarded series of :mod:`dualpose.algebra.series`.  For a pure ``S = ½(ω + ε v)`` this is the rigid
    transform of the twist ``[ω, v]`` (see :func:`dualquat_from_twist`).  Shape (..., 8) -> (..., 8).

    Tiny ``φ`` (down to 1e-300) keeps full relative accuracy.  Near ``φ = π`` the real vector part
    ``sin φ r_v/φ`` has relative condition ``~1/sin φ`` (one ulp of ``φ = |r_v|`` moves it by ``2 eps/sin φ``);
    the result is backward stable there.
    """
    s = as_array(s, "s", 8)
    value: NDArray[np.float64] = _native.dualquat_exp(s)
    return value


@fast_path(_native.dualquat_log, nan_declines=True)
def dualquat_log(s: ArrayLike) -> NDArray[np.float64]:
    """Principal logarithm of a general dual quaternion (Dantam 2014 eqs. (86)-(92)); (..., 8) -> (..., 8).

    With ``φ = atan2(|r_v|, r_w)`` (the real part's principal angle, in [0, π]), ``k = r_v·d_v`` and
    ``α = (r_w − (φ/|r_v|)|r|²)/|r_v|²``::

        (ln S)_r = [ (φ/|r_v|) r_v,  ln|r| ]
        (ln S)_d = [ ((k α − d_w)/|r|²) r_v + (φ/|r_v|) d_v,  (k + r_w d_w)/|r|² ]

    ``φ/|r_v|`` uses :func:`~dualpose.algebra.series.atan2c` and, for ``r_w >= 0``, ``α|r|``
    :func:`~dualpose.algebra.series.dqalpha`, so tiny angles keep full relative accuracy.  For ``r_w < 0`` the dual
    vector is evaluated in the equivalent form ``(r_w/|r|²) d_∥ − (d_w/|r|²) r_v + (φ/|r_v|) d_⊥`` (``d_∥``,
    ``d_⊥``: the parts of ``d_v`` along and across ``r_v``), which stays accurate up to ``φ = π``.
    ``dualquat_exp(dualquat_log(s)) == s``.  As ``r_v -> 0`` with ``r_w < 0`` (a 2π rotation of the double cover)
    the logarithm grows like ``|d_⊥|/|r_v|`` and is ill-conditioned; canonicalise first (as
    :func:`twist_from_dualquat` does) for the short screw.

    On the negative real axis of the real part (``r_v = 0``, ``r_w < 0``; a 2π rotation of the double cover) the
    generic formula is 0·∞ and a logarithm exists only with ``(ln S)_r`` parallel to the translation: the returned
    value is ``[π t̂, ln|r|, −d/|r|]`` with ``t̂ = −d_v/|d_v|`` the translation direction (axis x when ``d_v = 0``),
    the minimum-norm choice.  Raises ``ValueError`` for a zero real part.
    """
    s = as_array(s, "s", 8)
    out = _native.dualquat_log(s)
    _raise_zero(out, s, "s")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.dualquat_pow, nan_declines=True)
def dualquat_pow(s: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Power ``S**t = exp(t ln S)`` with the principal logarithm of :func:`dualquat_log`, in float64.

    Parameters
    ----------
    s : array_like, shape (..., 8)
        Dual quaternions (any nonzero real part; zero raises ``ValueError``).
    t : array_like, shape (...)
        Real exponents, broadcast against the leading axes of ``s``.

    Returns
    -------
    ndarray, shape (..., 8)
        For a unit ``s`` the screw motion scaled by ``t`` (angle and translation along the screw axis times
        ``t``).  No sign canonicalisation is applied (algebraic power, as :func:`~dualpose.algebra.quat.quat_pow`):
        ``(−s)**0.5`` is the long-way-round half screw.  See :func:`dualquat_sclerp` for the shortest screw.
    """
    s = as_array(s, "s", 8)
    t = as_scalar_array(t, "t")
    out = call_kernel(_native.dualquat_pow, (s, t), ("s", "t"))
    _raise_zero(out, s, "s")
    return out


@fast_path(_native.dualquat_from_twist)
def dualquat_from_twist(xi: ArrayLike) -> NDArray[np.float64]:
    """Rigid transform of exponential coordinates: ``dualquat_exp(½(ω + ε v))`` (Dantam 2014 eq. (84)).

    Parameters
    ----------
    xi : array_like, shape (..., 6)
        Twists ``[ω, v]``: ``ω`` rotation vector (radians), ``v`` the linear part (length units).

    Returns
    -------
    ndarray, shape (..., 8)
        Unit dual quaternions of ``exp([[ω×, v], [0, 0]])``: rotation ``exp(ω×)`` and translation ``J_l(ω) v``
        (the SO(3) left Jacobian -- not ``R v``).  Equals scipy's ``RigidTransform.from_exp_coords`` up to sign.
    """
    xi = as_array(xi, "xi", 6)
    result: NDArray[np.float64] = _native.dualquat_from_twist(xi)
    return result


@fast_path(_native.twist_from_dualquat, nan_declines=True)
def twist_from_dualquat(s: ArrayLike) -> NDArray[np.float64]:
    """Exponential coordinates ``[ω, v]`` (..., 6) of rigid transforms ``s`` (..., 8).

    ``s`` is normalized (:func:`dualquat_normalize`) and canonicalised (``r_w >= 0``), then ``2 ln s`` is taken
    (Dantam 2014 eqs. (86)-(92)), so ``|ω| <= π`` and ``s`` and ``−s`` give the same twist.  Inverse of
    :func:`dualquat_from_twist` on ``|ω| < π``; equals scipy's ``RigidTransform.as_exp_coords``.
    A zero real part raises ``ValueError``.
    """
    s = as_array(s, "s", 8)
    out = _native.twist_from_dualquat(s)
    _raise_zero(out, s, "s")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.dualquat_sclerp, nan_declines=True)
def dualquat_sclerp(s0: ArrayLike, s1: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Screw linear interpolation ``s0 (x) (canonical(s0* (x) s1))**t`` along the shortest screw.

    Parameters
    ----------
    s0, s1 : array_like, shape (..., 8)
        End poses; normalized inside (zero real part raises ``ValueError``).  The path does not depend on the
        sign of ``s1``; the overall sign follows ``s0``.
    t : array_like, shape (...)
        Interpolation parameter; 0 gives ``s0``, 1 gives ``±s1``; values outside [0, 1] extrapolate.

    Returns
    -------
    ndarray, shape (..., 8)
        Unit dual quaternions: constant-velocity screw motion (rotation about and translation along one fixed
        axis) from ``s0`` to ``s1``.

    Examples
    --------
    ``t`` broadcasts: three poses along the screw from the identity to ``T``, and their translations:

    >>> import numpy as np, dualpose as dp
    >>> T = dp.dualquat_from_qt(dp.quat_from_rotvec([0.0, 0.0, np.pi / 2]), [1.0, 2.0, 3.0])
    >>> path = dp.dualquat_sclerp(dp.dualquat_identity(), T, [0.0, 0.5, 1.0])
    >>> path.shape
    (3, 8)
    >>> dp.qt_from_dualquat(path)[1].round(6) + 0.0
    array([[0.      , 0.      , 0.      ],
           [0.914214, 0.792893, 1.5     ],
           [1.      , 2.      , 3.      ]])
    """
    s0 = as_array(s0, "s0", 8)
    s1 = as_array(s1, "s1", 8)
    t = as_scalar_array(t, "t")
    out = call_kernel(_native.dualquat_sclerp, (s0, s1, t), ("s0", "s1", "t"))
    if np.isnan(out).any():
        _raise_zero(out, s0, "s0")
        _raise_zero(out, s1, "s1")
    return out


@fast_path(_native.dualquat_from_screw, nan_declines=True)
def dualquat_from_screw(
    axis: ArrayLike, point: ArrayLike, pitch_distance: ArrayLike, angle: ArrayLike,
) -> NDArray[np.float64]:
    """Dual quaternions of screw motions (Walker 1991 eqs. (8)-(12)).

    ``r = [sin(θ/2) n, cos(θ/2)]`` and ``s = [(d/2) cos(θ/2) n + sin(θ/2) (p × n), −(d/2) sin(θ/2)]``: rotation by
    θ about the line through ``p`` with direction ``n`` and translation ``d`` along ``n``, so that
    ``t = (I − R) p + d n`` (Walker Appendix eq. (61)).

    Parameters
    ----------
    axis : array_like, shape (..., 3)
        Axis direction ``n``; normalized here (a zero axis raises ``ValueError``).
    point : array_like, shape (..., 3)
        Any point ``p`` on the axis (only its component ⊥ ``n`` matters).
    pitch_distance : array_like, shape (...)
        Translation ``d`` along ``n``, a length (not the pitch ratio ``d/θ``).
    angle : array_like, shape (...)
        Rotation angle θ, radians.

    Returns
    -------
    ndarray, shape (..., 8)
        Unit dual quaternions; all arguments broadcast.
    """
    axis = as_array(axis, "axis", 3)
    point = as_array(point, "point", 3)
    d = as_scalar_array(pitch_distance, "pitch_distance")
    th = as_scalar_array(angle, "angle")
    names = ("axis", "point", "pitch_distance", "angle")
    out = call_kernel(_native.dualquat_from_screw, (axis, point, d, th), names)
    if np.isnan(out).any() and np.any(np.all(axis == 0.0, axis=-1)):
        raise ValueError("axis must be a nonzero vector of shape (..., 3); a zero axis was given")
    return out


@fast_path(_native.screw_from_dualquat, nan_declines=True)
def screw_from_dualquat(
    s: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Walker screw parameters ``(n, p, d, θ)`` of rigid transforms (Walker 1991 Appendix 3, stable form).

    ``s`` (..., 8) is normalized and canonicalised (``r_w >= 0``), then ``θ = 2 atan2(|r_v|, r_w)`` ∈ [0, π],
    ``n = r_v/|r_v|``, ``d = 2 (r_w (n·s_v) − s_w |r_v|)`` and ``p = (r_v × s_v)/|r_v|²``, which is the point of
    the axis closest to the origin (``p ⊥ n``; Walker's eqs. (70)-(75) leave ``p + α n`` free).  These forms avoid
    Walker's division by ``sin(θ/2)``.  A pure translation gives ``θ = 0``, ``n = t/|t|``, ``d = |t|``, ``p = 0``;
    the identity gives ``n = [1, 0, 0]``, ``d = 0``, ``p = 0``, ``θ = 0``.

    Returns
    -------
    axis : ndarray, shape (..., 3)
        Unit axis ``n``.
    point : ndarray, shape (..., 3)
        Point ``p`` on the axis, ⊥ ``n``.
    pitch_distance : ndarray, shape (...)
        Translation ``d`` along ``n`` (length).
    angle : ndarray, shape (...)
        θ ∈ [0, π], radians.

    ``dualquat_from_screw(*screw_from_dualquat(s))`` is the canonical normalized ``s``.  A zero real part raises
    ``ValueError``.
    """
    s = as_array(s, "s", 8)
    axis, point, d, th = _native.screw_from_dualquat(s)
    _raise_zero(axis, s, "s")
    return axis, point, d, th


@fast_path(_native.dualquat_integrate_space)
def dualquat_integrate(
    s: ArrayLike, twist: ArrayLike, dt: ArrayLike, frame: Literal["space", "body"] = "space"
) -> NDArray[np.float64]:
    """Integrate a constant twist over ``dt`` exactly (Dantam 2014 eqs. (101)-(102)).

    Parameters
    ----------
    s : array_like, shape (..., 8)
        Pose at the start (body to world).
    twist : array_like, shape (..., 6)
        ``[ω, v]``.  ``frame="space"``: ``ω`` is the angular velocity in world coordinates (rad/s) and ``v`` the
        **spatial** linear velocity ``ṫ + t × ω = ṫ − ω × t`` -- Dantam's ``Ω`` of eq. (101), the velocity of
        the (body-fixed) point currently at the world origin, in world coordinates; the result is
        ``exp(Ω dt/2) (x) s``.  ``frame="body"``: ``ω`` and ``v`` are the body-frame angular velocity and the
        velocity of the body origin expressed in body coordinates (``Rᵀ ṫ``); the result is ``s (x) exp(Ω dt/2)``.
    dt : array_like, shape (...)
        Time step, seconds.

    Returns
    -------
    ndarray, shape (..., 8)
        The pose after ``dt``; ``dualquat_from_twist(twist * dt)`` composed on the left (space) or right (body).
    """
    s = as_array(s, "s", 8)
    xi = as_array(twist, "twist", 6)
    dt = as_scalar_array(dt, "dt")
    if frame == "space":
        kern = _native.dualquat_integrate_space
    elif frame == "body":
        kern = _native.dualquat_integrate_body
    else:
        raise ValueError(f"frame must be 'space' or 'body'; got {frame!r}")
    return call_kernel(kern, (s, xi, dt), ("s", "twist", "dt"))
