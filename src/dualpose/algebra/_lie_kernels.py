"""numba gufunc kernels for SO(3)/SE(3), implicit dual quaternions and quaternion calculus (not public API).

Imported lazily by :mod:`dualpose.algebra.lie`, :mod:`dualpose.algebra.implicit` and
:mod:`dualpose.algebra.derivatives`.  Quaternions are xyzw (scalar last, Hamilton); twists are ``[ω, v]``.
Every removable singularity goes through the guarded series of :mod:`dualpose.algebra.series`.  Kernels write
NaN where an argument that must be nonzero is zero; the wrappers turn that into a ValueError.

Flags passed as float scalars: ``sgn`` (+1 left Jacobian / space frame, -1 right Jacobian / body frame: the
right Jacobian is the left one at the negated argument), ``inv`` (0 the Jacobian, 1 its inverse), ``body``
(0 space frame, 1 body frame).
"""

from __future__ import annotations

import math

import numba as nb

from dualpose.algebra._kutil import cross, inv_norm2_scale, jit, norm3, norm4, qmul, rotate, rotate_any, rotmat
from dualpose.algebra.series import atan2c, cosc2, cosc4, dqalpha, dsinc, jinv, se3c, sinc, sinc3

_V = "float64[:]"
_S = "float64"
_M = "float64[:, :]"


def gu(types: str, layout: str):
    return nb.guvectorize([f"void({types})"], layout, nopython=True, cache=True)


# ---------------------------------------------------------------------------------------------------------------
# inline helpers
# ---------------------------------------------------------------------------------------------------------------


@jit
def so3_coeffs(th, inv):
    """(a, b, c) with J = a I + b Φ + c φφᵀ: the left Jacobian (inv == 0) or its inverse (inv != 0) at |φ| = th.

    J_l = I + cosc2 Φ + sinc3 Φ² and Φ² = φφᵀ − θ² I give a = 1 − θ² sinc3 = sinc(θ);
    J_l⁻¹ = I − Φ/2 + jinv Φ² gives a = 1 − θ² jinv = (θ/2) cot(θ/2) = cos(θ/2) / sinc(θ/2).
    """
    if inv == 0.0:
        return sinc(th), cosc2(th), sinc3(th)
    h = 0.5 * th
    return math.cos(h) / sinc(h), -0.5, jinv(th)


@jit
def so3_fill(x, y, z, a, b, c, o, r0, c0):
    """o[r0:r0+3, c0:c0+3] = a I + b [φ]× + c φφᵀ."""
    o[r0 + 0, c0 + 0] = a + c * x * x
    o[r0 + 0, c0 + 1] = -b * z + c * x * y
    o[r0 + 0, c0 + 2] = b * y + c * x * z
    o[r0 + 1, c0 + 0] = b * z + c * y * x
    o[r0 + 1, c0 + 1] = a + c * y * y
    o[r0 + 1, c0 + 2] = -b * x + c * y * z
    o[r0 + 2, c0 + 0] = -b * y + c * z * x
    o[r0 + 2, c0 + 1] = b * x + c * z * y
    o[r0 + 2, c0 + 2] = a + c * z * z


@jit
def so3_apply(x, y, z, a, b, c, ux, uy, uz):
    """(a I + b [φ]× + c φφᵀ) u."""
    cx, cy, cz = cross(x, y, z, ux, uy, uz)
    d = c * (x * ux + y * uy + z * uz)
    return (a * ux + b * cx + d * x, a * uy + b * cy + d * y, a * uz + b * cz + d * z)


