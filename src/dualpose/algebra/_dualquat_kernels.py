"""numba gufunc kernels for dual quaternions.  Imported lazily by :mod:`dualpose.algebra.dualquat`.

Layout: ``[r_x, r_y, r_z, r_w, d_x, d_y, d_z, d_w]`` (real part then dual part, each xyzw, Hamilton), with
``d = ½ t (x) r`` for a rigid transform.  Kernels write NaN where a real part that must be nonzero is zero; the
Python wrappers turn that into a ValueError.  Each kernel is one pass over the data; the inline helpers below
(exp, log, normalize, canonical flip) are shared so that fused kernels (pow, sclerp, twist) use exactly the same
arithmetic as the stand-alone ones.
"""

from __future__ import annotations

import math

import numba as nb

from dualpose.algebra._kutil import (
    cross,
    dq_mul,
    jit,
    log_norm,
    norm3,
    norm4,
    qmul,
    rotmat,
    transform_point,
    unit_scale,
)
from dualpose.algebra.series import atan2c, dqalpha, dsinc, sinc

_V = "float64[:]"
_S = "float64"
_M = "float64[:, :]"
_NAN = math.nan


def gu(types: str, layout: str):
    return nb.guvectorize([f"void({types})"], layout, nopython=True, cache=True)


# ---------------------------------------------------------------------------------------------------------------
# inline helpers (8 scalars in, 8 scalars out)
# ---------------------------------------------------------------------------------------------------------------


@jit
def flip_sign(x, y, z, w):
    """True when the quaternion is not the canonical representative (w > 0, ties as quat_canonical)."""
    return w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0)))))


@jit
def is_zero4(x, y, z, w):
    """A zero real part: kernels that need a nonzero one write NaN and return before any arithmetic, so no
    floating-point flag (numpy RuntimeWarning) is raised on the way to the wrapper's ValueError."""
    return x == 0.0 and y == 0.0 and z == 0.0 and w == 0.0


@jit
def fill_nan(o, k):
    for i in range(k):
        o[i] = _NAN


@jit
def dq_normalize(rx, ry, rz, rw, dx, dy, dz, dw):
    """S/|S| with the dual-number norm |S| = |r| + ε r·d/|r|: r' = r/|r|, d' = d/|r| - r'(r'·d)/|r|.

    A zero real part gives NaN everywhere.
    """
    n = norm4(rx, ry, rz, rw)
    if n == 0.0:
        n = _NAN
    rx, ry, rz, rw = rx / n, ry / n, rz / n, rw / n
    dx, dy, dz, dw = dx / n, dy / n, dz / n, dw / n
    m = rx * dx + ry * dy + rz * dz + rw * dw
    return rx, ry, rz, rw, dx - m * rx, dy - m * ry, dz - m * rz, dw - m * rw


@jit
def dq_exp(rx, ry, rz, rw, dx, dy, dz, dw):
    """General dual-quaternion exponential, Dantam 2014 eq. (84) with the e**(r_w + ε d_w) factor.

    phi = |r_v|, k = r_v·d_v; sin(phi)/phi is ``sinc`` (23) and (cos phi - sin(phi)/phi)/phi**2 is ``dsinc`` (85).
    """
    return dq_exp_angle(norm3(rx, ry, rz), rx, ry, rz, rw, dx, dy, dz, dw)


@jit
def dq_exp_angle(phi, rx, ry, rz, rw, dx, dy, dz, dw):
    """dq_exp with phi = |r_v| supplied by the caller (dualquat_pow passes |t| atan2(|r_v|, r_w): one rounding)."""
    k = rx * dx + ry * dy + rz * dz
    sc = sinc(phi)
    ds = dsinc(phi) * k
    c = math.cos(phi)
    e = math.exp(rw)
    ax, ay, az = sc * rx, sc * ry, sc * rz
    return (
        e * ax,
        e * ay,
        e * az,
        e * c,
        e * (sc * dx + ds * rx + dw * ax),
        e * (sc * dy + ds * ry + dw * ay),
        e * (sc * dz + ds * rz + dw * az),
        e * (dw * c - sc * k),
    )


