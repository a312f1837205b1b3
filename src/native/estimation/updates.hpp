// Kalman measurement updates shared by the error-state filter (Solà 2017 §6-7) and Hol's 22-state filter (Hol 2008
// Algorithm 1): the Joseph-form covariance update and the χ²-gated sequential update of two-row measurements.
//
// Matrices are row-major contiguous doubles; N (the state dimension) is a compile-time constant of the caller
// (15 for the error-state filter, 22 for Hol22) so that the fixed-size loops unroll and vectorise.  Plain + - * /
// in the order of the numba kernels they replace (no fast-math, no FMA contraction: see CMakeLists.txt).
#pragma once

#include "eskf_linalg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

namespace dualpose {

// Joseph-form covariance update  P <- (I − K H) P (I − K H)ᵀ + K R Kᵀ  in place, then exactly symmetrised
// (Bucy & Joseph 1968; Solà 2017 eq. 276).  P (N, N), K (N, m), H (m, N), R (m, m).
template <int N>
inline void joseph(double* P, const double* K, const double* H, const double* R, int m) {
    double A[N * N], AP[N * N];
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) {
            double kh = 0.0;
            for (int l = 0; l < m; ++l) kh += K[i * m + l] * H[l * N + j];
            A[i * N + j] = (i == j ? 1.0 : 0.0) - kh;
        }
    for (int i = 0; i < N; ++i) {
        double* row = AP + i * N;
        for (int j = 0; j < N; ++j) row[j] = 0.0;
        for (int k = 0; k < N; ++k) {
            const double a = A[i * N + k];
            for (int j = 0; j < N; ++j) row[j] += a * P[k * N + j];
        }
    }
    std::vector<double> kr_heap;
    double kr_stack[32];
    double* kr = m <= 32 ? kr_stack : (kr_heap.resize(m), kr_heap.data());
    for (int i = 0; i < N; ++i) {
        for (int l = 0; l < m; ++l) {  // (K R)[i, l]
            double s = 0.0;
            for (int c = 0; c < m; ++c) s += K[i * m + c] * R[c * m + l];
            kr[l] = s;
        }
        for (int j = 0; j < N; ++j) {
            double apa = 0.0;  // (A P Aᵀ)[i, j]
            for (int k = 0; k < N; ++k) apa += AP[i * N + k] * A[j * N + k];
            double krk = 0.0;  // (K R Kᵀ)[i, j]
            for (int l = 0; l < m; ++l) krk += kr[l] * K[j * m + l];
            P[i * N + j] = apa + krk;
        }
    }
    symmetrize<N>(P);  // keep exactly symmetric
}

// Joseph update for a 2-row measurement with noise s2 I₂, without forming I − K H:
// B = P − K (H P),  P <- B − (B Hᵀ) Kᵀ + s2 K Kᵀ  (= (I − KH) P (I − KH)ᵀ + K R Kᵀ), symmetrised.
// P (N, N), K (N, 2), H (2, N).
template <int N>
inline void joseph_2d(double* P, const double* K, const double* H, double s2) {
    double HP[2 * N];
    for (int j = 0; j < 2 * N; ++j) HP[j] = 0.0;
    for (int i = 0; i < 2; ++i)
        for (int k = 0; k < N; ++k) {
            const double h = H[i * N + k];
            if (h != 0.0)
                for (int j = 0; j < N; ++j) HP[i * N + j] += h * P[k * N + j];
        }
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) P[i * N + j] -= K[2 * i] * HP[j] + K[2 * i + 1] * HP[N + j];
    double C[N * 2];
    for (int i = 0; i < N; ++i) {
        double c0 = 0.0, c1 = 0.0;
        for (int k = 0; k < N; ++k) {
            const double pik = P[i * N + k];
            c0 += pik * H[k];
            c1 += pik * H[N + k];
        }
        C[2 * i] = c0;
        C[2 * i + 1] = c1;
    }
    for (int i = 0; i < N; ++i)
        for (int j = i; j < N; ++j) {
            const double ki0 = K[2 * i], ki1 = K[2 * i + 1], kj0 = K[2 * j], kj1 = K[2 * j + 1];
            const double v = P[i * N + j] - C[2 * i] * kj0 - C[2 * i + 1] * kj1 + s2 * (ki0 * kj0 + ki1 * kj1);
            const double w = P[j * N + i] - C[2 * j] * ki0 - C[2 * j + 1] * ki1 + s2 * (kj0 * ki0 + kj1 * ki1);
            P[i * N + j] = 0.5 * (v + w);
            P[j * N + i] = P[i * N + j];
        }
}

