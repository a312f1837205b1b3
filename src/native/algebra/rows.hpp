// The hot row kernels of the algebra and their contiguous row loops: one formula per kernel, used by the gufunc's
// strided path (the *_row functions) and by the C-contiguous loops (the *_rows functions, vectorised across rows), so
// both paths round identically.
//
// Fused multiply-add.  The products, the rotation, the transform and the inverses are written with mac/msub/nmac
// (c + a b, a b - c, c - a b).  On a CPU with FMA and AVX2 (kFused, checked once at load) each of them is one fused
// multiply-add (one rounding) on every path of these kernels -- the AVX-512 blocks, the four-row loops, the tails,
// the blocks with extreme rows, and the row kernel of the strided and single-element paths -- so every path gives the
// same bits.  On any other CPU every path rounds the product first, which is exactly the formulas of common/quat.hpp
// and common/kutil.hpp (qmul_t, rotate_lanes, transform_lanes) in the same order.  The choice is made per CPU, never
// per row, call or path.  (The squared norm of the rescaling test, unit_scale, stays unfused: other kernels share it.)
//
// Loops that need 2/|q|**2 check each block of rows: a block whose rows are all ordinary (common/kutil.hpp
// ordinary_sum: the absolute components sum to [2**-448, 2**448]) runs the branch-free formula with
// s2 = 2/|q|**2; any other block (zero, extreme or NaN norms) runs the row kernel, which rescales (common/kutil.hpp
// unit_scale) and gives NaN for a zero quaternion.  The result equals the row kernel's on every row; the return value
// is nonzero when some row's norm was outside the ordinary range (the wrappers then look for zeros).
#pragma once

#include "../common/dispatch.hpp"
#include "../common/dualquat.hpp"
#include "../common/kutil.hpp"
#include "../common/numpy_api.hpp"

#include <type_traits>

// Row kernels and formulas are inlined into their loops (the compiler's size heuristics would otherwise call them
// per row, or compile a vector formula for the baseline instruction set on its own).
#define DUALPOSE_ROW inline __attribute__((always_inline))