@jit
def dq_log(rx, ry, rz, rw, dx, dy, dz, dw):
    """Principal dual-quaternion logarithm, Dantam 2014 eqs. (86)-(92).

    The input is first scaled by 1/|r| (S = |r| (r/|r| + ε d/|r|), and ln of the real scalar |r| adds ln|r| to the
    real scalar part), so the formulas run on a unit real part with s = |r_v|, phi = atan2(s, r_w), k = r_v·d_v:

        (ln S)_r = [(phi/s) r_v, 0],   (ln S)_d = [(k alpha - d_w) r_v + (phi/s) d_v,  k + r_w d_w]

    For r_w >= 0, phi/s = ``atan2c`` and alpha = ``dqalpha(phi)`` (91)-(92) (tiny angles keep full relative
    accuracy).  For r_w < 0 the same vector is evaluated as r_w d_par - d_w r_v + phi (d_perp/s), d_par = (u·d_v) u,
    u = r_v/s, which is algebraically equal (alpha s**2 = r_w - phi/s) and has no 0·inf as s -> 0; dqalpha would
    recompute sin(phi) ~ s from phi ~ pi and lose relative accuracy there.

    Special point s = 0, r_w < 0 (phi = pi): with S/|r| = -1 + ε d, every ln = a + ε b with |a_v| = pi, a_w = 0 has
    exp real part -1 and dual part (-(a_v·b_v)/pi**2 a_v, -b_w), so a_v must be parallel to d_v.  We take
    a_v = pi t̂ with t̂ = -d_v/|d_v| the direction of the translation 2 vec(d (x) r*) (axis x when d_v = 0, as
    quat_log) and b = -d, the minimum-norm choice and the limit of the r_w < 0 formula along r_v ∥ d_v.
    Zero real part gives NaN.
    """
    if is_zero4(rx, ry, rz, rw):
        return _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, _NAN, _NAN
    n = norm4(rx, ry, rz, rw)
    ln = log_norm(rx, ry, rz, rw)
    rx, ry, rz, rw = rx / n, ry / n, rz / n, rw / n
    dx, dy, dz, dw = dx / n, dy / n, dz / n, dw / n
    s = norm3(rx, ry, rz)
    k = rx * dx + ry * dy + rz * dz
    dsc = k + rw * dw  # (90) scalar part: r·d
    if rw >= 0.0:
        f = atan2c(s, rw)
        c = k * dqalpha(math.atan2(s, rw)) - dw
        return f * rx, f * ry, f * rz, ln, c * rx + f * dx, c * ry + f * dy, c * rz + f * dz, dsc
    phi = math.atan2(s, rw)
    if s == 0.0:
        m = norm3(dx, dy, dz)
        if m == 0.0:
            return math.pi, 0.0, 0.0, ln, -dx, -dy, -dz, dsc
        g = -math.pi / (m if m > 0.0 else 1.0)
        return g * dx, g * dy, g * dz, ln, -dx, -dy, -dz, dsc
    ss = s if s > 0.0 else 1.0  # s > 0 here (or NaN); keeps speculated divisions flag-free
    ux, uy, uz = rx / ss, ry / ss, rz / ss
    kd = ux * dx + uy * dy + uz * dz
    px, py, pz = (dx - kd * ux) / ss, (dy - kd * uy) / ss, (dz - kd * uz) / ss
    a = rw * kd
    return (
        phi * ux,
        phi * uy,
        phi * uz,
        ln,
        a * ux - dw * rx + phi * px,
        a * uy - dw * ry + phi * py,
        a * uz - dw * rz + phi * pz,
        dsc,
    )


