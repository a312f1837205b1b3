"""numba kernels of the pose-from-correspondences solvers.  Imported lazily by :mod:`dualpose.registration`.

One problem is solved by :func:`solve_one` without allocating: the caller passes a work buffer.  Layout of the
result row ``out`` (``OUT_SIZE`` floats), shared with the Python wrappers:

=========  ==========================================================================================
``0:4``    rotation quaternion xyzw (``w >= 0``)
``4:7``    translation
``7``      scale (1 unless ``want_scale``)
``8``      cost ``E`` (the documented weighted sum of squares)
``9:13``   eigenvalues (descending) of the 4x4 matrix that decided the rotation: Walker's ``A`` (eq. (47))
           for ``dq``, Horn's ``N`` for ``horn`` and ``svd``
``13``     the gap that decided uniqueness: ``λ1 - λ2`` (``dq``, ``horn``) or ``2 (s2 + d s3)`` (``svd``)
``14:17``  singular values of the cross-covariance ``H`` (``svd`` only, else 0)
``17``     ``d = sign det(Vᵀ... )`` of the reflection guard (``svd`` only, else 0)
``18``     1 if the optimal rotation is unique (gap above tolerance), else 0
``19``     1 if the closed-form eigen-solve was accepted, 0 if the Jacobi iteration decided (diagnostic)
``20:22``  unused (0)
``22``     the gap tolerance used
``23``     the point part of the cost, ``Σβ‖r_i‖²``
``24``     0, or ``1 + index`` into ``BAD_INPUT`` of the first input holding NaN or infinity (nothing else is set)
=========  ==========================================================================================

Methods: 0 = ``dq`` (Walker 1991 §3.2 on centred data), 1 = ``horn`` (Horn 1987), 2 = ``svd`` (Arun 1987 /
Umeyama 1991).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from dualpose.algebra._kutil import quat_of_rotmat, rotmat

OUT_SIZE = 25
#: names of the arrays a non-zero ``out[24]`` points at (1-based code of the first non-finite input)
BAD_INPUT = ("model_points", "measured_points", "model_directions", "measured_directions")
#: relative tolerance on the eigen gap below which the optimal rotation is reported as not unique
GAP_RTOL = 1e-9

_njit = nb.njit(cache=True, error_model="numpy")
# inlined into the batch loop: a call passing a dozen arrays costs more (reference counting) than the solve
_inline = nb.njit(cache=True, error_model="numpy", inline="always")


@_njit
def jacobi_eigh(a, v, n):  # noqa: ANN001, ANN201
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
def _sorted_desc(a, order, n):  # noqa: ANN001, ANN201
    """Indices of the diagonal of ``a[:n, :n]`` sorted by decreasing value (insertion sort, n <= 4)."""
    for i in range(n):
        order[i] = i
    for i in range(1, n):
        j = i
        while j > 0 and a[order[j], order[j]] > a[order[j - 1], order[j - 1]]:
            order[j], order[j - 1] = order[j - 1], order[j]
            j -= 1


@_njit
def _fill_pure_block(m, s, scale):  # noqa: ANN001, ANN201
    """``m = scale * Σ Q(a)ᵀ W(b)`` for pure quaternions, given ``s = Σ a bᵀ`` (3x3), xyzw order.

    For pure ``a = [a, 0]``, ``b = [b, 0]`` Walker's matrices give ``Q(a)ᵀ W(b) = [[a bᵀ + b aᵀ - (a·b) I, -a×b],
    [-(a×b)ᵀ, a·b]]``, which is linear in ``a bᵀ``: the sum over correspondences needs only ``Σ a bᵀ``.
    """
    tr = s[0, 0] + s[1, 1] + s[2, 2]
    for i in range(3):
        for j in range(3):
            m[i, j] = scale * (s[i, j] + s[j, i] - (tr if i == j else 0.0))
    cx = s[1, 2] - s[2, 1]  # Σ a × b
    cy = s[2, 0] - s[0, 2]
    cz = s[0, 1] - s[1, 0]
    m[0, 3] = m[3, 0] = -scale * cx
    m[1, 3] = m[3, 1] = -scale * cy
    m[2, 3] = m[3, 2] = -scale * cz
    m[3, 3] = scale * tr


@_njit
def _pick_top(a, v, order, tol, q):  # noqa: ANN001, ANN201
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


@_njit
def _det3(a, b, c, d, e, f, g, h, i):  # noqa: ANN001, ANN202
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


@_njit
def _closed_form_top(a, q, ev, bound):  # noqa: ANN001, ANN201, C901
    """Largest eigenpair of the symmetric 4x4 ``a`` in closed form; returns False when it cannot vouch for it.

    The eigenvalues are the roots of ``det(λI - a) = λ⁴ + c3 λ³ + c2 λ² + c1 λ + c0`` (all real).  Newton's
    iteration from the Gershgorin upper bound decreases monotonically to the largest root (every derivative of
    the polynomial is positive above it); deflating by it and repeating gives the second, then a quadratic the
    last two.  The eigenvector is the column of ``adj(a - λ1 I)`` with the largest diagonal cofactor (that
    matrix is ``c v vᵀ`` for a simple root).  ``bound`` is an upper bound on λ1 known to the caller (for Horn's
    ``N``: ``E >= 0`` gives ``λ1 <= const / 2``, tight for a good fit, so Newton starts next to the root).
    Accepted only if ``‖a q - λ1 q‖ <= 1e-14 (λ1 - λ2)`` (eigenvector error ~ residual / gap) and the gap is a
    millionth of the spectrum's scale; otherwise the caller uses Jacobi.  ``ev`` receives the eigenvalues, descending.
    """
    a00, a01, a02, a03 = a[0, 0], a[0, 1], a[0, 2], a[0, 3]
    a11, a12, a13, a22, a23, a33 = a[1, 1], a[1, 2], a[1, 3], a[2, 2], a[2, 3], a[3, 3]
    # Gershgorin bounds and the spectrum's scale
    g0 = a00 + abs(a01) + abs(a02) + abs(a03)
    g1 = a11 + abs(a01) + abs(a12) + abs(a13)
    g2 = a22 + abs(a02) + abs(a12) + abs(a23)
    g3 = a33 + abs(a03) + abs(a13) + abs(a23)
    hi = min(max(max(g0, g1), max(g2, g3)), bound)  # ``bound``: the caller's upper bound on λ1
    lo = min(
        min(a00 - abs(a01) - abs(a02) - abs(a03), a11 - abs(a01) - abs(a12) - abs(a13)),
        min(a22 - abs(a02) - abs(a12) - abs(a23), a33 - abs(a03) - abs(a13) - abs(a23)),
    )
    scale = max(abs(hi), abs(lo))
    if scale == 0.0 or not math.isfinite(scale):
        return False
    # characteristic polynomial
    c3 = -(a00 + a11 + a22 + a33)
    c2 = (
        a00 * a11 - a01 * a01 + a00 * a22 - a02 * a02 + a00 * a33 - a03 * a03
        + a11 * a22 - a12 * a12 + a11 * a33 - a13 * a13 + a22 * a33 - a23 * a23
    )  # fmt: skip
    c1 = -(
        _det3(a11, a12, a13, a12, a22, a23, a13, a23, a33)
        + _det3(a00, a02, a03, a02, a22, a23, a03, a23, a33)
        + _det3(a00, a01, a03, a01, a11, a13, a03, a13, a33)
        + _det3(a00, a01, a02, a01, a11, a12, a02, a12, a22)
    )
    c0 = (
        a00 * _det3(a11, a12, a13, a12, a22, a23, a13, a23, a33)
        - a01 * _det3(a01, a12, a13, a02, a22, a23, a03, a23, a33)
        + a02 * _det3(a01, a11, a13, a02, a12, a23, a03, a13, a33)
        - a03 * _det3(a01, a11, a12, a02, a12, a22, a03, a13, a23)
    )
    lam = hi
    for _ in range(100):
        f = (((lam + c3) * lam + c2) * lam + c1) * lam + c0
        df = ((4.0 * lam + 3.0 * c3) * lam + 2.0 * c2) * lam + c1
        if f <= 0.0 or df <= 0.0:
            break
        step = f / df
        lam -= step
        if step <= 1e-15 * scale:
            break
    l1 = lam
    # deflate: cubic λ³ + b2 λ² + b1 λ + b0 = poly / (λ - λ1); its largest root from λ1 downwards
    b2 = c3 + l1
    b1 = c2 + l1 * b2
    b0 = c1 + l1 * b1
    lam = l1
    for _ in range(100):
        f = ((lam + b2) * lam + b1) * lam + b0
        df = (3.0 * lam + 2.0 * b2) * lam + b1
        if f <= 0.0 or df <= 0.0:
            break
        step = f / df
        lam -= step
        if step <= 1e-15 * scale:
            break
    l2 = lam
    gap = l1 - l2
    if not gap > 1e-6 * scale:
        return False
    e1 = b2 + l2
    e0 = b1 + l2 * e1
    disc = math.sqrt(max(e1 * e1 - 4.0 * e0, 0.0))
    l3 = 0.5 * (-e1 + disc)
    l4 = 0.5 * (-e1 - disc)
    # eigenvector: best column of adj(a - λ1 I)
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
        return False
    x, y, z, w = x / nrm, y / nrm, z / nrm, w / nrm
    r0 = a00 * x + a01 * y + a02 * z + a03 * w - l1 * x
    r1 = a01 * x + a11 * y + a12 * z + a13 * w - l1 * y
    r2 = a02 * x + a12 * y + a22 * z + a23 * w - l1 * z
    r3 = a03 * x + a13 * y + a23 * z + a33 * w - l1 * w
    if not math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3) <= 1e-14 * gap:
        return False
    if w < 0.0 or (w == 0.0 and (x < 0.0 or (x == 0.0 and (y < 0.0 or (y == 0.0 and z < 0.0))))):
        x, y, z, w = -x, -y, -z, -w
    q[0], q[1], q[2], q[3] = x, y, z, w
    ev[0], ev[1], ev[2], ev[3] = l1, l2, l3, l4
    return True


@_njit
def _c3_term_trace(c3, bw):  # noqa: ANN001, ANN201
    """``tr(C3ᵀ C3) / (4 bw)``: the trace of Walker's PSD term ``½ C3ᵀ (C2 + C2ᵀ)⁻¹ C3`` (0 without points)."""
    if bw == 0.0:
        return 0.0
    acc = 0.0
    for i in range(4):
        for j in range(4):
            acc += c3[i, j] * c3[i, j]
    return acc / (4.0 * bw)