@jit
def barfoot_q_apply(wx, wy, wz, vx, vy, vz, c1, c2, c3, x0, x1, x2):
    """Q(ω, v) x by cross products (no temporaries), with Barfoot's Q (Barfoot 2017, eq. (7.86), in [ω, v] order):

    Q = ½V + c1 (ΦV + VΦ + ΦVΦ) + c2 (ΦΦV + VΦΦ − 3ΦVΦ) + c3 (ΦVΦΦ + ΦΦVΦ),
    Φ = [ω]×, V = [v]×, c1 = sinc3(θ), c2 = cosc4(θ), c3 = se3c(θ), θ = |ω|.
    """
    a0, a1, a2 = cross(wx, wy, wz, x0, x1, x2)  # Φx
    b0, b1, b2 = cross(vx, vy, vz, x0, x1, x2)  # Vx
    ab0, ab1, ab2 = cross(wx, wy, wz, b0, b1, b2)  # ΦVx
    ba0, ba1, ba2 = cross(vx, vy, vz, a0, a1, a2)  # VΦx
    aba0, aba1, aba2 = cross(wx, wy, wz, ba0, ba1, ba2)  # ΦVΦx
    aab0, aab1, aab2 = cross(wx, wy, wz, ab0, ab1, ab2)  # ΦΦVx
    aa0, aa1, aa2 = cross(wx, wy, wz, a0, a1, a2)  # ΦΦx
    baa0, baa1, baa2 = cross(vx, vy, vz, aa0, aa1, aa2)  # VΦΦx
    abaa0, abaa1, abaa2 = cross(wx, wy, wz, baa0, baa1, baa2)  # ΦVΦΦx
    aaba0, aaba1, aaba2 = cross(wx, wy, wz, aba0, aba1, aba2)  # ΦΦVΦx
    return (
        0.5 * b0 + c1 * (ab0 + ba0 + aba0) + c2 * (aab0 + baa0 - 3.0 * aba0) + c3 * (abaa0 + aaba0),
        0.5 * b1 + c1 * (ab1 + ba1 + aba1) + c2 * (aab1 + baa1 - 3.0 * aba1) + c3 * (abaa1 + aaba1),
        0.5 * b2 + c1 * (ab2 + ba2 + aba2) + c2 * (aab2 + baa2 - 3.0 * aba2) + c3 * (abaa2 + aaba2),
    )


@jit
def qvec_sandwich(ax, ay, az, aw, tx, ty, tz, bx, by, bz, bw):
    """Vector part of a (x) [t, 0] (x) b*."""
    px, py, pz, pw = qmul(ax, ay, az, aw, tx, ty, tz, 0.0)
    rx, ry, rz, _ = qmul(px, py, pz, pw, -bx, -by, -bz, bw)
    return rx, ry, rz


# ---------------------------------------------------------------------------------------------------------------
# SO(3) / SE(3)
# ---------------------------------------------------------------------------------------------------------------


@gu(f"{_V},{_S},{_S},{_M}", "(n),(),()->(n,n)")
def so3_jacobian(phi, sgn, inv, o):
    x, y, z = sgn * phi[0], sgn * phi[1], sgn * phi[2]
    a, b, c = so3_coeffs(norm3(x, y, z), inv)
    so3_fill(x, y, z, a, b, c, o, 0, 0)


@gu(f"{_V},{_V},{_S},{_S},{_V}", "(n),(n),(),()->(n)")
def so3_jacobian_apply(phi, u, sgn, inv, o):
    x, y, z = sgn * phi[0], sgn * phi[1], sgn * phi[2]
    a, b, c = so3_coeffs(norm3(x, y, z), inv)
    o[0], o[1], o[2] = so3_apply(x, y, z, a, b, c, u[0], u[1], u[2])


@gu(f"{_V},{_M}", "(n)->(n,n)")
def so3_exp(phi, o):
    # Rodrigues: R = cos θ I + sinc θ Φ + cosc2 θ φφᵀ
    x, y, z = phi[0], phi[1], phi[2]
    th = norm3(x, y, z)
    so3_fill(x, y, z, math.cos(th), sinc(th), cosc2(th), o, 0, 0)


@gu(f"{_V},{_M},{_M},{_V}", "(k),(n,n)->(n,n),(n)")
def se3_exp(xi, d33, r, t):
    wx, wy, wz = xi[0], xi[1], xi[2]
    th = norm3(wx, wy, wz)
    so3_fill(wx, wy, wz, math.cos(th), sinc(th), cosc2(th), r, 0, 0)
    a, b, c = so3_coeffs(th, 0.0)
    t[0], t[1], t[2] = so3_apply(wx, wy, wz, a, b, c, xi[3], xi[4], xi[5])


