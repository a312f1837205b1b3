"""Quaternion algebra (Dantam 2014 §II-III).

Layout: a quaternion is a float64 array of shape ``(..., 4)`` ordered ``[x, y, z, w]`` (scalar last), multiplied
with the Hamilton product; a unit quaternion rotates vectors actively, ``v' = q (x) v (x) q*``.  Rotation vectors
and angular rates are ``(..., 3)`` arrays in radians (per second).  Every function broadcasts over all leading
axes and accepts array-likes.

NaN in elementwise algebra propagates (products, exp, log, rotation); a zero quaternion where a nonzero one is
needed raises ``ValueError``; matrix conversions refuse non-finite input.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose._validation import (
    FLAT_MIN_ELEMENTS,
    as_array,
    as_scalar_array,
    call_kernel,
    check_finite,
    identity_array,
    raise_if_zero_norm,
    try_flat_kernel,
)
from dualpose.algebra._fastpath import fast_path
from dualpose.algebra.hat import so3_hat

__all__ = [
    "quat_mul",
    "quat_conj",
    "quat_inv",
    "quat_norm",
    "quat_normalize",
    "quat_canonical",
    "quat_exp",
    "quat_log",
    "quat_pow",
    "quat_rotate",
    "quat_from_rotvec",
    "rotvec_from_quat",
    "quat_from_axis_angle",
    "axis_angle_from_quat",
    "quat_from_matrix",
    "matrix_from_quat",
    "quat_slerp",
    "quat_angle",
    "quat_integrate",
    "quat_left_matrix",
    "quat_right_matrix",
    "quat_mean",
    "quat_identity",
]

#: largest accepted |RᵀR − I| entry of quat_from_matrix (defined once, in the kernel)
_ORTHO_TOL = _native.QUAT_FROM_MATRIX_ORTHOGONALITY_TOL
_CONJ = np.array([-1.0, -1.0, -1.0, 1.0], dtype=np.float64)


def quat_identity(shape: int | tuple[int, ...] = ()) -> NDArray[np.float64]:
    """Identity quaternions ``[0, 0, 0, 1]`` (xyzw) of shape ``shape + (4,)``."""
    return identity_array(shape, 4)


@fast_path(_native.quat_mul, takes_out=True)
def quat_mul(p: ArrayLike, q: ArrayLike, out: np.ndarray | None = None) -> NDArray[np.float64]:
    """Hamilton product ``p (x) q`` (Dantam 2014 eq. (11); Walker 1991 ``Q(p) q = W(q) p``).

    Parameters
    ----------
    p, q : array_like, shape (..., 4)
        Quaternions, xyzw.  Leading axes broadcast.
    out : ndarray, shape (..., 4), optional
        Preallocated float64 array for the result (as for NumPy ufuncs); avoids an allocation in hot loops.

    Returns
    -------
    ndarray, shape (..., 4)
        The product, xyzw.  For unit quaternions, rotating by the result is rotating by ``q`` then by ``p``.

    Examples
    --------
    Two quarter turns about z make a half turn:

    >>> import numpy as np, dualpose as dp
    >>> q = dp.quat_from_rotvec([0.0, 0.0, np.pi / 2])
    >>> dp.quat_mul(q, q).round(12) + 0.0
    array([0., 0., 1., 0.])
    """
    p = as_array(p, "p", 4)
    q = as_array(q, "q", 4)
    return call_kernel(_native.quat_mul, (p, q), ("p", "q"), out)


@fast_path(_native.quat_conj)
def quat_conj(q: ArrayLike) -> NDArray[np.float64]:
    """Conjugate ``q* = [-x, -y, -z, w]`` (Dantam 2014 eq. (13)); shape (..., 4) -> (..., 4), xyzw."""
    q = as_array(q, "q", 4)
    return q * _CONJ


@fast_path(_native.quat_norm)
def quat_norm(q: ArrayLike) -> NDArray[np.float64]:
    """Euclidean norm ``|q|`` (Dantam 2014 eq. (12)), computed without underflow/overflow; (..., 4) -> (...)."""
    q = as_array(q, "q", 4)
    result: NDArray[np.float64] = _native.quat_norm(q)
    return result


@fast_path(_native.quat_normalize, nan_declines=True)
def quat_normalize(q: ArrayLike) -> NDArray[np.float64]:
    """``q / |q|``; shape (..., 4), xyzw.  Raises ``ValueError`` for a zero quaternion."""
    q = as_array(q, "q", 4)
    out = _native.quat_normalize(q)
    raise_if_zero_norm(out, q, "q")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.quat_inv, nan_declines=True)
def quat_inv(q: ArrayLike) -> NDArray[np.float64]:
    """Inverse ``q* / |q|**2`` (Dantam 2014 eq. (17)); shape (..., 4), xyzw.  Zero raises ``ValueError``."""
    q = as_array(q, "q", 4)
    out = _native.quat_inv(q)
    raise_if_zero_norm(out, q, "q")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.quat_canonical)
def quat_canonical(q: ArrayLike) -> NDArray[np.float64]:
    """The sign representative with ``w > 0`` (ties broken by the first nonzero of x, y, z being positive).

    ``q`` and ``-q`` are the same rotation; this picks one.  Shape (..., 4), xyzw.
    """
    q = as_array(q, "q", 4)
    result: NDArray[np.float64] = _native.quat_canonical(q)
    return result


@fast_path(_native.quat_exp)
def quat_exp(q: ArrayLike) -> NDArray[np.float64]:
    """Quaternion exponential ``e**q = e**w [sin|v| v/|v|, cos|v|]`` (Dantam 2014 eqs. (22)-(24)).

    The factor ``sin|v|/|v|`` uses the guarded series :func:`dualpose.algebra.series.sinc`.  For a pure
    quaternion ``[θu/2, 0]`` this is the unit quaternion rotating by θ about u.  Shape (..., 4), xyzw.
    """
    q = as_array(q, "q", 4)
    result: NDArray[np.float64] = _native.quat_exp(q)
    return result


@fast_path(_native.quat_log, nan_declines=True, max_rows=FLAT_MIN_ELEMENTS - 1)
def quat_log(q: ArrayLike) -> NDArray[np.float64]:
    """Principal quaternion logarithm ``[φ v/|v|, ln|q|]`` with ``φ = atan2(|v|, w)`` (Dantam 2014 (25)-(28)).

    ``φ/|v|`` comes from the guarded :func:`~dualpose.algebra.series.atan2c`, so tiny angles (down to 1e-300)
    keep full relative accuracy.  On the negative real axis (``v = 0, w < 0``) the axis x is chosen:
    ``ln(-a) = [π, 0, 0, ln a]`` so that ``quat_exp(quat_log(q)) == q``.  Shape (..., 4), xyzw.
    Raises ``ValueError`` for a zero quaternion.
    """
    q = as_array(q, "q", 4)
    if q.size >= 4 * FLAT_MIN_ELEMENTS and q.flags.c_contiguous:
        return _quat_log_flat(q)
    with np.errstate(divide="ignore"):  # ln 0 of a zero quaternion: refused just below, never a raw warning
        out = _native.quat_log(q)
    raise_if_zero_norm(out, q, "q")
    result: NDArray[np.float64] = out
    return result


def _quat_log_flat(q: np.ndarray) -> NDArray[np.float64]:
    """:func:`quat_log` of a C-contiguous (..., 4) array in three vectorised passes.

    The angle comes from NumPy's ``arctan2``, which uses SIMD (≤ 1 ulp) where the CPU has it: one libm ``atan2``
    call per element is more than half of the gufunc's time.  The values match the gufunc's to an ulp.
    """
    qf = q.reshape(-1)
    s = np.empty(qf.size // 4)
    phi = np.empty_like(s)
    _native.quat_log_prepare(qf, s, phi)
    np.arctan2(s, phi, out=phi)
    out = np.empty(q.shape)
    if _native.quat_log_finish(qf, s, phi, out.reshape(-1)):
        raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.quat_pow, nan_declines=True)
def quat_pow(q: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Power ``q**t = exp(t ln q)`` with the principal logarithm (Dantam 2014 eq. (30)).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Quaternions, xyzw (any norm; ``|q|**t`` scales the result).
    t : array_like, shape (...)
        Real exponents, broadcast against the leading axes of ``q``.

    Returns
    -------
    ndarray, shape (..., 4)
        For a unit ``q`` rotating by angle θ ∈ [0, 2π) about u, the rotation by ``tθ`` about u.  No sign
        canonicalisation is applied (``(-q)**0.5`` is not ``q**0.5``); see :func:`quat_slerp` for shortest arcs.
    """
    q = as_array(q, "q", 4)
    t = as_scalar_array(t, "t")
    out = call_kernel(_native.quat_pow, (q, t), ("q", "t"))
    raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.quat_rotate, nan_declines=True, takes_out=True)
