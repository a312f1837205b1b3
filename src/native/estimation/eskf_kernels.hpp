// Kernels of the error-state EKF (Solà 2017 §5-7) and of its camera measurement model, ports of the numba kernels
// that dualpose.estimation.eskf documents.  Layouts in eskf_layout.hpp: nominal x (16,), error δx (15,) with the
// local attitude error q = q̂ ⊗ Exp(δθ), covariance P (15, 15), noise (6,) = continuous-time variances
// [σ_g², σ_a², σ_bg², σ_ba²] and the squared relative scale-factor uncertainties [ε_g², ε_a²], camera intr (4,) = [fx, fy, cx, cy], q_bc (4, xyzw), p_bc (3,).
// Everything works in place on x and P.
#pragma once

#include "../common/quat.hpp"
#include "eskf_layout.hpp"
#include "eskf_linalg.hpp"
#include "updates.hpp"

#include <cstdint>
#include <vector>

namespace dualpose::eskf {

// Propagate the nominal state over dt with constant IMU input (Solà eq. 260) and write the error-state transition
// of the step (Solà eq. 269) to F (15, 15): δx⁻_{k+1} ≈ F δx⁺_k; w2, f2 <- |ω|², |f|² of the bias-corrected input.
inline void step_transition(double* x, const double* gyro, const double* accel, double dt, const double* gravity,
                            double* F, double& w2, double& f2) {
    double R[9];
    rotmat_xyzw(x[Q], x[Q + 1], x[Q + 2], x[Q + 3], R);
    const double wx = gyro[0] - x[BG], wy = gyro[1] - x[BG + 1], wz = gyro[2] - x[BG + 2];
    double ab[3];
    for (int i = 0; i < 3; ++i) ab[i] = accel[i] - x[BA + i];
    // --- error-state transition F (Solà eq. 269), written sparsely
    for (int i = 0; i < NE * NE; ++i) F[i] = 0.0;
    for (int i = 0; i < NE; ++i) F[i * NE + i] = 1.0;
    for (int i = 0; i < 3; ++i) F[(DP + i) * NE + DV + i] = dt;
    // -R [a]x dt
    const double Ax[9] = {0.0, -ab[2], ab[1], ab[2], 0.0, -ab[0], -ab[1], ab[0], 0.0};
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            const double ra = R[3 * i] * Ax[j] + R[3 * i + 1] * Ax[3 + j] + R[3 * i + 2] * Ax[6 + j];
            F[(DV + i) * NE + DTH + j] = -ra * dt;
            F[(DV + i) * NE + DBA + j] = -R[3 * i + j] * dt;
        }
    // R{ω dt}ᵀ
    double dq[4] = {0.0, 0.0, 0.0, 1.0};
    quat_mul_exp_inplace(dq, wx * dt, wy * dt, wz * dt);
    double Rw[9];
    rotmat_xyzw(dq[0], dq[1], dq[2], dq[3], Rw);
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) F[(DTH + i) * NE + DTH + j] = Rw[3 * j + i];
        F[(DTH + i) * NE + DBG + i] = -dt;
    }
    // --- nominal state; the specific force is rotated with the mean of the start and end attitudes (trapezoid),
    // which removes the first-order error ½ ω × a dt² per step of using the start attitude alone
    quat_mul_exp_inplace(x + Q, wx * dt, wy * dt, wz * dt);
    double R1[9];
    rotmat_xyzw(x[Q], x[Q + 1], x[Q + 2], x[Q + 3], R1);
    for (int i = 0; i < 3; ++i) {
        double s = 0.0;
        for (int k = 0; k < 3; ++k) s += (R[3 * i + k] + R1[3 * i + k]) * ab[k];
        const double aw = 0.5 * s + gravity[i];
        x[P + i] += x[V + i] * dt + 0.5 * aw * dt * dt;
        x[V + i] += aw * dt;
    }
    w2 = wx * wx + wy * wy + wz * wz;
    f2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
}