@gu(f"{_V},{_S},{_S},{_M}", "(n),(),()->(n,n)")
def se3_jacobian(xi, sgn, inv, o):
    # [[J, 0], [Q, J]] or [[J⁻¹, 0], [−J⁻¹ Q J⁻¹, J⁻¹]], J = J_l(ω), at sgn * xi
    wx, wy, wz = sgn * xi[0], sgn * xi[1], sgn * xi[2]
    vx, vy, vz = sgn * xi[3], sgn * xi[4], sgn * xi[5]
    th = norm3(wx, wy, wz)
    c1, c2, c3 = sinc3(th), cosc4(th), se3c(th)
    a, b, c = so3_coeffs(th, inv)
    so3_fill(wx, wy, wz, a, b, c, o, 0, 0)
    so3_fill(wx, wy, wz, a, b, c, o, 3, 3)
    for j in range(3):
        o[0, 3 + j] = o[1, 3 + j] = o[2, 3 + j] = 0.0
        x0, x1, x2 = o[0, j], o[1, j], o[2, j]  # column j of J (or J⁻¹)
        if inv == 0.0:
            x0, x1, x2 = 0.0, 0.0, 0.0
            if j == 0:
                x0 = 1.0
            elif j == 1:
                x1 = 1.0
            else:
                x2 = 1.0
        y0, y1, y2 = barfoot_q_apply(wx, wy, wz, vx, vy, vz, c1, c2, c3, x0, x1, x2)
        if inv != 0.0:
            y0, y1, y2 = so3_apply(wx, wy, wz, a, b, c, y0, y1, y2)
            y0, y1, y2 = -y0, -y1, -y2
        o[3, j], o[4, j], o[5, j] = y0, y1, y2


@gu(f"{_V},{_V},{_M},{_M}", "(n),(m),(k,k)->(k,k)")
def se3_adjoint(q, t, d66, o):
    # [[R, 0], [t× R, R]] for [ω, v] twists; R normalizes q (2/|q|² scale)
    m = rotmat(q[0], q[1], q[2], q[3])
    for i in range(3):
        for j in range(3):
            o[i, j] = m[3 * i + j]
    for j in range(3):
        r0, r1, r2 = o[0, j], o[1, j], o[2, j]
        o[3, j], o[4, j], o[5, j] = cross(t[0], t[1], t[2], r0, r1, r2)
        o[3, 3 + j], o[4, 3 + j], o[5, 3 + j] = r0, r1, r2
        o[0, 3 + j] = o[1, 3 + j] = o[2, 3 + j] = 0.0


# ---------------------------------------------------------------------------------------------------------------
# implicit dual quaternions (Dantam 2014 §V)
# ---------------------------------------------------------------------------------------------------------------


@gu(f"{_V},{_V},{_V},{_V},{_V},{_V}", "(n),(m),(n),(m)->(n),(m)")
def qt_mul(q1, t1, q2, t2, qo, to):
    # Dantam 2014 eqs. (104)-(105)
    qo[0], qo[1], qo[2], qo[3] = qmul(q1[0], q1[1], q1[2], q1[3], q2[0], q2[1], q2[2], q2[3])
    rx, ry, rz = rotate_any(q1[0], q1[1], q1[2], q1[3], t2[0], t2[1], t2[2])
    to[0], to[1], to[2] = rx + t1[0], ry + t1[1], rz + t1[2]


@gu(f"{_V},{_V},{_V},{_V}", "(n),(m),(m)->(m)")
def qt_transform(q, t, p, o):
    # Dantam 2014 eq. (106)
    rx, ry, rz = rotate_any(q[0], q[1], q[2], q[3], p[0], p[1], p[2])
    o[0], o[1], o[2] = rx + t[0], ry + t[1], rz + t[2]


@gu(f"{_V},{_V},{_V},{_V}", "(n),(m)->(n),(m)")
def qt_conj(q, t, qo, to):
    # Dantam 2014 §V-C: (q*, -rot(q*, t))
    x, y, z, w = -q[0], -q[1], -q[2], q[3]
    rx, ry, rz = rotate_any(x, y, z, w, t[0], t[1], t[2])
    qo[0], qo[1], qo[2], qo[3] = x, y, z, w
    to[0], to[1], to[2] = -rx, -ry, -rz