@jit
def dq_exp_twist(wx, wy, wz, vx, vy, vz):
    """exp(½(ω + ε v)) for the pure dual quaternion of a twist [ω, v] (Dantam (84) with zero scalar parts)."""
    hx, hy, hz = 0.5 * wx, 0.5 * wy, 0.5 * wz
    phi = norm3(hx, hy, hz)
    k = 0.5 * (hx * vx + hy * vy + hz * vz)
    sc = sinc(phi)
    ds = dsinc(phi) * k
    hs = 0.5 * sc
    return (
        sc * hx,
        sc * hy,
        sc * hz,
        math.cos(phi),
        hs * vx + ds * hx,
        hs * vy + ds * hy,
        hs * vz + ds * hz,
        -sc * k,
    )


# ---------------------------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------------------------


@gu(f"{_V},{_V},{_V}", "(n),(n)->(n)")
def dualquat_mul(a, b, o):
    # Dantam 2014 eq. (79); the flat kernel (C-contiguous batches) uses the same helper
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_mul(
        a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]
    )


@gu(f"{_V},{_V}", "(n)->(n)")
def dualquat_inv(s, o):
    # (r + ε d)^-1 = r^-1 - ε r^-1 d r^-1, with r^-1 = u*/n (u = r/n) so no square of n is formed.
    n = norm4(s[0], s[1], s[2], s[3])
    if n == 0.0:
        n = _NAN
    ux, uy, uz, uw = -s[0] / n, -s[1] / n, -s[2] / n, s[3] / n  # u*
    ix, iy, iz, iw = ux / n, uy / n, uz / n, uw / n
    px, py, pz, pw = qmul(ux, uy, uz, uw, s[4] / n, s[5] / n, s[6] / n, s[7] / n)
    px, py, pz, pw = qmul(px, py, pz, pw, ix, iy, iz, iw)
    o[0], o[1], o[2], o[3] = ix, iy, iz, iw
    o[4], o[5], o[6], o[7] = -px, -py, -pz, -pw


@gu(f"{_V},{_V},{_V}", "(n),(m)->(m)")
def dualquat_norm(s, d2, o):
    # |S| = sqrt(S S*) = |r| + ε (r·d)/|r|
    n = norm4(s[0], s[1], s[2], s[3])
    if n == 0.0:
        n = _NAN
    o[0] = n
    o[1] = (s[0] / n) * s[4] + (s[1] / n) * s[5] + (s[2] / n) * s[6] + (s[3] / n) * s[7]


@gu(f"{_V},{_V}", "(n)->(n)")
def dualquat_normalize(s, o):
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_normalize(s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7])


@gu(f"{_V},{_V}", "(n)->(n)")
def dualquat_canonical(s, o):
    # flip BOTH parts with the real part (the dual part is ½ t (x) r: flipping r alone negates t)
    if flip_sign(s[0], s[1], s[2], s[3]):
        for i in range(8):
            o[i] = -s[i]
    else:
        for i in range(8):
            o[i] = s[i]


@gu(f"{_V},{_V},{_V},{_V}", "(k),(m),(n)->(n)")
def dualquat_from_qt(q, t, d8, o):
    # Dantam 2014 eqs. (76)-(77): r = q/|q|, d = ½ t (x) r
    n = norm4(q[0], q[1], q[2], q[3])
    if n == 0.0:
        n = _NAN
    x, y, z, w = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    o[0], o[1], o[2], o[3] = x, y, z, w
    dx, dy, dz, dw = qmul(t[0], t[1], t[2], 0.0, x, y, z, w)
    o[4], o[5], o[6], o[7] = 0.5 * dx, 0.5 * dy, 0.5 * dz, 0.5 * dw


@jit
def _translation(rx, ry, rz, rw, dx, dy, dz, dw, s2):
    # t = 2 vec(d (x) r*)/|r|**2 = s2 * (r_w d_v - d_w r_v + r_v x d_v)  (Dantam (78), Walker (19)/(67))
    cx, cy, cz = cross(rx, ry, rz, dx, dy, dz)
    return (
        s2 * (rw * dx - dw * rx + cx),
        s2 * (rw * dy - dw * ry + cy),
        s2 * (rw * dz - dw * rz + cz),
    )


