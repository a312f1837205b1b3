"""numba kernel of the orientation-only error-state filter (AHRS) of :mod:`dualpose.estimation.ahrs`.

Imported lazily.  Layouts (xyzw quaternions, earth frame ENU, ``q`` rotates body vectors into the earth frame):

* nominal state: ``q`` (4,) and the gyroscope bias ``b`` (3,) rad/s;
* error state ``δx`` (6,) = ``[δθ (3), δb (3)]`` with a **global** (earth-frame) attitude error
  ``q = Exp(δθ) ⊗ q̂`` so that ``δθ_z`` is the heading error and ``δθ_x, δθ_y`` the inclination error;
* ``P`` (6, 6) covariance of ``δx``;
* ``params`` (``N_PARAMS``,) see the ``P_*`` indices below;
* ``stats`` (``N_STATS``,) counters written by the run, see the ``S_*`` indices.

One call processes a whole recording: one predict (gyroscope as input) per sample; every ``params[P_STRIDE]``
samples (once the first window is full) one accelerometer update and (9D) one magnetometer heading update with the
earth-frame mean specific force and field of the last ``params[P_WINDOW]`` samples.  Covariance updates use the
Joseph form, which stays valid for the deliberately restricted gains (the accelerometer does not correct heading,
the magnetometer does not correct inclination).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from dualpose.estimation._eskf_kernels import _rotmat_xyzw, quat_mul_exp_inplace
from dualpose.estimation.state import AHRS_D_ATTITUDE as _DTH
from dualpose.estimation.state import AHRS_D_GYRO_BIAS as _DB
from dualpose.estimation.state import AHRS_ERROR_DIM as _NE

# params indices
P_GYR_VAR = 0  # gyroscope white-noise density², rad²/s
P_BIAS_VAR = 1  # gyroscope bias random-walk density², rad²/s³
P_ACC_VAR = 2  # accelerometer per-sample noise variance, (m/s²)²
P_GRAVITY = 3  # local |g| (m/s²)
P_MAG_VAR = 4  # magnetometer per-sample noise variance, µT²
P_MAG_NORM = 5  # reference field magnitude, µT
P_MAG_DIP = 6  # reference dip angle, rad (positive: field points below the horizon)
P_USE_MAG = 7  # 1.0: 9D, 0.0: 6D
P_ACC_GATE = 8  # χ²(2) rejection threshold of the accelerometer innovation
P_MAG_GATE = 9  # χ²(1) rejection threshold of the heading innovation
P_GATE_RELEASE = 10  # samples of uninterrupted rejection after which a gate opens again (re-acquisition)
P_ACC_ADAPT = 11  # forgetting factor α (per sample) of the innovation-based estimate of the acceleration noise
P_MAG_ADAPT = 12  # same for the heading noise
P_WINDOW = 13  # samples averaged (in the earth frame) per accelerometer / magnetometer update
P_GYR_SCALE_VAR = 14  # gyroscope scale-factor / misalignment variance ε² times its correlation time, s
P_STRIDE = 15  # samples between updates (≤ window; windows overlap when smaller)
N_PARAMS = 16

# stats indices
S_ACC_REJECTED = 0
S_MAG_REJECTED = 1
S_ACC_NIS_SUM = 2
S_MAG_NIS_SUM = 3
S_ACC_INSIDE = 4  # accepted updates with NIS inside the two-sided 95% band (counted by the caller's bounds)
S_MAG_INSIDE = 5
S_MAG_SKIPPED = 6  # samples with a degenerate (vertical) field
N_STATS = 7

_CHI2_2_LO, _CHI2_2_HI = 0.0506356, 7.3777589  # two-sided 95% band of χ²(2)
_CHI2_1_LO, _CHI2_1_HI = 0.000982069, 5.0238862  # two-sided 95% band of χ²(1)


def _jit(sig: str):
    return nb.njit(sig, cache=True, nogil=True)


@_jit("void(f8[::1], f8, f8, f8)")
def exp_mul_quat_inplace(q, rx, ry, rz):
    """``q ← normalize(Exp(r) ⊗ q)`` (global error injection); ``q`` (4,) xyzw, ``r`` a rotation vector (rad).

    Evaluated as ``q ⊗ Exp(R(q)ᵀ r)`` (the same rotation, applied in the body frame) with the error-state
    filter's local injection."""
    x, y, z, w = -q[0], -q[1], -q[2], q[3]  # q*, whose rotation is R(q)ᵀ
    ax, ay, az = y * rz - z * ry + w * rx, z * rx - x * rz + w * ry, x * ry - y * rx + w * rz
    bx, by, bz = y * az - z * ay, z * ax - x * az, x * ay - y * ax
    quat_mul_exp_inplace(q, rx + 2.0 * bx, ry + 2.0 * by, rz + 2.0 * bz)