def quat_rotate(q: ArrayLike, v: ArrayLike, out: np.ndarray | None = None) -> NDArray[np.float64]:
    """Rotate vectors actively: ``v' = q (x) v (x) q*`` (Dantam 2014 eqs. (44)-(45)).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Rotations, xyzw.  Non-unit input is normalized (the kernel uses ``2/|q|**2``); zero raises.
    v : array_like, shape (..., 3)
        Vectors in the frame being rotated from.
    out : ndarray, shape (..., 3), optional
        Preallocated float64 array for the result.

    Returns
    -------
    ndarray, shape (..., 3)
        ``R(q) v``.

    Examples
    --------
    A quarter turn about z takes x to y; one rotation broadcasts over many vectors:

    >>> import numpy as np, dualpose as dp
    >>> q = dp.quat_from_rotvec([0.0, 0.0, np.pi / 2])
    >>> dp.quat_rotate(q, [1.0, 0.0, 0.0]).round(12) + 0.0
    array([0., 1., 0.])
    >>> dp.quat_rotate(q, np.eye(3)).shape
    (3, 3)
    """
    q = as_array(q, "q", 4)
    v = as_array(v, "v", 3)
    flat = try_flat_kernel(_native.flat_quat_rotate, (q, v), out, 3)
    if flat is not None:
        res, flagged = flat
        if flagged:  # some |q| was zero or extreme: rows are right, but look for a zero
            raise_if_zero_norm(res[..., 0], q, "q")
        return res
    res = call_kernel(_native.quat_rotate, (q, v), ("q", "v"), out)
    raise_if_zero_norm(res[..., 0], q, "q")  # a zero q makes every component NaN; one column is enough
    return res


