// Kernels of the Rauch–Tung–Striebel smoother (linear, and over the error-state filter's nodes), ports of the numba
// kernels that dualpose.estimation.smoother documents.  Layouts in eskf_layout.hpp: nominal state (16,), error
// state (15,) with the local (right) attitude error q = q̂ ⊗ Exp(δθ); the covariance of an error state is expressed
// in the tangent space of the nominal state it belongs to.  Derivation: docs/fusion.md, "Offline smoothing (RTS)".
#pragma once

#include "../common/kutil.hpp"
#include "../common/lie.hpp"
#include "../common/quat.hpp"
#include "../common/series.hpp"
#include "eskf_layout.hpp"
#include "eskf_linalg.hpp"

#include <cstdint>
#include <vector>

namespace dualpose::smoother {

using namespace eskf;

// out (15,) = x ⊟ y, the error state that takes the nominal y (16,) to x (16,): x = y ⊞ out with
// δθ = Log(q_y* ⊗ q_x) (rotation vector, angle in [0, π]).
inline void boxminus(const double* x, const double* y, double* out) {
    for (int i = 0; i < 3; ++i) {
        out[DP + i] = x[P + i] - y[P + i];
        out[DV + i] = x[V + i] - y[V + i];
        out[DBG + i] = x[BG + i] - y[BG + i];
        out[DBA + i] = x[BA + i] - y[BA + i];
    }
    store(out + DTH, rotvec_of_quat(qmul(Quat{-y[Q], -y[Q + 1], -y[Q + 2], y[Q + 3]}, load4(x + Q))));
}

// out (16,) = x ⊞ δx: p + δp, v + δv, q ⊗ Exp(δθ), b_g + δb_g, b_a + δb_a.
inline void boxplus(const double* x, const double* dx, double* out) {
    for (int i = 0; i < 3; ++i) {
        out[P + i] = x[P + i] + dx[DP + i];
        out[V + i] = x[V + i] + dx[DV + i];
        out[BG + i] = x[BG + i] + dx[DBG + i];
        out[BA + i] = x[BA + i] + dx[DBA + i];
    }
    for (int i = 0; i < 4; ++i) out[Q + i] = x[Q + i];
    quat_mul_exp_inplace(out + Q, dx[DTH], dx[DTH + 1], dx[DTH + 2]);
}

// out (3, 3) = the SO(3) right Jacobian J_r(φ) (inverse = 0) or J_r⁻¹(φ) (inverse = 1);
// J_r(φ) = J_l(−φ) (Solà 2017 eq. 183, 186): Exp(φ + δφ) ≈ Exp(φ) Exp(J_r(φ) δφ).
inline void right_jacobian(const double* phi, double inverse, double* out) {
    const double x = phi[0], y = phi[1], z = phi[2];
    const So3Coeffs k = so3_coeffs(norm3(x, y, z), inverse);
    so3_fill(-x, -y, -z, k.a, k.b, k.c, out, 3);
}

// S <- J S Jᵀ in place for J = diag(I₆, A, I₆) (15, 15): a change of attitude chart (A (3, 3)); the changed
// rows/columns are symmetrised.
inline void congruence_attitude(double* S, const double* A) {
    constexpr int n = NE;
    double rows[3 * n];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < n; ++j) {
            double s = 0.0;
            for (int k = 0; k < 3; ++k) s += A[3 * i + k] * S[(DTH + k) * n + j];
            rows[i * n + j] = s;
        }
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < n; ++j) S[(DTH + i) * n + j] = rows[i * n + j];
    for (int j = 0; j < n; ++j) {
        double* s = S + j * n + DTH;
        const double c0 = s[0] * A[0] + s[1] * A[1] + s[2] * A[2];
        const double c1 = s[0] * A[3] + s[1] * A[4] + s[2] * A[5];
        const double c2 = s[0] * A[6] + s[1] * A[7] + s[2] * A[8];
        s[0] = c0;
        s[1] = c1;
        s[2] = c2;
    }
    for (int i = DTH; i < DTH + 3; ++i)
        for (int j = 0; j < n; ++j) {
            const double s = 0.5 * (S[i * n + j] + S[j * n + i]);
            S[i * n + j] = s;
            S[j * n + i] = s;
        }
}

enum class Status { ok, not_finite, singular };

// Work arrays of rts_step for dimension n.
struct StepWork {
    int n;
    std::vector<double> LU, Gt, GD;
    std::vector<int> piv;
    explicit StepWork(int n_) : n(n_), LU(n_ * n_), Gt(n_ * n_), GD(n_ * n_), piv(n_) {}
};

