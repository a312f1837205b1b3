"""numba gufunc kernels for quaternions (xyzw, Hamilton).  Imported lazily by :mod:`dualpose.algebra.quat`.

Kernels write NaN where an argument that must be nonzero is zero; the Python wrappers turn that into a
ValueError.  Each kernel is one pass over the data.
"""

from __future__ import annotations

import math

import numba as nb

from dualpose.algebra._kutil import norm3, norm4, qmul, quat_log_parts, quat_of_rotmat, rotate_any, rotmat
from dualpose.algebra.series import atan2c, sinc

_V = "float64[:]"
_S = "float64"
_M = "float64[:, :]"
_LO = 2.0**-300
_HI = 2.0**300


def gu(types: str, layout: str):  # noqa: ANN201
    return nb.guvectorize([f"void({types})"], layout, nopython=True, cache=True)


@gu(f"{_V},{_V},{_V}", "(n),(n)->(n)")
def quat_mul(p, q, o):  # noqa: ANN001
    o[0], o[1], o[2], o[3] = qmul(p[0], p[1], p[2], p[3], q[0], q[1], q[2], q[3])


@gu(f"{_V},{_V}", "(n)->()")
def quat_norm(q, o):  # noqa: ANN001
    o[0] = norm4(q[0], q[1], q[2], q[3])


@gu(f"{_V},{_V}", "(n)->(n)")
def quat_normalize(q, o):  # noqa: ANN001
    n = norm4(q[0], q[1], q[2], q[3])
    if n == 0.0:
        n = math.nan
    o[0], o[1], o[2], o[3] = q[0] / n, q[1] / n, q[2] / n, q[3] / n


@gu(f"{_V},{_V}", "(n)->(n)")
def quat_inv(q, o):  # noqa: ANN001
    n = norm4(q[0], q[1], q[2], q[3])
    if n == 0.0:
        n = math.nan
    x, y, z, w = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    o[0], o[1], o[2], o[3] = -x / n, -y / n, -z / n, w / n


@gu(f"{_V},{_V}", "(n)->(n)")
def quat_canonical(q, o):  # noqa: ANN001
    x, y, z, w = q[0], q[1], q[2], q[3]
    flip = w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0)))))
    if flip:
        o[0], o[1], o[2], o[3] = -x, -y, -z, -w
    else:
        o[0], o[1], o[2], o[3] = x, y, z, w


@gu(f"{_V},{_V}", "(n)->(n)")
def quat_exp(q, o):  # noqa: ANN001
    # Dantam 2014 eq. (22)-(23)
    x, y, z, w = q[0], q[1], q[2], q[3]
    th = norm3(x, y, z)
    ew = math.exp(w)
    f = ew * sinc(th)
    o[0], o[1], o[2], o[3] = f * x, f * y, f * z, ew * math.cos(th)


@gu(f"{_V},{_V}", "(n)->(n)")
def quat_log(q, o):  # noqa: ANN001
    # Dantam 2014 eq. (25)-(28); at q_v = 0, q_w < 0 the axis x is chosen (any axis is a logarithm).
    # A zero q gives atan2c(0, 0) = NaN in the vector part (the wrapper raises).
    x, y, z, w = q[0], q[1], q[2], q[3]
    o[0], o[1], o[2], o[3] = quat_log_parts(x, y, z, w, atan2c(norm3(x, y, z), w))


@gu(f"{_V},{_S},{_V}", "(n),()->(n)")
def quat_pow(q, t, o):  # noqa: ANN001
    # Dantam 2014 eq. (30): q**t = exp(t ln q), principal logarithm.
    x, y, z, w = q[0], q[1], q[2], q[3]
    n = norm4(x, y, z, w)
    if n == 0.0:
        o[0] = o[1] = o[2] = o[3] = math.nan
        return
    s = norm3(x, y, z)
    phi = math.atan2(s, w)
    nt = n**t
    if s == 0.0 and w < 0.0:
        # ln q = (pi, 0, 0, ln n): axis x, as in quat_log
        o[0], o[1], o[2], o[3] = nt * math.sin(t * math.pi), 0.0, 0.0, nt * math.cos(t * math.pi)
        return
    a = nt * t * atan2c(s, w) * sinc(t * phi)
    o[0], o[1], o[2], o[3] = a * x, a * y, a * z, nt * math.cos(t * phi)


@gu(f"{_V},{_V},{_V}", "(n),(m)->(m)")
def quat_rotate(q, v, o):  # noqa: ANN001
    o[0], o[1], o[2] = rotate_any(q[0], q[1], q[2], q[3], v[0], v[1], v[2])


