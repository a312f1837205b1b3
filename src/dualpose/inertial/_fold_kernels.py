"""numba kernels that fold a sequence of rotation / screw vectors into (dual) quaternions (not public API).

Imported lazily by :mod:`dualpose.inertial.integrate`.  One pass over the updates per batch element: the state
lives in registers, each update is one exponential, one product and one renormalization.  Quaternions are xyzw
(Hamilton); dual quaternions ``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real``; screw vectors ``[σ, σ′]``.
The inline helpers are those of the algebra kernels, so the arithmetic is the algebra's.
"""

from __future__ import annotations

import math

import numba as nb

from dualpose.algebra._dualquat_kernels import dq_mul, dq_normalize
from dualpose.algebra._kutil import cross, norm3, norm4, qmul
from dualpose.algebra._lie_kernels import so3_apply, so3_coeffs
from dualpose.algebra.series import sinc

njit = nb.njit(cache=True, fastmath=False, error_model="numpy", nogil=True)


@nb.njit(cache=True, inline="always")
def half_exp(px, py, pz):
    """exp(Φ/2) = (sinc(|Φ|/2) Φ/2, cos(|Φ|/2)): the quaternion of rotation vector Φ (Dantam 2014 eq. (50))."""
    h = 0.5 * norm3(px, py, pz)
    f = 0.5 * sinc(h)
    return f * px, f * py, f * pz, math.cos(h)


@nb.njit(cache=True, inline="always")
def screw_half_exp(sx, sy, sz, tx, ty, tz):
    """exp(Φ̂/2) for the screw vector Φ̂ = σ + εσ′: r = exp(σ/2), dual = ½ Δt (x) r with Δt = J_l(σ) σ′."""
    rx, ry, rz, rw = half_exp(sx, sy, sz)
    a, b, c = so3_coeffs(norm3(sx, sy, sz), 0.0)
    dx, dy, dz = so3_apply(sx, sy, sz, a, b, c, tx, ty, tz)
    ex, ey, ez, ew = qmul(0.5 * dx, 0.5 * dy, 0.5 * dz, 0.0, rx, ry, rz, rw)
    return rx, ry, rz, rw, ex, ey, ez, ew


@nb.njit(cache=True, inline="always")
def update_vector(x, k, n, kmat, cprev, sgn):
    """Rotation / screw vector of update k from rows x[k n : k n + n] (width 3: [θ]; width 6: [θ, u]).

    ``Σ x_i + sgn Σ_{i<j} kmat[i, j] x_i × x_j`` (dual cross product for width 6), plus
    ``sgn cprev x_{kn−1} × x_{kn}`` (one-plus-previous; x_{−1} = 0).  Returns six scalars ``σ, σ′`` (σ′ = 0 for
    width 3).
    """
    dual = x.shape[1] == 6
    base = k * n
    sx = sy = sz = tx = ty = tz = 0.0
    for i in range(n):
        r = x[base + i]
        sx += r[0]
        sy += r[1]
        sz += r[2]
        if dual:
            tx += r[3]
            ty += r[4]
            tz += r[5]
    for i in range(n + 1):
        for j in range(i + 1, n + 1):
            # i == 0 is the previous sample (coefficient cprev, paired with the first sample only)
            if i == 0:
                c = cprev if (j == 1 and base > 0) else 0.0
            else:
                c = kmat[i - 1, j - 1]
            if c == 0.0:
                continue
            c *= sgn
            a = x[base + i - 1]
            b = x[base + j - 1]
            cx, cy, cz = cross(a[0], a[1], a[2], b[0], b[1], b[2])
            sx += c * cx
            sy += c * cy
            sz += c * cz
            if dual:
                ex, ey, ez = cross(a[0], a[1], a[2], b[3], b[4], b[5])
                fx, fy, fz = cross(a[3], a[4], a[5], b[0], b[1], b[2])
                tx += c * (ex + fx)
                ty += c * (ey + fy)
                tz += c * (ez + fz)
    return sx, sy, sz, tx, ty, tz


@njit
def update_vectors(x, n, kmat, cprev, sgn, out):
    """out[b, k] = update_vector(x[b], k, ...) (first 3 or 6 components)."""
    w = out.shape[2]
    for b in range(x.shape[0]):
        xb = x[b]
        for k in range(out.shape[1]):
            v = update_vector(xb, k, n, kmat, cprev, sgn)
            for c in range(w):
                out[b, k, c] = v[c]


@njit
def fold_quat(q0, x, n, kmat, cprev, sgn, out):
    """out[b, 0] = q0[b]/|q0[b]|; out[b, k+1] = normalize(out[b, k] (x) exp(Φ_k/2)), or exp(Φ_k/2) (x) out[b, k]
    when sgn < 0 (inertial frame), with Φ_k = update_vector(x[b], k, ...)."""
    left = sgn < 0.0
    for b in range(x.shape[0]):
        xb = x[b]
        x0, y, z, w = q0[b, 0], q0[b, 1], q0[b, 2], q0[b, 3]
        nn = norm4(x0, y, z, w)
        x0, y, z, w = x0 / nn, y / nn, z / nn, w / nn
        out[b, 0, 0], out[b, 0, 1], out[b, 0, 2], out[b, 0, 3] = x0, y, z, w
        for k in range(out.shape[1] - 1):
            px, py, pz, _, _, _ = update_vector(xb, k, n, kmat, cprev, sgn)
            ex, ey, ez, ew = half_exp(px, py, pz)
            if left:
                x0, y, z, w = qmul(ex, ey, ez, ew, x0, y, z, w)
            else:
                x0, y, z, w = qmul(x0, y, z, w, ex, ey, ez, ew)
            nn = norm4(x0, y, z, w)
            x0, y, z, w = x0 / nn, y / nn, z / nn, w / nn
            out[b, k + 1, 0], out[b, k + 1, 1], out[b, k + 1, 2], out[b, k + 1, 3] = x0, y, z, w


@njit
def fold_dualquat(s0, x, n, kmat, cprev, sgn, out):
    """As :func:`fold_quat` for dual quaternions and screw vectors; renormalized (dual-number norm) each update."""
    left = sgn < 0.0
    for b in range(x.shape[0]):
        xb = x[b]
        r0, r1, r2, r3, d0, d1, d2, d3 = dq_normalize(
            s0[b, 0], s0[b, 1], s0[b, 2], s0[b, 3], s0[b, 4], s0[b, 5], s0[b, 6], s0[b, 7]
        )
        o = out[b, 0]
        o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = r0, r1, r2, r3, d0, d1, d2, d3
        for k in range(out.shape[1] - 1):
            sx, sy, sz, tx, ty, tz = update_vector(xb, k, n, kmat, cprev, sgn)
            e0, e1, e2, e3, e4, e5, e6, e7 = screw_half_exp(sx, sy, sz, tx, ty, tz)
            if left:
                r0, r1, r2, r3, d0, d1, d2, d3 = dq_mul(e0, e1, e2, e3, e4, e5, e6, e7, r0, r1, r2, r3, d0, d1, d2, d3)
            else:
                r0, r1, r2, r3, d0, d1, d2, d3 = dq_mul(r0, r1, r2, r3, d0, d1, d2, d3, e0, e1, e2, e3, e4, e5, e6, e7)
            r0, r1, r2, r3, d0, d1, d2, d3 = dq_normalize(r0, r1, r2, r3, d0, d1, d2, d3)
            o = out[b, k + 1]
            o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7] = r0, r1, r2, r3, d0, d1, d2, d3