// One backward RTS step in error coordinates (Särkkä 2013 Thm 8.2; Solà 2017 §7 charts).
//
// P_post (n, n) filtered covariance at node i, P_prior_next (n, n) predicted covariance at i + 1, F (n, n)
// transition i → i + 1, mu_next (n,) / S_next (n, n) the smoothed mean / covariance at i + 1 relative to the
// prediction at i + 1.  Writes the smoothed mean relative to the filtered one at i, d_out (n,) = G mu_next, and its
// covariance S_out = P_post + G (S_next − P_prior_next) Gᵀ with the gain G = P_post Fᵀ P_prior_next⁻¹ obtained by
// a linear solve (P_prior_next Gᵀ = F P_post, LU with partial pivoting as numpy.linalg.solve), symmetrised.
// N > 0 fixes n = N at compile time (the error-state filter's 15), N = 0 takes w.n.
template <int N = 0>
inline Status rts_step(const double* P_post, const double* P_prior_next, const double* F, const double* mu_next,
                       const double* S_next, double* d_out, double* S_out, StepWork& w) {
    const int n = N > 0 ? N : w.n;
    double* LU = w.LU.data();
    double* Gt = w.Gt.data();
    double* GD = w.GD.data();
    mul_sparse_left<N, N, N>(F, P_post, Gt, n, n, n);  // Gt <- F P_post
    std::copy(P_prior_next, P_prior_next + n * n, LU);
    if (!all_finite(LU, n * n) || !all_finite(Gt, n * n)) return Status::not_finite;
    if (!lu_factor<N>(LU, n, w.piv.data())) return Status::singular;
    lu_solve<N, N>(LU, w.piv.data(), n, Gt, n);
    for (int i = 0; i < n; ++i) {  // d = G mu = Gtᵀ mu
        double s = 0.0;
        for (int j = 0; j < n; ++j) s += Gt[j * n + i] * mu_next[j];
        d_out[i] = s;
    }
    double* D = LU;  // the factors are no longer needed: D = S_next − P_prior_next
    for (int i = 0; i < n * n; ++i) D[i] = S_next[i] - P_prior_next[i];
    for (int i = 0; i < n; ++i) {  // GD = G D
        double* o = GD + i * n;
        for (int j = 0; j < n; ++j) o[j] = 0.0;
        for (int k = 0; k < n; ++k) {
            const double g = Gt[k * n + i];
            for (int j = 0; j < n; ++j) o[j] += g * D[k * n + j];
        }
    }
    for (int i = 0; i < n; ++i) {  // S_out = P_post + GD Gt
        double* o = S_out + i * n;
        for (int j = 0; j < n; ++j) o[j] = 0.0;
        for (int k = 0; k < n; ++k) {
            const double g = GD[i * n + k];
            for (int j = 0; j < n; ++j) o[j] += g * Gt[k * n + j];
        }
        for (int j = 0; j < n; ++j) o[j] = P_post[i * n + j] + o[j];
    }
    symmetrize<N>(S_out, n);
    return Status::ok;
}

// The K-step stacks of the backward passes: posterior / prior means (K, nx), covariances (K, n, n), transitions
// F (K, n, n) with F[i] the transition i → i + 1 (F[K − 1] unused), outputs x_smooth (K, nx), P_smooth (K, n, n).
struct Stacks {
    std::int64_t K;
    int nx, n;
    const double *x_post, *P_post, *x_prior, *P_prior, *F;
    double *x_smooth, *P_smooth;
};

// Linear RTS over K steps (nx == n).
Status rts_linear(const Stacks& s);

// Error-state RTS over the K nodes of the error-state filter (nx = 16, n = 15).  For i = K − 2 … 0: the smoothed
// state at i + 1 is written in the chart of the prediction there, μ = x^s_{i+1} ⊟ x⁻_{i+1},
// Σ = J_r⁻¹(μ_θ) P^s_{i+1} J_r⁻ᵀ(μ_θ) (attitude block); one linear step rts_step gives δ and S in the chart of the
// filtered state x⁺_i; then x^s_i = x⁺_i ⊞ δ and P^s_i = J_r(δ_θ) S J_rᵀ(δ_θ) (the smoother's reset, of which the
// filter's G = I − [½δθ]× is the first-order form).
Status rts_error_state(const Stacks& s);

}  // namespace dualpose::smoother