// Joseph update for an M-row measurement with noise covariance R (M, M), without forming I − K H (joseph_2d for any
// M and R): B = P − K (H P),  P <- B + (K R − B Hᵀ) Kᵀ  (= (I − KH) P (I − KH)ᵀ + K R Kᵀ), symmetrised.  P (N, N),
// K (N, M), H (M, N); the zeros of H are skipped (O(N² M) instead of the O(N³) of joseph).
template <int N, int M>
inline void joseph_rows(double* P, const double* K, const double* H, const double* R) {
    // every inner loop runs over a state index with unit stride (vectorisable; zeros of H skipped)
    double Kt[M * N], HP[M * N], Dt[M * N], Pn[N * N];
    for (int i = 0; i < N; ++i)
        for (int l = 0; l < M; ++l) Kt[l * N + i] = K[i * M + l];
    for (int j = 0; j < M * N; ++j) HP[j] = 0.0;
    for (int l = 0; l < M; ++l)
        for (int k = 0; k < N; ++k) {
            const double h = H[l * N + k];
            if (h != 0.0)
                for (int j = 0; j < N; ++j) HP[l * N + j] += h * P[k * N + j];
        }
    for (int i = 0; i < N; ++i)  // B = P − K (H P), in place
        for (int l = 0; l < M; ++l) {
            const double k = K[i * M + l];
            for (int j = 0; j < N; ++j) P[i * N + j] -= k * HP[l * N + j];
        }
    for (int l = 0; l < M; ++l) {  // Dᵀ = (K R − B Hᵀ)ᵀ
        double* d = Dt + l * N;
        for (int i = 0; i < N; ++i) d[i] = 0.0;
        for (int c = 0; c < M; ++c) {
            const double r = R[c * M + l];
            if (r != 0.0)
                for (int i = 0; i < N; ++i) d[i] += Kt[c * N + i] * r;
        }
        for (int k = 0; k < N; ++k) {
            const double h = H[l * N + k];
            if (h != 0.0)
                for (int i = 0; i < N; ++i) d[i] -= P[i * N + k] * h;
        }
    }
    for (int i = 0; i < N; ++i) {  // B + D Kᵀ
        double* o = Pn + i * N;
        for (int j = 0; j < N; ++j) o[j] = P[i * N + j];
        for (int l = 0; l < M; ++l) {
            const double d = Dt[l * N + i];
            for (int j = 0; j < N; ++j) o[j] += d * Kt[l * N + j];
        }
    }
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) P[i * N + j] = 0.5 * (Pn[i * N + j] + Pn[j * N + i]);
}

