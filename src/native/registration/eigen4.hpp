// The symmetric 4x4 eigenproblems of the registration solvers (Horn's N, Walker's A): the closed form
// (characteristic quartic, Newton for the two largest roots, eigenvector from the adjugate) and the cyclic Jacobi
// fallback with the smallest-rotation tie-break.  Matrices are given by their upper triangle
// (a00 a01 a02 a03 a11 a12 a13 a22 a23 a33), quaternions xyzw.  Ported from the numba solver, operation by
// operation.
#pragma once

#include "../common/kutil.hpp"

#include <cmath>

namespace dualpose::reg {

// Upper triangle of a symmetric 4x4 matrix.
struct Sym4 {
    double a00, a01, a02, a03, a11, a12, a13, a22, a23, a33;
};

// Python's max(a, b) / min(a, b) (the first argument unless the second compares greater / smaller).
inline double pymax(double a, double b) { return b > a ? b : a; }
inline double pymin(double a, double b) { return b < a ? b : a; }

inline double det3(double a, double b, double c, double d, double e, double f, double g, double h, double i) {
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
}

// Cyclic Jacobi: diagonalise the symmetric a (4x4, row-major) in place, eigenvectors in the columns of v.
void jacobi_eigh4(double* a, double* v);

// Eigenvector of the largest eigenvalue of the diagonalised a with eigenvectors v (from jacobi_eigh4); within a
// degenerate top eigenspace (eigenvalues within tol of the largest) the smallest rotation: the identity [0,0,0,1]
// projected onto that span, or the first eigenvector when the projection vanishes (every optimum a half-turn).
// Writes q (w >= 0) and the eigenvalues in descending order; returns 1 if the top eigenvalue is simple, else 0.
int jacobi_top(const Sym4& m, double tol, double* q, double* eigenvalues);

// det(λI - A) = λ⁴ + c3 λ³ + c2 λ² + c1 λ + c0 (all roots real), the Newton start for the largest root (the
// smaller of the Gershgorin upper bound and bound, an upper bound on λ1 known to the caller) and the spectrum's
// scale; all zero when the scale is 0 or not finite (the closed form is then skipped).
struct CharPoly {
    double c3, c2, c1, c0, start, scale;
};

__attribute__((always_inline)) inline CharPoly char_poly(const Sym4& m, double bound) {
    const double a00 = m.a00, a01 = m.a01, a02 = m.a02, a03 = m.a03, a11 = m.a11;
    const double a12 = m.a12, a13 = m.a13, a22 = m.a22, a23 = m.a23, a33 = m.a33;
    using std::fabs;
    const double g0 = a00 + fabs(a01) + fabs(a02) + fabs(a03);
    const double g1 = a11 + fabs(a01) + fabs(a12) + fabs(a13);
    const double g2 = a22 + fabs(a02) + fabs(a12) + fabs(a23);
    const double g3 = a33 + fabs(a03) + fabs(a13) + fabs(a23);
    const double hi = pymin(pymax(pymax(g0, g1), pymax(g2, g3)), bound);
    const double lo = pymin(pymin(a00 - fabs(a01) - fabs(a02) - fabs(a03), a11 - fabs(a01) - fabs(a12) - fabs(a13)),
                            pymin(a22 - fabs(a02) - fabs(a12) - fabs(a23), a33 - fabs(a03) - fabs(a13) - fabs(a23)));
    const double scale = pymax(fabs(hi), fabs(lo));
    if (scale == 0.0 || !std::isfinite(scale)) return {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    const double d00 = det3(a11, a12, a13, a12, a22, a23, a13, a23, a33);
    const double c3 = -(a00 + a11 + a22 + a33);
    const double c2 = a00 * a11 - a01 * a01 + a00 * a22 - a02 * a02 + a00 * a33 - a03 * a03 + a11 * a22 - a12 * a12 +
                      a11 * a33 - a13 * a13 + a22 * a33 - a23 * a23;
    const double c1 = -(d00 + det3(a00, a02, a03, a02, a22, a23, a03, a23, a33) +
                        det3(a00, a01, a03, a01, a11, a13, a03, a13, a33) +
                        det3(a00, a01, a02, a01, a11, a12, a02, a12, a22));
    const double c0 = a00 * d00 - a01 * det3(a01, a12, a13, a02, a22, a23, a03, a23, a33) +
                      a02 * det3(a01, a11, a13, a02, a12, a23, a03, a13, a33) -
                      a03 * det3(a01, a11, a12, a02, a12, a22, a03, a13, a23);
    return {c3, c2, c1, c0, hi, scale};
}

// The two largest roots of m staged quartics (structure of arrays, one entry per problem), in place: l1 from its
// staged upper bound, l2 from the Laguerre-Samuelson bound of the deflated cubic (or from l1).  Newton from an
// upper bound decreases monotonically to the largest root; each sweep takes one step for every problem until
// none moves by more than 1e-15 x scale.  Vectorised across the problems (they are independent).
void largest_roots(const double* c3, const double* c2, const double* c1, const double* c0, const double* scale,
                   double* l1, double* l2, int m);

// Unit eigenvector of the largest root l1 of A read off the adjugate of A - l1 I (the column with the largest
// diagonal cofactor), w >= 0, and λ3, λ4 from the quadratic left after deflating l1 and l2.  ok is false when the
// closed form cannot vouch for the answer (gap below a millionth of the scale, or residual
// ‖A q - λ1 q‖ > 1e-14 (λ1 - λ2)): the caller then uses Jacobi.
struct TopVector {
    bool ok;
    double x, y, z, w, l3, l4;
};

// always inlined (as the numba kernel's inline="always"): it runs once per problem in the block loop
__attribute__((always_inline)) inline TopVector closed_form_vector(const Sym4& m, double c3, double c2, double l1,
                                                                 double l2, double scale) {
    const double a00 = m.a00, a01 = m.a01, a02 = m.a02, a03 = m.a03, a11 = m.a11;
    const double a12 = m.a12, a13 = m.a13, a22 = m.a22, a23 = m.a23, a33 = m.a33;
    const double gap = l1 - l2;
    if (scale == 0.0 || !(gap > 1e-6 * scale)) return {false, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    const double b2 = c3 + l1;
    const double b1 = c2 + l1 * b2;
    const double e1 = b2 + l2;
    const double e0 = b1 + l2 * e1;
    const double disc = std::sqrt(pymax(e1 * e1 - 4.0 * e0, 0.0));
    const double m00 = a00 - l1, m11 = a11 - l1, m22 = a22 - l1, m33 = a33 - l1;
    const double d0 = det3(m11, a12, a13, a12, m22, a23, a13, a23, m33);
    const double d1 = det3(m00, a02, a03, a02, m22, a23, a03, a23, m33);
    const double d2 = det3(m00, a01, a03, a01, m11, a13, a03, a13, m33);
    const double d3 = det3(m00, a01, a02, a01, m11, a12, a02, a12, m22);
    const double f0 = std::fabs(d0), f1 = std::fabs(d1), f2 = std::fabs(d2), f3 = std::fabs(d3);
    // cofactor C_ij = (-1)^(i+j) det(minor without row i, column j); column j of adj = (C_j0, C_j1, C_j2, C_j3)
    double x, y, z, w;
    if (f0 >= f1 && f0 >= f2 && f0 >= f3) {
        x = d0;
        y = -det3(a01, a12, a13, a02, m22, a23, a03, a23, m33);
        z = det3(a01, m11, a13, a02, a12, a23, a03, a13, m33);
        w = -det3(a01, m11, a12, a02, a12, m22, a03, a13, a23);
    } else if (f1 >= f2 && f1 >= f3) {
        x = -det3(a01, a02, a03, a12, m22, a23, a13, a23, m33);
        y = d1;
        z = -det3(m00, a02, a03, a01, a12, a13, a03, a23, m33);
        w = det3(m00, a02, a03, a01, a12, a13, a02, m22, a23);
    } else if (f2 >= f3) {
        x = det3(a01, a02, a03, m11, a12, a13, a13, a23, m33);
        y = -det3(m00, a02, a03, a01, a12, a13, a03, a23, m33);
        z = d2;
        w = -det3(m00, a01, a03, a01, m11, a13, a02, a12, a23);
    } else {
        x = -det3(a01, a02, a03, m11, a12, a13, a12, m22, a23);
        y = det3(m00, a02, a03, a01, a12, a13, a02, m22, a23);
        z = -det3(m00, a01, a03, a01, m11, a13, a02, a12, a23);
        w = d3;
    }
    double nrm = std::sqrt(x * x + y * y + z * z + w * w);
    if (!(nrm > 0.0) || !std::isfinite(nrm)) return {false, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    if (flip_sign({x, y, z, w})) nrm = -nrm;
    x = x / nrm, y = y / nrm, z = z / nrm, w = w / nrm;
    const double r0 = a00 * x + a01 * y + a02 * z + a03 * w - l1 * x;
    const double r1 = a01 * x + a11 * y + a12 * z + a13 * w - l1 * y;
    const double r2 = a02 * x + a12 * y + a22 * z + a23 * w - l1 * z;
    const double r3 = a03 * x + a13 * y + a23 * z + a33 * w - l1 * w;
    const bool ok = std::sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3) <= 1e-14 * gap;
    return {ok, x, y, z, w, 0.5 * (-e1 + disc), 0.5 * (-e1 - disc)};
}

}  // namespace dualpose::reg