namespace dualpose {

// Whether the kernels below use fused multiply-adds (see above).
extern const bool kFused;

// One rounding of a b + c (K = 0), a b - c (K = 1) or c - a b (K = 2).  For a double this is __builtin_fma (one
// instruction in a function compiled for FMA).  For a GCC vector of doubles on x86-64 with GCC it is one
// vfmadd231pd / vfmsub231pd / vfnmadd231pd on the whole register (inline assembly: GCC's vectoriser does not
// reliably turn lane-by-lane __builtin_fma into one instruction, and a scalar fma per lane costs 4 to 8 times
// more); such code runs only in functions compiled for FMA (ymm) or AVX-512 (zmm).  Elsewhere lane by lane.
template <int K, class T>
DUALPOSE_ROW T fused(T a, T b, T c) {
    if constexpr (std::is_same_v<T, double>) {
        return K == 0 ? __builtin_fma(a, b, c) : K == 1 ? __builtin_fma(a, b, -c) : __builtin_fma(-a, b, c);
    } else {
#if DUALPOSE_HAVE_AVX512
        if constexpr (sizeof(T) == 64) {
            if constexpr (K == 0) asm("vfmadd231pd %g2, %g1, %g0" : "+v"(c) : "v"(a), "v"(b));
            else if constexpr (K == 1) asm("vfmsub231pd %g2, %g1, %g0" : "+v"(c) : "v"(a), "v"(b));
            else asm("vfnmadd231pd %g2, %g1, %g0" : "+v"(c) : "v"(a), "v"(b));
            return c;
        } else if constexpr (sizeof(T) == 32) {
            if constexpr (K == 0) asm("vfmadd231pd %t2, %t1, %t0" : "+v"(c) : "v"(a), "v"(b));
            else if constexpr (K == 1) asm("vfmsub231pd %t2, %t1, %t0" : "+v"(c) : "v"(a), "v"(b));
            else asm("vfnmadd231pd %t2, %t1, %t0" : "+v"(c) : "v"(a), "v"(b));
            return c;
        }
#endif
        T r;
        for (unsigned k = 0; k < sizeof(T) / sizeof(double); ++k) r[k] = fused<K>(a[k], b[k], c[k]);
        return r;
    }
}
// c + a b, a b - c and c - a b: fused when F, else the product rounded first (the operands in the formulas' order).
template <bool F, class T>
DUALPOSE_ROW T mac(T a, T b, T c) {
    if constexpr (F) return fused<0>(a, b, c);
    else return c + a * b;
}
template <bool F, class T>
DUALPOSE_ROW T msub(T a, T b, T c) {
    if constexpr (F) return fused<1>(a, b, c);
    else return a * b - c;
}
template <bool F, class T>
DUALPOSE_ROW T nmac(T a, T b, T c) {
    if constexpr (F) return fused<2>(a, b, c);
    else return c - a * b;
}

// a (x) b, Hamilton (Dantam 2014 eq. (17)): qmul_t (common/quat.hpp) term by term in its order, for any
// quaternion-like struct QT.
template <bool F, class QT>
DUALPOSE_ROW QT qmul_f(const QT& a, const QT& b) {
    return {nmac<F>(a.z, b.y, mac<F>(a.y, b.z, mac<F>(a.x, b.w, a.w * b.x))),
            mac<F>(a.z, b.x, mac<F>(a.y, b.w, nmac<F>(a.x, b.z, a.w * b.y))),
            mac<F>(a.z, b.w, nmac<F>(a.y, b.x, mac<F>(a.x, b.y, a.w * b.z))),
            nmac<F>(a.z, b.z, nmac<F>(a.y, b.y, nmac<F>(a.x, b.x, a.w * b.w)))};
}

// rotate_lanes (common/kutil.hpp, Dantam 2014 eq. (45)) in its order: v + s2 q_v x (q_v x v + w v).
template <bool F, class T>
DUALPOSE_ROW void rotate_f(T x, T y, T z, T w, T vx, T vy, T vz, T s2, T& ox, T& oy, T& oz) {
    const T ax = mac<F>(w, vx, msub<F>(y, vz, z * vy)), ay = mac<F>(w, vy, msub<F>(z, vx, x * vz)),
            az = mac<F>(w, vz, msub<F>(x, vy, y * vx));
    const T bx = msub<F>(y, az, z * ay), by = msub<F>(z, ax, x * az), bz = msub<F>(x, ay, y * ax);
    ox = mac<F>(s2, bx, vx);
    oy = mac<F>(s2, by, vy);
    oz = mac<F>(s2, bz, vz);
}

// transform_lanes (common/kutil.hpp) in its order: p + s2 [r_v x (r_v x p + w p + d_v) + w d_v - d_w r_v].
template <bool F, class T>
DUALPOSE_ROW void transform_f(T x, T y, T z, T w, T dx, T dy, T dz, T dw, T px, T py, T pz, T s2, T& ox, T& oy,
                              T& oz) {
    const T cx = msub<F>(y, pz, z * py), cy = msub<F>(z, px, x * pz), cz = msub<F>(x, py, y * px);
    const T ax = mac<F>(w, px, cx) + dx, ay = mac<F>(w, py, cy) + dy, az = mac<F>(w, pz, cz) + dz;
    const T bx = msub<F>(y, az, z * ay), by = msub<F>(z, ax, x * az), bz = msub<F>(x, ay, y * ax);
    ox = mac<F>(s2, nmac<F>(dw, x, mac<F>(w, dx, bx)), px);
    oy = mac<F>(s2, nmac<F>(dw, y, mac<F>(w, dy, by)), py);
    oz = mac<F>(s2, nmac<F>(dw, z, mac<F>(w, dz, bz)), pz);
}

// Inverses with one reciprocal 1/|q|**2 multiplied in, for a quaternion of ordinary magnitude (common/kutil.hpp
// ordinary_sum: no square under- or overflows): q^-1 = q* s, and (r + ε d)^-1 = i - ε i d i with i = r* s
// (Dantam 2014 eq. (17), and the dual-number inverse).
template <bool F, class QT>
DUALPOSE_ROW QT inv_ordinary_f(const QT& q) {
    const auto s = 1.0 / mac<F>(q.w, q.w, mac<F>(q.z, q.z, mac<F>(q.y, q.y, q.x * q.x)));
    return {-q.x * s, -q.y * s, -q.z * s, q.w * s};
}
template <bool F, class QT>
DUALPOSE_ROW void dq_inv_ordinary_f(const QT& r, const QT& d, QT& oi, QT& od) {
    oi = inv_ordinary_f<F>(r);
    const QT p = qmul_f<F>(qmul_f<F>(oi, d), oi);
    od = {-p.x, -p.y, -p.z, -p.w};
}

// The row kernels, for F fixed; the *_row functions below choose by kFused.
template <bool F>
DUALPOSE_ROW void quat_mul_row_f(const double* p, const double* q, double* o) {
    store(o, qmul_f<F>(load4(p), load4(q)));
}

// R(q/|q|) v (Dantam 2014 eq. (45)), as common/kutil.hpp rotate_any.
template <bool F>
DUALPOSE_ROW void quat_rotate_row_f(const double* q, const double* v, double* o) {
    const Scale u = unit_scale(load4(q));
    const Quat a = scale(u.c, load4(q));
    Vec3 r;
    rotate_f<F>(a.x, a.y, a.z, a.w, v[0], v[1], v[2], u.s2, r.x, r.y, r.z);
    store(o, r);
}

// Dantam 2014 eq. (79).
template <bool F>
DUALPOSE_ROW void dualquat_mul_row_f(const double* a, const double* b, double* o) {
    const Quat ar = load4(a), ad = load4(a + 4), br = load4(b), bd = load4(b + 4);
    const Quat r = qmul_f<F>(ar, br), e = qmul_f<F>(ar, bd), f = qmul_f<F>(ad, br);
    store(o, r);
    store(o + 4, Quat{e.x + f.x, e.y + f.y, e.z + f.z, e.w + f.w});
}

// p' = R p + t (Dantam 2014 eq. (95) in the implicit form (106)); s2 = 2/|r|**2 normalizes a non-unit real part
// (extreme norms rescaled first).
template <bool F>
DUALPOSE_ROW void dualquat_transform_row_f(const double* s, const double* p, double* o) {
    DualQuat d = load8(s);
    const Scale u = unit_scale(d.r);
    if (u.c != 1.0) d = scale(u.c, d);
    Vec3 r;
    transform_f<F>(d.r.x, d.r.y, d.r.z, d.r.w, d.d.x, d.d.y, d.d.z, d.d.w, p[0], p[1], p[2], u.s2, r.x, r.y, r.z);
    store(o, r);
}

// q*/|q|**2: the one-reciprocal formula for ordinary magnitudes; else q*/|q|/|q| with the guarded norm (no square
// formed: exact rescaling for every finite nonzero magnitude), NaN for zero.
template <bool F>
DUALPOSE_ROW void quat_inv_row_f(const double* q, double* o) {
    if (ordinary_sum(abs_sum(q[0], q[1], q[2], q[3]))) {
        store(o, inv_ordinary_f<F>(load4(q)));
        return;
    }
    double n = norm4(load4(q));
    if (n == 0.0) n = kNaN;
    const double x = q[0] / n, y = q[1] / n, z = q[2] / n, w = q[3] / n;
    store(o, Quat{-x / n, -y / n, -z / n, w / n});
}

// (r + ε d)^-1 = r^-1 - ε r^-1 d r^-1: dq_inv_ordinary_f for an ordinary real part; else with r^-1 = u*/n
// (u = r/n), so no square of n is formed; NaN for a zero real part.
template <bool F>
DUALPOSE_ROW void dualquat_inv_row_f(const double* s, double* o) {
    if (ordinary_sum(abs_sum(s[0], s[1], s[2], s[3]))) {
        Quat i, p;
        dq_inv_ordinary_f<F>(load4(s), load4(s + 4), i, p);
        store(o, i);
        store(o + 4, p);
        return;
    }
    double n = norm4(load4(s));
    if (n == 0.0) n = kNaN;
    const Quat u = {-s[0] / n, -s[1] / n, -s[2] / n, s[3] / n};  // u*
    const Quat i = {u.x / n, u.y / n, u.z / n, u.w / n};
    const Quat p = qmul_f<F>(qmul_f<F>(u, Quat{s[4] / n, s[5] / n, s[6] / n, s[7] / n}), i);
    store(o, i);
    store(o + 4, neg(p));
}

// The fused row kernels (compiled for FMA, rows.cpp) and the row kernels of the gufuncs.
void quat_mul_row_fused(const double* p, const double* q, double* o);
void quat_rotate_row_fused(const double* q, const double* v, double* o);
void dualquat_mul_row_fused(const double* a, const double* b, double* o);
void dualquat_transform_row_fused(const double* s, const double* p, double* o);
void quat_inv_row_fused(const double* q, double* o);
void dualquat_inv_row_fused(const double* s, double* o);

inline void quat_mul_row(const double* p, const double* q, double* o) {
    kFused ? quat_mul_row_fused(p, q, o) : quat_mul_row_f<false>(p, q, o);
}
inline void quat_rotate_row(const double* q, const double* v, double* o) {
    kFused ? quat_rotate_row_fused(q, v, o) : quat_rotate_row_f<false>(q, v, o);
}
inline void dualquat_mul_row(const double* a, const double* b, double* o) {
    kFused ? dualquat_mul_row_fused(a, b, o) : dualquat_mul_row_f<false>(a, b, o);
}
inline void dualquat_transform_row(const double* s, const double* p, double* o) {
    kFused ? dualquat_transform_row_fused(s, p, o) : dualquat_transform_row_f<false>(s, p, o);
}
inline void quat_inv_row(const double* q, double* o) {
    kFused ? quat_inv_row_fused(q, o) : quat_inv_row_f<false>(q, o);
}
inline void dualquat_inv_row(const double* s, double* o) {
    kFused ? dualquat_inv_row_fused(s, o) : dualquat_inv_row_f<false>(s, o);
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
int quat_mul_rows(const double* p, const double* q, double* o, npy_intp n);  // 0
int quat_rotate_rows(const double* q, const double* v, double* o, npy_intp n);
int dualquat_mul_rows(const double* a, const double* b, double* o, npy_intp n);
int dualquat_transform_rows(const double* s, const double* p, double* o, npy_intp n);
int quat_inv_rows(const double* q, double* o, npy_intp n);
int dualquat_inv_rows(const double* s, double* o, npy_intp n);

}  // namespace dualpose
