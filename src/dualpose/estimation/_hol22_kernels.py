"""numba kernels of Hol's 22-state EKF (:mod:`dualpose.estimation.hol22`): Algorithm 1 over a whole recording.

The same equations as the step-by-step methods of :class:`~dualpose.estimation.hol22.Hol22EKF` (which stay the
readable reference and are checked against these kernels in the tests):

* state ``x`` (22,) = ``[b^e, ḃ^e, b̈^e, q^{be} xyzw, ω^b_{eb}, δ^b_ω, δ^b_a]``, covariance ``P`` (22, 22);
* time update (eq. 9): ``x ← f(x, T)``, ``P ← F P Fᵀ + diag(qdiag) T``, ``qdiag`` (22,) the process spectral
  densities (zero outside b̈, ω and the biases);
* IMU update (eq. 11a, 11b) with ``R_imu`` (6, 6), camera update (eq. 11c) per correspondence, χ²-gated in order of
  prior NIS, noise ``(Z σ_px)² I₂``; the quaternion is renormalized after each update and its covariance block
  projected (``J = (I − u uᵀ)/|q|``).

Imported lazily; every kernel has an explicit signature (compiled or loaded from the cache on import).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from dualpose.estimation._eskf_kernels import joseph, sequential_gated_update
from dualpose.estimation.state import HOL22_ACCEL_BIAS as _BA
from dualpose.estimation.state import HOL22_ACCELERATION as _A
from dualpose.estimation.state import HOL22_ANGULAR_VELOCITY as _W
from dualpose.estimation.state import HOL22_DIM as _N
from dualpose.estimation.state import HOL22_GYRO_BIAS as _BG
from dualpose.estimation.state import HOL22_POSITION as _P
from dualpose.estimation.state import HOL22_QUAT_BE as _Q
from dualpose.estimation.state import HOL22_VELOCITY as _V

V, M, T = "f8[::1]", "f8[:,::1]", "f8[:,:,::1]"
VA = "f8[:]"  # any layout (slices and rows)


def _jit(sig: str):
    return nb.njit(sig, cache=True, nogil=True)


@_jit(f"void({VA}, {M}, {T})")
def rot_be_and_derivs(q, R, dR):
    """``R^{be}(q)`` (the quadratic form, a rotation for unit q, xyzw) into ``R`` (3, 3), ``∂R/∂q_i`` into ``dR``
    (4, 3, 3)."""
    x, y, z, w = q[0], q[1], q[2], q[3]
    R[0, 0], R[0, 1], R[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)
    R[1, 0], R[1, 1], R[1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)
    R[2, 0], R[2, 1], R[2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    x2, y2, z2, w2 = 2 * x, 2 * y, 2 * z, 2 * w
    dR[0, 0, 0], dR[0, 0, 1], dR[0, 0, 2] = 0.0, y2, z2
    dR[0, 1, 0], dR[0, 1, 1], dR[0, 1, 2] = y2, -2 * x2, -w2
    dR[0, 2, 0], dR[0, 2, 1], dR[0, 2, 2] = z2, w2, -2 * x2
    dR[1, 0, 0], dR[1, 0, 1], dR[1, 0, 2] = -2 * y2, x2, w2
    dR[1, 1, 0], dR[1, 1, 1], dR[1, 1, 2] = x2, 0.0, z2
    dR[1, 2, 0], dR[1, 2, 1], dR[1, 2, 2] = -w2, z2, -2 * y2
    dR[2, 0, 0], dR[2, 0, 1], dR[2, 0, 2] = -2 * z2, -w2, x2
    dR[2, 1, 0], dR[2, 1, 1], dR[2, 1, 2] = w2, -2 * z2, y2
    dR[2, 2, 0], dR[2, 2, 1], dR[2, 2, 2] = x2, y2, 0.0
    dR[3, 0, 0], dR[3, 0, 1], dR[3, 0, 2] = 0.0, -z2, y2
    dR[3, 1, 0], dR[3, 1, 1], dR[3, 1, 2] = z2, 0.0, -x2
    dR[3, 2, 0], dR[3, 2, 1], dR[3, 2, 2] = -y2, x2, 0.0


@_jit(f"void({V}, {M}, f8, {V})")
def time_update(x, P, dt, qdiag):
    """Eq. 9 over ``dt`` seconds in place: constant acceleration / angular velocity, ``q ← exp(−dt/2 ω) ⊙ q``."""
    if dt <= 0.0:
        return
    wx, wy, wz = x[_W], x[_W + 1], x[_W + 2]
    r = math.sqrt(wx * wx + wy * wy + wz * wz)
    th = 0.5 * dt * r
    s = 0.5 * dt * (math.sin(th) / th if th > 1e-8 else 1.0 - th * th / 6.0)  # sin(θ)/|ω|
    c2 = -((0.5 * dt) ** 3) / 3.0 if th < 1e-4 else (0.5 * dt * math.cos(th) - s) / (r * r)
    ax, ay, az, aw = -s * wx, -s * wy, -s * wz, math.cos(th)  # dq = exp(−dt/2 ω), xyzw
    F = np.eye(_N)
    for i in range(3):
        F[_P + i, _V + i] = dt
        F[_P + i, _A + i] = 0.5 * dt * dt
        F[_V + i, _A + i] = dt
    # ∂(dq ⊙ q)/∂q = Q(dq) (left-multiplication matrix, xyzw)
    L = F[_Q : _Q + 4, _Q : _Q + 4]
    L[0, 0], L[0, 1], L[0, 2], L[0, 3] = aw, -az, ay, ax
    L[1, 0], L[1, 1], L[1, 2], L[1, 3] = az, aw, -ax, ay
    L[2, 0], L[2, 1], L[2, 2], L[2, 3] = -ay, ax, aw, az
    L[3, 0], L[3, 1], L[3, 2], L[3, 3] = -ax, -ay, -az, aw
    # ∂(dq ⊙ q)/∂ω = W(q) ∂dq/∂ω, W the right-multiplication matrix of q
    qx, qy, qz, qw = x[_Q], x[_Q + 1], x[_Q + 2], x[_Q + 3]
    W = np.array([[qw, qz, -qy, qx], [-qz, qw, qx, qy], [qy, -qx, qw, qz], [-qx, -qy, -qz, qw]])
    J = np.empty((4, 3))
    om = (wx, wy, wz)
    for i in range(3):
        for j in range(3):
            J[i, j] = -((s if i == j else 0.0) + c2 * om[i] * om[j])
        J[3, i] = -0.5 * dt * s * om[i]
    F[_Q : _Q + 4, _W : _W + 3] = W @ J
    # state
    for i in range(3):
        x[_P + i] += dt * x[_V + i] + 0.5 * dt * dt * x[_A + i]
        x[_V + i] += dt * x[_A + i]
    x[_Q], x[_Q + 1], x[_Q + 2], x[_Q + 3] = (
        aw * qx + qw * ax + ay * qz - az * qy,
        aw * qy + qw * ay + az * qx - ax * qz,
        aw * qz + qw * az + ax * qy - ay * qx,
        aw * qw - ax * qx - ay * qy - az * qz,
    )
    P[:, :] = F @ P @ F.T
    for i in range(_N):
        P[i, i] += qdiag[i] * dt


@_jit(f"void({V}, {M})")
def normalize(x, P):
    """``q ← q/|q|`` and ``P ← J P Jᵀ`` with ``J = I`` except the quaternion block ``(I − u uᵀ)/|q|``."""
    q = _Q
    nq = math.sqrt(x[q] * x[q] + x[q + 1] * x[q + 1] + x[q + 2] * x[q + 2] + x[q + 3] * x[q + 3])
    u = np.empty(4)
    for i in range(4):
        u[i] = x[q + i] / nq
        x[q + i] = u[i]
    Jq = np.empty((4, 4))
    for i in range(4):
        for j in range(4):
            Jq[i, j] = ((1.0 if i == j else 0.0) - u[i] * u[j]) / nq
    tmp = np.empty(4)
    for c in range(_N):  # quaternion rows ← Jq P[q, :]
        for i in range(4):
            tmp[i] = Jq[i, 0] * P[q, c] + Jq[i, 1] * P[q + 1, c] + Jq[i, 2] * P[q + 2, c] + Jq[i, 3] * P[q + 3, c]
        for i in range(4):
            P[q + i, c] = tmp[i]
    for r in range(_N):  # quaternion columns ← P[:, q] Jqᵀ
        for i in range(4):
            tmp[i] = Jq[i, 0] * P[r, q] + Jq[i, 1] * P[r, q + 1] + Jq[i, 2] * P[r, q + 2] + Jq[i, 3] * P[r, q + 3]
        for i in range(4):
            P[r, q + i] = tmp[i]


@_jit(f"f8({V}, {M}, {VA}, {VA}, {V}, {M}, {M}, {T})")
def imu_update(x, P, accel, gyro, gravity, R_imu, R, dR):
    """Accelerometer + gyroscope update (eq. 11a, 11b) in place; returns the NIS (6 dof).  ``R``, ``dR``: work."""
    rot_be_and_derivs(x[_Q : _Q + 4], R, dR)
    H = np.zeros((6, _N))
    nu = np.empty(6)
    d = np.empty(3)
    for i in range(3):
        d[i] = x[_A + i] - gravity[i]
    for i in range(3):
        h = x[_BA + i]
        for j in range(3):
            h += R[i, j] * d[j]
            H[i, _A + j] = R[i, j]
        for k in range(4):
            acc = 0.0
            for j in range(3):
                acc += dR[k, i, j] * d[j]
            H[i, _Q + k] = acc
        H[i, _BA + i] = 1.0
        nu[i] = accel[i] - h
        H[3 + i, _W + i] = 1.0
        H[3 + i, _BG + i] = 1.0
        nu[3 + i] = gyro[i] - (x[_W + i] + x[_BG + i])
    HP = H @ P
    S = HP @ H.T + R_imu
    K = np.linalg.solve(S, HP).T
    x += K @ nu
    joseph(P, K, H, R_imu)
    normalize(x, P)
    return nu @ np.linalg.solve(S, nu)


@_jit(f"void({V}, {M}, {M}, {M}, {V}, {V}, {M}, {V}, f8, f8, {V}, i8[:], {M}, {T})")
def camera_update(x, P, pixels, points, intr, p_bc, Rcb, depth_floor_sigma, sigma_px, gate, nis_out, acc_out, R, dR):
    """Eq. 11c for one frame in place: ``h = [−f I₂, zⁱ] R^{cb}(R^{be}(z^e − b^e) − c^b)`` (measured 0), noise
    ``(max(Z, depth_floor) σ_px)² I₂``, linearised at the predicted state, χ²-gated in order of prior NIS.
    ``depth_floor_sigma`` (1,) holds the depth floor (1e-3 m).  ``nis_out`` (M,), ``acc_out`` (M,) receive the
    NIS and 1/0; ``R``, ``dR``: work."""
    fx, fy, cx, cy = intr[0], intr[1], intr[2], intr[3]
    m = pixels.shape[0]
    rot_be_and_derivs(x[_Q : _Q + 4], R, dR)
    h = np.empty((m, 2))
    H = np.zeros((m, 2, _N))
    depth = np.empty(m)
    AR = np.empty((2, 3))
    d = np.empty(3)
    zb = np.empty(3)
    zc = np.empty(3)
    for k in range(m):
        for i in range(3):
            d[i] = points[k, i] - x[_P + i]
        for i in range(3):
            zb[i] = R[i, 0] * d[0] + R[i, 1] * d[1] + R[i, 2] * d[2] - p_bc[i]
        for i in range(3):
            zc[i] = Rcb[i, 0] * zb[0] + Rcb[i, 1] * zb[1] + Rcb[i, 2] * zb[2]
        u, v = pixels[k, 0] - cx, pixels[k, 1] - cy
        h[k, 0] = -fx * zc[0] + u * zc[2]
        h[k, 1] = -fy * zc[1] + v * zc[2]
        depth[k] = zc[2]
        for j in range(3):
            AR[0, j] = -fx * Rcb[0, j] + u * Rcb[2, j]
            AR[1, j] = -fy * Rcb[1, j] + v * Rcb[2, j]
        for i in range(2):
            for j in range(3):
                H[k, i, _P + j] = -(AR[i, 0] * R[0, j] + AR[i, 1] * R[1, j] + AR[i, 2] * R[2, j])
            for q in range(4):
                acc = 0.0
                for a in range(3):
                    acc += AR[i, a] * (dR[q, a, 0] * d[0] + dR[q, a, 1] * d[1] + dR[q, a, 2] * d[2])
                H[k, i, _Q + q] = acc
    floor = depth_floor_sigma[0]
    s2 = np.empty(m)
    for k in range(m):
        s2[k] = (max(depth[k], floor) * sigma_px) ** 2
        h[k, 0], h[k, 1] = -h[k, 0], -h[k, 1]  # residual: measured 0 minus predicted h
    dx = np.zeros(_N)
    sequential_gated_update(P, h, H, s2, depth, gate, dx, nis_out, acc_out)
    x += dx
    normalize(x, P)


@_jit(
    f"void({V}, {M}, {M}, {V}, i8[:], {M}, {M}, {V}, {M}, {V}, {V}, {M}, {V}, {V}, {M}, f8, f8, "
    f"{M}, {T}, {V}, i8[:])"
)
def run(t, gyro, accel, cam_t, offsets, pixels, points, x, P, qdiag, gravity, R_imu, intr, p_bc, Rcb, sigma_px,
        gate, X, Ps, nis_out, acc_out):  # fmt: skip
    """Hol's Algorithm 1 over a recording: for each IMU time, first every camera frame up to it (time update to
    the frame time, camera update), then the time update to the IMU time and the IMU update.  ``cam_t`` (F,) is
    already on the IMU clock; frames before ``t[0]`` are skipped (their NIS stays NaN).  Writes the state and
    covariance after each IMU update to ``X`` (N, 22), ``Ps`` (N, 22, 22)."""
    n = t.shape[0]
    nf = cam_t.shape[0]
    R = np.empty((3, 3))
    dR = np.empty((4, 3, 3))
    floor = np.array([1e-3])
    j = 0
    while j < nf and cam_t[j] < t[0]:
        j += 1
    tc = t[0]
    for k in range(n):
        while j < nf and cam_t[j] <= t[k]:
            time_update(x, P, cam_t[j] - tc, qdiag)
            tc = cam_t[j]
            a, b = offsets[j], offsets[j + 1]
            camera_update(x, P, pixels[a:b], points[a:b], intr, p_bc, Rcb, floor, sigma_px, gate, nis_out[a:b],
                          acc_out[a:b], R, dR)  # fmt: skip
            j += 1
        time_update(x, P, t[k] - tc, qdiag)
        tc = t[k]
        imu_update(x, P, accel[k], gyro[k], gravity, R_imu, R, dR)
        X[k] = x
        Ps[k] = P