@_njit
def top_eigvec(a, v, order, tol, q, ev, bound):  # noqa: ANN001, ANN201
    """Eigenvector ``q`` of the largest eigenvalue of the symmetric 4x4 ``a`` (destroyed); eigenvalues into ``ev``.

    Closed form when it can vouch for the answer (:func:`_closed_form_top`), else cyclic Jacobi with the
    smallest-rotation tie-break (:func:`_pick_top`).  Returns ``(unique, closed_form)``.
    """
    if _closed_form_top(a, q, ev, bound):
        return (1 if ev[0] - ev[1] > tol else 0), 1
    jacobi_eigh(a, v, 4)
    _sorted_desc(a, order, 4)
    unique = _pick_top(a, v, order, tol, q)
    for i in range(4):
        ev[i] = a[order[i], order[i]]
    return unique, 0


_M2 = "float64[:, ::1]"
_M3 = "float64[:, :, ::1]"
_V1 = "float64[::1]"


@_inline
def _solve(p0, p1, beta, n0, n1, alpha, b, method, want_scale, a, v, s, c3keep, vec, order, out):  # noqa: ANN001, ANN201, C901
    """Solve problem ``b``: model ``p0[b]`` (n, 3) -> measured ``p1[b]``, model ``n0[b]`` (m, 3) -> ``n1[b]``.

    ``beta[b]`` (n,) and ``alpha[b]`` (m,) are the point and direction weights; the result goes to ``out[b, b]``.
    ``a, v, c3keep`` (4, 4), ``s`` (3, 3), ``vec`` (12,) and ``order`` (4,) are work buffers (no allocation and no
    array views per problem: both cost more than the arithmetic at n = 10).
    """
    npt = p0.shape[1]
    ndir = n0.shape[1]
    qv = vec[0:4]
    sv = vec[4:8]
    ev = vec[8:12]
    for i in range(OUT_SIZE):
        out[b, i] = 0.0
    for k in range(npt):
        for i in range(3):
            if not math.isfinite(p0[b, k, i]):
                out[b, 24] = 1.0
                return
            if not math.isfinite(p1[b, k, i]):
                out[b, 24] = 2.0
                return
    for k in range(ndir):
        for i in range(3):
            if not math.isfinite(n0[b, k, i]):
                out[b, 24] = 3.0
                return
            if not math.isfinite(n1[b, k, i]):
                out[b, 24] = 4.0
                return
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
    # second moments of the centred data: s = Σ β p̃' p⁰'ᵀ + Σ α ñ n⁰ᵀ (a = measured, b = model)
    s00 = s01 = s02 = s10 = s11 = s12 = s20 = s21 = s22 = 0.0
    ss0 = 0.0  # Σβ |p0'|²
    ss1 = 0.0  # Σβ |p1'|²
    asum = 0.0
    for k in range(npt):
        bk = beta[b, k]
        x0, y0, z0 = p0[b, k, 0] - ax, p0[b, k, 1] - ay, p0[b, k, 2] - az
        d1x, d1y, d1z = p1[b, k, 0] - bx, p1[b, k, 1] - by, p1[b, k, 2] - bz
        ss0 += bk * (x0 * x0 + y0 * y0 + z0 * z0)
        ss1 += bk * (d1x * d1x + d1y * d1y + d1z * d1z)
        x1, y1, z1 = bk * d1x, bk * d1y, bk * d1z
        s00 += x1 * x0
        s01 += x1 * y0
        s02 += x1 * z0
        s10 += y1 * x0
        s11 += y1 * y0
        s12 += y1 * z0
        s20 += z1 * x0
        s21 += z1 * y0
        s22 += z1 * z0
    for k in range(ndir):
        ak = alpha[b, k]
        asum += ak
        x0, y0, z0 = n0[b, k, 0], n0[b, k, 1], n0[b, k, 2]
        x1, y1, z1 = ak * n1[b, k, 0], ak * n1[b, k, 1], ak * n1[b, k, 2]
        s00 += x1 * x0
        s01 += x1 * y0
        s02 += x1 * z0
        s10 += y1 * x0
        s11 += y1 * y0
        s12 += y1 * z0
        s20 += z1 * x0
        s21 += z1 * y0
        s22 += z1 * z0
    s[0, 0], s[0, 1], s[0, 2] = s00, s01, s02
    s[1, 0], s[1, 1], s[1, 2] = s10, s11, s12
    s[2, 0], s[2, 1], s[2, 2] = s20, s21, s22
    # E = const - 2 Σ(measured · R model): the largest possible |λ| of Horn's N is const / 2
    const = ss0 + ss1 + 2.0 * asum

    tdq_x = tdq_y = tdq_z = 0.0
    if method == 0:
        # Walker §3.2 on centred data.  Position quaternions ½[p; 0] with weights 4β make Walker's error (31)
        # equal to the documented cost; direction quaternions [n; 0] keep weights α.
        # C1 = -2 Σ α Q(ñ)ᵀW(n⁰) - 2 Σ 4β Q(½p̃)ᵀW(½p⁰) = -2 Σ_blocks (eq. (35))
        _fill_pure_block(a, s, -2.0)
        bw = 4.0 * wsum  # C2 = (Σ 4β) I (eq. (36))
        # C3 = 2 Σ 4β (W(½p⁰) - Q(½p̃)) = 4 (W(Σβ p⁰') - Q(Σβ p̃'))  (eq. (37)); the centred sums are ~0 but
        # are kept so that the solve is Walker's, with rounding residue and all
        g0x = g0y = g0z = g1x = g1y = g1z = 0.0
        for k in range(npt):
            bk = beta[b, k]
            g0x += bk * (p0[b, k, 0] - ax)
            g0y += bk * (p0[b, k, 1] - ay)
            g0z += bk * (p0[b, k, 2] - az)
            g1x += bk * (p1[b, k, 0] - bx)
            g1y += bk * (p1[b, k, 1] - by)
            g1z += bk * (p1[b, k, 2] - bz)
        # W(g0) - Q(g1) for pure quaternions: [[-K(g0) - K(g1), g0 - g1], [-(g0 - g1)ᵀ, 0]]
        hx, hy, hz = g0x + g1x, g0y + g1y, g0z + g1z
        dx, dy, dz = g0x - g1x, g0y - g1y, g0z - g1z
        c3 = v  # reuse v as C3 storage until the eigen solve
        c3[0, 0] = c3[1, 1] = c3[2, 2] = c3[3, 3] = 0.0
        c3[0, 1], c3[0, 2], c3[1, 0], c3[1, 2], c3[2, 0], c3[2, 1] = hz, -hy, -hz, hx, hy, -hx
        c3[0, 3], c3[1, 3], c3[2, 3] = dx, dy, dz
        c3[3, 0], c3[3, 1], c3[3, 2] = -dx, -dy, -dz
        for i in range(4):
            for j in range(4):
                c3[i, j] *= 4.0
        # A = ½ (C3ᵀ (2 C2)⁻¹ C3 - C1 - C1ᵀ) (eq. (47)); C1 is symmetric here
        for i in range(4):
            for j in range(4):
                acc = 0.0
                if bw > 0.0:
                    for k in range(4):
                        acc += c3[k, i] * c3[k, j]
                    acc /= 2.0 * bw
                a[i, j] = 0.5 * acc - a[i, j]
        # keep C3 for s = -(2 C2)⁻¹ C3 r (eq. (45)); v is overwritten by the eigen solve
        for i in range(4):
            for j in range(4):
                c3keep[i, j] = c3[i, j]
        tol = GAP_RTOL * 2.0 * max(const, 1e-300)
        # λ1(A) <= const (the cost is >= 0) + the largest eigenvalue of the PSD C3 term (<= its trace)
        bound = const * (1.0 + 1e-12) + _c3_term_trace(c3keep, bw)
        unique, fast = top_eigvec(a, v, order, tol, qv, ev, bound)
        # s = -(C2 + C2ᵀ)⁻¹ C3 r and t = 2 vec(W(r)ᵀ s)  (eq. (45), Walker eq. (19))
        if bw > 0.0:
            for i in range(4):
                acc = 0.0
                for k in range(4):
                    acc += c3keep[i, k] * qv[k]
                sv[i] = -acc / (2.0 * bw)
            # W(r)ᵀ s = s (x) r*
            rx, ry, rz, rw = -qv[0], -qv[1], -qv[2], qv[3]
            sx, sy, sz, sw = sv[0], sv[1], sv[2], sv[3]
            tdq_x = 2.0 * (sw * rx + rw * sx + sy * rz - sz * ry)
            tdq_y = 2.0 * (sw * ry + rw * sy + sz * rx - sx * rz)
            tdq_z = 2.0 * (sw * rz + rw * sz + sx * ry - sy * rx)
        out[b, 13] = ev[0] - ev[1]
    else:
        # Horn (1987) in xyzw order: N = [[H + Hᵀ - tr(H) I, Δ], [Δᵀ, tr H]] with H = Σ model' measured'ᵀ,
        # Δ = (H23 - H32, H31 - H13, H12 - H21); qᵀ N q = Σ measured' · R model'
        tr = s[0, 0] + s[1, 1] + s[2, 2]
        for i in range(3):
            for j in range(3):
                a[i, j] = s[j, i] + s[i, j] - (tr if i == j else 0.0)  # H = sᵀ
        a[0, 3] = a[3, 0] = s[2, 1] - s[1, 2]
        a[1, 3] = a[3, 1] = s[0, 2] - s[2, 0]
        a[2, 3] = a[3, 2] = s[1, 0] - s[0, 1]
        a[3, 3] = tr
        tol = GAP_RTOL * max(const, 1e-300)
        unique, fast = top_eigvec(a, v, order, tol, qv, ev, 0.5 * const * (1.0 + 1e-12))
        out[b, 13] = ev[0] - ev[1]
        if method == 2:
            # Arun / Kabsch with Umeyama's reflection guard: H = U S Vᵀ, R = V diag(1, 1, d) Uᵀ, d = sign det(V Uᵀ)
            h = np.empty((3, 3))
            for i in range(3):
                for j in range(3):
                    h[i, j] = s[j, i]
            u, sig, vt = np.linalg.svd(h)
            det = np.linalg.det(vt.T @ u.T)
            d = 1.0 if det >= 0.0 else -1.0
            out[b, 14], out[b, 15], out[b, 16] = sig[0], sig[1], sig[2]
            out[b, 17] = d
            gap = 2.0 * (sig[1] + d * sig[2])
            out[b, 13] = gap
            unique = 1 if gap > tol else 0
            if unique == 1:
                vd = vt.T.copy()
                for i in range(3):
                    vd[i, 2] *= d
                r = vd @ u.T
                qv[0], qv[1], qv[2], qv[3] = quat_of_rotmat(r)
    out[b, 18] = unique
    out[b, 9], out[b, 10], out[b, 11], out[b, 12] = ev[0], ev[1], ev[2], ev[3]
    out[b, 19] = fast
    out[b, 22] = tol
    out[b, 0], out[b, 1], out[b, 2], out[b, 3] = qv[0], qv[1], qv[2], qv[3]
    m = rotmat(qv[0], qv[1], qv[2], qv[3])
    # scale (Umeyama 1991 eq. (42)): measured ≈ s R model + t, s = Σβ p̃'·R p⁰' / Σβ |p⁰'|²
    scale = 1.0
    if want_scale and ss0 > 0.0:
        acc = 0.0
        for i in range(3):
            for j in range(3):
                acc += s[i, j] * m[3 * i + j]
        scale = acc / ss0
    out[b, 7] = scale
    # translation: t = c1 - s R c0 (+ Walker's centred t, ~0)
    out[b, 4] = bx - scale * (m[0] * ax + m[1] * ay + m[2] * az) + tdq_x
    out[b, 5] = by - scale * (m[3] * ax + m[4] * ay + m[5] * az) + tdq_y
    out[b, 6] = bz - scale * (m[6] * ax + m[7] * ay + m[8] * az) + tdq_z
    # cost from residuals of the centred data (no cancellation at large offsets)
    cost = 0.0
    for k in range(npt):
        x0, y0, z0 = p0[b, k, 0] - ax, p0[b, k, 1] - ay, p0[b, k, 2] - az
        rx = scale * (m[0] * x0 + m[1] * y0 + m[2] * z0) + tdq_x - (p1[b, k, 0] - bx)
        ry = scale * (m[3] * x0 + m[4] * y0 + m[5] * z0) + tdq_y - (p1[b, k, 1] - by)
        rz = scale * (m[6] * x0 + m[7] * y0 + m[8] * z0) + tdq_z - (p1[b, k, 2] - bz)
        cost += beta[b, k] * (rx * rx + ry * ry + rz * rz)
    out[b, 23] = cost
    for k in range(ndir):
        x0, y0, z0 = n0[b, k, 0], n0[b, k, 1], n0[b, k, 2]
        rx = m[0] * x0 + m[1] * y0 + m[2] * z0 - n1[b, k, 0]
        ry = m[3] * x0 + m[4] * y0 + m[5] * z0 - n1[b, k, 1]
        rz = m[6] * x0 + m[7] * y0 + m[8] * z0 - n1[b, k, 2]
        cost += alpha[b, k] * (rx * rx + ry * ry + rz * rz)
    out[b, 8] = cost