// χ²-gated sequential update with m two-row measurements linearised at one state, in place on P (N, N).
//
// r (m, 2) residuals and H (m, 2, N) Jacobians at the linearisation point, s2 (m,) noise variances (s2[k] I₂),
// depth (m,) camera depths (rows with depth <= 1e-6 are skipped, NIS inf).  Rows are taken in increasing order of
// their prior NIS (so that after a dropout the most consistent ones tighten P before the doubtful ones are gated;
// NaN last, as numpy's argsort); each sees r − H dx with the correction dx (N,) accumulated so far (the sequence
// equals one batch update of the accepted rows) and the current P (Joseph form, joseph_2d).  nis_out (m,) receives
// each row's NIS at its turn, accepted_out (m,) 1/0; returns the number accepted.  dx is left for the caller to
// inject.
template <int N>
inline std::int64_t sequential_gated_update(double* P, const double* r, const double* H, const double* s2,
                                            const double* depth, double gate, double* dx, double* nis_out,
                                            std::int64_t* accepted_out, std::int64_t m) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    std::vector<double> prior(m);
    std::vector<std::int64_t> order(m);
    double HP[2 * N], PHt[N * 2], K[N * 2];
    for (std::int64_t k = 0; k < m; ++k) {
        order[k] = k;
        if (depth[k] <= 1e-6) {
            prior[k] = inf;
            continue;
        }
        const double* Hk = H + k * 2 * N;
        for (int i = 0; i < 2; ++i)  // S = (H P) Hᵀ + s2 I
            for (int j = 0; j < N; ++j) {
                double s = 0.0;
                for (int l = 0; l < N; ++l) s += Hk[i * N + l] * P[l * N + j];
                HP[i * N + j] = s;
            }
        double S[4];
        for (int i = 0; i < 2; ++i)
            for (int c = 0; c < 2; ++c) {
                double s = 0.0;
                for (int j = 0; j < N; ++j) s += HP[i * N + j] * Hk[c * N + j];
                S[2 * i + c] = s;
            }
        S[0] += s2[k];
        S[3] += s2[k];
        const double det = S[0] * S[3] - S[1] * S[2];
        const double a = r[2 * k], b = r[2 * k + 1];
        prior[k] = (S[3] * a * a - 2.0 * S[1] * a * b + S[0] * b * b) / det;
    }
    std::stable_sort(order.begin(), order.end(), [&](std::int64_t i, std::int64_t j) {
        const double a = prior[i], b = prior[j];
        return a < b || (std::isnan(b) && !std::isnan(a));
    });
    std::int64_t n_acc = 0;
    for (std::int64_t k : order) {
        accepted_out[k] = 0;
        nis_out[k] = inf;
        if (depth[k] <= 1e-6) continue;
        const double* Hk = H + k * 2 * N;
        double nu[2];
        for (int i = 0; i < 2; ++i) {
            double hd = 0.0;
            for (int j = 0; j < N; ++j) hd += Hk[i * N + j] * dx[j];
            nu[i] = r[2 * k + i] - hd;
        }
        for (int j = 0; j < N; ++j) {  // P Hᵀ
            double s0 = 0.0, s1 = 0.0;
            for (int l = 0; l < N; ++l) {
                s0 += P[j * N + l] * Hk[l];
                s1 += P[j * N + l] * Hk[N + l];
            }
            PHt[2 * j] = s0;
            PHt[2 * j + 1] = s1;
        }
        double S[4];  // H (P Hᵀ) + s2 I
        for (int i = 0; i < 2; ++i)
            for (int c = 0; c < 2; ++c) {
                double s = 0.0;
                for (int j = 0; j < N; ++j) s += Hk[i * N + j] * PHt[2 * j + c];
                S[2 * i + c] = s;
            }
        S[0] += s2[k];
        S[3] += s2[k];
        const double det = S[0] * S[3] - S[1] * S[2];
        const double Si[4] = {S[3] / det, -S[1] / det, -S[2] / det, S[0] / det};
        const double nis = nu[0] * (Si[0] * nu[0] + Si[1] * nu[1]) + nu[1] * (Si[2] * nu[0] + Si[3] * nu[1]);
        nis_out[k] = nis;
        if (nis > gate) continue;
        for (int j = 0; j < N; ++j) {  // K = P Hᵀ S⁻¹, dx += K ν
            K[2 * j] = PHt[2 * j] * Si[0] + PHt[2 * j + 1] * Si[2];
            K[2 * j + 1] = PHt[2 * j] * Si[1] + PHt[2 * j + 1] * Si[3];
            dx[j] += K[2 * j] * nu[0] + K[2 * j + 1] * nu[1];
        }
        joseph_2d<N>(P, K, Hk, s2[k]);
        accepted_out[k] = 1;
        ++n_acc;
    }
    return n_acc;
}

}  // namespace dualpose
