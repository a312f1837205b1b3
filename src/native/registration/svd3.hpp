// Singular value decomposition of a 3x3 matrix without LAPACK: one-sided (Hestenes) Jacobi, H V = U Σ.
//
// Column pairs of H V are rotated until orthogonal (Demmel & Veselić 1992: relative accuracy of the computed
// singular values, so a rank-deficient H gets a singular value of ~1e-16 σ1, not ~1e-8 σ1 as through Hᵀ H).  The
// matrix is scaled by its largest entry first (no overflow of the squared column norms).  Singular values in
// descending order; U, V orthogonal (U is built from u1, u2 and u1 × u2, so it stays orthonormal when H is
// rank-deficient).
#pragma once

namespace dualpose::reg {

// h, u, v 3x3 row-major; h = u diag(sig) vᵀ.
void svd3(const double* h, double* u, double* sig, double* v);

}  // namespace dualpose::reg