@_jit("void(f8[:,::1], f8[:,::1], f8[:,::1], f8)")
def joseph_update(P, K, H, r):
    """``P ← (I − K H) P (I − K H)ᵀ + r K Kᵀ`` for a measurement of dimension m with isotropic noise ``r``.

    ``P`` (6, 6), ``K`` (6, m), ``H`` (m, 6).  Valid for any gain ``K`` (here: optimal gains with rows zeroed).
    """
    m = H.shape[0]
    A = np.eye(_NE)
    for i in range(_NE):
        for j in range(_NE):
            s = 0.0
            for k in range(m):
                s += K[i, k] * H[k, j]
            A[i, j] -= s
    AP = A @ P
    Pn = AP @ A.T
    for i in range(_NE):
        for j in range(_NE):
            s = 0.0
            for k in range(m):
                s += K[i, k] * K[j, k]
            Pn[i, j] += r * s
    for i in range(_NE):
        for j in range(_NE):
            P[i, j] = 0.5 * (Pn[i, j] + Pn[j, i])


@_jit("void(f8[::1], f8[::1], f8[:,::1], f8[::1])")
def inject_and_reset(q, b, P, dx):
    """Inject ``δx`` (6,) into ``q`` and ``b`` and apply the reset Jacobian ``G = diag(I + [½δθ]×, I)`` to ``P``.

    For the global error ``q = Exp(δθ) ⊗ q̂`` the reset Jacobian is ``I + [½δθ]×`` (Solà 2017, eq. 287 with the
    sign of the global error).
    """
    a, c, e = _DTH, _DTH + 1, _DTH + 2
    exp_mul_quat_inplace(q, dx[a], dx[c], dx[e])
    for i in range(3):
        b[i] += dx[_DB + i]
    hx, hy, hz = 0.5 * dx[a], 0.5 * dx[c], 0.5 * dx[e]
    G = np.eye(_NE)
    G[a, c], G[a, e] = -hz, hy
    G[c, a], G[c, e] = hz, -hx
    G[e, a], G[e, c] = -hy, hx
    Pn = G @ P @ G.T
    for i in range(_NE):
        for j in range(_NE):
            P[i, j] = Pn[i, j]


@_jit("void(f8[:,::1], f8[::1])")
def left_rotate_inplace(C, dx):
    """``C ← Exp(δθ) C`` for a rotation matrix ``C`` (3, 3) and ``δθ = dx[:3]`` (Rodrigues, guarded near 0)."""
    x, y, z = dx[0], dx[1], dx[2]
    a2 = x * x + y * y + z * z
    if a2 < 1e-8:
        s, c = 1.0 - a2 / 6.0, 0.5 - a2 / 24.0
    else:
        a = math.sqrt(a2)
        s, c = math.sin(a) / a, (1.0 - math.cos(a)) / a2
    E = np.empty((3, 3))
    E[0, 0] = 1.0 - c * (y * y + z * z)
    E[1, 1] = 1.0 - c * (x * x + z * z)
    E[2, 2] = 1.0 - c * (x * x + y * y)
    E[0, 1], E[1, 0] = c * x * y - s * z, c * x * y + s * z
    E[0, 2], E[2, 0] = c * x * z + s * y, c * x * z - s * y
    E[1, 2], E[2, 1] = c * y * z - s * x, c * y * z + s * x
    Cn = E @ C
    for i in range(3):
        for j in range(3):
            C[i, j] = Cn[i, j]


@_jit("f8(f8[::1], f8[::1], f8)")
def heading_of_field(m_e, out_h, eps):
    """Heading of an earth-frame field vector ``m_e`` (3,): ``atan2(m_x, m_y)`` (rad, 0 = north, positive towards
    east); ``out_h[0]`` receives the horizontal magnitude.  Returns NaN when the horizontal part is below ``eps``."""
    h = math.sqrt(m_e[0] * m_e[0] + m_e[1] * m_e[1])
    out_h[0] = h
    if h < eps:
        return math.nan
    return math.atan2(m_e[0], m_e[1])