@gu(f"{_V},{_V},{_V}", "(m),(n)->(n)")
def quat_from_rotvec(v, d4, o):  # noqa: ANN001
    # Dantam 2014 eq. (50): q = (sin(|v|/2) v/|v|, cos(|v|/2))
    th = norm3(v[0], v[1], v[2])
    h = 0.5 * th
    f = 0.5 * sinc(h)
    o[0], o[1], o[2], o[3] = f * v[0], f * v[1], f * v[2], math.cos(h)


@gu(f"{_V},{_V},{_V}", "(n),(m)->(m)")
def rotvec_from_quat(q, d3, o):  # noqa: ANN001
    # Dantam 2014 eq. (51)-(53) with the atan2 angle; the sign is chosen so the angle is in [0, pi].
    x, y, z, w = q[0], q[1], q[2], q[3]
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = norm3(x, y, z)
    f = 2.0 * atan2c(s, w)
    o[0], o[1], o[2] = f * x, f * y, f * z


@gu(f"{_V},{_S},{_V},{_V}", "(m),(),(n)->(n)")
def quat_from_axis_angle(axis, angle, d4, o):  # noqa: ANN001
    n = norm3(axis[0], axis[1], axis[2])
    if n == 0.0:
        n = math.nan
    h = 0.5 * angle
    f = math.sin(h) / n
    o[0], o[1], o[2], o[3] = f * axis[0], f * axis[1], f * axis[2], math.cos(h)


@gu(f"{_V},{_V},{_V},{_V}", "(n),(m)->(m),()")
def axis_angle_from_quat(q, d3, axis, angle):  # noqa: ANN001
    x, y, z, w = q[0], q[1], q[2], q[3]
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = norm3(x, y, z)
    if s == 0.0:
        if w == 0.0:
            axis[0] = axis[1] = axis[2] = angle[0] = math.nan
            return
        axis[0], axis[1], axis[2] = 1.0, 0.0, 0.0
        angle[0] = 0.0
        return
    axis[0], axis[1], axis[2] = x / s, y / s, z / s
    angle[0] = 2.0 * math.atan2(s, w)


@gu(f"{_V},{_M},{_M}", "(n),(m,m)->(m,m)")
def matrix_from_quat(q, d33, o):  # noqa: ANN001
    # Dantam 2014 eq. (108) / Walker 1991 eq. (4), scaled by 2/|q|**2 so non-unit input is normalised.
    m = rotmat(q[0], q[1], q[2], q[3])
    for i in range(3):
        for j in range(3):
            o[i, j] = m[3 * i + j]


#: largest accepted |R^T R - I| entry in quat_from_matrix (docs/conventions.md, "Rotation matrices")
ORTHOGONALITY_TOL = 1e-5


@gu(f"{_M},{_V},{_V}", "(m,m),(n)->(n)")
def quat_from_matrix(r, d4, o):  # noqa: ANN001
    # Refuse (NaN, reported by the caller) a matrix that is not a rotation: max |R^T R - I| > tol or det R <= 0.
    a0, a1, a2 = r[0, 0], r[1, 0], r[2, 0]
    b0, b1, b2 = r[0, 1], r[1, 1], r[2, 1]
    c0, c1, c2 = r[0, 2], r[1, 2], r[2, 2]
    g = max(
        abs(a0 * a0 + a1 * a1 + a2 * a2 - 1.0),
        abs(b0 * b0 + b1 * b1 + b2 * b2 - 1.0),
        abs(c0 * c0 + c1 * c1 + c2 * c2 - 1.0),
        abs(a0 * b0 + a1 * b1 + a2 * b2),
        abs(a0 * c0 + a1 * c1 + a2 * c2),
        abs(b0 * c0 + b1 * c1 + b2 * c2),
    )
    det = a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0)
    if not (g <= ORTHOGONALITY_TOL and det > 0.0):
        o[0] = o[1] = o[2] = o[3] = math.nan
        return
    o[0], o[1], o[2], o[3] = quat_of_rotmat(r)


