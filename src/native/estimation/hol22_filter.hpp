// Steps of Hol's 22-state EKF (Hol 2008 / Hol et al. 2007): time update (eq. 9), renormalisation, IMU update
// (eq. 11a, 11b) and camera update (eq. 11c), in place on the state x (22,) (hol22_layout.hpp) and the covariance
// P (22, 22) row-major.  The readable reference is the numpy step methods of dualpose.estimation.hol22.Hol22EKF
// (compared with the compiled loop in tests/estimation/test_hol22.py).
#pragma once

#include "../common/quat.hpp"
#include "../common/series.hpp"
#include "eskf_linalg.hpp"
#include "hol22_layout.hpp"
#include "updates.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace dualpose::hol22 {

constexpr int N = DIM;

// R^{be}(q) (the quadratic form, a rotation for unit q, xyzw) into R (3, 3) and ∂R/∂q_i into dR (4, 3, 3).
inline void rot_be_and_derivs(const double* q, double* R, double* dR) {
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    rotmat_xyzw(x, y, z, w, R);
    const double x2 = 2 * x, y2 = 2 * y, z2 = 2 * z, w2 = 2 * w;
    const double d[36] = {
        0.0, y2, z2, y2, -2 * x2, -w2, z2, w2, -2 * x2,   // ∂R/∂x
        -2 * y2, x2, w2, x2, 0.0, z2, -w2, z2, -2 * y2,   // ∂R/∂y
        -2 * z2, -w2, x2, w2, -2 * z2, y2, x2, y2, 0.0,   // ∂R/∂z
        0.0, -z2, y2, z2, 0.0, -x2, -y2, x2, 0.0,         // ∂R/∂w
    };
    std::copy(d, d + 36, dR);
}

// u <- F u for a state vector u stored with the given stride (a column of P: stride N; a row: stride 1), F the
// eq. 9 Jacobian: identity except b^e += T ḃ + T²/2 b̈, ḃ += T b̈ and the quaternion rows q <- L q + WJ ω
// (L = ∂(dq ⊙ q)/∂q, WJ = ∂(dq ⊙ q)/∂ω).
inline void apply_process_jacobian(double* u, std::ptrdiff_t step, double dt, const double* L, const double* WJ) {
    auto at = [&](int i) -> double& { return u[i * step]; };
    const double h = 0.5 * dt * dt;
    for (int i = 0; i < 3; ++i) {
        at(POSITION + i) = at(POSITION + i) + dt * at(VELOCITY + i) + h * at(ACCELERATION + i);
        at(VELOCITY + i) = at(VELOCITY + i) + dt * at(ACCELERATION + i);
    }
    double t[4];
    for (int i = 0; i < 4; ++i) {
        double s = 0.0;
        for (int j = 0; j < 4; ++j) s += L[4 * i + j] * at(QUAT_BE + j);
        for (int j = 0; j < 3; ++j) s += WJ[3 * i + j] * at(ANGULAR_VELOCITY + j);
        t[i] = s;
    }
    for (int i = 0; i < 4; ++i) at(QUAT_BE + i) = t[i];
}

// Eq. 9 over dt seconds in place: constant acceleration / angular velocity, q <- exp(−dt/2 ω) ⊙ q (eq. 10b; the
// Jacobian ∂dq/∂ω as dualpose.estimation.hol22._exp_half, with the shared guarded sinc / dsinc of
// common/series.hpp), P <- F P Fᵀ + diag(qdiag) dt (F applied through its sparsity: columns, then rows).
inline void time_update(double* x, double* P, double dt, const double* qdiag) {
    if (dt <= 0.0) return;
    const double wx = x[ANGULAR_VELOCITY], wy = x[ANGULAR_VELOCITY + 1], wz = x[ANGULAR_VELOCITY + 2];
    const double r = std::sqrt(wx * wx + wy * wy + wz * wz);
    const double th = 0.5 * dt * r;
    const double h = 0.5 * dt;
    const double s = h * sinc(th);            // sin(θ)/|ω|
    const double c2 = h * h * h * dsinc(th);  // (h cos θ − s)/|ω|² = h³ (θ cos θ − sin θ)/θ³, no cancellation
    const double dq[4] = {-s * wx, -s * wy, -s * wz, std::cos(th)};  // exp(−dt/2 ω), xyzw
    const double ax = dq[0], ay = dq[1], az = dq[2], aw = dq[3];
    // ∂(dq ⊙ q)/∂q = Q(dq) (left-multiplication matrix, xyzw)
    const double L[16] = {aw, -az, ay, ax, az, aw, -ax, ay, -ay, ax, aw, az, -ax, -ay, -az, aw};
    // ∂(dq ⊙ q)/∂ω = W(q) ∂dq/∂ω, W the right-multiplication matrix of q
    const double qx = x[QUAT_BE], qy = x[QUAT_BE + 1], qz = x[QUAT_BE + 2], qw = x[QUAT_BE + 3];
    const double W[16] = {qw, qz, -qy, qx, -qz, qw, qx, qy, qy, -qx, qw, qz, -qx, -qy, -qz, qw};
    const double om[3] = {wx, wy, wz};
    double J[12];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) J[3 * i + j] = -((i == j ? s : 0.0) + c2 * om[i] * om[j]);
        J[9 + i] = -0.5 * dt * s * om[i];
    }
    double WJ[12];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 3; ++j) {
            double acc = 0.0;
            for (int k = 0; k < 4; ++k) acc += W[4 * i + k] * J[3 * k + j];
            WJ[3 * i + j] = acc;
        }
    // state
    for (int i = 0; i < 3; ++i) {
        x[POSITION + i] += dt * x[VELOCITY + i] + 0.5 * dt * dt * x[ACCELERATION + i];
        x[VELOCITY + i] += dt * x[ACCELERATION + i];
    }
    const double q[4] = {qx, qy, qz, qw};
    qmul(dq, q, x + QUAT_BE);
    // P <- F P Fᵀ: F on every column (F P), then on every row ((F P) Fᵀ)
    for (int c = 0; c < N; ++c) apply_process_jacobian(P + c, N, dt, L, WJ);
    for (int r = 0; r < N; ++r) apply_process_jacobian(P + r * N, 1, dt, L, WJ);
    for (int i = 0; i < N; ++i) P[i * N + i] += qdiag[i] * dt;
}

