// Scalar helpers shared by every kernel: guarded norms, the Hamilton and dual-quaternion products, rotation,
// rigid transform of a point, the unit scale of a non-unit quaternion, ln|q|, the rotation matrix and Shepperd's
// quaternion of a rotation matrix.  Quaternions are xyzw (scalar last, Hamilton product).
//
// Plain + - * / and libm only, in the order of the formulas documented below (no fast-math, no FMA contraction:
// see CMakeLists.txt), so every caller (gufunc, flat path, whole-recording loop) rounds identically.  (The hot
// kernels of algebra/rows.hpp evaluate the product, rotation and transform in the same order with fused
// multiply-adds on a CPU that has them.)
#pragma once

#include "quat.hpp"  // Vec3, Quat, qmul

#include <algorithm>
#include <cmath>
#include <limits>

namespace dualpose {

// [real xyzw, dual xyzw]
struct DualQuat {
    Quat r, d;
};
// (c, s2) of unit_scale
struct Scale {
    double c, s2;
};

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kPi = 3.141592653589793;
inline constexpr double kTiny = 1e-280;
inline constexpr double kHuge = 1e280;

inline Vec3 load3(const double* p) { return {p[0], p[1], p[2]}; }
inline Quat load4(const double* p) { return {p[0], p[1], p[2], p[3]}; }
inline DualQuat load8(const double* p) { return {{p[0], p[1], p[2], p[3]}, {p[4], p[5], p[6], p[7]}}; }
inline void store(double* o, Vec3 v) {
    o[0] = v.x;
    o[1] = v.y;
    o[2] = v.z;
}
inline void store(double* o, Quat q) {
    o[0] = q.x;
    o[1] = q.y;
    o[2] = q.z;
    o[3] = q.w;
}
inline void store(double* o, const DualQuat& s) {
    store(o, s.r);
    store(o + 4, s.d);
}
inline Quat neg(Quat q) { return {-q.x, -q.y, -q.z, -q.w}; }
inline Quat conj(Quat q) { return {-q.x, -q.y, -q.z, q.w}; }
inline DualQuat neg(const DualQuat& s) { return {neg(s.r), neg(s.d)}; }
inline Quat scale(double f, Quat q) { return {f * q.x, f * q.y, f * q.z, f * q.w}; }
inline DualQuat scale(double f, const DualQuat& s) { return {scale(f, s.r), scale(f, s.d)}; }

// The magnitude test every kernel shares: (|x| + |y| + |z| + |w|) / 8 in [2**-451, 2**445] (false for zero, inf
// and NaN; the / 8 keeps the sum of four components near the largest double finite).  Then every square and |q|**2
// lie in [1e-271, 1e271]: no underflow, no overflow (and no floating-point overflow flag, so NumPy raises no
// RuntimeWarning).  Testing the components, not |q|**2, means extreme input is never squared before it is
// rescaled; NaN is caught by the quiet a == a before any ordered comparison (which would raise the invalid flag).
inline constexpr double kOrdinaryLo = 0x1p-451, kOrdinaryHi = 0x1p445;
inline bool ordinary_sum(double a) { return a == a && a >= kOrdinaryLo && a <= kOrdinaryHi; }
inline double abs_sum(double x, double y, double z, double w = 0.0) {
    return std::fabs(x) * 0.125 + std::fabs(y) * 0.125 + std::fabs(z) * 0.125 + std::fabs(w) * 0.125;
}

// sqrt(x² + y² + z² + w²) of a finite nonzero vector outside the ordinary range: computed on the components
// scaled exactly by the power of two of the largest one (|exponent| <= 1000: 2**e stays a normal double).
inline double norm_rescaled(double x, double y, double z, double w) {
    const double m = std::max(std::max(std::fabs(x), std::fabs(y)), std::max(std::fabs(z), std::fabs(w)));
    int e;
    std::frexp(m, &e);
    e = std::clamp(-e, -1000, 1000);
    x = std::ldexp(x, e), y = std::ldexp(y, e), z = std::ldexp(z, e), w = std::ldexp(w, e);
    return std::ldexp(std::sqrt(x * x + y * y + z * z + w * w), -e);
}

// Euclidean norm of a 3-vector without underflow or overflow of the squares (NaN propagates).
inline double norm3(double x, double y, double z) {
    const double a = abs_sum(x, y, z);
    if (ordinary_sum(a)) return std::sqrt(x * x + y * y + z * z);
    if (a != a || a == 0.0 || a == kInf) return a;
    return norm_rescaled(x, y, z, 0.0);
}
inline double norm3(Vec3 v) { return norm3(v.x, v.y, v.z); }

// Euclidean norm of a 4-vector without underflow or overflow of the squares (NaN propagates).
inline double norm4(double x, double y, double z, double w) {
    const double a = abs_sum(x, y, z, w);
    if (ordinary_sum(a)) return std::sqrt(x * x + y * y + z * z + w * w);
    if (a != a || a == 0.0 || a == kInf) return a;
    return norm_rescaled(x, y, z, w);
}
inline double norm4(Quat q) { return norm4(q.x, q.y, q.z, q.w); }

// (a + ε b)(c + ε d) = a c + ε (a d + b c): Dantam 2014 eq. (79), for any struct DQ with quaternion-like
// members r and d (see qmul_t).
template <class DQ>
inline DQ dq_mul_t(const DQ& a, const DQ& b) {
    const auto r = qmul_t(a.r, b.r), e = qmul_t(a.r, b.d), f = qmul_t(a.d, b.r);
    return {r, {e.x + f.x, e.y + f.y, e.z + f.z, e.w + f.w}};
}
inline DualQuat dq_mul(const DualQuat& a, const DualQuat& b) { return dq_mul_t(a, b); }

inline Vec3 cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

// v + s2 * q_v x (q_v x v + w v): Dantam 2014 eq. (45); s2 = 2/|q|**2 (2 for a unit quaternion).  Written for any
// arithmetic type T (double, or a GCC vector of doubles holding one component of several rows: the vectorised row
// loops evaluate this same expression lane by lane, so they round as the scalar kernels).
template <class T>
inline void rotate_lanes(T x, T y, T z, T w, T vx, T vy, T vz, T s2, T& ox, T& oy, T& oz) {
    T ax = y * vz - z * vy, ay = z * vx - x * vz, az = x * vy - y * vx;  // q_v x v
    ax += w * vx;
    ay += w * vy;
    az += w * vz;
    const T bx = y * az - z * ay, by = z * ax - x * az, bz = x * ay - y * ax;  // q_v x (q_v x v + w v)
    ox = vx + s2 * bx;
    oy = vy + s2 * by;
    oz = vz + s2 * bz;
}
inline Vec3 rotate(Quat q, Vec3 v, double s2) {
    Vec3 o;
    rotate_lanes(q.x, q.y, q.z, q.w, v.x, v.y, v.z, s2, o.x, o.y, o.z);
    return o;
}

// R p + t for the dual quaternion s = [r, d]; s2 = 2/|r|**2.  R p = p + s2 r_v x (r_v x p + w p) (Dantam 2014
// eq. (45)) and t = s2 (w d_v - d_w r_v + r_v x d_v) (eq. (78)), fused into
// p + s2 [r_v x (r_v x p + w p + d_v) + w d_v - d_w r_v].  For any arithmetic type T, as rotate_lanes.
template <class T>
inline void transform_lanes(T x, T y, T z, T w, T dx, T dy, T dz, T dw, T px, T py, T pz, T s2, T& ox, T& oy,
                            T& oz) {
    const T cx = y * pz - z * py, cy = z * px - x * pz, cz = x * py - y * px;
    const T ax = cx + w * px + dx, ay = cy + w * py + dy, az = cz + w * pz + dz;
    const T bx = y * az - z * ay, by = z * ax - x * az, bz = x * ay - y * ax;
    ox = px + s2 * (bx + w * dx - dw * x);
    oy = py + s2 * (by + w * dy - dw * y);
    oz = pz + s2 * (bz + w * dz - dw * z);
}
inline Vec3 transform_point(const DualQuat& s, Vec3 p, double s2) {
    Vec3 o;
    transform_lanes(s.r.x, s.r.y, s.r.z, s.r.w, s.d.x, s.d.y, s.d.z, s.d.w, p.x, p.y, p.z, s2, o.x, o.y, o.z);
    return o;
}

// The exponent e (|e| <= 1000) of the power of two 2**e that brings the largest |component| of q into [1/2, 1)
// when q is outside the ordinary range (ordinary_sum); 0 for ordinary, zero and non-finite q.  Multiplying by
// 2**e is exact (no rounding, subnormal components included), so a kernel that is invariant to the scale of q can
// run on 2**e q and be exact for every finite nonzero magnitude, while ordinary input is not touched
// (bit-identical results).  The bound 1000 keeps 2**e a normal double; the smallest subnormal (2**-1074) then
// lands at 2**-74, far inside the ordinary range.
inline int extreme_exponent(double x, double y, double z, double w) {
    const double a = abs_sum(x, y, z, w);
    if (a != a || ordinary_sum(a) || a == 0.0 || a == kInf) return 0;
    const double m = std::max(std::max(std::fabs(x), std::fabs(y)), std::max(std::fabs(z), std::fabs(w)));
    int e;
    std::frexp(m, &e);
    return std::clamp(-e, -1000, 1000);
}
inline int extreme_exponent(Quat q) { return extreme_exponent(q.x, q.y, q.z, q.w); }
inline Quat ldexp4(Quat q, int e) {
    return {std::ldexp(q.x, e), std::ldexp(q.y, e), std::ldexp(q.z, e), std::ldexp(q.w, e)};
}
// q times the power of two that brings its largest |component| into [1/2, 1) (exact; q itself when zero or not
// finite).
inline Quat pow2_unit(Quat q) {
    const double m = std::max(std::max(std::fabs(q.x), std::fabs(q.y)), std::max(std::fabs(q.z), std::fabs(q.w)));
    if (!(m > 0.0 && m < kInf)) return q;  // zero, inf or NaN (NaN: the comparisons are false)
    int e;
    std::frexp(m, &e);
    return ldexp4(q, -e);
}

// 2**e q with e = extreme_exponent(q): q itself unless its magnitude is extreme (see extreme_exponent).
inline Quat ordinary_magnitude(Quat q) {
    const int e = extreme_exponent(q);
    return e == 0 ? q : ldexp4(q, e);
}

// (c, s2) with s2 = 2/|c q|**2, for formulas that need 2/|q|**2 (rotation, matrices, transforms).  For ordinary
// magnitudes c = 1 and s2 = 2/|q|**2; for |q|**2 outside [1e-280, 1e280] c is the power of two of
// extreme_exponent (exact, also for subnormal components) and the caller scales the quaternion (and a dual part)
// by c first.  A zero quaternion gives a quiet NaN; a NaN one propagates.
inline Scale unit_scale(Quat q) {
    const double a = abs_sum(q.x, q.y, q.z, q.w);
    if (ordinary_sum(a)) return {1.0, 2.0 / (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w)};
    if (a != a) return {1.0, a};
    if (a == 0.0 || a == kInf) return {kNaN, kNaN};
    const double c = std::ldexp(1.0, extreme_exponent(q));
    const Quat u = scale(c, q);
    return {c, 2.0 / (u.x * u.x + u.y * u.y + u.z * u.z + u.w * u.w)};
}

// 2/|q|**2 (quiet NaN for a zero quaternion); prefer unit_scale, which also survives |q| ~ 1e-200.
inline double inv_norm2_scale(Quat q) {
    const Scale u = unit_scale(q);
    return u.c == 1.0 ? u.s2 : (u.s2 * u.c) * u.c;  // exact-scaled: 2/|q|**2 = c**2 2/|c q|**2
}

// ln|q|, one branch on |q|**2.  For |q|**2 in [1/2, 2] it is ln(1 + d)/2 with d = (w - 1)(w + 1) + |q_v|**2
// (w - 1 exact), ln(1 + d) by Goldberg's (1991, Thm. 4) ln(u) d/(u - 1), u = 1 + d rounded (d itself when u == 1);
// elsewhere ln(|q|**2)/2, and outside [1e-280, 1e280] the guarded norm.
inline double log_norm(Quat q) {
    const int e = extreme_exponent(q);  // exact rescaling first: ln|q| = ln|2**e q| - e ln 2
    if (e != 0) return log_norm(ldexp4(q, e)) - e * 0.6931471805599453;
    const double s2 = q.x * q.x + q.y * q.y + q.z * q.z;
    const double n2 = s2 + q.w * q.w;
    if (0.5 <= n2 && n2 <= 2.0) {
        const double d = (q.w - 1.0) * (q.w + 1.0) + s2;
        const double u = 1.0 + d;
        const double den = u - 1.0;
        const bool nz = den != 0.0;
        const double f = std::log(u) / (nz ? den : 1.0);
        return 0.5 * d * (nz ? f : 1.0);
    }
    if (kTiny <= n2 && n2 <= kHuge) return 0.5 * std::log(n2);
    return std::log(norm4(q));
}

// Dantam 2014 eqs. (25)-(28) given f = atan2c(|q_v|, w): (f q_v, ln|q|); f = inf (v = 0, w < 0) gives the x axis,
// [π, 0, 0, ln|w|].  A zero q gives NaN (f = NaN).
inline Quat quat_log_parts(Quat q, double f) {
    if (f == kInf) return {kPi, 0.0, 0.0, log_norm(q)};
    return {f * q.x, f * q.y, f * q.z, log_norm(q)};
}

// Row-major rotation matrix of q/|q| (Dantam 2014 eq. (108)); NaN for a zero quaternion.
struct Mat3 {
    double m[9];
    double operator()(int i, int j) const { return m[3 * i + j]; }
};
inline Mat3 rotmat(Quat q) {
    const Scale u = unit_scale(q);
    const double c = u.c, s = u.s2;
    const double x = c * q.x, y = c * q.y, z = c * q.z, w = c * q.w;
    const double xx = s * x * x, yy = s * y * y, zz = s * z * z;
    const double xy = s * x * y, xz = s * x * z, yz = s * y * z;
    const double wx = s * w * x, wy = s * w * y, wz = s * w * z;
    return {{1.0 - (yy + zz), xy - wz, xz + wy, xy + wz, 1.0 - (xx + zz), yz - wx, xz - wy, yz + wx, 1.0 - (xx + yy)}};
}

// R(q/|q|) v for any nonzero q (NaN for zero), without under/overflow for |q| ~ 1e-200 or 1e200.
inline Vec3 rotate_any(Quat q, Vec3 v) {
    const Scale u = unit_scale(q);
    return rotate(scale(u.c, q), v, u.s2);
}

// Unit quaternion (x, y, z, w), w >= 0, of a 3x3 rotation matrix r (row-major, r[3 i + j]): Shepperd's method,
// branching on the largest of (trace, R00, R11, R22).
inline Quat quat_of_rotmat(const double* r) {
    const double r00 = r[0], r11 = r[4], r22 = r[8];
    const double tr = r00 + r11 + r22;
    double x, y, z, w;
    if (tr >= r00 && tr >= r11 && tr >= r22) {
        const double k = std::sqrt(1.0 + tr), h = 0.5 / k;
        x = (r[7] - r[5]) * h, y = (r[2] - r[6]) * h, z = (r[3] - r[1]) * h, w = 0.5 * k;
    } else if (r00 >= r11 && r00 >= r22) {
        const double k = std::sqrt(1.0 + r00 - r11 - r22), h = 0.5 / k;
        x = 0.5 * k, y = (r[1] + r[3]) * h, z = (r[2] + r[6]) * h, w = (r[7] - r[5]) * h;
    } else if (r11 >= r22) {
        const double k = std::sqrt(1.0 - r00 + r11 - r22), h = 0.5 / k;
        x = (r[1] + r[3]) * h, y = 0.5 * k, z = (r[5] + r[7]) * h, w = (r[2] - r[6]) * h;
    } else {
        const double k = std::sqrt(1.0 - r00 - r11 + r22), h = 0.5 / k;
        x = (r[2] + r[6]) * h, y = (r[5] + r[7]) * h, z = 0.5 * k, w = (r[3] - r[1]) * h;
    }
    double n = norm4(x, y, z, w);
    if (w < 0.0) n = -n;
    return {x / n, y / n, z / n, w / n};
}

// True when q is not the canonical representative of ±q (w > 0; ties broken on x, then y, then z).
inline bool flip_sign(Quat q) {
    return q.w < 0.0 || (q.w == 0.0 && (q.x < 0.0 || (q.x == 0.0 && (q.y < 0.0 || (q.y == 0.0 && q.z < 0.0)))));
}

inline bool is_zero4(Quat q) { return q.x == 0.0 && q.y == 0.0 && q.z == 0.0 && q.w == 0.0; }

}  // namespace dualpose