@_jit("void(f8[::1], f8[::1], f8[:,::1], f8, f8, f8, f8, f8, f8, f8, f8[:,::1], f8[:,::1])")
def predict(q, b, P, gx, gy, gz, dt, gyr_var, bias_var, scale_var, R, RP):
    """One predict in place with the gyroscope sample ``(gx, gy, gz)`` (rad/s) over ``dt`` (s): ``q ← q ⊗ Exp((ω −
    b) dt)``, ``P ← F P Fᵀ + Q`` with ``F = [[I, −R dt], [0, I]]`` (global attitude error) and ``Q = diag((σ_g² +
    ε²|ω − b|²) dt I, σ_b² dt I)`` (``gyr_var`` = σ_g², ``bias_var`` = σ_b², ``scale_var`` = ε² · 1 s).  ``R``,
    ``RP`` (3, 3) are work arrays."""
    wx, wy, wz = gx - b[0], gy - b[1], gz - b[2]
    _rotmat_xyzw(q[0], q[1], q[2], q[3], R)
    quat_mul_exp_inplace(q, wx * dt, wy * dt, wz * dt)
    # P ← F P Fᵀ, F = [[I, -R dt], [0, I]], written blockwise: P = [[A, B], [Bᵀ, C]]
    # A' = A − dt (R Bᵀ + B Rᵀ) + dt² R C Rᵀ, B' = B − dt R C, C' = C
    for i in range(3):
        for j in range(3):
            s = 0.0
            for m in range(3):
                s += R[i, m] * P[_DB + m, _DB + j]
            RP[i, j] = s  # R C
    for i in range(3):
        for j in range(3):
            s = 0.0
            for m in range(3):
                # (R Bᵀ)[i, j] + (B Rᵀ)[i, j] with B[i, m] = P[_DTH + i, _DB + m]
                s += R[i, m] * P[_DTH + j, _DB + m] + P[_DTH + i, _DB + m] * R[j, m] - dt * RP[i, m] * R[j, m]
            P[_DTH + i, _DTH + j] -= dt * s
    for i in range(3):
        for j in range(3):
            P[_DTH + i, _DB + j] -= dt * RP[i, j]
            P[_DB + j, _DTH + i] = P[_DTH + i, _DB + j]
    # white rate noise plus the rate-proportional error of scale factor and axis misalignment
    q_theta = (gyr_var + scale_var * (wx * wx + wy * wy + wz * wz)) * dt
    for i in range(3):
        P[_DTH + i, _DTH + i] += q_theta
        P[_DB + i, _DB + i] += bias_var * dt


