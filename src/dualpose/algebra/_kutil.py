"""Inline scalar helpers shared by the numba kernels (not public API).

Kept only for the numba kernels of other layers that still import them; the algebra itself uses the C++ copies in
``src/native/common/kutil.hpp``.
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
def qmul(ax, ay, az, aw, bx, by, bz, bw):
    """Hamilton product a (x) b of two xyzw quaternions given as scalars."""
    return (
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


@jit
def dq_mul(ax, ay, az, aw, bx, by, bz, bw, cx, cy, cz, cw, dx, dy, dz, dw):
    """(a + ε b)(c + ε d) = a c + ε (a d + b c): Dantam 2014 eq. (79), dual quaternions as 2 x 4 xyzw scalars.

    Only ``+ - *`` and :func:`qmul`, as the C++ ``dq_mul`` (common/kutil.hpp), so both round alike.
    """
    rx, ry, rz, rw = qmul(ax, ay, az, aw, cx, cy, cz, cw)
    ex, ey, ez, ew = qmul(ax, ay, az, aw, dx, dy, dz, dw)
    fx, fy, fz, fw = qmul(bx, by, bz, bw, cx, cy, cz, cw)
    return rx, ry, rz, rw, ex + fx, ey + fy, ez + fz, ew + fw


@jit
def cross(ax, ay, az, bx, by, bz):
    return (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)


@jit
def rotate(x, y, z, w, vx, vy, vz, s2):
    """v + s2 * q_v x (q_v x v + w v): Dantam 2014 eq. (45); s2 = 2/|q|**2 (2 for a unit quaternion)."""
    ax, ay, az = cross(x, y, z, vx, vy, vz)
    ax += w * vx
    ay += w * vy
    az += w * vz
    bx, by, bz = cross(x, y, z, ax, ay, az)
    return (vx + s2 * bx, vy + s2 * by, vz + s2 * bz)


@jit
def transform_point(x, y, z, w, dx, dy, dz, dw, px, py, pz, s2):
    """``R p + t`` for the dual quaternion ``[x, y, z, w, dx, dy, dz, dw]``; ``s2 = 2/|r|**2``.

    R p = p + s2 r_v x (r_v x p + w p) (Dantam 2014 eq. (45)) and t = s2 (w d_v - d_w r_v + r_v x d_v) (eq. (78)),
    fused into p + s2 [r_v x (r_v x p + w p + d_v) + w d_v - d_w r_v], as the C++ ``transform_point``.
    """
    cx, cy, cz = y * pz - z * py, z * px - x * pz, x * py - y * px
    ax, ay, az = cx + w * px + dx, cy + w * py + dy, cz + w * pz + dz
    bx, by, bz = y * az - z * ay, z * ax - x * az, x * ay - y * ax
    return (px + s2 * (bx + w * dx - dw * x), py + s2 * (by + w * dy - dw * y), pz + s2 * (bz + w * dz - dw * z))


@jit
def unit_scale(x, y, z, w):
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
def inv_norm2_scale(x, y, z, w):
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


@jit
def log_norm(x, y, z, w):
    """ln|q|, one branch on |q|**2 (no square root on the common paths).

    For |q|**2 in [1/2, 2] it is ln(1 + d)/2 with d = (w - 1)(w + 1) + x² + y² + z² (w - 1 is exact for w in
    [0.5, 2]): for a rounded unit quaternion |q| rounds to 1 (or 1 ± ulp) while ln|q| is ~1e-17, comparable to a
    tiny rotation's log, and the factored d keeps it to full accuracy.  ln(1 + d) is Goldberg's (1991, Thm. 4)
    ``ln(u) d/(u - 1)`` with u = 1 + d rounded (``d`` itself when u == 1, selected without a branch): a few ulp,
    and 3x faster than glibc's log1p.  Elsewhere ln(|q|**2)/2, whose absolute error (≈ 2ε from rounding |q|**2) is
    small against |ln|q|| >= ln(2)/2.  Outside [1e-280, 1e280] the guarded norm avoids under- and overflow.
    """
    s2 = x * x + y * y + z * z
    n2 = s2 + w * w
    if 0.5 <= n2 <= 2.0:
        d = (w - 1.0) * (w + 1.0) + s2
        u = 1.0 + d
        den = u - 1.0
        nz = den != 0.0
        f = math.log(u) / (den if nz else 1.0)
        return 0.5 * d * (f if nz else 1.0)
    if _TINY <= n2 <= _HUGE:
        return 0.5 * math.log(n2)
    return math.log(norm4(x, y, z, w))


@jit
def quat_log_parts(x, y, z, w, f):
    """Dantam 2014 eqs. (25)-(28) given ``f = atan2c(|q_v|, w)``: ``(f q_v, ln|q|)``; f = inf (v = 0, w < 0) gives
    the x axis, ``[π, 0, 0, ln|w|]``.  A zero q gives NaN (f = NaN)."""
    if f == math.inf:
        return math.pi, 0.0, 0.0, log_norm(x, y, z, w)
    return f * x, f * y, f * z, log_norm(x, y, z, w)


@jit
def rotmat(x, y, z, w):
    """Row-major entries of the rotation matrix of q/|q| (Dantam 2014 eq. (108)); NaN for a zero quaternion."""
    c, s = unit_scale(x, y, z, w)
    x, y, z, w = c * x, c * y, c * z, c * w
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    return (
        1.0 - (yy + zz), xy - wz, xz + wy,
        xy + wz, 1.0 - (xx + zz), yz - wx,
        xz - wy, yz + wx, 1.0 - (xx + yy),
    )  # fmt: skip


@jit
def rotate_any(x, y, z, w, vx, vy, vz):
    """R(q/|q|) v for any nonzero q (NaN for zero), without under/overflow for |q| ~ 1e-200 or 1e200."""
    c, s2 = unit_scale(x, y, z, w)
    return rotate(c * x, c * y, c * z, c * w, vx, vy, vz, s2)


@jit
def quat_of_rotmat(r):
    """Unit quaternion (x, y, z, w), ``w >= 0``, of a 3x3 rotation matrix ``r`` (Shepperd's method)."""
    # branch on the largest of (trace, R00, R11, R22); result normalized, w >= 0
    r00, r11, r22 = r[0, 0], r[1, 1], r[2, 2]
    tr = r00 + r11 + r22
    if tr >= r00 and tr >= r11 and tr >= r22:
        k = math.sqrt(1.0 + tr)
        h = 0.5 / k
        x, y, z, w = (r[2, 1] - r[1, 2]) * h, (r[0, 2] - r[2, 0]) * h, (r[1, 0] - r[0, 1]) * h, 0.5 * k
    elif r00 >= r11 and r00 >= r22:
        k = math.sqrt(1.0 + r00 - r11 - r22)
        h = 0.5 / k
        x, y, z, w = 0.5 * k, (r[0, 1] + r[1, 0]) * h, (r[0, 2] + r[2, 0]) * h, (r[2, 1] - r[1, 2]) * h
    elif r11 >= r22:
        k = math.sqrt(1.0 - r00 + r11 - r22)
        h = 0.5 / k
        x, y, z, w = (r[0, 1] + r[1, 0]) * h, 0.5 * k, (r[1, 2] + r[2, 1]) * h, (r[0, 2] - r[2, 0]) * h
    else:
        k = math.sqrt(1.0 - r00 - r11 + r22)
        h = 0.5 / k
        x, y, z, w = (r[0, 2] + r[2, 0]) * h, (r[1, 2] + r[2, 1]) * h, 0.5 * k, (r[1, 0] - r[0, 1]) * h
    n = norm4(x, y, z, w)
    if w < 0.0:
        n = -n
    return x / n, y / n, z / n, w / n