// P += Q dt (Solà eq. 262) for noise (6,); the scale-factor terms ε² |ω|² · 1 s and ε_a² |f|² · 1 s add to the
// densities (model error proportional to the signal, as a white noise of 1 s correlation time).
inline void add_process_noise(double* Pm, const double* noise, double dt, double w2, double f2) {
    const double q_th = (noise[0] + noise[4] * w2) * dt, q_v = (noise[1] + noise[5] * f2) * dt;
    for (int i = 0; i < 3; ++i) {
        Pm[(DV + i) * (NE + 1)] += q_v;
        Pm[(DTH + i) * (NE + 1)] += q_th;
        Pm[(DBG + i) * (NE + 1)] += noise[2] * dt;
        Pm[(DBA + i) * (NE + 1)] += noise[3] * dt;
    }
}

// Propagate nominal state and covariance over dt with constant IMU input (Solà eq. 260, 269-270) and write the
// error-state transition of the step (Solà eq. 269) to F (15, 15): P = F P Fᵀ + Q.
inline void predict_transition(double* x, double* Pm, const double* gyro, const double* accel, double dt,
                               const double* gravity, const double* noise, double* F) {
    double w2, f2;
    step_transition(x, gyro, accel, dt, gravity, F, w2, f2);
    congruence_sparse<NE>(F, Pm);
    add_process_noise(Pm, noise, dt, w2, f2);
}

// Reprojection residual r = pixel − π(R_bcᵀ(R_wbᵀ(z − p) − p_bc)) (2,) and H = ∂π/∂δx (2, 15); returns the depth Z
// of the point in the camera frame (the model is valid only for Z > 0).  R = R_wb of x's attitude, Rbc = R_bc
// (3, 3) row-major, computed once per frame by camera_batch.
inline double camera_residual_jacobian(const double* x, const double* R, const double* Rbc, const double* intr,
                                       const double* p_bc, const double* pixel, const double* point, double* r,
                                       double* H) {
    double d[3], pb[3], pc[3];
    for (int i = 0; i < 3; ++i) d[i] = point[i] - x[P + i];
    for (int i = 0; i < 3; ++i) pb[i] = R[i] * d[0] + R[3 + i] * d[1] + R[6 + i] * d[2];  // R_wbᵀ (z − p)
    for (int i = 0; i < 3; ++i) pb[i] -= p_bc[i];
    for (int i = 0; i < 3; ++i) pc[i] = Rbc[i] * pb[0] + Rbc[3 + i] * pb[1] + Rbc[6 + i] * pb[2];
    for (int i = 0; i < 3; ++i) pb[i] += p_bc[i];
    const double X = pc[0], Y = pc[1], Z = pc[2];
    const double fx = intr[0], fy = intr[1];
    const double iz = 1.0 / Z;
    r[0] = pixel[0] - (fx * X * iz + intr[2]);
    r[1] = pixel[1] - (fy * Y * iz + intr[3]);
    const double J[6] = {fx * iz, 0.0, -fx * X * iz * iz, 0.0, fy * iz, -fy * Y * iz * iz};
    double JB[6], JR[6];  // ∂π/∂p_b = J R_bcᵀ; ∂π/∂(z − p) in world = JB R_wbᵀ
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 3; ++j)
            JB[3 * i + j] = J[3 * i] * Rbc[3 * j] + J[3 * i + 1] * Rbc[3 * j + 1] + J[3 * i + 2] * Rbc[3 * j + 2];
    for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 3; ++j)
            JR[3 * i + j] = JB[3 * i] * R[3 * j] + JB[3 * i + 1] * R[3 * j + 1] + JB[3 * i + 2] * R[3 * j + 2];
    for (int i = 0; i < 2; ++i) {
        double* h = H + i * NE;
        for (int j = 0; j < NE; ++j) h[j] = 0.0;
        for (int j = 0; j < 3; ++j) h[DP + j] = -JR[3 * i + j];
        // ∂p_b/∂δθ = [p_b]x
        const double* jb = JB + 3 * i;
        h[DTH] = jb[1] * pb[2] - jb[2] * pb[1];
        h[DTH + 1] = jb[2] * pb[0] - jb[0] * pb[2];
        h[DTH + 2] = jb[0] * pb[1] - jb[1] * pb[0];
    }
    return Z;
}