@_jit(
    "void(f8[:,::1], f8[:,::1], f8[:,::1], f8, f8[::1], f8[::1], f8[:,::1], f8[::1], f8[:,::1], f8[:,::1],"
    " f8[:,::1], f8[:,::1], f8[::1])"
)
def run_ahrs(gyr, acc, mag, dt, q, b, P, params, Ha, Hm, out_q, out_b, stats):
    """Run the filter over all samples; ``q`` (4,), ``b`` (3,), ``P`` (6, 6) are the initial state, updated in place.

    Per sample k: predict ``q ← q ⊗ Exp((ω_k − b) dt)``, ``P ← F P Fᵀ + Q`` with ``F = [[I, −R dt], [0, I]]``,
    ``Q = diag((σ_g² + ε²|ω|²) dt I, σ_b² dt I)``; accumulate ``R̂ a_k`` and ``R̂ m_k`` in the sliding window; every
    stride samples the accelerometer update of inclination and (9D) the magnetometer heading update.
    ``Ha`` (2, 6) and ``Hm`` (1, 6) are the measurement Jacobians of
    :func:`dualpose.estimation.ahrs.accelerometer_jacobian`
    and :func:`dualpose.estimation.ahrs.heading_jacobian`.  Writes ``out_q[k]`` (xyzw) and ``out_b[k]`` after the
    updates of sample k.
    """
    n = gyr.shape[0]
    gyr_var, bias_var, acc_var, grav = params[P_GYR_VAR], params[P_BIAS_VAR], params[P_ACC_VAR], params[P_GRAVITY]
    mag_var, mag_norm, mag_dip = params[P_MAG_VAR], params[P_MAG_NORM], params[P_MAG_DIP]
    use_mag = params[P_USE_MAG] > 0.5
    acc_gate, mag_gate, release = params[P_ACC_GATE], params[P_MAG_GATE], params[P_GATE_RELEASE]
    R = np.empty((3, 3))
    RP = np.empty((3, 3))
    v = np.empty(3)
    hh = np.empty(1)
    dx = np.empty(_NE)
    Ka = np.zeros((_NE, 2))
    PH = np.zeros((_NE, 2))
    Km = np.zeros((_NE, 1))
    acc_closed = 0
    mag_closed = 0
    acc_alpha, mag_alpha = params[P_ACC_ADAPT], params[P_MAG_ADAPT]
    acc_extra = 0.0
    n_win = max(1, int(params[P_WINDOW]))
    scale_var = params[P_GYR_SCALE_VAR]
    stride = max(1, min(n_win, int(params[P_STRIDE])))
    overlap = n_win / stride
    acc_alpha = min(1.0, acc_alpha * stride)  # the forgetting factors are given per sample
    mag_alpha = min(1.0, mag_alpha * stride)
    release = max(1.0, release / stride)  # the gates count updates
    acc_sum = np.zeros(3)
    mag_sum = np.zeros(3)
    mag_mean = np.zeros(3)
    ring_a = np.zeros((n_win, 3))
    ring_m = np.zeros((n_win, 3))
    ring_d = np.zeros(n_win)
    Cm = np.eye(3)  # accumulated corrections: current earth frame = Cm · uncorrected frame
    mag_dist_sum = 0.0
    mag_dist = 0.0
    head = 0
    filled = 0
    since = 0
    mag_extra = 0.0
    for k in range(n):
        # ---- predict: gyroscope as input (global error: δθ̇ = −R δb + R n_g)
        predict(q, b, P, gyr[k, 0], gyr[k, 1], gyr[k, 2], dt, gyr_var, bias_var, scale_var, R, RP)
        _rotmat_xyzw(q[0], q[1], q[2], q[3], R)

        # ---- accumulate the window: specific force and field rotated into the estimated earth frame.  They are
        # stored in the "uncorrected" frame (the earth frame before all corrections so far, C⁻¹ R̂ v) so that a
        # correction applied later rotates the whole window at once: current-frame mean = C · mean.
        ax, ay, az = acc[k, 0], acc[k, 1], acc[k, 2]
        for i in range(3):
            v[i] = R[i, 0] * ax + R[i, 1] * ay + R[i, 2] * az
        for i in range(3):
            e = Cm[0, i] * v[0] + Cm[1, i] * v[1] + Cm[2, i] * v[2]
            acc_sum[i] += e - ring_a[head, i]
            ring_a[head, i] = e
        if use_mag:
            mx, my, mz = mag[k, 0], mag[k, 1], mag[k, 2]
            for i in range(3):
                v[i] = R[i, 0] * mx + R[i, 1] * my + R[i, 2] * mz
            # disturbance lower bound of this sample: change of the field's magnitude and dip from the reference
            hs = math.sqrt(v[0] * v[0] + v[1] * v[1])
            dn = math.sqrt(mx * mx + my * my + mz * mz) - mag_norm
            dd = mag_norm * (math.atan2(-v[2], hs) - mag_dip)
            dist = dn * dn + dd * dd
            mag_dist_sum += dist - ring_d[head]
            ring_d[head] = dist
            for i in range(3):
                e = Cm[0, i] * v[0] + Cm[1, i] * v[1] + Cm[2, i] * v[2]
                mag_sum[i] += e - ring_m[head, i]
                ring_m[head, i] = e
        head = head + 1 if head + 1 < n_win else 0
        filled = min(filled + 1, n_win)
        since += 1
        window_done = filled == n_win and since >= stride
        if window_done:
            since = 0
            for i in range(3):
                v[i] = (Cm[i, 0] * acc_sum[0] + Cm[i, 1] * acc_sum[1] + Cm[i, 2] * acc_sum[2]) / n_win
            mag_dist = max(mag_dist_sum / n_win, 0.0)
            # |mean a_lin| >= | |mean R a| - g |: that much unmodelled acceleration is certainly present
            dev = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) - grav
            # innovation-based (Sage-Husa / Mehra) estimate of the unmodelled acceleration variance per axis:
            # E[νᵀν]/2 = tr(HPHᵀ)/2 + r  ⇒  r̂ ← (1 − α) r̂ + α max(νᵀν/2 − tr(HPHᵀ)/2 − σ²/N, 0)
            if acc_alpha > 0.0:
                hph = 0.0  # tr(H P Hᵀ) / 2
                for i in range(2):
                    for j in range(_NE):
                        for m in range(_NE):
                            hph += 0.5 * Ha[i, j] * P[j, m] * Ha[i, m]
                acc_extra = (1.0 - acc_alpha) * acc_extra + acc_alpha * max(
                    0.5 * (v[0] * v[0] + v[1] * v[1]) - hph - acc_var / n_win, 0.0
                )
            # overlapping windows share samples: each update carries 1/overlap of a window's information
            r = (acc_var / n_win + dev * dev + acc_extra) * overlap
            # S = H P Hᵀ + r I
            for i in range(_NE):
                for c in range(2):
                    t = 0.0
                    for m in range(_NE):
                        t += P[i, m] * Ha[c, m]
                    PH[i, c] = t
            s00, s01, s11 = r, 0.0, r
            for m in range(_NE):
                s00 += Ha[0, m] * PH[m, 0]
                s01 += Ha[0, m] * PH[m, 1]
                s11 += Ha[1, m] * PH[m, 1]
            det = s00 * s11 - s01 * s01
            i00, i01, i11 = s11 / det, -s01 / det, s00 / det
            nis = v[0] * (i00 * v[0] + i01 * v[1]) + v[1] * (i01 * v[0] + i11 * v[1])
            if nis > acc_gate and acc_closed < release:
                acc_closed += 1
                stats[S_ACC_REJECTED] += 1.0
            else:
                if nis <= acc_gate:
                    acc_closed = 0  # after a release the gate stays open until an innovation fits again
                stats[S_ACC_NIS_SUM] += nis
                if _CHI2_2_LO <= nis <= _CHI2_2_HI:
                    stats[S_ACC_INSIDE] += 1.0
                for i in range(_NE):
                    ph0, ph1 = PH[i, 0], PH[i, 1]
                    Ka[i, 0] = ph0 * i00 + ph1 * i01
                    Ka[i, 1] = ph0 * i01 + ph1 * i11
                Ka[_DTH + 2, 0] = 0.0  # the accelerometer never corrects heading
                Ka[_DTH + 2, 1] = 0.0
                for i in range(_NE):
                    dx[i] = Ka[i, 0] * v[0] + Ka[i, 1] * v[1]
                joseph_update(P, Ka, Ha, r)
                inject_and_reset(q, b, P, dx)
                left_rotate_inplace(Cm, dx)

        # ---- magnetometer (9D): heading of the horizontal part of the field averaged in the earth frame over the
        # same window (inclination-decoupled), with the field's per-sample disturbance level accumulated alongside
        if use_mag and window_done:
            for i in range(3):
                mag_mean[i] = (Cm[i, 0] * mag_sum[0] + Cm[i, 1] * mag_sum[1] + Cm[i, 2] * mag_sum[2]) / n_win
            psi = heading_of_field(mag_mean, hh, 1e-3 * mag_norm)
            h = hh[0]
            if math.isnan(psi):
                stats[S_MAG_SKIPPED] += 1.0
            else:
                r0 = (mag_var / n_win + mag_dist) / (h * h) * overlap
                for i in range(_NE):
                    t = 0.0
                    for m in range(_NE):
                        t += P[i, m] * Hm[0, m]
                    Km[i, 0] = t  # P Hᵀ for now
                hph = 0.0
                for m in range(_NE):
                    hph += Hm[0, m] * Km[m, 0]
                if mag_alpha > 0.0:
                    mag_extra = (1.0 - mag_alpha) * mag_extra + mag_alpha * max(psi * psi - hph - r0, 0.0)
                r = r0 + mag_extra
                s = hph + r
                nis = psi * psi / s
                if nis > mag_gate and mag_closed < release:
                    mag_closed += 1
                    stats[S_MAG_REJECTED] += 1.0
                else:
                    if nis <= mag_gate:
                        mag_closed = 0
                    stats[S_MAG_NIS_SUM] += nis
                    if _CHI2_1_LO <= nis <= _CHI2_1_HI:
                        stats[S_MAG_INSIDE] += 1.0
                    for i in range(_NE):
                        Km[i, 0] /= s
                    Km[_DTH, 0] = 0.0  # the magnetometer never corrects inclination
                    Km[_DTH + 1, 0] = 0.0
                    for i in range(_NE):
                        dx[i] = Km[i, 0] * psi
                    joseph_update(P, Km, Hm, r)
                    inject_and_reset(q, b, P, dx)
                    left_rotate_inplace(Cm, dx)
        for i in range(4):
            out_q[k, i] = q[i]
        for i in range(3):
            out_b[k, i] = b[i]
