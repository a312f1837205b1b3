"""numba kernels of the pose-from-correspondences solvers.  Imported lazily by :mod:`dualpose.registration`.

One problem is solved by :func:`solve_one` without allocating: the caller passes a work buffer.  The result row
``out`` (``ROW_SIZE`` floats) has the layout of :mod:`dualpose.registration._row`, shared with the Python wrappers.

Methods: 0 = ``dq`` (Walker 1991 §3.2 on centred data), 1 = ``horn`` (Horn 1987), 2 = ``svd`` (Arun 1987 /
Umeyama 1991).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from dualpose.algebra._kutil import quat_of_rotmat
from dualpose.registration import _row as R

OUT_SIZE = R.ROW_SIZE
BAD_INPUT = R.BAD_INPUT_NAMES
#: relative tolerance on the eigen gap below which the optimal rotation is reported as not unique
GAP_RTOL = 1e-9

_njit = nb.njit(cache=True, error_model="numpy")
# inlined into the batch loop: a call passing a dozen arrays costs more (reference counting) than the solve
_inline = nb.njit(cache=True, error_model="numpy", inline="always")


@_njit
def jacobi_eigh(a, v, n):
    """Cyclic Jacobi: diagonalise the symmetric ``a[:n, :n]`` in place, eigenvectors in the columns of ``v``."""
    for i in range(n):
        for j in range(n):
            v[i, j] = 1.0 if i == j else 0.0
    total = 0.0
    for i in range(n):
        for j in range(n):
            total += a[i, j] * a[i, j]
    if total == 0.0:
        return
    for _sweep in range(40):
        off = 0.0
        for p in range(n - 1):
            for q in range(p + 1, n):
                off += a[p, q] * a[p, q]
        if off <= 1e-36 * total:
            return
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = a[p, q]
                if apq == 0.0:
                    continue
                theta = (a[q, q] - a[p, p]) / (2.0 * apq)
                if abs(theta) > 1e150:
                    t = 0.5 / theta
                else:
                    t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):  # columns p, q
                    akp, akq = a[k, p], a[k, q]
                    a[k, p] = c * akp - s * akq
                    a[k, q] = s * akp + c * akq
                for k in range(n):  # rows p, q
                    apk, aqk = a[p, k], a[q, k]
                    a[p, k] = c * apk - s * aqk
                    a[q, k] = s * apk + c * aqk
                a[p, q] = 0.0
                a[q, p] = 0.0
                for k in range(n):
                    vkp, vkq = v[k, p], v[k, q]
                    v[k, p] = c * vkp - s * vkq
                    v[k, q] = s * vkp + c * vkq


@_njit
def _sorted_desc(a, order, n):
    """Indices of the diagonal of ``a[:n, :n]`` sorted by decreasing value (insertion sort, n <= 4)."""
    for i in range(n):
        order[i] = i
    for i in range(1, n):
        j = i
        while j > 0 and a[order[j], order[j]] > a[order[j - 1], order[j - 1]]:
            order[j], order[j - 1] = order[j - 1], order[j]
            j -= 1


@_njit
def _pick_top(a, v, order, tol, q):
    """Eigenvector of the largest eigenvalue; within a degenerate top eigenspace, the smallest rotation.

    The tie-break projects the identity ``[0, 0, 0, 1]`` onto the span of the eigenvectors whose eigenvalues are
    within ``tol`` of the largest (the set of optimal rotations); if that projection vanishes (every optimum is a
    half-turn), the first eigenvector is used.  Returns 1 if the top eigenvalue is simple, else 0.
    """
    top = a[order[0], order[0]]
    unique = 1 if top - a[order[1], order[1]] > tol else 0
    for i in range(4):
        q[i] = v[i, order[0]]
    if unique == 0:
        px = py = pz = pw = 0.0
        for k in range(4):
            col = order[k]
            if top - a[col, col] <= tol:
                w = v[3, col]
                px += w * v[0, col]
                py += w * v[1, col]
                pz += w * v[2, col]
                pw += w * v[3, col]
        nrm = math.sqrt(px * px + py * py + pz * pz + pw * pw)
        if nrm > 1e-6:
            q[0], q[1], q[2], q[3] = px / nrm, py / nrm, pz / nrm, pw / nrm
    nrm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    x, y, z, w = q[0], q[1], q[2], q[3]
    flip = w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0)))))
    if flip:
        nrm = -nrm
    for i in range(4):
        q[i] /= nrm
    return unique


@_inline
def _det3(a, b, c, d, e, f, g, h, i):
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


# :func:`solve_batch` works through blocks of ``BLOCK`` problems in three phases: (1) each problem's moments, its
# symmetric 4x4 matrix and that matrix's characteristic polynomial; (2) :func:`_largest_roots`, the Newton
# iterations for the two largest roots of every polynomial of the block as one loop across the problems (one
# problem's iterations are a chain of dependent divisions; the problems of a block are independent, so that loop
# vectorises); (3) each eigenvector read off the adjugate (:func:`_closed_form_vector`) and the result row.  Per
# problem everything stays in scalars: the block tables below are the only memory.
#: problems solved together (the block tables stay in the L1 cache)
BLOCK = 32
# rows of ``eig`` (NEIG, BLOCK), one column per problem: det(λI - A) = λ⁴ + c3 λ³ + c2 λ² + c1 λ + c0, the
# two largest roots, the spectrum's scale (0: the closed form is skipped)
_C3, _C2, _C1, _C0, _L1, _L2, _SCALE = range(7)
NEIG = 7
# columns of ``blk`` (BLOCK, NBLK): A's upper triangle (a00 a01 a02 a03 a11 a12 a13 a22 a23 a33), the moments s
# (row-major), the centroids, Σβ|p⁰'|², Walker's 4Σβ, the gap tolerance, Walker's C3 as (h, d), a skip flag
_A = 0
_S = 10
_AX, _AY, _AZ, _BX, _BY, _BZ = 19, 20, 21, 22, 23, 24
_SS0, _BW, _TOL = 25, 26, 27
_H = 28
_SKIP = 34
NBLK = 35


@_inline
def _char_poly(a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, bound):
    """``(c3, c2, c1, c0, start, scale)``: the characteristic polynomial of the symmetric 4x4 ``A`` (upper
    triangle given), the Newton start for its largest root and the spectrum's scale; all zero when the scale is 0
    or not finite (the closed form is then skipped).

    ``det(λI - A) = λ⁴ + c3 λ³ + c2 λ² + c1 λ + c0`` (all roots real).  The start is the smaller of the Gershgorin
    upper bound and ``bound``, an upper bound on λ1 known to the caller (for Horn's ``N``: ``E >= 0`` gives
    ``λ1 <= const / 2``, tight for a good fit, so Newton starts next to the root).
    """
    g0 = a00 + abs(a01) + abs(a02) + abs(a03)
    g1 = a11 + abs(a01) + abs(a12) + abs(a13)
    g2 = a22 + abs(a02) + abs(a12) + abs(a23)
    g3 = a33 + abs(a03) + abs(a13) + abs(a23)
    hi = min(max(max(g0, g1), max(g2, g3)), bound)
    lo = min(
        min(a00 - abs(a01) - abs(a02) - abs(a03), a11 - abs(a01) - abs(a12) - abs(a13)),
        min(a22 - abs(a02) - abs(a12) - abs(a23), a33 - abs(a03) - abs(a13) - abs(a23)),
    )
    scale = max(abs(hi), abs(lo))
    if scale == 0.0 or not math.isfinite(scale):
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    d00 = _det3(a11, a12, a13, a12, a22, a23, a13, a23, a33)
    c3 = -(a00 + a11 + a22 + a33)
    c2 = (
        a00 * a11 - a01 * a01 + a00 * a22 - a02 * a02 + a00 * a33 - a03 * a03
        + a11 * a22 - a12 * a12 + a11 * a33 - a13 * a13 + a22 * a33 - a23 * a23
    )  # fmt: skip
    c1 = -(
        d00
        + _det3(a00, a02, a03, a02, a22, a23, a03, a23, a33)
        + _det3(a00, a01, a03, a01, a11, a13, a03, a13, a33)
        + _det3(a00, a01, a02, a01, a11, a12, a02, a12, a22)
    )
    c0 = (
        a00 * d00
        - a01 * _det3(a01, a12, a13, a02, a22, a23, a03, a23, a33)
        + a02 * _det3(a01, a11, a13, a02, a12, a23, a03, a13, a33)
        - a03 * _det3(a01, a11, a12, a02, a12, a22, a03, a13, a23)
    )
    return c3, c2, c1, c0, hi, scale


@_njit
def _largest_roots(eig, m):
    """λ1 and λ2 (rows ``_L1``, ``_L2``) of the staged problems ``eig[:, :m]``, in place.

    Newton's iteration from an upper bound decreases monotonically to the largest root (every derivative of the
    polynomial is positive above it); each sweep takes one step for every problem (a converged problem takes
    zero steps) until none moves by more than ``1e-15 × scale``.  λ1 starts from the staged bound.  λ2 is the
    largest root of the deflated cubic ``λ³ + b2 λ² + b1 λ + b0 = poly / (λ − λ1)``; it starts from the
    Laguerre–Samuelson bound on the cubic's roots (their mean + √2 × their standard deviation) when the cubic and
    its first two derivatives are positive there (which places it above every root), else from λ1.
    """
    for _ in range(100):
        moving = 0
        for j in range(m):
            lam = eig[_L1, j]
            c3, c2, c1 = eig[_C3, j], eig[_C2, j], eig[_C1, j]
            f = (((lam + c3) * lam + c2) * lam + c1) * lam + eig[_C0, j]
            df = ((4.0 * lam + 3.0 * c3) * lam + 2.0 * c2) * lam + c1
            step = f / df if (f > 0.0) & (df > 0.0) else 0.0
            eig[_L1, j] = lam - step
            moving += 1 if step > 1e-15 * eig[_SCALE, j] else 0
        if moving == 0:
            break
    for j in range(m):
        l1 = eig[_L1, j]
        b2 = eig[_C3, j] + l1
        b1 = eig[_C2, j] + l1 * b2
        b0 = eig[_C1, j] + l1 * b1
        mu = -b2 / 3.0
        u = mu + math.sqrt(max(2.0 * ((b2 * b2 - 2.0 * b1) / 3.0 - mu * mu), 0.0))
        f = ((u + b2) * u + b1) * u + b0
        df = (3.0 * u + 2.0 * b2) * u + b1
        eig[_L2, j] = u if (u < l1) & (f > 0.0) & (df > 0.0) & (3.0 * u + b2 > 0.0) else l1
    for _ in range(100):
        moving = 0
        for j in range(m):
            l1 = eig[_L1, j]
            b2 = eig[_C3, j] + l1
            b1 = eig[_C2, j] + l1 * b2
            b0 = eig[_C1, j] + l1 * b1
            lam = eig[_L2, j]
            f = ((lam + b2) * lam + b1) * lam + b0
            df = (3.0 * lam + 2.0 * b2) * lam + b1
            step = f / df if (f > 0.0) & (df > 0.0) else 0.0
            eig[_L2, j] = lam - step
            moving += 1 if step > 1e-15 * eig[_SCALE, j] else 0
        if moving == 0:
            break


@_inline
def _closed_form_vector(a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, c3, c2, l1, l2, scale):
    """Unit eigenvector of the largest root ``l1`` of the symmetric 4x4 ``A`` (upper triangle; ``c3, c2`` from
    :func:`_char_poly`, ``l2`` the second root, ``scale`` the spectrum's scale).

    Returns ``(ok, x, y, z, w, λ3, λ4)``; ``ok`` is False when the closed form cannot vouch for the answer (the
    caller then uses Jacobi).  The eigenvector is the column of ``adj(A - λ1 I)`` with the largest diagonal
    cofactor (that matrix is ``c v vᵀ`` for a simple root), ``w >= 0``; λ3, λ4 are the roots of the quadratic left
    after deflating λ1 and λ2.  Accepted only if ``‖A q - λ1 q‖ <= 1e-14 (λ1 - λ2)`` (eigenvector error ~
    residual / gap) and the gap is a millionth of the spectrum's scale.
    """
    gap = l1 - l2
    if scale == 0.0 or not gap > 1e-6 * scale:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    b2 = c3 + l1
    b1 = c2 + l1 * b2
    e1 = b2 + l2
    e0 = b1 + l2 * e1
    disc = math.sqrt(max(e1 * e1 - 4.0 * e0, 0.0))
    m00, m11, m22, m33 = a00 - l1, a11 - l1, a22 - l1, a33 - l1
    d0 = _det3(m11, a12, a13, a12, m22, a23, a13, a23, m33)
    d1 = _det3(m00, a02, a03, a02, m22, a23, a03, a23, m33)
    d2 = _det3(m00, a01, a03, a01, m11, a13, a03, a13, m33)
    d3 = _det3(m00, a01, a02, a01, m11, a12, a02, a12, m22)
    e_0, e_1, e_2, e_3 = abs(d0), abs(d1), abs(d2), abs(d3)
    # cofactor C_ij = (-1)^(i+j) det(minor without row i, column j); column j of adj = (C_j0, C_j1, C_j2, C_j3)
    if e_0 >= e_1 and e_0 >= e_2 and e_0 >= e_3:
        x = d0
        y = -_det3(a01, a12, a13, a02, m22, a23, a03, a23, m33)
        z = _det3(a01, m11, a13, a02, a12, a23, a03, a13, m33)
        w = -_det3(a01, m11, a12, a02, a12, m22, a03, a13, a23)
    elif e_1 >= e_2 and e_1 >= e_3:
        x = -_det3(a01, a02, a03, a12, m22, a23, a13, a23, m33)
        y = d1
        z = -_det3(m00, a02, a03, a01, a12, a13, a03, a23, m33)
        w = _det3(m00, a02, a03, a01, a12, a13, a02, m22, a23)
    elif e_2 >= e_3:
        x = _det3(a01, a02, a03, m11, a12, a13, a13, a23, m33)
        y = -_det3(m00, a02, a03, a01, a12, a13, a03, a23, m33)
        z = d2
        w = -_det3(m00, a01, a03, a01, m11, a13, a02, a12, a23)
    else:
        x = -_det3(a01, a02, a03, m11, a12, a13, a12, m22, a23)
        y = _det3(m00, a02, a03, a01, a12, a13, a02, m22, a23)
        z = -_det3(m00, a01, a03, a01, m11, a13, a02, a12, a23)
        w = d3
    nrm = math.sqrt(x * x + y * y + z * z + w * w)
    if not nrm > 0.0 or not math.isfinite(nrm):
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0))))):
        nrm = -nrm
    x, y, z, w = x / nrm, y / nrm, z / nrm, w / nrm
    r0 = a00 * x + a01 * y + a02 * z + a03 * w - l1 * x
    r1 = a01 * x + a11 * y + a12 * z + a13 * w - l1 * y
    r2 = a02 * x + a12 * y + a22 * z + a23 * w - l1 * z
    r3 = a03 * x + a13 * y + a23 * z + a33 * w - l1 * w
    ok = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3) <= 1e-14 * gap
    return ok, x, y, z, w, 0.5 * (-e1 + disc), 0.5 * (-e1 - disc)


@_njit
def _jacobi_top(blk, j, tol, a, v, order, vec):
    """The fallback: cyclic Jacobi on ``A`` (slot ``j`` of ``blk``) with the smallest-rotation tie-break
    (:func:`_pick_top`); ``vec[0:4]`` the eigenvector, ``vec[4:8]`` the eigenvalues (descending).  Returns
    ``unique``."""
    idx = 0
    for r in range(4):
        for c in range(r, 4):
            a[r, c] = a[c, r] = blk[j, _A + idx]
            idx += 1
    jacobi_eigh(a, v, 4)
    _sorted_desc(a, order, 4)
    unique = _pick_top(a, v, order, tol, vec[0:4])
    for i in range(4):
        vec[4 + i] = a[order[i], order[i]]
    return unique


@_njit
def _first_bad_input(p0, p1, n0, n1, b):
    """``1 + index`` into ``BAD_INPUT`` of the first of problem ``b``'s inputs holding NaN or infinity, else
    ``len(BAD_INPUT) + 1`` (all finite: the moments overflowed)."""
    for k in range(p0.shape[1]):
        for i in range(3):
            if not math.isfinite(p0[b, k, i]):
                return 1
            if not math.isfinite(p1[b, k, i]):
                return 2
    for k in range(n0.shape[1]):
        for i in range(3):
            if not math.isfinite(n0[b, k, i]):
                return 3
            if not math.isfinite(n1[b, k, i]):
                return 4
    return 5


@_inline
def _add_outer(s00, s01, s02, s10, s11, s12, s20, s21, s22, x1, y1, z1, x0, y0, z0):
    """``s + x1 x0ᵀ`` for the 3x3 ``s`` given row-major as scalars."""
    return (
        s00 + x1 * x0, s01 + x1 * y0, s02 + x1 * z0,
        s10 + y1 * x0, s11 + y1 * y0, s12 + y1 * z0,
        s20 + z1 * x0, s21 + z1 * y0, s22 + z1 * z0,
    )  # fmt: skip


@_inline
def _horn_matrix(s00, s01, s02, s10, s11, s12, s20, s21, s22):
    """Upper triangle (a00 a01 a02 a03 a11 a12 a13 a22 a23 a33) of Horn's (1987) ``N`` in xyzw order.

    ``N = [[H + Hᵀ - tr(H) I, Δ], [Δᵀ, tr H]]`` with ``H = sᵀ = Σ model' measured'ᵀ`` and
    ``Δ = (H23 - H32, H31 - H13, H12 - H21)``, so that ``qᵀ N q = Σ measured' · R model'``.  For pure quaternions
    Walker's ``Σ Q(a)ᵀ W(b)`` is the same matrix of ``s = Σ a bᵀ``.
    """
    tr = s00 + s11 + s22
    return (
        s00 + s00 - tr, s01 + s10, s02 + s20, s21 - s12,
        s11 + s11 - tr, s12 + s21, s02 - s20,
        s22 + s22 - tr, s10 - s01,
        tr,
    )  # fmt: skip


@_inline
def _walker_matrix(a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, hx, hy, hz, dx, dy, dz, bw):
    """Walker's ``A`` (eq. (47)) from Horn's ``N`` (upper triangle) and ``C3``; returns its upper triangle and
    ``tr(C3ᵀ C3) / (4 bw)`` (the trace of the PSD ``C3`` term, 0 without points).

    Position quaternions ½[p; 0] with weights 4β make Walker's error (31) equal to the documented cost; direction
    quaternions [n; 0] keep weights α.  C1 = -2 Σ_blocks = -2 N (eq. (35)), C2 = bw I with bw = Σ 4β (eq. (36)),
    C3 = 2 Σ 4β (W(½p⁰) - Q(½p̃)) = 4 (W(g0) - Q(g1)) (eq. (37)) with the centred sums g0 = Σβ p⁰', g1 = Σβ p̃'
    (~0; kept so that the solve is Walker's, rounding residue and all).  For pure quaternions
    W(g0) - Q(g1) = [[-K(g0) - K(g1), g0 - g1], [-(g0 - g1)ᵀ, 0]], i.e. C3 = [[-[h]×, d], [-dᵀ, 0]] with
    h = 4 (g0 + g1), d = 4 (g0 - g1); then A = ½ (C3ᵀ (2 C2)⁻¹ C3 - C1 - C1ᵀ) = 2 N + C3ᵀ C3 / (4 bw).
    """
    a00, a01, a02, a03, a11 = a00 + a00, a01 + a01, a02 + a02, a03 + a03, a11 + a11
    a12, a13, a22, a23, a33 = a12 + a12, a13 + a13, a22 + a22, a23 + a23, a33 + a33
    if not bw > 0.0:
        return a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, 0.0
    k4 = 1.0 / (4.0 * bw)
    t00, t11 = hz * hz + hy * hy + dx * dx, hz * hz + hx * hx + dy * dy
    t22, t33 = hy * hy + hx * hx + dz * dz, dx * dx + dy * dy + dz * dz
    return (
        a00 + k4 * t00, a01 + k4 * (dx * dy - hx * hy), a02 + k4 * (dx * dz - hx * hz), a03 + k4 * (hy * dz - hz * dy),
        a11 + k4 * t11, a12 + k4 * (dy * dz - hy * hz), a13 + k4 * (hz * dx - hx * dz),
        a22 + k4 * t22, a23 + k4 * (hx * dy - hy * dx),
        a33 + k4 * t33,
        k4 * (t00 + t11 + t22 + t33),
    )  # fmt: skip


@_inline
def _walker_translation(x, y, z, w, hx, hy, hz, dx, dy, dz, bw):
    """Walker's centred translation (~0): ``s = -(C2 + C2ᵀ)⁻¹ C3 r`` (eq. (45)), ``t = 2 vec(W(r)ᵀ s)`` (eq. (19))."""
    k2 = -1.0 / (2.0 * bw)
    sx = k2 * (hz * y - hy * z + dx * w)
    sy = k2 * (-hz * x + hx * z + dy * w)
    sz = k2 * (hy * x - hx * y + dz * w)
    sw = k2 * (-dx * x - dy * y - dz * z)
    # W(r)ᵀ s = s (x) r*
    rx, ry, rz, rw = -x, -y, -z, w
    return (
        2.0 * (sw * rx + rw * sx + sy * rz - sz * ry),
        2.0 * (sw * ry + rw * sy + sz * rx - sx * rz),
        2.0 * (sw * rz + rw * sz + sx * ry - sy * rx),
    )


@_njit
def _svd_rotation(s00, s01, s02, s10, s11, s12, s20, s21, s22):
    """Arun / Kabsch with Umeyama's reflection guard: ``H = U S Vᵀ`` (``H = sᵀ``), ``R = V diag(1, 1, d) Uᵀ``,
    ``d = sign det(V Uᵀ)``.  Returns ``(x, y, z, w, σ1, σ2, σ3, d)`` (the quaternion of R, xyzw)."""
    h = np.empty((3, 3))
    h[0, 0], h[0, 1], h[0, 2] = s00, s10, s20
    h[1, 0], h[1, 1], h[1, 2] = s01, s11, s21
    h[2, 0], h[2, 1], h[2, 2] = s02, s12, s22
    u, sig, vt = np.linalg.svd(h)
    d = 1.0 if np.linalg.det(vt.T @ u.T) >= 0.0 else -1.0
    vd = vt.T.copy()
    for i in range(3):
        vd[i, 2] *= d
    x, y, z, w = quat_of_rotmat(vd @ u.T)
    return x, y, z, w, sig[0], sig[1], sig[2], d


_M2 = "float64[:, ::1]"
_M3 = "float64[:, :, ::1]"
_V1 = "float64[::1]"


@nb.njit(f"void({_M3}, {_M3}, {_M2}, {_M3}, {_M3}, {_M2}, int64, boolean, {_M2})", cache=True, error_model="numpy")
def solve_batch(p0, p1, beta, n0, n1, alpha, method, want_scale, out):
    """Solve ``B`` independent problems: ``p0, p1`` (B, n, 3), ``beta`` (B, n), ``n0, n1`` (B, m, 3), ``alpha``
    (B, m); ``out`` (B, OUT_SIZE).

    Problem ``b``: model ``p0[b]`` -> measured ``p1[b]`` with point weights ``beta[b]``, model ``n0[b]`` ->
    measured ``n1[b]`` with direction weights ``alpha[b]``.  Blocks of ``BLOCK`` problems: (1) moments, the 4x4
    matrix and its characteristic polynomial, (2) :func:`_largest_roots` for the whole block, (3) eigenvector,
    translation, scale, cost.  The per-problem work is written out here, in scalars, with helpers that take and
    return scalars: an array passed to a function costs reference counting, which at n = 10 costs more than the
    arithmetic (arrays go only to the rare paths: a non-finite input, the Jacobi fallback).
    """
    a = np.empty((4, 4))
    v = np.empty((4, 4))
    vec = np.empty(8)
    order = np.empty(4, np.int64)
    blk = np.empty((BLOCK, NBLK))
    eig = np.empty((NEIG, BLOCK))
    nprob, npt, ndir = p0.shape[0], p0.shape[1], n0.shape[1]
    for start in range(0, nprob, BLOCK):
        nblk = min(BLOCK, nprob - start)
        # ---- phase 1: moments, the 4x4 matrix, its characteristic polynomial
        for j in range(nblk):
            b = start + j
            for i in range(OUT_SIZE):
                out[b, i] = 0.0
            # weighted centroids (the translation is recovered at the end: t = c1 - s R c0)
            wsum = 0.0
            ax = ay = az = bx = by = bz = 0.0
            for k in range(npt):
                bk = beta[b, k]
                wsum += bk
                ax += bk * p0[b, k, 0]
                ay += bk * p0[b, k, 1]
                az += bk * p0[b, k, 2]
                bx += bk * p1[b, k, 0]
                by += bk * p1[b, k, 1]
                bz += bk * p1[b, k, 2]
            if wsum > 0.0:
                ax, ay, az, bx, by, bz = ax / wsum, ay / wsum, az / wsum, bx / wsum, by / wsum, bz / wsum
            # second moments of the centred data: s = Σ β p̃' p⁰'ᵀ + Σ α ñ n⁰ᵀ (a = measured, b = model), and the
            # centred sums g0 = Σβ p⁰', g1 = Σβ p̃' (Walker's C3)
            s00 = s01 = s02 = s10 = s11 = s12 = s20 = s21 = s22 = 0.0
            ss0 = ss1 = 0.0  # Σβ |p0'|², Σβ |p1'|²
            g0x = g0y = g0z = g1x = g1y = g1z = 0.0
            for k in range(npt):
                bk = beta[b, k]
                x0, y0, z0 = p0[b, k, 0] - ax, p0[b, k, 1] - ay, p0[b, k, 2] - az
                d1x, d1y, d1z = p1[b, k, 0] - bx, p1[b, k, 1] - by, p1[b, k, 2] - bz
                ss0 += bk * (x0 * x0 + y0 * y0 + z0 * z0)
                ss1 += bk * (d1x * d1x + d1y * d1y + d1z * d1z)
                g0x += bk * x0
                g0y += bk * y0
                g0z += bk * z0
                g1x += bk * d1x
                g1y += bk * d1y
                g1z += bk * d1z
                x1, y1, z1 = bk * d1x, bk * d1y, bk * d1z
                s00, s01, s02, s10, s11, s12, s20, s21, s22 = _add_outer(
                    s00, s01, s02, s10, s11, s12, s20, s21, s22, x1, y1, z1, x0, y0, z0
                )
            asum = 0.0
            for k in range(ndir):
                ak = alpha[b, k]
                asum += ak
                x0, y0, z0 = n0[b, k, 0], n0[b, k, 1], n0[b, k, 2]
                x1, y1, z1 = ak * n1[b, k, 0], ak * n1[b, k, 1], ak * n1[b, k, 2]
                s00, s01, s02, s10, s11, s12, s20, s21, s22 = _add_outer(
                    s00, s01, s02, s10, s11, s12, s20, s21, s22, x1, y1, z1, x0, y0, z0
                )
            # a NaN or infinity anywhere in the inputs makes these sums non-finite (0·inf and inf - inf are NaN):
            # only then look for the culprit; finite inputs whose moments overflow get their own code
            chk = ax + ay + az + bx + by + bz + ss0 + ss1 + s00 + s01 + s02 + s10 + s11 + s12 + s20 + s21 + s22
            if not math.isfinite(chk):
                out[b, R.BAD_INPUT] = _first_bad_input(p0, p1, n0, n1, b)
                blk[j, _SKIP] = 1.0
                for r in range(NEIG):
                    eig[r, j] = 0.0
                continue
            # E = const - 2 Σ(measured · R model): the largest possible |λ| of Horn's N is const / 2
            const = ss0 + ss1 + 2.0 * asum
            a00, a01, a02, a03, a11, a12, a13, a22, a23, a33 = _horn_matrix(s00, s01, s02, s10, s11, s12, s20, s21, s22)
            hx, hy, hz = 4.0 * (g0x + g1x), 4.0 * (g0y + g1y), 4.0 * (g0z + g1z)
            dx, dy, dz = 4.0 * (g0x - g1x), 4.0 * (g0y - g1y), 4.0 * (g0z - g1z)
            bw = 4.0 * wsum
            if method == 0:
                a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, c3_trace = _walker_matrix(
                    a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, hx, hy, hz, dx, dy, dz, bw
                )
                tol = GAP_RTOL * 2.0 * max(const, 1e-300)
                # λ1(A) <= const (the cost is >= 0) + the largest eigenvalue of the PSD C3 term (<= its trace)
                bound = const * (1.0 + 1e-12) + c3_trace
            else:
                tol = GAP_RTOL * max(const, 1e-300)
                bound = 0.5 * const * (1.0 + 1e-12)
            c3, c2, c1, c0, lam, scale = _char_poly(a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, bound)
            eig[_C3, j], eig[_C2, j], eig[_C1, j], eig[_C0, j] = c3, c2, c1, c0
            eig[_L1, j], eig[_SCALE, j] = lam, scale  # _largest_roots sets _L2
            blk[j, _A + 0], blk[j, _A + 1], blk[j, _A + 2], blk[j, _A + 3], blk[j, _A + 4] = a00, a01, a02, a03, a11
            blk[j, _A + 5], blk[j, _A + 6], blk[j, _A + 7], blk[j, _A + 8], blk[j, _A + 9] = a12, a13, a22, a23, a33
            blk[j, _S + 0], blk[j, _S + 1], blk[j, _S + 2] = s00, s01, s02
            blk[j, _S + 3], blk[j, _S + 4], blk[j, _S + 5] = s10, s11, s12
            blk[j, _S + 6], blk[j, _S + 7], blk[j, _S + 8] = s20, s21, s22
            blk[j, _AX], blk[j, _AY], blk[j, _AZ], blk[j, _BX], blk[j, _BY], blk[j, _BZ] = ax, ay, az, bx, by, bz
            blk[j, _SS0], blk[j, _BW], blk[j, _TOL] = ss0, bw, tol
            blk[j, _H + 0], blk[j, _H + 1], blk[j, _H + 2] = hx, hy, hz
            blk[j, _H + 3], blk[j, _H + 4], blk[j, _H + 5] = dx, dy, dz
            blk[j, _SKIP] = 0.0
        # ---- phase 2: the two largest roots of every polynomial of the block
        _largest_roots(eig, nblk)
        # ---- phase 3: eigenvector, translation, scale, cost
        for j in range(nblk):
            if blk[j, _SKIP] != 0.0:
                continue
            b = start + j
            a00, a01, a02, a03, a11 = blk[j, _A + 0], blk[j, _A + 1], blk[j, _A + 2], blk[j, _A + 3], blk[j, _A + 4]
            a12, a13, a22, a23, a33 = blk[j, _A + 5], blk[j, _A + 6], blk[j, _A + 7], blk[j, _A + 8], blk[j, _A + 9]
            tol = blk[j, _TOL]
            l1, l2 = eig[_L1, j], eig[_L2, j]
            fast, x, y, z, w, l3, l4 = _closed_form_vector(
                a00, a01, a02, a03, a11, a12, a13, a22, a23, a33, eig[_C3, j], eig[_C2, j], l1, l2, eig[_SCALE, j]
            )
            if fast:
                unique = 1 if l1 - l2 > tol else 0
            else:
                unique = _jacobi_top(blk, j, tol, a, v, order, vec)
                x, y, z, w, l1, l2, l3, l4 = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5], vec[6], vec[7]
            gap = l1 - l2
            tdq_x = tdq_y = tdq_z = 0.0
            bw = blk[j, _BW]
            if method == 0 and bw > 0.0:
                tdq_x, tdq_y, tdq_z = _walker_translation(
                    x, y, z, w, blk[j, _H], blk[j, _H + 1], blk[j, _H + 2], blk[j, _H + 3], blk[j, _H + 4],
                    blk[j, _H + 5], bw,
                )  # fmt: skip
            if method == 2:
                sx, sy, sz, sw, sig0, sig1, sig2, d = _svd_rotation(
                    blk[j, _S], blk[j, _S + 1], blk[j, _S + 2], blk[j, _S + 3], blk[j, _S + 4], blk[j, _S + 5],
                    blk[j, _S + 6], blk[j, _S + 7], blk[j, _S + 8],
                )  # fmt: skip
                out[b, R.SINGULAR_AT], out[b, R.SINGULAR_AT + 1], out[b, R.SINGULAR_AT + 2] = sig0, sig1, sig2
                out[b, R.REFLECTION] = d
                gap = 2.0 * (sig1 + d * sig2)
                unique = 1 if gap > tol else 0
                if unique == 1:
                    x, y, z, w = sx, sy, sz, sw
            out[b, R.EIGEN_GAP] = gap
            out[b, R.UNIQUE] = unique
            e = R.EIGENVALUES_AT
            out[b, e], out[b, e + 1], out[b, e + 2], out[b, e + 3] = l1, l2, l3, l4
            out[b, R.CLOSED_FORM] = 1.0 if fast else 0.0
            out[b, R.GAP_TOLERANCE] = tol
            qa = R.QUAT_AT
            out[b, qa], out[b, qa + 1], out[b, qa + 2], out[b, qa + 3] = x, y, z, w
            # every path above returns a unit quaternion: R = I + 2w[v]x + 2[v]x² (Dantam 2014 eq. (108))
            m0, m1, m2 = 1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - w * z), 2.0 * (x * z + w * y)
            m3, m4, m5 = 2.0 * (x * y + w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - w * x)
            m6, m7, m8 = 2.0 * (x * z - w * y), 2.0 * (y * z + w * x), 1.0 - 2.0 * (x * x + y * y)
            ax, ay, az = blk[j, _AX], blk[j, _AY], blk[j, _AZ]
            bx, by, bz = blk[j, _BX], blk[j, _BY], blk[j, _BZ]
            # scale (Umeyama 1991 eq. (42)): measured ≈ s R model + t, s = Σβ p̃'·R p⁰' / Σβ |p⁰'|²
            scale = 1.0
            ss0 = blk[j, _SS0]
            if want_scale and ss0 > 0.0:
                scale = (
                    blk[j, _S] * m0 + blk[j, _S + 1] * m1 + blk[j, _S + 2] * m2
                    + blk[j, _S + 3] * m3 + blk[j, _S + 4] * m4 + blk[j, _S + 5] * m5
                    + blk[j, _S + 6] * m6 + blk[j, _S + 7] * m7 + blk[j, _S + 8] * m8
                ) / ss0  # fmt: skip
            out[b, R.SCALE] = scale
            # translation: t = c1 - s R c0 (+ Walker's centred t, ~0)
            out[b, R.TRANSLATION_AT] = bx - scale * (m0 * ax + m1 * ay + m2 * az) + tdq_x
            out[b, R.TRANSLATION_AT + 1] = by - scale * (m3 * ax + m4 * ay + m5 * az) + tdq_y
            out[b, R.TRANSLATION_AT + 2] = bz - scale * (m6 * ax + m7 * ay + m8 * az) + tdq_z
            # cost from residuals of the centred data (no cancellation at large offsets)
            cost = 0.0
            for k in range(npt):
                x0, y0, z0 = p0[b, k, 0] - ax, p0[b, k, 1] - ay, p0[b, k, 2] - az
                rx = scale * (m0 * x0 + m1 * y0 + m2 * z0) + tdq_x - (p1[b, k, 0] - bx)
                ry = scale * (m3 * x0 + m4 * y0 + m5 * z0) + tdq_y - (p1[b, k, 1] - by)
                rz = scale * (m6 * x0 + m7 * y0 + m8 * z0) + tdq_z - (p1[b, k, 2] - bz)
                cost += beta[b, k] * (rx * rx + ry * ry + rz * rz)
            out[b, R.POINT_COST] = cost
            for k in range(ndir):
                x0, y0, z0 = n0[b, k, 0], n0[b, k, 1], n0[b, k, 2]
                rx = m0 * x0 + m1 * y0 + m2 * z0 - n1[b, k, 0]
                ry = m3 * x0 + m4 * y0 + m5 * z0 - n1[b, k, 1]
                rz = m6 * x0 + m7 * y0 + m8 * z0 - n1[b, k, 2]
                cost += alpha[b, k] * (rx * rx + ry * ry + rz * rz)
            out[b, R.COST] = cost


@nb.njit(f"void({_M2}, {_M2}, {_V1}, {_M2}, {_M2}, {_V1}, int64, boolean, {_V1})", cache=True)
def solve_one(p0, p1, beta, n0, n1, alpha, method, want_scale, out):
    """One problem: ``p0, p1`` (n, 3), ``beta`` (n,), ``n0, n1`` (m, 3), ``alpha`` (m,); ``out`` (OUT_SIZE,)."""
    n, m = p0.shape[0], n0.shape[0]
    solve_batch(
        p0.reshape((1, n, 3)), p1.reshape((1, n, 3)), beta.reshape((1, n)), n0.reshape((1, m, 3)),
        n1.reshape((1, m, 3)), alpha.reshape((1, m)), method, want_scale, out.reshape((1, out.shape[0])),
    )  # fmt: skip