// camera_residual_jacobian for every row: pixels (m, 2), points (m, 3) -> r (m, 2), H (m, 2, 15), depth (m,).
inline void camera_batch(const double* x, const double* intr, const double* q_bc, const double* p_bc,
                         const double* pixels, const double* points, std::int64_t m, double* r, double* H,
                         double* depth) {
    double R[9], Rbc[9];
    rotmat_xyzw(x[Q], x[Q + 1], x[Q + 2], x[Q + 3], R);
    rotmat_xyzw(q_bc[0], q_bc[1], q_bc[2], q_bc[3], Rbc);
    for (std::int64_t k = 0; k < m; ++k)
        depth[k] = camera_residual_jacobian(x, R, Rbc, intr, p_bc, pixels + 2 * k, points + 3 * k, r + 2 * k,
                                            H + k * 2 * NE);
}

// Inject δx into the nominal state and apply the reset Jacobian G = diag(I, I, I − [½δθ]×, I, I)
// (Solà eq. 285-287): P <- G P Gᵀ.
inline void inject_reset(double* x, double* Pm, const double* dx) {
    for (int i = 0; i < 3; ++i) {
        x[P + i] += dx[DP + i];
        x[V + i] += dx[DV + i];
        x[BG + i] += dx[DBG + i];
        x[BA + i] += dx[DBA + i];
    }
    quat_mul_exp_inplace(x + Q, dx[DTH], dx[DTH + 1], dx[DTH + 2]);
    double G[NE * NE] = {};
    for (int i = 0; i < NE; ++i) G[i * NE + i] = 1.0;
    const double hx = 0.5 * dx[DTH], hy = 0.5 * dx[DTH + 1], hz = 0.5 * dx[DTH + 2];
    constexpr int a = DTH, b = DTH + 1, c = DTH + 2;
    G[a * NE + b] = hz;
    G[a * NE + c] = -hy;
    G[b * NE + a] = -hz;
    G[b * NE + c] = hx;
    G[c * NE + a] = hy;
    G[c * NE + b] = -hx;
    congruence_sparse<NE>(G, Pm);
}

// Sequential χ²-gated update with the m point correspondences of one frame, each linearised at the predicted
// nominal state (so the sequence equals one batch update of the accepted ones) and taken in increasing order of
// prior NIS (sequential_gated_update); then injection and reset.  nis_out (m,), accepted_out (m,) 1/0; returns the
// number accepted.
inline std::int64_t update_points(double* x, double* Pm, const double* intr, const double* q_bc, const double* p_bc,
                                  const double* pixels, const double* points, std::int64_t m, double sigma_px,
                                  double gate, double* nis_out, std::int64_t* accepted_out) {
    std::vector<double> work(static_cast<std::size_t>(m) * (2 + 2 * NE + 2));
    double* r = work.data();
    double* H = r + 2 * m;
    double* depth = H + 2 * NE * m;
    double* s2 = depth + m;
    camera_batch(x, intr, q_bc, p_bc, pixels, points, m, r, H, depth);
    for (std::int64_t k = 0; k < m; ++k) s2[k] = sigma_px * sigma_px;
    double dx[NE] = {};
    const std::int64_t n_acc =
        sequential_gated_update<NE>(Pm, r, H, s2, depth, gate, dx, nis_out, accepted_out, m);
    inject_reset(x, Pm, dx);
    return n_acc;
}

}  // namespace dualpose::eskf