@gu(f"{_V},{_V},{_V},{_V},{_V}", "(k),(n),(m)->(n),(m)")
def qt_from_twist(xi, d4, d3, qo, to):
    # q = exp(ω/2) (Dantam 2014 eq. (50)), t = J_l(ω) v
    wx, wy, wz = xi[0], xi[1], xi[2]
    th = norm3(wx, wy, wz)
    h = 0.5 * th
    f = 0.5 * sinc(h)
    qo[0], qo[1], qo[2], qo[3] = f * wx, f * wy, f * wz, math.cos(h)
    a, b, c = so3_coeffs(th, 0.0)
    to[0], to[1], to[2] = so3_apply(wx, wy, wz, a, b, c, xi[3], xi[4], xi[5])


@gu(f"{_V},{_V},{_V},{_V}", "(n),(m),(k)->(k)")
def twist_from_qt(q, t, d6, o):
    # ω = 2 ln(±q) with |ω| <= π (Dantam 2014 eqs. (51)-(53)), v = J_l(ω)⁻¹ t
    x, y, z, w = q[0], q[1], q[2], q[3]
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = norm3(x, y, z)
    if s == 0.0 and w == 0.0:
        for i in range(6):
            o[i] = math.nan
        return
    f = 2.0 * atan2c(s, w)
    wx, wy, wz = f * x, f * y, f * z
    a, b, c = so3_coeffs(norm3(wx, wy, wz), 1.0)
    o[0], o[1], o[2] = wx, wy, wz
    o[3], o[4], o[5] = so3_apply(wx, wy, wz, a, b, c, t[0], t[1], t[2])


@gu(
    f"{_V},{_V},{_V},{_V},{_V},{_V},{_V},{_V},{_V},{_V}",
    "(n),(m),(n),(m),(n),(m),(n),(m)->(n),(m)",
)
def qt_mul_derivative(q1, t1, q1d, t1d, q2, t2, q2d, t2d, qo, to):
    # Dantam 2014 eq. (107) applied to the normalized rotation u = q1/|q1| (the map qt_mul uses)
    ax, ay, az, aw = qmul(q1d[0], q1d[1], q1d[2], q1d[3], q2[0], q2[1], q2[2], q2[3])
    bx, by, bz, bw = qmul(q1[0], q1[1], q1[2], q1[3], q2d[0], q2d[1], q2d[2], q2d[3])
    qo[0], qo[1], qo[2], qo[3] = ax + bx, ay + by, az + bz, aw + bw
    n = norm4(q1[0], q1[1], q1[2], q1[3])
    if n == 0.0:
        to[0] = to[1] = to[2] = math.nan
        return
    ux, uy, uz, uw = q1[0] / n, q1[1] / n, q1[2] / n, q1[3] / n
    k = ux * q1d[0] + uy * q1d[1] + uz * q1d[2] + uw * q1d[3]
    dx, dy, dz, dw = (q1d[0] - k * ux) / n, (q1d[1] - k * uy) / n, (q1d[2] - k * uz) / n, (q1d[3] - k * uw) / n
    rx, ry, rz = rotate(ux, uy, uz, uw, t2d[0], t2d[1], t2d[2], 2.0)
    sx, sy, sz = qvec_sandwich(dx, dy, dz, dw, t2[0], t2[1], t2[2], ux, uy, uz, uw)
    to[0] = t1d[0] + rx + 2.0 * sx
    to[1] = t1d[1] + ry + 2.0 * sy
    to[2] = t1d[2] + rz + 2.0 * sz


# ---------------------------------------------------------------------------------------------------------------
# quaternion calculus (Dantam 2014 §II-I, II-J, III-C, III-D)
# ---------------------------------------------------------------------------------------------------------------