@fast_path(_native.quat_from_rotvec)
def quat_from_rotvec(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion ``exp(v/2) = [sin(|v|/2) v/|v|, cos(|v|/2)]`` of rotation vectors (Dantam 2014 eq. (50)).

    Parameters
    ----------
    rotvec : array_like, shape (..., 3)
        Rotation vectors θu, radians; any magnitude (angles > π wrap).

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternions, xyzw.  Tiny angles keep full relative accuracy (no flush to zero).

    Examples
    --------
    >>> import numpy as np, dualpose as dp
    >>> dp.quat_from_rotvec([[0.0, 0.0, 0.0], [np.pi, 0.0, 0.0]]).round(12) + 0.0
    array([[0., 0., 0., 1.],
           [1., 0., 0., 0.]])
    """
    v = as_array(rotvec, "rotvec", 3)
    result: NDArray[np.float64] = _native.quat_from_rotvec(v)
    return result


@fast_path(_native.rotvec_from_quat, nan_declines=True)
def rotvec_from_quat(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector ``2 ln q`` with angle in [0, π] (Dantam 2014 eqs. (51)-(53), atan2 form).

    ``q`` and ``-q`` give the same result; non-unit input is treated as its normalization (the map is scale
    invariant).  Shape (..., 4) -> (..., 3), radians.  Raises ``ValueError`` for a zero quaternion.
    """
    q = as_array(q, "q", 4)
    out = _native.rotvec_from_quat(q)
    raise_if_zero_norm(out, q, "q")
    value: NDArray[np.float64] = out
    return value


@fast_path(_native.quat_from_axis_angle, nan_declines=True)
def quat_from_axis_angle(axis: ArrayLike, angle: ArrayLike) -> NDArray[np.float64]:
    """Quaternion ``[sin(θ/2) u, cos(θ/2)]`` of an axis (normalized here) and angle θ in radians.

    ``axis`` has shape (..., 3), ``angle`` shape (...); they broadcast.  Returns (..., 4), xyzw.  A zero axis
    raises ``ValueError``.
    """
    axis = as_array(axis, "axis", 3)
    angle = as_scalar_array(angle, "angle")
    out = call_kernel(_native.quat_from_axis_angle, (axis, angle), ("axis", "angle"))
    if np.isnan(out).any() and np.any(np.all(axis == 0.0, axis=-1)):
        raise ValueError("axis must be a nonzero vector of shape (..., 3); a zero axis was given")
    return out


@fast_path(_native.axis_angle_from_quat, nan_declines=True)
def axis_angle_from_quat(q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit axis (..., 3) and angle θ ∈ [0, π] (...) of rotations ``q`` (..., 4, xyzw).

    The sign of ``q`` is chosen so that θ ≤ π; the identity returns axis ``[1, 0, 0]`` and θ = 0 (any axis is
    valid there).  Uses ``θ = 2 atan2(|v|, w)`` (Dantam 2014 eq. (51)).
    """
    q = as_array(q, "q", 4)
    axis, angle = _native.axis_angle_from_quat(q)
    raise_if_zero_norm(axis, q, "q")
    return axis, angle


@fast_path(_native.matrix_from_quat, nan_declines=True)
def matrix_from_quat(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix of quaternions (Dantam 2014 eq. (108); Walker 1991 eq. (4)).

    ``q`` has shape (..., 4), xyzw; non-unit input is normalized, zero raises.  Returns (..., 3, 3) with
    ``R @ v == quat_rotate(q, v)``; column i is the child frame's axis i in parent coordinates.
    """
    q = as_array(q, "q", 4)
    out = _native.matrix_from_quat(q)
    raise_if_zero_norm(out, q, "q")
    result: NDArray[np.float64] = out
    return result


@fast_path(_native.quat_from_matrix, nan_declines=True)
def quat_from_matrix(matrix: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion (xyzw, ``w >= 0``) of rotation matrices, shape (..., 3, 3) -> (..., 4).

    Shepperd's method (Walker 1991 eqs. (21)-(24) made stable by branching on the largest of the trace and the
    diagonal), then normalized.  Exact for 180° rotations.  A nearly orthogonal matrix (as files rounded to 6-7
    digits and other libraries give) maps to a quaternion within ``O(|RᵀR − I|)`` of its nearest rotation.

    Raises
    ------
    ValueError
        For non-finite input, and for a matrix that is not a rotation: ``max |RᵀR − I| > 1e-5`` (entrywise;
        singular, scaled or sheared matrices) or ``det R <= 0`` (reflections).  The message gives the batch index
        of the first such matrix and why (docs/conventions.md, "Rotation matrices").
    """
    m = as_array(matrix, "matrix", (3, 3))
    check_finite(m, "matrix")
    out = _native.quat_from_matrix(m)
    if np.isnan(out).any():
        raise_not_rotation(out, m, "matrix")
    result: NDArray[np.float64] = out
    return result


def raise_not_rotation(out: np.ndarray, m: np.ndarray, name: str) -> None:
    """Raise the ValueError of :func:`quat_from_matrix` for the first matrix of ``m`` whose ``out`` row is NaN."""
    bad = np.isnan(out).any(axis=-1)
    idx = np.unravel_index(int(np.argmax(bad)), bad.shape) if bad.ndim else ()
    r = m[idx]
    err = float(np.abs(r.T @ r - np.eye(3)).max())
    det = float(np.linalg.det(r))
    where = f"{name}[{', '.join(map(str, idx))}]" if idx else name
    why = (
        f"det = {det:.3g} <= 0 (a reflection or singular matrix)"
        if det <= 0 and err <= _ORTHO_TOL
        else f"max |RᵀR − I| = {err:.3g} > {_ORTHO_TOL:g} (not orthogonal; det = {det:.3g})"
    )
    raise ValueError(f"{where} is not a rotation matrix: {why}")


@fast_path(_native.quat_slerp, nan_declines=True)
def quat_slerp(q0: ArrayLike, q1: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
    """Spherical linear interpolation ``q0 (x) (q0* (x) q1)**t`` on the shorter arc (Dantam 2014 eq. (58)).

    Parameters
    ----------
    q0, q1 : array_like, shape (..., 4)
        End orientations, xyzw (normalized inside; zero raises).  The result does not depend on their signs
        except for the overall sign, which follows ``q0``.
    t : array_like, shape (...)
        Interpolation parameter; 0 gives ``q0``, 1 gives ``±q1``; values outside [0, 1] extrapolate.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    q0 = as_array(q0, "q0", 4)
    q1 = as_array(q1, "q1", 4)
    t = as_scalar_array(t, "t")
    out = call_kernel(_native.quat_slerp, (q0, q1, t), ("q0", "q1", "t"))
    if np.isnan(out).any():
        raise_if_zero_norm(out, q0, "q0")
        raise_if_zero_norm(out, q1, "q1")
    return out


@fast_path(_native.quat_angle, nan_declines=True)
def quat_angle(p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """Rotation angle between orientations ``p`` and ``q``, in [0, π] radians.

    Computed as ``4 atan2(min(|p−q|, |p+q|), max(|p−q|, |p+q|))`` on the normalized inputs: Kahan's atan2 form
    of the angle between the 4-vectors (Dantam 2014 eq. (42)), doubled, and invariant under ``q -> -q``
    (double cover).  Accurate for tiny and for near-π angles, unlike ``2 acos|p·q|``.
    Shapes (..., 4) and (..., 4) broadcast; returns (...).
    """
    p = as_array(p, "p", 4)
    q = as_array(q, "q", 4)
    out = call_kernel(_native.quat_angle, (p, q), ("p", "q"))
    if np.isnan(out).any():
        raise_if_zero_norm(out, p, "p")
        raise_if_zero_norm(out, q, "q")
    return out


@fast_path(_native.quat_integrate_space)
def quat_integrate(
    q: ArrayLike, omega: ArrayLike, dt: ArrayLike, frame: Literal["space", "body"] = "space"
) -> NDArray[np.float64]:
    """Integrate a constant angular velocity over ``dt`` exactly (Dantam 2014 eq. (62)).

    Parameters
    ----------
    q : array_like, shape (..., 4)
        Orientation at the start, xyzw.
    omega : array_like, shape (..., 3)
        Angular velocity, rad/s, in the space (world) frame (``frame="space"``: ``exp(ω dt/2) (x) q``) or in
        the body frame (``frame="body"``: ``q (x) exp(ω dt/2)``).
    dt : array_like, shape (...)
        Time step, seconds.

    Returns
    -------
    ndarray, shape (..., 4)
    """
    q = as_array(q, "q", 4)
    omega = as_array(omega, "omega", 3)
    dt = as_scalar_array(dt, "dt")
    if frame == "space":
        kern = _native.quat_integrate_space
    elif frame == "body":
        kern = _native.quat_integrate_body
    else:
        raise ValueError(f"frame must be 'space' or 'body'; got {frame!r}")
    return call_kernel(kern, (q, omega, dt), ("q", "omega", "dt"))


def _qw_matrix(q: np.ndarray, sign: float) -> NDArray[np.float64]:
    v, w = q[..., :3], q[..., 3]
    out = np.empty(q.shape[:-1] + (4, 4))
    out[..., :3, :3] = w[..., None, None] * np.eye(3) + sign * so3_hat(v)
    out[..., :3, 3] = v
    out[..., 3, :3] = -v
    out[..., 3, 3] = w
    return out


def quat_left_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """Walker's ``Q(q)`` (Walker 1991 eq. (15)): the 4x4 matrix with ``Q(p) @ q == quat_mul(p, q)``.

    ``Q(q) = [[w I + K(v), v], [-vᵀ, w]]`` in xyzw order (Walker's scalar-last layout is dualpose's).
    Shape (..., 4) -> (..., 4, 4).
    """
    return _qw_matrix(as_array(q, "q", 4), 1.0)


def quat_right_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """Walker's ``W(q)`` (Walker 1991 eq. (16)): the 4x4 matrix with ``W(q) @ p == quat_mul(p, q)``.

    ``W(q) = [[w I - K(v), v], [-vᵀ, w]]`` in xyzw order.  Shape (..., 4) -> (..., 4, 4).
    """
    return _qw_matrix(as_array(q, "q", 4), -1.0)


def quat_mean(quats: ArrayLike, weights: ArrayLike | None = None) -> NDArray[np.float64]:
    """Weighted average orientation (Markley, Cheng, Crassidis & Oshman 2007).

    The maximiser of ``Σ w_i (q·q_i)²`` over unit q: the eigenvector of the largest eigenvalue of
    ``M = Σ w_i q_i q_iᵀ``.  Insensitive to the signs of the ``q_i`` (double cover).

    Parameters
    ----------
    quats : array_like, shape (..., n, 4)
        Orientations, xyzw (normalized inside; zero raises).  The mean is over axis -2.
    weights : array_like, shape (..., n), optional
        Non-negative weights (not all zero); uniform when omitted.

    Returns
    -------
    ndarray, shape (..., 4)
        Unit quaternion with ``w >= 0``.
    """
    qs = as_array(quats, "quats", 4)
    if qs.ndim < 2 or qs.shape[-2] == 0:
        raise ValueError(f"quats must have shape (..., n, 4) with n >= 1; got shape {qs.shape}")
    check_finite(qs, "quats")
    qs = quat_normalize(qs)
    if weights is None:
        w = np.ones(qs.shape[:-1])
    else:
        given = as_scalar_array(weights, "weights")
        try:
            w = np.broadcast_to(given, qs.shape[:-1])
        except ValueError:
            raise ValueError(
                f"weights must have shape (..., n) matching quats {qs.shape[:-1]}; got {np.shape(given)}"
            ) from None
        check_finite(w, "weights")
        if np.any(w < 0) or np.any(w.sum(axis=-1) == 0):
            raise ValueError("weights must be non-negative and not all zero")
    m = np.einsum("...n,...ni,...nj->...ij", w, qs, qs)
    _, vecs = np.linalg.eigh(m)
    return quat_canonical(vecs[..., :, -1])