// q <- q/|q| and P <- J P Jᵀ with J = I except the quaternion block (I − u uᵀ)/|q|.
inline void normalize(double* x, double* P) {
    constexpr int q = QUAT_BE;
    const double nq = std::sqrt(x[q] * x[q] + x[q + 1] * x[q + 1] + x[q + 2] * x[q + 2] + x[q + 3] * x[q + 3]);
    double u[4], Jq[16], tmp[4];
    for (int i = 0; i < 4; ++i) {
        u[i] = x[q + i] / nq;
        x[q + i] = u[i];
    }
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) Jq[4 * i + j] = ((i == j ? 1.0 : 0.0) - u[i] * u[j]) / nq;
    for (int c = 0; c < N; ++c) {  // quaternion rows <- Jq P[q, :]
        for (int i = 0; i < 4; ++i)
            tmp[i] = Jq[4 * i] * P[q * N + c] + Jq[4 * i + 1] * P[(q + 1) * N + c] + Jq[4 * i + 2] * P[(q + 2) * N + c] +
                     Jq[4 * i + 3] * P[(q + 3) * N + c];
        for (int i = 0; i < 4; ++i) P[(q + i) * N + c] = tmp[i];
    }
    for (int r = 0; r < N; ++r) {  // quaternion columns <- P[:, q] Jqᵀ
        const double* p = P + r * N + q;
        for (int i = 0; i < 4; ++i)
            tmp[i] = Jq[4 * i] * p[0] + Jq[4 * i + 1] * p[1] + Jq[4 * i + 2] * p[2] + Jq[4 * i + 3] * p[3];
        for (int i = 0; i < 4; ++i) P[r * N + q + i] = tmp[i];
    }
}

// Accelerometer + gyroscope update (eq. 11a, 11b) in place; returns the NIS (6 dof).  accel, gyro (3,) the
// measurements, gravity (3,) g^e, R_imu (6, 6) the measurement noise.
inline double imu_update(double* x, double* P, const double* accel, const double* gyro, const double* gravity,
                         const double* R_imu) {
    constexpr int NR = N + 1;  // right-hand sides of the solve: the columns of H P, then ν
    double R[9], dR[36], H[6 * N] = {}, nu[6], d[3];
    rot_be_and_derivs(x + QUAT_BE, R, dR);
    for (int i = 0; i < 3; ++i) d[i] = x[ACCELERATION + i] - gravity[i];
    for (int i = 0; i < 3; ++i) {
        double h = x[ACCEL_BIAS + i];
        for (int j = 0; j < 3; ++j) {
            h += R[3 * i + j] * d[j];
            H[i * N + ACCELERATION + j] = R[3 * i + j];
        }
        for (int k = 0; k < 4; ++k) {
            double acc = 0.0;
            for (int j = 0; j < 3; ++j) acc += dR[9 * k + 3 * i + j] * d[j];
            H[i * N + QUAT_BE + k] = acc;
        }
        H[i * N + ACCEL_BIAS + i] = 1.0;
        nu[i] = accel[i] - h;
        H[(3 + i) * N + ANGULAR_VELOCITY + i] = 1.0;
        H[(3 + i) * N + GYRO_BIAS + i] = 1.0;
        nu[3 + i] = gyro[i] - (x[ANGULAR_VELOCITY + i] + x[GYRO_BIAS + i]);
    }
    // H P (H has at most 8 nonzeros per row), S = (H P) Hᵀ + R_imu
    double HP[6 * N], S[36], X[6 * NR];
    mul_sparse_left<6, N, N>(H, P, HP);
    for (int i = 0; i < 6; ++i)
        for (int c = 0; c < 6; ++c) {
            double s = 0.0;
            for (int j = 0; j < N; ++j) s += HP[i * N + j] * H[c * N + j];
            S[6 * i + c] = s + R_imu[6 * i + c];
        }
    for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < N; ++j) X[i * NR + j] = HP[i * N + j];
        X[i * NR + N] = nu[i];
    }
    int piv[6];
    lu_factor(S, 6, piv);        // S is positive definite (R_imu is): no zero pivot
    lu_solve(S, piv, 6, X, NR);  // X = S⁻¹ [H P, ν]
    double K[N * 6];             // K = (S⁻¹ H P)ᵀ = P Hᵀ S⁻¹
    double nis = 0.0;
    for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < N; ++j) K[j * 6 + i] = X[i * NR + j];
        nis += nu[i] * X[i * NR + N];
    }
    for (int j = 0; j < N; ++j) {
        double s = 0.0;
        for (int i = 0; i < 6; ++i) s += K[j * 6 + i] * nu[i];
        x[j] += s;
    }
    joseph_rows<N, 6>(P, K, H, R_imu);
    normalize(x, P);
    return nis;
}

