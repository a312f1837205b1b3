// Small dense linear algebra of the error-state filter and its smoother: products that skip the structural zeros
// of a sparse left factor, and LU with partial pivoting (the algorithm of LAPACK dgetrf/dgetrs, which numpy's
// linalg.solve / inv use).  Row-major contiguous doubles.
#pragma once

#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

namespace dualpose {

// out (R, C) = A (R, K) B (K, C), skipping the zero entries of A (exact: a skipped term is +0 for finite B).
// out may not alias A or B.  R, K, C > 0 fix the sizes at compile time; 0 takes r_, k_, c_ at run time.
template <int R, int K, int C>
inline void mul_sparse_left(const double* A, const double* B, double* out, int r_ = R, int k_ = K, int c_ = C) {
    const int nr = R > 0 ? R : r_, nk = K > 0 ? K : k_, nc = C > 0 ? C : c_;
    for (int i = 0; i < nr; ++i) {
        double* o = out + i * nc;
        for (int j = 0; j < nc; ++j) o[j] = 0.0;
        for (int k = 0; k < nk; ++k) {
            const double a = A[i * nk + k];
            if (a != 0.0)
                for (int j = 0; j < nc; ++j) o[j] += a * B[k * nc + j];
        }
    }
}

// S (n, n) <- (S + Sᵀ) / 2 element by element: exactly symmetric afterwards.  N > 0 fixes n at compile time.
template <int N = 0>
inline void symmetrize(double* S, int n_ = N) {
    const int n = N > 0 ? N : n_;
    for (int i = 0; i < n; ++i)
        for (int j = i + 1; j < n; ++j) {
            const double s = 0.5 * (S[i * n + j] + S[j * n + i]);
            S[i * n + j] = s;
            S[j * n + i] = s;
        }
}

// P <- A P Aᵀ (N, N) for a sparse A (the transition F or the reset Jacobian G):  W = (A P)ᵀ, P = (A W)ᵀ, each
// element summed over k in increasing order as (A P) Aᵀ.
template <int N>
inline void congruence_sparse(const double* A, double* P) {
    double AP[N * N], W[N * N];
    mul_sparse_left<N, N, N>(A, P, AP);
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) W[j * N + i] = AP[i * N + j];
    mul_sparse_left<N, N, N>(A, W, AP);  // AP now (A P Aᵀ)ᵀ
    for (int i = 0; i < N; ++i)
        for (int j = 0; j < N; ++j) P[i * N + j] = AP[j * N + i];
}

// In-place LU factorisation with partial pivoting of A (n, n): P A = L U (unit L below, U on and above the
// diagonal), piv[k] the row swapped with row k at step k.  Returns false if a pivot is exactly zero (singular).
// N > 0 fixes n at compile time (the loops then unroll and vectorise); N = 0 takes n at run time.
template <int N = 0>
inline bool lu_factor(double* A, int n_, int* piv) {
    const int n = N > 0 ? N : n_;
    bool ok = true;
    for (int k = 0; k < n; ++k) {
        int p = k;
        double best = std::fabs(A[k * n + k]);
        for (int i = k + 1; i < n; ++i) {
            const double v = std::fabs(A[i * n + k]);
            if (v > best) {
                best = v;
                p = i;
            }
        }
        piv[k] = p;
        if (p != k)
            for (int j = 0; j < n; ++j) std::swap(A[k * n + j], A[p * n + j]);
        const double d = A[k * n + k];
        if (d == 0.0) {
            ok = false;
            continue;
        }
        const double inv = 1.0 / d;
        for (int i = k + 1; i < n; ++i) {
            const double l = A[i * n + k] * inv;
            A[i * n + k] = l;
            if (l != 0.0)
                for (int j = k + 1; j < n; ++j) A[i * n + j] -= l * A[k * n + j];
        }
    }
    return ok;
}

// Solve (P A) X = B in place on B (n, nrhs) with the factors of lu_factor (N, NRHS > 0: sizes fixed at compile
// time).
template <int N = 0, int NRHS = 0>
inline void lu_solve(const double* LU, const int* piv, int n_, double* B, int nrhs_) {
    const int n = N > 0 ? N : n_;
    const int nrhs = NRHS > 0 ? NRHS : nrhs_;
    for (int k = 0; k < n; ++k)
        if (piv[k] != k)
            for (int j = 0; j < nrhs; ++j) std::swap(B[k * nrhs + j], B[piv[k] * nrhs + j]);
    for (int k = 0; k < n; ++k)  // L y = b
        for (int i = k + 1; i < n; ++i) {
            const double l = LU[i * n + k];
            if (l != 0.0)
                for (int j = 0; j < nrhs; ++j) B[i * nrhs + j] -= l * B[k * nrhs + j];
        }
    for (int k = n - 1; k >= 0; --k) {  // U x = y
        const double d = LU[k * n + k];
        for (int j = 0; j < nrhs; ++j) B[k * nrhs + j] /= d;
        for (int i = 0; i < k; ++i) {
            const double u = LU[i * n + k];
            if (u != 0.0)
                for (int j = 0; j < nrhs; ++j) B[i * nrhs + j] -= u * B[k * nrhs + j];
        }
    }
}

inline bool all_finite(const double* a, std::int64_t n) {
    for (std::int64_t i = 0; i < n; ++i)
        if (!std::isfinite(a[i])) return false;
    return true;
}

}  // namespace dualpose
