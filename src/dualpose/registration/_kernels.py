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
``19:22``  eigenvalues (descending) of the model scatter ``Σβ p'p'ᵀ + Σα n nᵀ``
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
WORK_SIZE = 80
#: relative tolerance on the eigen gap below which the optimal rotation is reported as not unique
GAP_RTOL = 1e-9

_njit = nb.njit(cache=True, error_model="numpy")


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
def solve_one(p0, p1, beta, n0, n1, alpha, method, want_scale, work, out):  # noqa: ANN001, ANN201, C901
    """Solve one problem: model ``p0`` (n, 3) -> measured ``p1`` (n, 3), model ``n0`` (m, 3) -> measured ``n1``.

    ``beta`` (n,) and ``alpha`` (m,) are the point and direction weights.  ``work`` is a (WORK_SIZE,) buffer.
    """
    npt = p0.shape[0]
    ndir = n0.shape[0]
    a = work[0:16].reshape((4, 4))
    v = work[16:32].reshape((4, 4))
    s = work[32:41].reshape((3, 3))  # Σ (measured') (model')ᵀ  (a = measured, b = model)
    sc = work[41:50].reshape((3, 3))  # model scatter
    qv = work[50:54]
    c0 = work[54:57]
    c1 = work[57:60]
    c3keep = work[60:76].reshape((4, 4))
    sv = work[76:80]
    order = np.empty(4, np.int64)
    for i in range(OUT_SIZE):
        out[i] = 0.0
    for k in range(npt):
        for i in range(3):
            if not math.isfinite(p0[k, i]):
                out[24] = 1.0
                return
            if not math.isfinite(p1[k, i]):
                out[24] = 2.0
                return
    for k in range(ndir):
        for i in range(3):
            if not math.isfinite(n0[k, i]):
                out[24] = 3.0
                return
            if not math.isfinite(n1[k, i]):
                out[24] = 4.0
                return
    # weighted centroids (the translation is recovered at the end: t = c1 - s R c0)
    wsum = 0.0
    for i in range(3):
        c0[i] = 0.0
        c1[i] = 0.0
    for k in range(npt):
        wsum += beta[k]
    if npt > 0 and wsum > 0.0:
        for k in range(npt):
            for i in range(3):
                c0[i] += beta[k] * p0[k, i]
                c1[i] += beta[k] * p1[k, i]
        for i in range(3):
            c0[i] /= wsum
            c1[i] /= wsum
    # second moments of the centred data
    for i in range(3):
        for j in range(3):
            s[i, j] = 0.0
            sc[i, j] = 0.0
    ss0 = 0.0  # Σβ |p0'|²
    ss1 = 0.0  # Σβ |p1'|²
    asum = 0.0
    for k in range(npt):
        bk = beta[k]
        x0, y0, z0 = p0[k, 0] - c0[0], p0[k, 1] - c0[1], p0[k, 2] - c0[2]
        x1, y1, z1 = p1[k, 0] - c1[0], p1[k, 1] - c1[1], p1[k, 2] - c1[2]
        ss0 += bk * (x0 * x0 + y0 * y0 + z0 * z0)
        ss1 += bk * (x1 * x1 + y1 * y1 + z1 * z1)
        m0 = (x0, y0, z0)
        m1 = (x1, y1, z1)
        for i in range(3):
            for j in range(3):
                s[i, j] += bk * m1[i] * m0[j]
                sc[i, j] += bk * m0[i] * m0[j]
    for k in range(ndir):
        ak = alpha[k]
        asum += ak
        for i in range(3):
            for j in range(3):
                s[i, j] += ak * n1[k, i] * n0[k, j]
                sc[i, j] += ak * n0[k, i] * n0[k, j]
    # E = const - 2 Σ(measured · R model): the largest possible |λ| of Horn's N is const / 2
    const = ss0 + ss1 + 2.0 * asum
    # model scatter eigenvalues (geometry classification)
    for i in range(3):
        for j in range(3):
            a[i, j] = sc[i, j]
    jacobi_eigh(a, v, 3)
    d0, d1, d2 = a[0, 0], a[1, 1], a[2, 2]
    if d0 < d1:
        d0, d1 = d1, d0
    if d1 < d2:
        d1, d2 = d2, d1
    if d0 < d1:
        d0, d1 = d1, d0
    out[19], out[20], out[21] = d0, d1, d2

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
            bk = beta[k]
            g0x += bk * (p0[k, 0] - c0[0])
            g0y += bk * (p0[k, 1] - c0[1])
            g0z += bk * (p0[k, 2] - c0[2])
            g1x += bk * (p1[k, 0] - c1[0])
            g1y += bk * (p1[k, 1] - c1[1])
            g1z += bk * (p1[k, 2] - c1[2])
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
        jacobi_eigh(a, v, 4)
        _sorted_desc(a, order, 4)
        tol = GAP_RTOL * 2.0 * max(const, 1e-300)
        unique = _pick_top(a, v, order, tol, qv)
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
        for i in range(4):
            out[9 + i] = a[order[i], order[i]]
        out[13] = a[order[0], order[0]] - a[order[1], order[1]]
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
        jacobi_eigh(a, v, 4)
        _sorted_desc(a, order, 4)
        tol = GAP_RTOL * max(const, 1e-300)
        unique = _pick_top(a, v, order, tol, qv)
        for i in range(4):
            out[9 + i] = a[order[i], order[i]]
        out[13] = a[order[0], order[0]] - a[order[1], order[1]]
        if method == 2:
            # Arun / Kabsch with Umeyama's reflection guard: H = U S Vᵀ, R = V diag(1, 1, d) Uᵀ, d = sign det(V Uᵀ)
            h = np.empty((3, 3))
            for i in range(3):
                for j in range(3):
                    h[i, j] = s[j, i]
            u, sig, vt = np.linalg.svd(h)
            det = np.linalg.det(vt.T @ u.T)
            d = 1.0 if det >= 0.0 else -1.0
            out[14], out[15], out[16] = sig[0], sig[1], sig[2]
            out[17] = d
            gap = 2.0 * (sig[1] + d * sig[2])
            out[13] = gap
            unique = 1 if gap > tol else 0
            if unique == 1:
                vd = vt.T.copy()
                for i in range(3):
                    vd[i, 2] *= d
                r = vd @ u.T
                qv[0], qv[1], qv[2], qv[3] = quat_of_rotmat(r)
    out[18] = unique
    out[22] = tol
    out[0], out[1], out[2], out[3] = qv[0], qv[1], qv[2], qv[3]
    m = rotmat(qv[0], qv[1], qv[2], qv[3])
    # scale (Umeyama 1991 eq. (42)): measured ≈ s R model + t, s = Σβ p̃'·R p⁰' / Σβ |p⁰'|²
    scale = 1.0
    if want_scale and ss0 > 0.0:
        acc = 0.0
        for i in range(3):
            for j in range(3):
                acc += s[i, j] * m[3 * i + j]
        scale = acc / ss0
    out[7] = scale
    # translation: t = c1 - s R c0 (+ Walker's centred t, ~0)
    for i in range(3):
        rc = m[3 * i] * c0[0] + m[3 * i + 1] * c0[1] + m[3 * i + 2] * c0[2]
        out[4 + i] = c1[i] - scale * rc
    out[4] += tdq_x
    out[5] += tdq_y
    out[6] += tdq_z
    # cost from residuals of the centred data (no cancellation at large offsets)
    cost = 0.0
    for k in range(npt):
        x0, y0, z0 = p0[k, 0] - c0[0], p0[k, 1] - c0[1], p0[k, 2] - c0[2]
        rx = scale * (m[0] * x0 + m[1] * y0 + m[2] * z0) + tdq_x - (p1[k, 0] - c1[0])
        ry = scale * (m[3] * x0 + m[4] * y0 + m[5] * z0) + tdq_y - (p1[k, 1] - c1[1])
        rz = scale * (m[6] * x0 + m[7] * y0 + m[8] * z0) + tdq_z - (p1[k, 2] - c1[2])
        cost += beta[k] * (rx * rx + ry * ry + rz * rz)
    out[23] = cost
    for k in range(ndir):
        x0, y0, z0 = n0[k, 0], n0[k, 1], n0[k, 2]
        rx = m[0] * x0 + m[1] * y0 + m[2] * z0 - n1[k, 0]
        ry = m[3] * x0 + m[4] * y0 + m[5] * z0 - n1[k, 1]
        rz = m[6] * x0 + m[7] * y0 + m[8] * z0 - n1[k, 2]
        cost += alpha[k] * (rx * rx + ry * ry + rz * rz)
    out[8] = cost


@_njit
def solve_batch(p0, p1, beta, n0, n1, alpha, method, want_scale, out):  # noqa: ANN001, ANN201
    """Solve ``B`` independent problems: ``p0, p1`` (B, n, 3), ``beta`` (B, n), ``n0, n1`` (B, m, 3), ``alpha``
    (B, m); ``out`` (B, OUT_SIZE)."""
    work = np.empty(WORK_SIZE)
    for b in range(p0.shape[0]):
        solve_one(p0[b], p1[b], beta[b], n0[b], n1[b], alpha[b], method, want_scale, work, out[b])