@gu(f"{_V},{_V},{_V},{_V},{_V}", "(n),(k),(m)->(k),(m)")
def qt_from_dualquat(s, d4, d3, q, t):
    n = norm4(s[0], s[1], s[2], s[3])
    if n == 0.0:
        n = _NAN
    x, y, z, w = s[0] / n, s[1] / n, s[2] / n, s[3] / n
    q[0], q[1], q[2], q[3] = x, y, z, w
    t[0], t[1], t[2] = _translation(x, y, z, w, s[4] / n, s[5] / n, s[6] / n, s[7] / n, 2.0)


@gu(f"{_V},{_M},{_M}", "(n),(p,p)->(p,p)")
def matrix_from_dualquat(s, d44, o):
    # Walker 1991 eqs. (17)-(19) / Dantam 2014 eqs. (108)-(109), scaled by 2/|r|**2 (non-unit r normalized)
    x, y, z, w = s[0], s[1], s[2], s[3]
    dx, dy, dz, dw = s[4], s[5], s[6], s[7]
    c, sc = unit_scale(x, y, z, w)
    if c != 1.0:
        x, y, z, w, dx, dy, dz, dw = c * x, c * y, c * z, c * w, c * dx, c * dy, c * dz, c * dw
    m = rotmat(x, y, z, w)
    for i in range(3):
        for j in range(3):
            o[i, j] = m[3 * i + j]
    o[0, 3], o[1, 3], o[2, 3] = _translation(x, y, z, w, dx, dy, dz, dw, sc)
    o[3, 0] = o[3, 1] = o[3, 2] = 0.0
    o[3, 3] = 1.0


@gu(f"{_M},{_V},{_V},{_V}", "(p,p),(k),(n)->(n)")
def dualquat_from_rt(m, r, d8, o):
    # Walker 1991 eq. (25): s = W(r) t with t = ½ [t; 0], i.e. s = ½ t (x) r; r is already a unit quaternion
    x, y, z, w = r[0], r[1], r[2], r[3]
    o[0], o[1], o[2], o[3] = x, y, z, w
    dx, dy, dz, dw = qmul(m[0, 3], m[1, 3], m[2, 3], 0.0, x, y, z, w)
    o[4], o[5], o[6], o[7] = 0.5 * dx, 0.5 * dy, 0.5 * dz, 0.5 * dw


@gu(f"{_V},{_V},{_V}", "(n),(m)->(m)")
def dualquat_transform(s, p, o):
    # p' = R p + t (Dantam 2014 eq. (95) in the implicit form (106)), see _kutil.transform_point; s2 = 2/|r|**2
    # normalizes a non-unit real part (extreme norms rescaled first).  The flat kernel uses the same helper.
    x, y, z, w = s[0], s[1], s[2], s[3]
    dx, dy, dz, dw = s[4], s[5], s[6], s[7]
    c, s2 = unit_scale(x, y, z, w)
    if c != 1.0:
        x, y, z, w, dx, dy, dz, dw = c * x, c * y, c * z, c * w, c * dx, c * dy, c * dz, c * dw
    o[0], o[1], o[2] = transform_point(x, y, z, w, dx, dy, dz, dw, p[0], p[1], p[2], s2)


@gu(f"{_V},{_V}", "(n)->(n)")
def dualquat_exp(s, o):
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_exp(s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7])


@gu(f"{_V},{_V}", "(n)->(n)")
def dualquat_log(s, o):
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_log(s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7])


@gu(f"{_V},{_S},{_V}", "(n),()->(n)")
def dualquat_pow(s, t, o):
    # S**t = exp(t ln S), principal logarithm, no canonicalisation
    if is_zero4(s[0], s[1], s[2], s[3]):
        fill_nan(o, 8)
        return
    # The rotation angle of exp(t ln S) is |t| phi with phi = atan2(|r_v|, r_w) (pi on the negative real axis); it is
    # passed in rather than recomputed as |t (phi/|r_v|) r_v| (three more roundings, amplified by t).
    a0, a1, a2, a3, a4, a5, a6, a7 = dq_log(s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7])
    phi = abs(t) * math.atan2(norm3(s[0], s[1], s[2]), s[3])
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_exp_angle(
        phi, t * a0, t * a1, t * a2, t * a3, t * a4, t * a5, t * a6, t * a7
    )