@gu(f"{_V},{_V},{_S},{_V}", "(n),(m),()->(n)")
def quat_derivative(q, w, body, o):
    # Dantam 2014 eq. (46): ½ ω (x) q (space) or ½ q (x) ω (body)
    if body == 0.0:
        r = qmul(w[0], w[1], w[2], 0.0, q[0], q[1], q[2], q[3])
    else:
        r = qmul(q[0], q[1], q[2], q[3], w[0], w[1], w[2], 0.0)
    o[0], o[1], o[2], o[3] = 0.5 * r[0], 0.5 * r[1], 0.5 * r[2], 0.5 * r[3]


@gu(f"{_V},{_V},{_S},{_V},{_V}", "(n),(n),(),(m)->(m)")
def omega_from_quat_derivative(q, qd, body, d3, o):
    # Dantam 2014 eq. (47): 2 vec(q̇ (x) q*) / |q|² (space) or 2 vec(q* (x) q̇) / |q|² (body)
    s2 = inv_norm2_scale(q[0], q[1], q[2], q[3])
    if body == 0.0:
        r = qmul(qd[0], qd[1], qd[2], qd[3], -q[0], -q[1], -q[2], q[3])
    else:
        r = qmul(-q[0], -q[1], -q[2], q[3], qd[0], qd[1], qd[2], qd[3])
    o[0], o[1], o[2] = s2 * r[0], s2 * r[1], s2 * r[2]


@gu(f"{_V},{_V},{_V},{_S},{_V}", "(n),(m),(m),()->(n)")
def quat_second_derivative(q, w, wd, body, o):
    # Dantam 2014 eq. (48): ½ (ω̇ (x) q + ω (x) q̇) with q̇ = ½ ω (x) q (space); mirrored for the body frame
    if body == 0.0:
        a = qmul(wd[0], wd[1], wd[2], 0.0, q[0], q[1], q[2], q[3])
        p = qmul(w[0], w[1], w[2], 0.0, q[0], q[1], q[2], q[3])
        b = qmul(w[0], w[1], w[2], 0.0, p[0], p[1], p[2], p[3])
    else:
        a = qmul(q[0], q[1], q[2], q[3], wd[0], wd[1], wd[2], 0.0)
        p = qmul(q[0], q[1], q[2], q[3], w[0], w[1], w[2], 0.0)
        b = qmul(p[0], p[1], p[2], p[3], w[0], w[1], w[2], 0.0)
    for i in range(4):
        o[i] = 0.5 * a[i] + 0.25 * b[i]


@gu(f"{_V},{_V},{_V},{_S},{_V},{_V}", "(n),(n),(n),(),(m)->(m)")
def angular_acceleration_from_quat(q, qd, qdd, body, d3, o):
    # d/dt of 2 vec(q̇ (x) q*)/|q|²; for |q| = 1 this is Dantam 2014 eq. (49): ω̇ = 2 vec(q̈ (x) q*)
    s2 = inv_norm2_scale(q[0], q[1], q[2], q[3])
    if body == 0.0:
        a = qmul(qdd[0], qdd[1], qdd[2], qdd[3], -q[0], -q[1], -q[2], q[3])
        b = qmul(qd[0], qd[1], qd[2], qd[3], -q[0], -q[1], -q[2], q[3])
    else:
        a = qmul(-q[0], -q[1], -q[2], q[3], qdd[0], qdd[1], qdd[2], qdd[3])
        b = qmul(-q[0], -q[1], -q[2], q[3], qd[0], qd[1], qd[2], qd[3])
    k = s2 * (q[0] * qd[0] + q[1] * qd[1] + q[2] * qd[2] + q[3] * qd[3])
    o[0], o[1], o[2] = s2 * (a[0] - k * b[0]), s2 * (a[1] - k * b[1]), s2 * (a[2] - k * b[2])


