"""numba kernels shared with Hol's 22-state filter and the AHRS (``_hol22_kernels``, ``_ahrs_kernels``): the Joseph
updates, the χ²-gated sequential update, the rotation matrix and the local Exp injection.

The error-state filter itself (predict, camera model, updates, whole-run loop) and the RTS smoother are native
(``dualpose._native.eskf_*`` / ``smoother_*``, ``src/native/estimation``), as are these kernels
(``src/native/estimation/updates.hpp``, ``src/native/common/quat.hpp``); this module is deleted once the Hol22 and
AHRS kernels no longer import it.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

V, M, T = "f8[::1]", "f8[:,::1]", "f8[:,:,::1]"  # C-contiguous (the Python wrappers ensure it)
VA, MA = "f8[:]", "f8[:,:]"  # any layout: slices written element by element


def _jit(sig: str):
    """Eager compilation (explicit signature) so that importing this module compiles or loads every kernel, as
    the cache-freshness stamps of :mod:`dualpose._kernel_cache` expect."""
    return nb.njit(sig, cache=True, nogil=True)


@_jit(f"void(f8, f8, f8, f8, {MA})")
def _rotmat_xyzw(qx, qy, qz, qw, out):
    """Rotation matrix of a unit quaternion (xyzw), written to ``out`` (3, 3)."""
    out[0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz)
    out[0, 1] = 2.0 * (qx * qy - qz * qw)
    out[0, 2] = 2.0 * (qx * qz + qy * qw)
    out[1, 0] = 2.0 * (qx * qy + qz * qw)
    out[1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz)
    out[1, 2] = 2.0 * (qy * qz - qx * qw)
    out[2, 0] = 2.0 * (qx * qz - qy * qw)
    out[2, 1] = 2.0 * (qy * qz + qx * qw)
    out[2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy)


@_jit(f"void({VA}, f8, f8, f8)")
def quat_mul_exp_inplace(q, rx, ry, rz):
    """``q ← normalize(q ⊗ Exp(r))`` for a rotation vector ``r`` (radians); ``q`` is a (4,) slice, xyzw."""
    a2 = rx * rx + ry * ry + rz * rz
    a = math.sqrt(a2)
    if a < 1e-4:
        s = 0.5 - a2 / 48.0
        c = 1.0 - a2 / 8.0
    else:
        s = math.sin(0.5 * a) / a
        c = math.cos(0.5 * a)
    bx, by, bz, bw = s * rx, s * ry, s * rz, c
    ax, ay, az, aw = q[0], q[1], q[2], q[3]
    x = aw * bx + bw * ax + ay * bz - az * by
    y = aw * by + bw * ay + az * bx - ax * bz
    z = aw * bz + bw * az + ax * by - ay * bx
    w = aw * bw - ax * bx - ay * by - az * bz
    n = math.sqrt(x * x + y * y + z * z + w * w)
    q[0], q[1], q[2], q[3] = x / n, y / n, z / n, w / n


@_jit(f"void({M}, {M}, {M}, {M})")
def joseph(P, K, H, R):
    """Joseph-form covariance update ``P ← (I − K H) P (I − K H)ᵀ + K R Kᵀ`` in place."""
    A = np.eye(P.shape[0]) - K @ H
    AP = A @ P
    P[:, :] = AP @ A.T + K @ R @ K.T
    # keep exactly symmetric
    for i in range(P.shape[0]):
        for j in range(i + 1, P.shape[0]):
            s = 0.5 * (P[i, j] + P[j, i])
            P[i, j] = s
            P[j, i] = s


@_jit(f"void({M}, {MA}, {MA}, f8)")
def joseph_2d(P, K, H, s2):
    """Joseph update for a 2-row measurement with noise ``s2 I₂``, without forming ``I − K H``:
    ``B = P − K (H P)``, ``P ← B − (B Hᵀ) Kᵀ + s2 K Kᵀ`` (= (I − KH) P (I − KH)ᵀ + K R Kᵀ), symmetrised."""
    n = P.shape[0]
    HP = np.zeros((2, n))
    for i in range(2):
        for k in range(n):
            h = H[i, k]
            if h != 0.0:
                for j in range(n):
                    HP[i, j] += h * P[k, j]
    for i in range(n):
        for j in range(n):
            P[i, j] -= K[i, 0] * HP[0, j] + K[i, 1] * HP[1, j]
    C = np.zeros((n, 2))
    for i in range(n):
        for k in range(n):
            pik = P[i, k]
            C[i, 0] += pik * H[0, k]
            C[i, 1] += pik * H[1, k]
    for i in range(n):
        for j in range(i, n):
            v = P[i, j] - C[i, 0] * K[j, 0] - C[i, 1] * K[j, 1] + s2 * (K[i, 0] * K[j, 0] + K[i, 1] * K[j, 1])
            w = P[j, i] - C[j, 0] * K[i, 0] - C[j, 1] * K[i, 1] + s2 * (K[j, 0] * K[i, 0] + K[j, 1] * K[i, 1])
            P[i, j] = 0.5 * (v + w)
            P[j, i] = P[i, j]


@_jit(f"i8({M}, {M}, {T}, {V}, {V}, f8, {V}, {V}, i8[:])")
def sequential_gated_update(P, r, H, s2, depth, gate, dx, nis_out, accepted_out):
    """χ²-gated sequential update with M two-row measurements linearised at one state, in place on ``P``.

    ``r`` (M, 2) residuals and ``H`` (M, 2, n) Jacobians at the linearisation point, ``s2`` (M,) noise variances
    (``s2[k] I₂``), ``depth`` (M,) camera depths (rows with depth ≤ 1e-6 are skipped, NIS inf).  Rows are taken in
    increasing order of their prior NIS (so that after a dropout the most consistent ones tighten ``P`` before the
    doubtful ones are gated); each sees ``r − H dx`` with the correction ``dx`` (n,) accumulated so far (the
    sequence equals one batch update of the accepted rows) and the current ``P`` (Joseph form, :func:`joseph_2d`).
    ``nis_out`` (M,) receives each row's NIS at its turn, ``accepted_out`` (M,) 1/0; returns the number accepted.
    ``dx`` is left for the caller to inject.  Shared by the error-state filter and Hol's 22-state filter.
    """
    m = r.shape[0]
    prior = np.empty(m)
    for k in range(m):
        if depth[k] <= 1e-6:
            prior[k] = np.inf
            continue
        S = H[k] @ P @ H[k].T
        S[0, 0] += s2[k]
        S[1, 1] += s2[k]
        det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
        a, b = r[k, 0], r[k, 1]
        prior[k] = (S[1, 1] * a * a - 2.0 * S[0, 1] * a * b + S[0, 0] * b * b) / det
    nu = np.empty(2)
    n_acc = 0
    for k in np.argsort(prior):
        accepted_out[k] = 0
        nis_out[k] = np.inf
        if depth[k] <= 1e-6:
            continue
        Hk = H[k]
        hd = Hk @ dx
        nu[0] = r[k, 0] - hd[0]
        nu[1] = r[k, 1] - hd[1]
        PHt = P @ Hk.T
        S = Hk @ PHt
        S[0, 0] += s2[k]
        S[1, 1] += s2[k]
        det = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
        Si = np.array([[S[1, 1], -S[0, 1]], [-S[1, 0], S[0, 0]]]) / det
        nis = nu[0] * (Si[0, 0] * nu[0] + Si[0, 1] * nu[1]) + nu[1] * (Si[1, 0] * nu[0] + Si[1, 1] * nu[1])
        nis_out[k] = nis
        if nis > gate:
            continue
        K = PHt @ Si
        dx += K @ nu
        joseph_2d(P, K, Hk, s2[k])
        accepted_out[k] = 1
        n_acc += 1
    return n_acc