@gu(f"{_V},{_V},{_V}", "(m),(n)->(n)")
def dualquat_from_twist(xi, d8, o):
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_exp_twist(xi[0], xi[1], xi[2], xi[3], xi[4], xi[5])


@gu(f"{_V},{_V},{_V}", "(n),(m)->(m)")
def twist_from_dualquat(s, d6, o):
    # normalize, canonicalise (r_w >= 0 so |ω| <= pi), then 2 ln S; the scalar parts are 0 for a unit S
    if is_zero4(s[0], s[1], s[2], s[3]):
        fill_nan(o, 6)
        return
    r0, r1, r2, r3, d0, d1, d2, d3 = dq_normalize(s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7])
    if flip_sign(r0, r1, r2, r3):
        r0, r1, r2, r3, d0, d1, d2, d3 = -r0, -r1, -r2, -r3, -d0, -d1, -d2, -d3
    a0, a1, a2, a3, a4, a5, a6, a7 = dq_log(r0, r1, r2, r3, d0, d1, d2, d3)
    o[0], o[1], o[2] = 2.0 * a0, 2.0 * a1, 2.0 * a2
    o[3], o[4], o[5] = 2.0 * a4, 2.0 * a5, 2.0 * a6


@gu(f"{_V},{_V},{_S},{_V}", "(n),(n),()->(n)")
def dualquat_sclerp(s0, s1, t, o):
    # s0 (x) (canonical(s0* (x) s1))**t: the shortest screw from s0 to s1; inputs normalized
    if is_zero4(s0[0], s0[1], s0[2], s0[3]) or is_zero4(s1[0], s1[1], s1[2], s1[3]):
        fill_nan(o, 8)
        return
    a0, a1, a2, a3, a4, a5, a6, a7 = dq_normalize(s0[0], s0[1], s0[2], s0[3], s0[4], s0[5], s0[6], s0[7])
    b0, b1, b2, b3, b4, b5, b6, b7 = dq_normalize(s1[0], s1[1], s1[2], s1[3], s1[4], s1[5], s1[6], s1[7])
    c0, c1, c2, c3, c4, c5, c6, c7 = dq_mul(-a0, -a1, -a2, a3, -a4, -a5, -a6, a7, b0, b1, b2, b3, b4, b5, b6, b7)
    if flip_sign(c0, c1, c2, c3):
        c0, c1, c2, c3, c4, c5, c6, c7 = -c0, -c1, -c2, -c3, -c4, -c5, -c6, -c7
    l0, l1, l2, l3, l4, l5, l6, l7 = dq_log(c0, c1, c2, c3, c4, c5, c6, c7)
    e0, e1, e2, e3, e4, e5, e6, e7 = dq_exp(t * l0, t * l1, t * l2, t * l3, t * l4, t * l5, t * l6, t * l7)
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_mul(
        a0, a1, a2, a3, a4, a5, a6, a7, e0, e1, e2, e3, e4, e5, e6, e7
    )


@gu(f"{_V},{_V},{_S},{_S},{_V},{_V}", "(m),(m),(),(),(n)->(n)")
def dualquat_from_screw(axis, p, dist, theta, d8, o):
    # Walker 1991 eqs. (11)-(12): r = [sin(θ/2) n, cos(θ/2)], s = [(d/2) cos(θ/2) n + sin(θ/2) p x n, -(d/2) sin(θ/2)]
    if axis[0] == 0.0 and axis[1] == 0.0 and axis[2] == 0.0:
        fill_nan(o, 8)
        return
    n = norm3(axis[0], axis[1], axis[2])
    nx, ny, nz = axis[0] / n, axis[1] / n, axis[2] / n
    h = 0.5 * theta
    sh, ch = math.sin(h), math.cos(h)
    hd = 0.5 * dist
    mx, my, mz = cross(p[0], p[1], p[2], nx, ny, nz)
    o[0], o[1], o[2], o[3] = sh * nx, sh * ny, sh * nz, ch
    a = hd * ch
    o[4], o[5], o[6], o[7] = a * nx + sh * mx, a * ny + sh * my, a * nz + sh * mz, -hd * sh