@nb.njit(f"void({_M3}, {_M3}, {_M2}, {_M3}, {_M3}, {_M2}, int64, boolean, {_M2})", cache=True)
def solve_batch(p0, p1, beta, n0, n1, alpha, method, want_scale, out):  # noqa: ANN001, ANN201
    """Solve ``B`` independent problems: ``p0, p1`` (B, n, 3), ``beta`` (B, n), ``n0, n1`` (B, m, 3), ``alpha``
    (B, m); ``out`` (B, OUT_SIZE)."""
    a = np.empty((4, 4))
    v = np.empty((4, 4))
    s = np.empty((3, 3))
    c3keep = np.empty((4, 4))
    vec = np.empty(12)
    order = np.empty(4, np.int64)
    for b in range(p0.shape[0]):
        _solve(p0, p1, beta, n0, n1, alpha, b, method, want_scale, a, v, s, c3keep, vec, order, out)


@nb.njit(f"void({_M2}, {_M2}, {_V1}, {_M2}, {_M2}, {_V1}, int64, boolean, {_V1})", cache=True)
def solve_one(p0, p1, beta, n0, n1, alpha, method, want_scale, out):  # noqa: ANN001, ANN201
    """One problem: ``p0, p1`` (n, 3), ``beta`` (n,), ``n0, n1`` (m, 3), ``alpha`` (m,); ``out`` (OUT_SIZE,)."""
    n, m = p0.shape[0], n0.shape[0]
    solve_batch(
        p0.reshape((1, n, 3)), p1.reshape((1, n, 3)), beta.reshape((1, n)), n0.reshape((1, m, 3)),
        n1.reshape((1, m, 3)), alpha.reshape((1, m)), method, want_scale, out.reshape((1, out.shape[0])),
    )  # fmt: skip
