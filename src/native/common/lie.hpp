// SO(3)/SE(3) scalars shared by the Lie gufuncs, the inertial folds and the smoother: the coefficients of the left
// Jacobian and its inverse, a I + b [φ]× + c φφᵀ as a matrix block or applied to a vector, Barfoot's Q applied to
// a vector, and the terms of the principal-log Jacobian.
#pragma once

#include "kutil.hpp"
#include "series.hpp"

#include <cmath>
#include <cstddef>

namespace dualpose {

// exp(v/2) = (sin(|v|/2) v/|v|, cos(|v|/2)): the unit quaternion of the rotation vector v (Dantam 2014 eq. (50)),
// with the guarded sinc, exact at v = 0.
inline Quat quat_exp_rotvec(Vec3 v) {
    const double h = 0.5 * norm3(v.x, v.y, v.z);
    const double f = 0.5 * sinc(h);
    return {f * v.x, f * v.y, f * v.z, std::cos(h)};
}


// ln q for any q: quat_log_parts on 2**e q (extreme_exponent) for the vector part, which does not depend on the
// scale, and ln|q| for the scalar part (log_norm is exact-scaled itself).  Ordinary q: the formula unchanged.
inline Quat quat_log_any(Quat q) {
    const Quat u = ordinary_magnitude(q);
    const double s = norm3(u.x, u.y, u.z);
    Quat o = quat_log_parts(u, atan2c(s, u.w));
    o.w = log_norm(q);
    return o;
}

// The rotation vector of q with the angle in [0, π] (the sign of q chosen so that w >= 0): 2 ln(±q), Dantam 2014
// eqs. (51)-(53) with the atan2 angle (atan2c: exact at q_v = 0; NaN for a zero q).
inline Vec3 rotvec_of_quat(Quat q) {
    q = ordinary_magnitude(q);  // scale-invariant: exact for subnormal and huge magnitudes too
    if (q.w < 0.0) q = neg(q);
    const double f = 2.0 * atan2c(norm3(q.x, q.y, q.z), q.w);
    return {f * q.x, f * q.y, f * q.z};
}

struct So3Coeffs {
    double a, b, c;
};

// (a, b, c) with J = a I + b Φ + c φφᵀ: the left Jacobian (inv == 0) or its inverse (inv != 0) at |φ| = th.
// J_l = I + cosc2 Φ + sinc3 Φ² and Φ² = φφᵀ − θ² I give a = 1 − θ² sinc3 = sinc(θ);
// J_l⁻¹ = I − Φ/2 + jinv Φ² gives a = 1 − θ² jinv = (θ/2) cot(θ/2) = cos(θ/2) / sinc(θ/2).
inline So3Coeffs so3_coeffs(double th, double inv) {
    if (inv == 0.0) return {sinc(th), cosc2(th), sinc3(th)};
    const double h = 0.5 * th;
    return {std::cos(h) / sinc(h), -0.5, jinv(th)};
}

// o[(r0 + i) * ld + c0 + j] = (a I + b [φ]× + c φφᵀ)[i][j], φ = (x, y, z); ld is the row length of o.
inline void so3_fill(double x, double y, double z, double a, double b, double c, double* o, std::ptrdiff_t ld,
                     std::ptrdiff_t r0 = 0, std::ptrdiff_t c0 = 0) {
    double* p0 = o + r0 * ld + c0;
    double* p1 = p0 + ld;
    double* p2 = p1 + ld;
    p0[0] = a + c * x * x;
    p0[1] = -b * z + c * x * y;
    p0[2] = b * y + c * x * z;
    p1[0] = b * z + c * y * x;
    p1[1] = a + c * y * y;
    p1[2] = -b * x + c * y * z;
    p2[0] = -b * y + c * z * x;
    p2[1] = b * x + c * z * y;
    p2[2] = a + c * z * z;
}
inline void so3_fill(Vec3 p, So3Coeffs k, double* o, std::ptrdiff_t ld, std::ptrdiff_t r0 = 0,
                     std::ptrdiff_t c0 = 0) {
    so3_fill(p.x, p.y, p.z, k.a, k.b, k.c, o, ld, r0, c0);
}

// (a I + b [φ]× + c φφᵀ) u.
inline Vec3 so3_apply(Vec3 p, So3Coeffs k, Vec3 u) {
    const Vec3 cr = cross(p, u);
    const double d = k.c * (p.x * u.x + p.y * u.y + p.z * u.z);
    return {k.a * u.x + k.b * cr.x + d * p.x, k.a * u.y + k.b * cr.y + d * p.y, k.a * u.z + k.b * cr.z + d * p.z};
}

// Q(ω, v) x by cross products, with Barfoot's Q (Barfoot 2017, eq. (7.86), in [ω, v] order):
// Q = ½V + c1 (ΦV + VΦ + ΦVΦ) + c2 (ΦΦV + VΦΦ − 3ΦVΦ) + c3 (ΦVΦΦ + ΦΦVΦ),
// Φ = [ω]×, V = [v]×, c1 = sinc3(θ), c2 = cosc4(θ), c3 = se3c(θ), θ = |ω|.
inline Vec3 barfoot_q_apply(Vec3 w, Vec3 v, double c1, double c2, double c3, Vec3 x) {
    const Vec3 a = cross(w, x);       // Φx
    const Vec3 b = cross(v, x);       // Vx
    const Vec3 ab = cross(w, b);      // ΦVx
    const Vec3 ba = cross(v, a);      // VΦx
    const Vec3 aba = cross(w, ba);    // ΦVΦx
    const Vec3 aab = cross(w, ab);    // ΦΦVx
    const Vec3 aa = cross(w, a);      // ΦΦx
    const Vec3 baa = cross(v, aa);    // VΦΦx
    const Vec3 abaa = cross(w, baa);  // ΦVΦΦx
    const Vec3 aaba = cross(w, aba);  // ΦΦVΦx
    return {
        0.5 * b.x + c1 * (ab.x + ba.x + aba.x) + c2 * (aab.x + baa.x - 3.0 * aba.x) + c3 * (abaa.x + aaba.x),
        0.5 * b.y + c1 * (ab.y + ba.y + aba.y) + c2 * (aab.y + baa.y - 3.0 * aba.y) + c3 * (abaa.y + aaba.y),
        0.5 * b.z + c1 * (ab.z + ba.z + aba.z) + c2 * (aab.z + baa.z - 3.0 * aba.z) + c3 * (abaa.z + aaba.z),
    };
}

// Vector part of a (x) [t, 0] (x) b*.
inline Vec3 qvec_sandwich(Quat a, Vec3 t, Quat b) {
    const Quat p = qmul(a, {t.x, t.y, t.z, 0.0});
    const Quat r = qmul(p, conj(b));
    return {r.x, r.y, r.z};
}

// Terms of the principal-log Jacobian: n = |q|, u = q_v/n, wh = w/n, g = φ/|q_v| (atan2c), a = dqalpha(φ).
// For w > 0 (φ < π/2) a comes from the guarded series; for w <= 0 the closed form (ŵ ŝ − φ)/ŝ³ with ŝ = |v|/n
// has no cancellation and keeps its accuracy up to the pole at π.  Zero q or the negative real axis: all NaN.
struct LogJacTerms {
    double n, ux, uy, uz, wh, g, a;
};
inline LogJacTerms log_jac_terms(Quat q) {
    const double n = norm4(q);
    const double s = norm3(q.x, q.y, q.z);
    if (n == 0.0 || (s == 0.0 && q.w < 0.0)) return {kNaN, kNaN, kNaN, kNaN, kNaN, kNaN, kNaN};
    const double ux = q.x / n, uy = q.y / n, uz = q.z / n, wh = q.w / n;
    const double g = atan2c(s, q.w);
    const double ph = std::atan2(s, q.w);
    double a;
    if (q.w > 0.0) {
        a = dqalpha(ph);
    } else {
        const double sh = s / n;
        a = (wh * sh - ph) / (sh * sh * sh);
    }
    return {n, ux, uy, uz, wh, g, a};
}

}  // namespace dualpose
