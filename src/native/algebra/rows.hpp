// The hot row kernels of the algebra and their contiguous row loops: one scalar formula per kernel (from
// common/kutil.hpp), used by the gufunc's strided path (the *_row functions) and by the C-contiguous loops (the
// *_rows functions, vectorised across rows and cloned per instruction set), so both paths round identically.
//
// Loops that need 2/|q|**2 check each block of four rows: a block whose rows are all ordinary (common/kutil.hpp
// ordinary_sum: the absolute components sum to [2**-448, 2**448]) runs the branch-free formula with
// s2 = 2/|q|**2; any other block (zero, extreme or NaN norms) runs the row kernel, which rescales (common/kutil.hpp unit_scale) and gives NaN for a zero quaternion.  The
// result equals the row kernel's on every row; the return value is nonzero when some row's norm was outside
// the ordinary range (the wrappers then look for zeros).
#pragma once

#include "../common/dualquat.hpp"
#include "../common/kutil.hpp"
#include "../common/numpy_api.hpp"

// Row kernels are inlined into their loops (the compiler's size heuristics would otherwise call them per row).
#define DUALPOSE_ROW inline __attribute__((always_inline))

namespace dualpose {

DUALPOSE_ROW void quat_mul_row(const double* p, const double* q, double* o) { store(o, qmul(load4(p), load4(q))); }

// R(q/|q|) v (Dantam 2014 eq. (45)).
DUALPOSE_ROW void quat_rotate_row(const double* q, const double* v, double* o) {
    store(o, rotate_any(load4(q), load3(v)));
}

// Dantam 2014 eq. (79).
DUALPOSE_ROW void dualquat_mul_row(const double* a, const double* b, double* o) { store(o, dq_mul(load8(a), load8(b))); }

// p' = R p + t (Dantam 2014 eq. (95) in the implicit form (106)); s2 = 2/|r|**2 normalizes a non-unit real part
// (extreme norms rescaled first).
DUALPOSE_ROW void dualquat_transform_row(const double* s, const double* p, double* o) {
    DualQuat d = load8(s);
    const Scale u = unit_scale(d.r);
    if (u.c != 1.0) d = scale(u.c, d);
    store(o, transform_point(d, load3(p), u.s2));
}

// Inverses with one reciprocal 1/|q|**2 multiplied in, for a quaternion of ordinary magnitude (common/kutil.hpp
// ordinary_sum: no square under- or overflows): q^-1 = q* s, and (r + ε d)^-1 = i - ε i d i with i = r* s
// (Dantam 2014 eq. (17), and the dual-number inverse).  For any arithmetic type T (double, or a GCC vector of
// doubles holding one component of several rows), as rotate_lanes.
template <class QT>
inline QT inv_ordinary_t(const QT& q) {
    const auto s = 1.0 / (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
    return {-q.x * s, -q.y * s, -q.z * s, q.w * s};
}
template <class QT>
inline void dq_inv_ordinary_t(const QT& r, const QT& d, QT& oi, QT& od) {
    oi = inv_ordinary_t(r);
    const QT p = qmul_t(qmul_t(oi, d), oi);
    od = {-p.x, -p.y, -p.z, -p.w};
}

// q*/|q|**2: the one-reciprocal formula for ordinary magnitudes; else q*/|q|/|q| with the guarded norm (no square
// formed: exact for every finite nonzero magnitude), NaN for zero.
DUALPOSE_ROW void quat_inv_row(const double* q, double* o) {
    if (ordinary_sum(abs_sum(q[0], q[1], q[2], q[3]))) {
        store(o, inv_ordinary_t(load4(q)));
        return;
    }
    double n = norm4(load4(q));
    if (n == 0.0) n = kNaN;
    const double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
    store(o, Quat{-x / n, -y / n, -z / n, w / n});
}

// (r + ε d)^-1 = r^-1 - ε r^-1 d r^-1: dq_inv_ordinary_t for an ordinary real part; else with r^-1 = u*/n
// (u = r/n), so no square of n is formed; NaN for a zero real part.
DUALPOSE_ROW void dualquat_inv_row(const double* s, double* o) {
    if (ordinary_sum(abs_sum(s[0], s[1], s[2], s[3]))) {
        Quat i, p;
        dq_inv_ordinary_t(load4(s), load4(s + 4), i, p);
        store(o, i);
        store(o + 4, p);
        return;
    }
    double n = norm4(load4(s));
    if (n == 0.0) n = kNaN;
    const Quat u = {-s[0] / n, -s[1] / n, -s[2] / n, s[3] / n};  // u*
    const Quat i = {u.x / n, u.y / n, u.z / n, u.w / n};
    Quat p = qmul(u, Quat{s[4] / n, s[5] / n, s[6] / n, s[7] / n});
    p = qmul(p, i);
    store(o, i);
    store(o + 4, neg(p));
}

// q* = q [-1, -1, -1, 1] (and both parts of a dual quaternion alike), multiplied as NumPy multiplies by the sign
// pattern (a NaN stays the NaN it was, a signalling NaN is quieted): the signs are read through a volatile, so the
// compiler cannot fold the products into sign flips.
extern const volatile double kMinusOne, kPlusOne;
DUALPOSE_ROW void quat_conj_row(const double* q, double* o) {
    const double m = kMinusOne, p = kPlusOne;
    o[0] = q[0] * m;
    o[1] = q[1] * m;
    o[2] = q[2] * m;
    o[3] = q[3] * p;
}
DUALPOSE_ROW void dualquat_conj_row(const double* s, double* o) {
    quat_conj_row(s, o);
    quat_conj_row(s + 4, o + 4);
}

void quat_conj_rows(const double* q, double* o, npy_intp n);
void dualquat_conj_rows(const double* s, double* o, npy_intp n);
void quat_mul_rows(const double* p, const double* q, double* o, npy_intp n);
int quat_rotate_rows(const double* q, const double* v, double* o, npy_intp n);
int dualquat_mul_rows(const double* a, const double* b, double* o, npy_intp n);
int dualquat_transform_rows(const double* s, const double* p, double* o, npy_intp n);
int quat_inv_rows(const double* q, double* o, npy_intp n);
int dualquat_inv_rows(const double* s, double* o, npy_intp n);

}  // namespace dualpose