@gu(f"{_V},{_V},{_V}", "(n),(n)->(n)")
def quat_exp_derivative(q, qd, o):
    # Dantam 2014 eqs. (32)-(37) times e^w, plus ẇ e^q
    x, y, z, w = q[0], q[1], q[2], q[3]
    ph = norm3(x, y, z)
    e = math.exp(w)
    sc = sinc(ph)
    ds = dsinc(ph)
    vd = x * qd[0] + y * qd[1] + z * qd[2]
    wd = qd[3]
    f = wd * sc + ds * vd
    o[0] = e * (sc * qd[0] + f * x)
    o[1] = e * (sc * qd[1] + f * y)
    o[2] = e * (sc * qd[2] + f * z)
    o[3] = e * (wd * math.cos(ph) - vd * sc)


@gu(f"{_V},{_M}", "(n)->(n,n)")
def quat_exp_jacobian(q, o):
    x, y, z, w = q[0], q[1], q[2], q[3]
    ph = norm3(x, y, z)
    e = math.exp(w)
    sc = e * sinc(ph)
    ds = e * dsinc(ph)
    so3_fill(x, y, z, sc, 0.0, ds, o, 0, 0)
    o[0, 3], o[1, 3], o[2, 3] = sc * x, sc * y, sc * z
    o[3, 0], o[3, 1], o[3, 2] = -sc * x, -sc * y, -sc * z
    o[3, 3] = e * math.cos(ph)


@jit
def log_jac_terms(x, y, z, w):
    """(n, u, ŵ, g, A) for the principal-log Jacobian: u = v/n, ŵ = w/n, g = φ/|v|, A = dqalpha(φ).

    For w > 0 (φ < π/2), A comes from the guarded series; for w <= 0 the closed form (ŵ ŝ − φ)/ŝ³ with
    ŝ = |v|/n has no cancellation and, unlike an evaluation through φ, keeps its accuracy up to the pole at π.
    """
    n = norm4(x, y, z, w)
    s = norm3(x, y, z)
    if n == 0.0 or (s == 0.0 and w < 0.0):
        # zero (the wrapper raises) or the negative real axis, where ln q jumps: quiet NaN, no FP flags
        return math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan
    ux, uy, uz, wh = x / n, y / n, z / n, w / n
    g = atan2c(s, w)
    ph = math.atan2(s, w)
    if w > 0.0:
        a = dqalpha(ph)
    else:
        sh = s / n
        a = (wh * sh - ph) / (sh * sh * sh)
    return n, ux, uy, uz, wh, g, a


@gu(f"{_V},{_M}", "(n)->(n,n)")
def quat_log_jacobian(q, o):
    n, ux, uy, uz, wh, g, a = log_jac_terms(q[0], q[1], q[2], q[3])
    so3_fill(ux, uy, uz, g, 0.0, a / n, o, 0, 0)
    o[0, 3], o[1, 3], o[2, 3] = -ux / n, -uy / n, -uz / n
    o[3, 0], o[3, 1], o[3, 2] = ux / n, uy / n, uz / n
    o[3, 3] = wh / n


@gu(f"{_V},{_V},{_V}", "(n),(n)->(n)")
def quat_log_derivative(q, qd, o):
    n, ux, uy, uz, wh, g, a = log_jac_terms(q[0], q[1], q[2], q[3])
    uv = ux * qd[0] + uy * qd[1] + uz * qd[2]
    f = (a * uv - qd[3]) / n
    o[0] = g * qd[0] + f * ux
    o[1] = g * qd[1] + f * uy
    o[2] = g * qd[2] + f * uz
    o[3] = (uv + wh * qd[3]) / n


@gu(f"{_V},{_V},{_V},{_V}", "(m),(m),(n)->(n)")
def quat_derivative_from_rotvec_rate(v, vd, d4, o):
    # Dantam 2014 eqs. (54)-(57) with y = v/2, ẏ = v̇/2, φ = |y|
    yx, yy, yz = 0.5 * v[0], 0.5 * v[1], 0.5 * v[2]
    dx, dy, dz = 0.5 * vd[0], 0.5 * vd[1], 0.5 * vd[2]
    ph = norm3(yx, yy, yz)
    sc = sinc(ph)
    yd = yx * dx + yy * dy + yz * dz
    f = dsinc(ph) * yd
    o[0], o[1], o[2] = sc * dx + f * yx, sc * dy + f * yy, sc * dz + f * yz
    o[3] = -yd * sc