@gu(f"{_V},{_V},{_V},{_V},{_V},{_V}", "(n),(m)->(m),(m),(),()")
def screw_from_dualquat(s, d3, axis, point, dist, theta):
    # Walker 1991 Appendix 3 in stable form, on the normalized, canonical (r_w >= 0) dual quaternion:
    # θ = 2 atan2(|r_v|, r_w), n = r_v/|r_v|, d/2 = r_w (n·s_v) - s_w |r_v|, p = (r_v x s_v)/|r_v|**2 (the foot ⊥ n)
    if is_zero4(s[0], s[1], s[2], s[3]):
        fill_nan(axis, 3)
        fill_nan(point, 3)
        dist[0] = theta[0] = _NAN
        return
    r0, r1, r2, r3, d0, d1, d2, d3_ = dq_normalize(s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7])
    if flip_sign(r0, r1, r2, r3):
        r0, r1, r2, r3, d0, d1, d2, d3_ = -r0, -r1, -r2, -r3, -d0, -d1, -d2, -d3_
    sv = norm3(r0, r1, r2)
    if sv == 0.0:
        # pure translation (r = [0, 0, 0, 1]): t = 2 s_v; the identity gets axis x
        point[0] = point[1] = point[2] = 0.0
        theta[0] = 0.0
        tx, ty, tz = 2.0 * d0, 2.0 * d1, 2.0 * d2
        tn = norm3(tx, ty, tz)
        if tn == 0.0:
            axis[0], axis[1], axis[2] = 1.0, 0.0, 0.0
            dist[0] = 0.0
        else:
            tn_ = tn if tn > 0.0 else 1.0
            axis[0], axis[1], axis[2] = tx / tn_, ty / tn_, tz / tn_
            dist[0] = tn
        return
    ux, uy, uz = r0 / sv, r1 / sv, r2 / sv
    axis[0], axis[1], axis[2] = ux, uy, uz
    theta[0] = 2.0 * math.atan2(sv, r3)
    dist[0] = 2.0 * (r3 * (ux * d0 + uy * d1 + uz * d2) - d3_ * sv)
    cx, cy, cz = cross(ux, uy, uz, d0, d1, d2)
    point[0], point[1], point[2] = cx / sv, cy / sv, cz / sv


@gu(f"{_V},{_V},{_S},{_V}", "(n),(m),()->(n)")
def dualquat_integrate_space(s, xi, dt, o):
    # Dantam 2014 eq. (102): exp(Ω dt/2) (x) s, Ω = [ω, v_s] a spatial twist
    e0, e1, e2, e3, e4, e5, e6, e7 = dq_exp_twist(
        xi[0] * dt, xi[1] * dt, xi[2] * dt, xi[3] * dt, xi[4] * dt, xi[5] * dt
    )
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_mul(
        e0, e1, e2, e3, e4, e5, e6, e7, s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7]
    )


@gu(f"{_V},{_V},{_S},{_V}", "(n),(m),()->(n)")
def dualquat_integrate_body(s, xi, dt, o):
    # s (x) exp(Ω_b dt/2), Ω_b = [ω_b, v_b] a body twist
    e0, e1, e2, e3, e4, e5, e6, e7 = dq_exp_twist(
        xi[0] * dt, xi[1] * dt, xi[2] * dt, xi[3] * dt, xi[4] * dt, xi[5] * dt
    )
    o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = dq_mul(
        s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], e0, e1, e2, e3, e4, e5, e6, e7
    )