@gu(f"{_V},{_V},{_S},{_V}", "(n),(n),()->(n)")
def quat_slerp(p, q, t, o):  # noqa: ANN001
    # Dantam 2014 eq. (58): p (x) (p* (x) q)**t along the shorter arc; inputs normalised.
    np_ = norm4(p[0], p[1], p[2], p[3])
    nq = norm4(q[0], q[1], q[2], q[3])
    if np_ == 0.0 or nq == 0.0:
        o[0] = o[1] = o[2] = o[3] = math.nan
        return
    px, py, pz, pw = p[0] / np_, p[1] / np_, p[2] / np_, p[3] / np_
    qx, qy, qz, qw = q[0] / nq, q[1] / nq, q[2] / nq, q[3] / nq
    rx, ry, rz, rw = qmul(-px, -py, -pz, pw, qx, qy, qz, qw)
    if rw < 0.0:
        rx, ry, rz, rw = -rx, -ry, -rz, -rw
    s = norm3(rx, ry, rz)
    phi = math.atan2(s, rw)
    a = t * atan2c(s, rw) * sinc(t * phi) if s > 0.0 else t
    o[0], o[1], o[2], o[3] = qmul(px, py, pz, pw, a * rx, a * ry, a * rz, math.cos(t * phi))


@gu(f"{_V},{_V},{_V}", "(n),(n)->()")
def quat_angle(p, q, o):  # noqa: ANN001
    # Rotation angle between two orientations, 4 atan2(min(|p-q|,|p+q|), max(...)) in [0, pi]
    # (Dantam 2014 eq. (42) gives the angle between the 4-vectors; the rotation angle is twice it).
    np_ = norm4(p[0], p[1], p[2], p[3])
    nq = norm4(q[0], q[1], q[2], q[3])
    if np_ == 0.0 or nq == 0.0:
        o[0] = math.nan
        return
    # Form p/|p| -+ q/|q| without dividing the components first: with a = q - p, b = q + p (exact when
    # p ~ +-q) and k = (|q| - |p|)/(|p||q|) from |q|**2 - |p|**2 = a.b, p/|p| - q/|q| = q k - a/|p| and
    # p/|p| + q/|q| = b/|p| - q k, so the smaller of the two keeps full relative accuracy (tiny angles and angles
    # near pi) even when |p|, |q| are not exactly 1 in float64.  Inputs of extreme norm are first scaled
    # (exactly, by a power of two) so that a.b cannot overflow; near-unit inputs are left alone (a, b exact).
    p0, p1, p2, p3 = p[0], p[1], p[2], p[3]
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    if not (_LO <= np_ <= _HI):
        e = -math.frexp(np_)[1]
        p0, p1, p2, p3 = math.ldexp(p0, e), math.ldexp(p1, e), math.ldexp(p2, e), math.ldexp(p3, e)
        np_ = math.ldexp(np_, e)
    if not (_LO <= nq <= _HI):
        e = -math.frexp(nq)[1]
        q0, q1, q2, q3 = math.ldexp(q0, e), math.ldexp(q1, e), math.ldexp(q2, e), math.ldexp(q3, e)
        nq = math.ldexp(nq, e)
    a0, a1, a2, a3 = q0 - p0, q1 - p1, q2 - p2, q3 - p3
    b0, b1, b2, b3 = q0 + p0, q1 + p1, q2 + p2, q3 + p3
    k = (a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3) / ((np_ + nq) * np_ * nq)
    d = norm4(q0 * k - a0 / np_, q1 * k - a1 / np_, q2 * k - a2 / np_, q3 * k - a3 / np_)
    s = norm4(b0 / np_ - q0 * k, b1 / np_ - q1 * k, b2 / np_ - q2 * k, b3 / np_ - q3 * k)
    o[0] = 4.0 * math.atan2(min(d, s), max(d, s))


@gu(f"{_V},{_V},{_S},{_V}", "(n),(m),()->(n)")
def quat_integrate_space(q, w, dt, o):  # noqa: ANN001
    # Dantam 2014 eq. (62): q1 = exp(omega dt / 2) (x) q0, omega in the space (world) frame
    vx, vy, vz = w[0] * dt, w[1] * dt, w[2] * dt
    h = 0.5 * norm3(vx, vy, vz)
    f = 0.5 * sinc(h)
    o[0], o[1], o[2], o[3] = qmul(f * vx, f * vy, f * vz, math.cos(h), q[0], q[1], q[2], q[3])


@gu(f"{_V},{_V},{_S},{_V}", "(n),(m),()->(n)")
def quat_integrate_body(q, w, dt, o):  # noqa: ANN001
    # q1 = q0 (x) exp(omega dt / 2), omega in the body frame
    vx, vy, vz = w[0] * dt, w[1] * dt, w[2] * dt
    h = 0.5 * norm3(vx, vy, vz)
    f = 0.5 * sinc(h)
    o[0], o[1], o[2], o[3] = qmul(q[0], q[1], q[2], q[3], f * vx, f * vy, f * vz, math.cos(h))