// Work arrays of camera_update, reused from frame to frame.
struct CameraWork {
    std::vector<double> h, H, depth, s2;
    void resize(std::int64_t m) {
        h.resize(2 * m);
        H.assign(2 * N * m, 0.0);
        depth.resize(m);
        s2.resize(m);
    }
};

// Eq. 11c for one frame of m correspondences in place: h = [−f I₂, zⁱ] R^{cb}(R^{be}(z^e − b^e) − c^b) (measured 0),
// noise (max(Z, depth_floor) σ_px)² I₂, linearised at the predicted state, χ²-gated in order of prior NIS
// (sequential_gated_update).  pixels (m, 2), points (m, 3), intr = (fx, fy, cx, cy), p_bc (3,), Rcb (3, 3);
// nis_out (m,), acc_out (m,) receive the NIS and 1/0.
inline void camera_update(double* x, double* P, const double* pixels, const double* points, std::int64_t m,
                          const double* intr, const double* p_bc, const double* Rcb, double depth_floor,
                          double sigma_px, double gate, double* nis_out, std::int64_t* acc_out, CameraWork& w) {
    const double fx = intr[0], fy = intr[1], cx = intr[2], cy = intr[3];
    double R[9], dR[36], AR[6], d[3], zb[3], zc[3];
    rot_be_and_derivs(x + QUAT_BE, R, dR);
    w.resize(m);
    for (std::int64_t k = 0; k < m; ++k) {
        double* Hk = w.H.data() + k * 2 * N;
        for (int i = 0; i < 3; ++i) d[i] = points[3 * k + i] - x[POSITION + i];
        for (int i = 0; i < 3; ++i) zb[i] = R[3 * i] * d[0] + R[3 * i + 1] * d[1] + R[3 * i + 2] * d[2] - p_bc[i];
        for (int i = 0; i < 3; ++i) zc[i] = Rcb[3 * i] * zb[0] + Rcb[3 * i + 1] * zb[1] + Rcb[3 * i + 2] * zb[2];
        const double u = pixels[2 * k] - cx, v = pixels[2 * k + 1] - cy;
        w.h[2 * k] = -fx * zc[0] + u * zc[2];
        w.h[2 * k + 1] = -fy * zc[1] + v * zc[2];
        w.depth[k] = zc[2];
        for (int j = 0; j < 3; ++j) {
            AR[j] = -fx * Rcb[j] + u * Rcb[6 + j];
            AR[3 + j] = -fy * Rcb[3 + j] + v * Rcb[6 + j];
        }
        for (int i = 0; i < 2; ++i) {
            for (int j = 0; j < 3; ++j)
                Hk[i * N + POSITION + j] = -(AR[3 * i] * R[j] + AR[3 * i + 1] * R[3 + j] + AR[3 * i + 2] * R[6 + j]);
            for (int q = 0; q < 4; ++q) {
                double acc = 0.0;
                for (int a = 0; a < 3; ++a) {
                    const double* g = dR + 9 * q + 3 * a;
                    acc += AR[3 * i + a] * (g[0] * d[0] + g[1] * d[1] + g[2] * d[2]);
                }
                Hk[i * N + QUAT_BE + q] = acc;
            }
        }
    }
    for (std::int64_t k = 0; k < m; ++k) {
        const double sd = std::max(w.depth[k], depth_floor) * sigma_px;
        w.s2[k] = sd * sd;
        w.h[2 * k] = -w.h[2 * k];  // residual: measured 0 minus predicted h
        w.h[2 * k + 1] = -w.h[2 * k + 1];
    }
    double dx[N] = {};
    sequential_gated_update<N>(P, w.h.data(), w.H.data(), w.s2.data(), w.depth.data(), gate, dx, nis_out, acc_out,
                               m);
    for (int i = 0; i < N; ++i) x[i] += dx[i];
    normalize(x, P);
}

}  // namespace dualpose::hol22
