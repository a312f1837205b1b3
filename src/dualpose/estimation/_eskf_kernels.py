"""numba kernels of the error-state EKF (Solà 2017 §5-7) and of the camera measurement model.

Imported lazily by :mod:`dualpose.estimation.eskf` and :mod:`dualpose.estimation.models`.  Layouts (block offsets
from :mod:`dualpose.estimation.state`):

* nominal state ``x`` (16,) = :data:`~dualpose.estimation.state.ESKF_STATE`;
* error state ``δx`` (15,) = :data:`~dualpose.estimation.state.ESKF_ERROR` with the attitude error local (right):
  ``q = q̂ ⊗ Exp(δθ)``;
* covariance ``P`` (15, 15); ``noise`` (4,) = continuous-time variances ``[σ_g², σ_a², σ_bg², σ_ba²]``;
* camera ``cam`` (10,) = ``[fx, fy, cx, cy, q_bc (4, xyzw), ...]`` is split as ``intr`` (4,), ``q_bc`` (4,),
  ``p_bc`` (3,).

Everything works in place on ``x`` and ``P``; small fixed-size loops, no allocation in the inner loops except the
per-call work arrays.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from dualpose.estimation.state import ESKF_ACCEL_BIAS as _BA
from dualpose.estimation.state import ESKF_D_ACCEL_BIAS as _DBA
from dualpose.estimation.state import ESKF_D_ATTITUDE as _DTH
from dualpose.estimation.state import ESKF_D_GYRO_BIAS as _DBG
from dualpose.estimation.state import ESKF_D_POSITION as _DP
from dualpose.estimation.state import ESKF_D_VELOCITY as _DV
from dualpose.estimation.state import ESKF_DIM as _NX
from dualpose.estimation.state import ESKF_ERROR_DIM as _NE
from dualpose.estimation.state import ESKF_GYRO_BIAS as _BG
from dualpose.estimation.state import ESKF_POSITION as _P
from dualpose.estimation.state import ESKF_QUAT as _Q
from dualpose.estimation.state import ESKF_VELOCITY as _V

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


@_jit(f"void({V}, {M}, {V}, {V}, f8, {V}, {V}, {M})")
def predict_transition(x, P, gyro, accel, dt, gravity, noise, F):
    """:func:`predict` that also writes the error-state transition matrix of the step (Solà eq. 269) to ``F``
    (15, 15), ``δx⁻_{k+1} ≈ F δx⁺_k`` (the offline smoother needs it)."""
    R = np.empty((3, 3))
    _rotmat_xyzw(x[_Q], x[_Q + 1], x[_Q + 2], x[_Q + 3], R)
    wx, wy, wz = gyro[0] - x[_BG], gyro[1] - x[_BG + 1], gyro[2] - x[_BG + 2]
    ab = np.empty(3)
    for i in range(3):
        ab[i] = accel[i] - x[_BA + i]
    # --- error-state transition F (Solà eq. 269), written sparsely
    F[:, :] = 0.0
    for i in range(_NE):
        F[i, i] = 1.0
    for i in range(3):
        F[_DP + i, _DV + i] = dt
    # -R [a]x dt
    Ax = np.array([[0.0, -ab[2], ab[1]], [ab[2], 0.0, -ab[0]], [-ab[1], ab[0], 0.0]])
    RA = R @ Ax
    for i in range(3):
        for j in range(3):
            F[_DV + i, _DTH + j] = -RA[i, j] * dt
            F[_DV + i, _DBA + j] = -R[i, j] * dt
    # R{ω dt}ᵀ
    dq = np.array([0.0, 0.0, 0.0, 1.0])
    quat_mul_exp_inplace(dq, wx * dt, wy * dt, wz * dt)
    Rw = np.empty((3, 3))
    _rotmat_xyzw(dq[0], dq[1], dq[2], dq[3], Rw)
    for i in range(3):
        for j in range(3):
            F[_DTH + i, _DTH + j] = Rw[j, i]
        F[_DTH + i, _DBG + i] = -dt
    # --- nominal state; the specific force is rotated with the mean of the start and end attitudes (trapezoid),
    # which removes the first-order error ½ ω × a dt² per step of using the start attitude alone
    quat_mul_exp_inplace(x[_Q : _Q + 4], wx * dt, wy * dt, wz * dt)
    R1 = np.empty((3, 3))
    _rotmat_xyzw(x[_Q], x[_Q + 1], x[_Q + 2], x[_Q + 3], R1)
    aw = 0.5 * ((R + R1) @ ab)
    for i in range(3):
        aw[i] += gravity[i]
        x[_P + i] += x[_V + i] * dt + 0.5 * aw[i] * dt * dt
        x[_V + i] += aw[i] * dt
    # --- covariance: P = F P Fᵀ + Q
    FP = F @ P
    P[:, :] = FP @ F.T
    for i in range(3):
        P[_DV + i, _DV + i] += noise[1] * dt
        P[_DTH + i, _DTH + i] += noise[0] * dt
        P[_DBG + i, _DBG + i] += noise[2] * dt
        P[_DBA + i, _DBA + i] += noise[3] * dt


@_jit(f"void({V}, {M}, {V}, {V}, f8, {V}, {V})")
def predict(x, P, gyro, accel, dt, gravity, noise):
    """Propagate nominal state and covariance over ``dt`` with constant IMU input (Solà eq. 260, 269-270).

    ``gyro`` (3,) rad/s and ``accel`` (3,) m/s² are the (held or averaged) measurements over the step.
    """
    predict_transition(x, P, gyro, accel, dt, gravity, noise, np.empty((_NE, _NE)))


@_jit(f"f8({V}, {V}, {V}, {V}, {VA}, {VA}, {VA}, {MA})")
def camera_residual_jacobian(x, intr, q_bc, p_bc, pixel, point, r, H):
    """Reprojection residual ``r = pixel − π(R_bcᵀ(R_wbᵀ(z − p) − p_bc))`` (2,) and ``H = ∂π/∂δx`` (2, 15).

    Returns the depth Z of the point in the camera frame (the model is valid only for Z > 0).
    """
    R = np.empty((3, 3))
    _rotmat_xyzw(x[_Q], x[_Q + 1], x[_Q + 2], x[_Q + 3], R)
    Rbc = np.empty((3, 3))
    _rotmat_xyzw(q_bc[0], q_bc[1], q_bc[2], q_bc[3], Rbc)
    d = np.empty(3)
    for i in range(3):
        d[i] = point[i] - x[_P + i]
    pb = R.T @ d
    for i in range(3):
        pb[i] -= p_bc[i]
    pc = Rbc.T @ pb
    for i in range(3):
        pb[i] += p_bc[i]
    X, Y, Z = pc[0], pc[1], pc[2]
    fx, fy = intr[0], intr[1]
    iz = 1.0 / Z
    r[0] = pixel[0] - (fx * X * iz + intr[2])
    r[1] = pixel[1] - (fy * Y * iz + intr[3])
    J = np.array([[fx * iz, 0.0, -fx * X * iz * iz], [0.0, fy * iz, -fy * Y * iz * iz]])
    JB = J @ Rbc.T  # (2, 3): ∂π/∂p_b
    JR = JB @ R.T  # ∂π/∂(z − p) in world
    for i in range(2):
        for j in range(_NE):
            H[i, j] = 0.0
        for j in range(3):
            H[i, _DP + j] = -JR[i, j]
        # ∂p_b/∂δθ = [p_b]x
        H[i, _DTH] = JB[i, 1] * pb[2] - JB[i, 2] * pb[1]
        H[i, _DTH + 1] = JB[i, 2] * pb[0] - JB[i, 0] * pb[2]
        H[i, _DTH + 2] = JB[i, 0] * pb[1] - JB[i, 1] * pb[0]
    return Z


@_jit(f"void({V}, {V}, {V}, {V}, {M}, {M}, {M}, {T}, {V})")
def camera_batch(x, intr, q_bc, p_bc, pixels, points, r, H, depth):
    """:func:`camera_residual_jacobian` for every row: ``r`` (M, 2), ``H`` (M, 2, 15), ``depth`` (M,)."""
    for m in range(pixels.shape[0]):
        depth[m] = camera_residual_jacobian(x, intr, q_bc, p_bc, pixels[m], points[m], r[m], H[m])


@_jit(f"void({V}, {M}, {V})")
def inject_reset(x, P, dx):
    """Inject ``δx`` into the nominal state and apply the reset Jacobian ``G`` (Solà eq. 285-287): P ← G P Gᵀ."""
    for i in range(3):
        x[_P + i] += dx[_DP + i]
        x[_V + i] += dx[_DV + i]
        x[_BG + i] += dx[_DBG + i]
        x[_BA + i] += dx[_DBA + i]
    quat_mul_exp_inplace(x[_Q : _Q + 4], dx[_DTH], dx[_DTH + 1], dx[_DTH + 2])
    G = np.eye(_NE)
    hx, hy, hz = 0.5 * dx[_DTH], 0.5 * dx[_DTH + 1], 0.5 * dx[_DTH + 2]
    a, b, c = _DTH, _DTH + 1, _DTH + 2
    G[a, b], G[a, c] = hz, -hy
    G[b, a], G[b, c] = -hz, hx
    G[c, a], G[c, b] = hy, -hx
    GP = G @ P
    P[:, :] = GP @ G.T


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


@_jit(f"i8({V}, {M}, {V}, {V}, {V}, {M}, {M}, f8, f8, {V}, i8[:])")
def update_points(x, P, intr, q_bc, p_bc, pixels, points, sigma_px, gate, nis_out, accepted_out):
    """Sequential χ²-gated update with the point correspondences of one frame.

    Every correspondence is linearised at the predicted nominal state (so the sequence equals one batch update
    of the accepted ones); they are processed in increasing order of their prior NIS, so that after a dropout the
    most consistent correspondences tighten ``P`` before the doubtful ones are gated.  ``nis_out`` (M,) receives the
    NIS of each correspondence against the covariance at its turn, ``accepted_out`` (M,) 1/0.  Returns the number
    accepted.
    """
    m = pixels.shape[0]
    r = np.empty((m, 2))
    H = np.empty((m, 2, _NE))
    depth = np.empty(m)
    camera_batch(x, intr, q_bc, p_bc, pixels, points, r, H, depth)
    dx = np.zeros(_NE)
    n_acc = sequential_gated_update(P, r, H, np.full(m, sigma_px * sigma_px), depth, gate, dx, nis_out, accepted_out)
    inject_reset(x, P, dx)
    return n_acc


@_jit(f"f8({V}, {M}, {V}, {M}, {M})")
def update_dense(x, P, r, H, R):
    """Batch update with residual ``r`` (m,), Jacobian ``H`` (m, 15), noise ``R`` (m, m); returns the NIS."""
    S = H @ P @ H.T + R
    Si = np.linalg.inv(S)
    nis = r @ (Si @ r)
    K = P @ H.T @ Si
    dx = K @ r
    joseph(P, K, H, R)
    inject_reset(x, P, dx)
    return nis


_RUN_ARGS = (
    f"{V}, {M}, {M}, {V}, i8[:], {M}, {M}, {V}, {M}, {V}, {V}, {V}, {V}, {V}, f8, f8, {M}, {T}, {M}, {T}, {V}, i8[:]"
)
_NODE_ARGS = f"b1, {M}, {T}, {M}, {T}, {T}, {V}, i8[:], i8[:]"


@_jit(f"i8(i8, f8, {V}, {M}, {M}, {M}, {T}, {M}, {T}, {T}, {V})")
def _record_prediction(m, tn, x, P, F, XA, PA, XB, PB, FS, TN):
    """Store the transition out of node ``m`` and open node ``m + 1`` (prior = posterior = the predicted state)."""
    FS[m] = F
    m += 1
    XA[m] = x
    PA[m] = P
    XB[m] = x
    PB[m] = P
    TN[m] = tn
    return m


@_jit(f"i8({_RUN_ARGS}, {_NODE_ARGS})")
def _run_impl(t, gyro, accel, cam_t, offsets, pixels, points, x, P, gravity, noise, intr, q_bc, p_bc, sigma_px, gate,
              X, Ps, XF, PF, nis_out, accepted_out,
              record, XA, PA, XB, PB, FS, TN, imu_node, frame_node):  # fmt: skip
    """The loop of :func:`run`; with ``record`` it also stores every filter node (see :func:`run_recorded`).

    A node is created at ``t[0]`` and after every prediction (to an IMU time or a camera time); a camera update
    changes the posterior of the current node.  Returns the number of nodes.
    """
    n = t.shape[0]
    nf = cam_t.shape[0]
    F = np.empty((_NE, _NE))
    m = 0
    if record:
        XA[0] = x
        PA[0] = P
        TN[0] = t[0]
        for j in range(nf):
            frame_node[j] = -1
    j = 0
    while j < nf and cam_t[j] < t[0]:
        XF[j] = np.nan
        j += 1
    while j < nf and cam_t[j] == t[0]:
        a, b = offsets[j], offsets[j + 1]
        update_points(x, P, intr, q_bc, p_bc, pixels[a:b], points[a:b], sigma_px, gate, nis_out[a:b],
                      accepted_out[a:b])  # fmt: skip
        XF[j] = x
        PF[j] = P
        if record:
            frame_node[j] = 0
        j += 1
    X[0] = x
    Ps[0] = P
    if record:
        XB[0] = x
        PB[0] = P
        imu_node[0] = 0
    g_cur = np.empty(3)
    a_cur = np.empty(3)
    g_mid = np.empty(3)
    a_mid = np.empty(3)
    for k in range(n - 1):
        t0, t1 = t[k], t[k + 1]
        tc = t0
        g_cur[:] = gyro[k]
        a_cur[:] = accel[k]
        while j < nf and cam_t[j] <= t1:
            tj = cam_t[j]
            w = (tj - t0) / (t1 - t0)
            for i in range(3):
                gj = (1.0 - w) * gyro[k, i] + w * gyro[k + 1, i]
                aj = (1.0 - w) * accel[k, i] + w * accel[k + 1, i]
                g_mid[i] = 0.5 * (g_cur[i] + gj)
                a_mid[i] = 0.5 * (a_cur[i] + aj)
                g_cur[i] = gj
                a_cur[i] = aj
            if tj > tc:
                predict_transition(x, P, g_mid, a_mid, tj - tc, gravity, noise, F)
                if record:
                    m = _record_prediction(m, tj, x, P, F, XA, PA, XB, PB, FS, TN)
            tc = tj
            a, b = offsets[j], offsets[j + 1]
            update_points(x, P, intr, q_bc, p_bc, pixels[a:b], points[a:b], sigma_px, gate, nis_out[a:b],
                          accepted_out[a:b])  # fmt: skip
            XF[j] = x
            PF[j] = P
            if record:
                XB[m] = x
                PB[m] = P
                frame_node[j] = m
            j += 1
        if t1 > tc:
            for i in range(3):
                g_mid[i] = 0.5 * (g_cur[i] + gyro[k + 1, i])
                a_mid[i] = 0.5 * (a_cur[i] + accel[k + 1, i])
            predict_transition(x, P, g_mid, a_mid, t1 - tc, gravity, noise, F)
            if record:
                m = _record_prediction(m, t1, x, P, F, XA, PA, XB, PB, FS, TN)
        X[k + 1] = x
        Ps[k + 1] = P
        if record:
            imu_node[k + 1] = m
    while j < nf:
        XF[j] = np.nan
        j += 1
    if record:
        FS[m] = np.eye(_NE)  # no transition out of the last node
    return m + 1


@_jit(f"void({_RUN_ARGS})")
def run(t, gyro, accel, cam_t, offsets, pixels, points, x, P, gravity, noise, intr, q_bc, p_bc, sigma_px, gate,
        X, Ps, XF, PF, nis_out, accepted_out):  # fmt: skip
    """Filter a whole stream.  IMU samples ``t`` (N,), camera times ``cam_t`` (F,) already on the IMU clock.

    The IMU input is taken as linear between samples: each step uses the mean of the (interpolated) measurements at
    its two ends, and a step is split exactly at every camera time.  Writes the state/covariance after each IMU time
    to ``X`` (N, 16), ``Ps`` (N, 15, 15) and after each camera update to ``XF`` (F, 16), ``PF`` (F, 15, 15).
    Frames before ``t[0]`` or after ``t[-1]`` are skipped (their ``XF`` row is NaN).
    """
    e2, e3 = np.empty((0, _NX)), np.empty((0, _NE, _NE))
    _run_impl(t, gyro, accel, cam_t, offsets, pixels, points, x, P, gravity, noise, intr, q_bc, p_bc, sigma_px, gate,
              X, Ps, XF, PF, nis_out, accepted_out,
              False, e2, e3, e2, e3, e3, np.empty(0), np.empty(0, np.int64), np.empty(0, np.int64))  # fmt: skip


@_jit(f"i8({_RUN_ARGS}, {M}, {T}, {M}, {T}, {T}, {V}, i8[:], i8[:])")
def run_recorded(t, gyro, accel, cam_t, offsets, pixels, points, x, P, gravity, noise, intr, q_bc, p_bc, sigma_px,
                 gate, X, Ps, XF, PF, nis_out, accepted_out,
                 XA, PA, XB, PB, FS, TN, imu_node, frame_node):  # fmt: skip
    """:func:`run` that also stores what the RTS smoother needs, for every filter node ``i`` (K ≤ N + F of them:
    ``t[0]``, each IMU time and each camera time strictly between IMU times):

    ``XA`` (K, 16) / ``PA`` (K, 15, 15) the prior (predicted) nominal state and covariance, ``XB`` / ``PB`` the
    posterior (after the camera update and reset at that node; equal to the prior at nodes without an update),
    ``FS`` (K, 15, 15) the error-state transition from node i to i + 1 (identity for the last node), ``TN`` (K,) the
    node times, ``imu_node`` (N,) / ``frame_node`` (F,) the node of each IMU time / camera frame (−1: skipped).
    Arrays must hold at least N + F nodes; returns the number K written.
    """
    return _run_impl(t, gyro, accel, cam_t, offsets, pixels, points, x, P, gravity, noise, intr, q_bc, p_bc, sigma_px,
                     gate, X, Ps, XF, PF, nis_out, accepted_out,
                     True, XA, PA, XB, PB, FS, TN, imu_node, frame_node)  # fmt: skip
