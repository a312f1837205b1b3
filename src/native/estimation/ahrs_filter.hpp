// Steps of the orientation-only error-state filter (AHRS): predict, Joseph update, injection and reset.
//
// Nominal state q (4,) xyzw (body -> earth, ENU) and gyroscope bias b (3,) rad/s; error state δx = [δθ, δb] (6,)
// with a global attitude error q = Exp(δθ) ⊗ q̂ (ahrs_layout.hpp); P (6, 6) row-major.  Used by the whole-recording
// loop (ahrs_run.cpp) and, one sample at a time, by dualpose.estimation.ahrs.estimator.AhrsFilter.
#pragma once

#include "../common/quat.hpp"
#include "../common/series.hpp"
#include "ahrs_layout.hpp"
#include "eskf_linalg.hpp"
#include "updates.hpp"

#include <cmath>

namespace dualpose::ahrs {

constexpr int NE = ERROR_DIM;

// q <- normalize(Exp(r) ⊗ q) (global error injection), evaluated as q ⊗ Exp(R(q)ᵀ r) (the same rotation applied in
// the body frame) with the error-state filters' local injection quat_mul_exp_inplace.
inline void exp_mul_quat_inplace(double* q, double rx, double ry, double rz) {
    const double x = -q[0], y = -q[1], z = -q[2], w = q[3];  // q*, whose rotation is R(q)ᵀ
    const double ax = y * rz - z * ry + w * rx, ay = z * rx - x * rz + w * ry, az = x * ry - y * rx + w * rz;
    const double bx = y * az - z * ay, by = z * ax - x * az, bz = x * ay - y * ax;
    quat_mul_exp_inplace(q, rx + 2.0 * bx, ry + 2.0 * by, rz + 2.0 * bz);
}

// P <- (I − K H) P (I − K H)ᵀ + r K Kᵀ (symmetrised) for a measurement of dimension M with isotropic noise r:
// the shared Joseph form joseph_rows (updates.hpp) with R = r I.  K (6, M), H (M, 6) row-major.  Valid for any gain
// K (here: optimal gains with rows zeroed).
template <int M>
inline void joseph_update(double* P, const double* K, const double* H, double r) {
    double R[M * M] = {};
    for (int i = 0; i < M; ++i) R[i * M + i] = r;
    joseph_rows<NE, M>(P, K, H, R);
}

// Inject δx (6,) into q and b and apply the reset Jacobian G = diag(I + [½δθ]×, I) to P: P <- G P Gᵀ.  For the
// global error q = Exp(δθ) ⊗ q̂ the reset Jacobian is I + [½δθ]× (Solà 2017, eq. 287 with the sign of the global
// error).
inline void inject_and_reset(double* q, double* b, double* P, const double* dx) {
    constexpr int a = D_ATTITUDE, c = D_ATTITUDE + 1, e = D_ATTITUDE + 2;
    exp_mul_quat_inplace(q, dx[a], dx[c], dx[e]);
    for (int i = 0; i < 3; ++i) b[i] += dx[D_GYRO_BIAS + i];
    const double hx = 0.5 * dx[a], hy = 0.5 * dx[c], hz = 0.5 * dx[e];
    double G[NE * NE] = {};
    for (int i = 0; i < NE; ++i) G[i * NE + i] = 1.0;
    G[a * NE + c] = -hz;
    G[a * NE + e] = hy;
    G[c * NE + a] = hz;
    G[c * NE + e] = -hx;
    G[e * NE + a] = -hy;
    G[e * NE + c] = hx;
    congruence_sparse<NE>(G, P);
}

// C <- Exp(δθ) C for a rotation matrix C (3, 3) row-major and δθ = dx[0:3]: Rodrigues' formula
// Exp(δθ) = I + sinc(a) [δθ]× + cosc2(a) [δθ]×², a = |δθ|, with the guarded series of common/series.hpp.
inline void left_rotate_inplace(double* C, const double* dx) {
    const double x = dx[0], y = dx[1], z = dx[2];
    const double a = std::sqrt(x * x + y * y + z * z);
    const double s = sinc(a), c = cosc2(a);
    double E[9];
    E[0] = 1.0 - c * (y * y + z * z);
    E[4] = 1.0 - c * (x * x + z * z);
    E[8] = 1.0 - c * (x * x + y * y);
    E[1] = c * x * y - s * z;
    E[3] = c * x * y + s * z;
    E[2] = c * x * z + s * y;
    E[6] = c * x * z - s * y;
    E[5] = c * y * z - s * x;
    E[7] = c * y * z + s * x;
    double Cn[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Cn[i * 3 + j] = E[i * 3] * C[j] + E[i * 3 + 1] * C[3 + j] + E[i * 3 + 2] * C[6 + j];
    for (int k = 0; k < 9; ++k) C[k] = Cn[k];
}

// Second-order Butterworth low-pass of DC group delay tau (s) at sampling interval dt (s), by the bilinear transform
// with pre-warped cut-off fc = √2 / (2π tau) (the discretisation VQF uses for its inertial-frame accelerometer
// filter, Laidig & Seel 2023, with its time constant tau): H(z) = b0 (1 + 2z⁻¹ + z⁻²) / (1 + a1 z⁻¹ + a2 z⁻²).
// A continuous 2nd-order Butterworth of cut-off ωc has DC group delay √2/ωc = tau and noise-equivalent bandwidth
// ωc / (4√2) = 1 / (4 tau): the same delay (T/2) and the same white-noise averaging (T samples' worth) as a boxcar
// mean over T = 2 tau, with a response to a sinusoid of frequency f that falls as (fc/f)² instead of 1/(π f T).
struct LowPass2 {
    double b0, a1, a2;
};
inline LowPass2 butterworth_lowpass(double tau, double dt) {
    constexpr double pi = 3.14159265358979323846;
    const double fc = std::sqrt(2.0) / (2.0 * pi * tau);
    const double c = std::tan(pi * fc * dt);
    const double d = c * c + std::sqrt(2.0) * c + 1.0;
    return LowPass2{c * c / d, 2.0 * (c * c - 1.0) / d, (1.0 - std::sqrt(2.0) * c + c * c) / d};
}

// One sample x through the filter (transposed direct form II, state z (2,)); returns the output.  start: set z to
// the steady state of a constant input x first (output = x).
inline double lowpass_step(const LowPass2& f, double* z, double x, bool start) {
    if (start) {
        z[0] = (1.0 - f.b0) * x;
        z[1] = (f.b0 - f.a2) * x;
    }
    const double y = f.b0 * x + z[0];
    z[0] = 2.0 * f.b0 * x - f.a1 * y + z[1];
    z[1] = f.b0 * x - f.a2 * y;
    return y;
}

// Heading of an earth-frame field vector m_e (3,): atan2(m_x, m_y) (rad, 0 = north, positive towards east); *h
// receives the horizontal magnitude.  NaN when the horizontal part is below eps.
inline double heading_of_field(const double* m_e, double* h, double eps) {
    *h = std::sqrt(m_e[0] * m_e[0] + m_e[1] * m_e[1]);
    if (*h < eps) return NAN;
    return std::atan2(m_e[0], m_e[1]);
}

// One predict in place with the gyroscope sample (gx, gy, gz) (rad/s) over dt (s): q <- q ⊗ Exp((ω − b) dt),
// P <- F P Fᵀ + Q with F = [[I, −R dt], [0, I]] (global attitude error, Solà 2017 §5) and
// Q = diag((σ_g² + ε²|ω − b|²) dt I, σ_b² dt I) (gyr_var = σ_g², bias_var = σ_b², scale_var = ε² · 1 s).
// R (9,) receives the rotation matrix of q before the step.
inline void predict(double* q, const double* b, double* P, double gx, double gy, double gz, double dt,
                    double gyr_var, double bias_var, double scale_var, double* R) {
    constexpr int T = D_ATTITUDE, B = D_GYRO_BIAS;
    const double wx = gx - b[0], wy = gy - b[1], wz = gz - b[2];
    rotmat_xyzw(q[0], q[1], q[2], q[3], R);
    quat_mul_exp_inplace(q, wx * dt, wy * dt, wz * dt);
    // P <- F P Fᵀ written blockwise: P = [[A, B], [Bᵀ, C]]
    // A' = A − dt (R Bᵀ + B Rᵀ) + dt² R C Rᵀ, B' = B − dt R C, C' = C
    double RP[9];  // R C
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double s = 0.0;
            for (int m = 0; m < 3; ++m) s += R[i * 3 + m] * P[(B + m) * NE + B + j];
            RP[i * 3 + j] = s;
        }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            double s = 0.0;
            for (int m = 0; m < 3; ++m)
                // (R Bᵀ)[i, j] + (B Rᵀ)[i, j] with B[i, m] = P[T + i, B + m]
                s += R[i * 3 + m] * P[(T + j) * NE + B + m] + P[(T + i) * NE + B + m] * R[j * 3 + m] -
                     dt * RP[i * 3 + m] * R[j * 3 + m];
            P[(T + i) * NE + T + j] -= dt * s;
        }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            P[(T + i) * NE + B + j] -= dt * RP[i * 3 + j];
            P[(B + j) * NE + T + i] = P[(T + i) * NE + B + j];
        }
    // white rate noise plus the rate-proportional error of scale factor and axis misalignment
    const double q_theta = (gyr_var + scale_var * (wx * wx + wy * wy + wz * wz)) * dt;
    for (int i = 0; i < 3; ++i) {
        P[(T + i) * NE + T + i] += q_theta;
        P[(B + i) * NE + B + i] += bias_var * dt;
    }
}

}  // namespace dualpose::ahrs
