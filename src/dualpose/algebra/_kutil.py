"""Inline scalar helpers shared by the numba kernels (not public API).

Quaternions are handled as four scalars ``(x, y, z, w)``: scalar last, Hamilton product.
"""

from __future__ import annotations

import math

import numba as nb

jit = nb.njit(cache=True, inline="always", fastmath=False, error_model="numpy")
D3_SIG = "float64[:]"

_TINY = 1e-280
_HUGE = 1e280


@jit
def norm3(x: float, y: float, z: float) -> float:
    """Euclidean norm of a 3-vector without underflow or overflow of the squares."""
    s = x * x + y * y + z * z
    if s != s:  # NaN: return it without an ordered (signalling) comparison
        return s
    if _TINY <= s <= _HUGE:
        return math.sqrt(s)
    m = max(abs(x), abs(y), abs(z))
    if m == 0.0 or m == math.inf or s != s:
        return m if s == s else s
    x, y, z = x / m, y / m, z / m
    return m * math.sqrt(x * x + y * y + z * z)


@jit
def norm4(x: float, y: float, z: float, w: float) -> float:
    """Euclidean norm of a 4-vector without underflow or overflow of the squares."""
    s = x * x + y * y + z * z + w * w
    if s != s:
        return s
    if _TINY <= s <= _HUGE:
        return math.sqrt(s)
    m = max(abs(x), abs(y), abs(z), abs(w))
    if m == 0.0 or m == math.inf or s != s:
        return m if s == s else s
    x, y, z, w = x / m, y / m, z / m, w / m
    return m * math.sqrt(x * x + y * y + z * z + w * w)


@jit
def qmul(ax, ay, az, aw, bx, by, bz, bw):  # noqa: ANN001, ANN201
    """Hamilton product a (x) b of two xyzw quaternions given as scalars."""
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


@jit
def cross(ax, ay, az, bx, by, bz):  # noqa: ANN001, ANN201
    return (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)


@jit
def rotate(x, y, z, w, vx, vy, vz, s2):  # noqa: ANN001, ANN201
    """v + s2 * q_v x (q_v x v + w v): Dantam 2014 eq. (45); s2 = 2/|q|**2 (2 for a unit quaternion)."""
    ax, ay, az = cross(x, y, z, vx, vy, vz)
    ax += w * vx
    ay += w * vy
    az += w * vz
    bx, by, bz = cross(x, y, z, ax, ay, az)
    return (vx + s2 * bx, vy + s2 * by, vz + s2 * bz)


@jit
def unit_scale(x, y, z, w):  # noqa: ANN001, ANN201
    """(c, s2) with s2 = 2/|c q|**2, for formulas that need 2/|q|**2 (rotation, matrices, transforms).

    For ordinary magnitudes c = 1 and s2 = 2/|q|**2; for |q| near 1e-200 or 1e200 c = 1/|q| and s2 = 2, and the
    caller scales the quaternion (and a dual part) by c first, so nothing under- or overflows.  A zero quaternion
    gives a quiet NaN; a NaN one propagates.
    """
    n2 = x * x + y * y + z * z + w * w
    if n2 != n2:
        return 1.0, n2
    if _TINY <= n2 <= _HUGE:
        return 1.0, 2.0 / n2
    n = norm4(x, y, z, w)
    if n == 0.0:
        return math.nan, math.nan
    return 1.0 / n, 2.0


@jit
def inv_norm2_scale(x, y, z, w):  # noqa: ANN001, ANN201
    """2/|q|**2 (quiet NaN for a zero quaternion); prefer :func:`unit_scale`, which also survives |q| ~ 1e-200."""
    n2 = x * x + y * y + z * z + w * w
    if n2 != n2:
        return n2
    if _TINY <= n2 <= _HUGE:
        return 2.0 / n2
    n = norm4(x, y, z, w)
    if n == 0.0:
        return math.nan
    return (2.0 / n) / n
