// Dual-quaternion scalars shared by the gufuncs and the inertial folds: normalization, exp, principal log, the
// exponential of a twist and the translation of a dual quaternion (layout [r, d], d = ½ t (x) r).
#pragma once

#include "kutil.hpp"
#include "series.hpp"

#include <cmath>

namespace dualpose {

// S/|S| with the dual-number norm |S| = |r| + ε r·d/|r|: r' = r/|r|, d' = d/|r| - r'(r'·d)/|r|.  Zero r: all NaN.
inline DualQuat dq_normalize(const DualQuat& s_) {
    const int e = extreme_exponent(s_.r);  // the result does not depend on the scale: exact 2**e rescaling
    const DualQuat s = e == 0 ? s_ : DualQuat{ldexp4(s_.r, e), ldexp4(s_.d, e)};
    double n = norm4(s.r);
    if (n == 0.0) n = kNaN;
    const Quat r = {s.r.x / n, s.r.y / n, s.r.z / n, s.r.w / n};
    const Quat d = {s.d.x / n, s.d.y / n, s.d.z / n, s.d.w / n};
    const double m = r.x * d.x + r.y * d.y + r.z * d.z + r.w * d.w;
    return {r, {d.x - m * r.x, d.y - m * r.y, d.z - m * r.z, d.w - m * r.w}};
}

// dq_exp with phi = |r_v| supplied by the caller (dualquat_pow passes |t| atan2(|r_v|, r_w): one rounding).
inline DualQuat dq_exp_angle(double phi, const DualQuat& s) {
    const Quat& r = s.r;
    const Quat& d = s.d;
    const double k = r.x * d.x + r.y * d.y + r.z * d.z;
    const double sc = sinc(phi);
    const double ds = dsinc(phi) * k;
    const double c = std::cos(phi);
    const double e = std::exp(r.w);
    const double ax = sc * r.x, ay = sc * r.y, az = sc * r.z;
    return {{e * ax, e * ay, e * az, e * c},
            {e * (sc * d.x + ds * r.x + d.w * ax), e * (sc * d.y + ds * r.y + d.w * ay),
             e * (sc * d.z + ds * r.z + d.w * az), e * (d.w * c - sc * k)}};
}

// General dual-quaternion exponential, Dantam 2014 eq. (84) with the e**(r_w + ε d_w) factor: phi = |r_v|,
// sin(phi)/phi is sinc (23) and (cos phi - sin(phi)/phi)/phi**2 is dsinc (85).
inline DualQuat dq_exp(const DualQuat& s) { return dq_exp_angle(norm3(s.r.x, s.r.y, s.r.z), s); }

// Principal dual-quaternion logarithm, Dantam 2014 eqs. (86)-(92) (the derivation and the special point
// s = 0, r_w < 0 are documented at dualpose.algebra.dualquat.dualquat_log).  On the unit real part r/|r|, with
// s = |r_v|, phi = atan2(s, r_w), k = r_v·d_v:  (ln S)_r = [(phi/s) r_v, ln|r|],
// (ln S)_d = [(k alpha - d_w) r_v + (phi/s) d_v, k + r_w d_w]; for r_w < 0 the vector is evaluated as
// r_w d_par - d_w r_v + phi (d_perp/s) (no 0·inf as s -> 0).  Zero real part gives NaN.
inline DualQuat dq_log(const DualQuat& s0) {
    if (is_zero4(s0.r)) return {{kNaN, kNaN, kNaN, kNaN}, {kNaN, kNaN, kNaN, kNaN}};
    const double ln = log_norm(s0.r);
    const int e = extreme_exponent(s0.r);  // all but ln|r| are scale-invariant: exact 2**e rescaling
    const DualQuat s_ = e == 0 ? s0 : DualQuat{ldexp4(s0.r, e), ldexp4(s0.d, e)};
    const double n = norm4(s_.r);
    const double rx = s_.r.x / n, ry = s_.r.y / n, rz = s_.r.z / n, rw = s_.r.w / n;
    const double dx = s_.d.x / n, dy = s_.d.y / n, dz = s_.d.z / n, dw = s_.d.w / n;
    const double s = norm3(rx, ry, rz);
    const double k = rx * dx + ry * dy + rz * dz;
    const double dsc = k + rw * dw;  // (90) scalar part: r·d
    if (rw >= 0.0) {
        const double f = atan2c(s, rw);
        const double c = k * dqalpha(std::atan2(s, rw)) - dw;
        return {{f * rx, f * ry, f * rz, ln}, {c * rx + f * dx, c * ry + f * dy, c * rz + f * dz, dsc}};
    }
    const double phi = std::atan2(s, rw);
    if (s == 0.0) {
        const double m = norm3(dx, dy, dz);
        if (m == 0.0) return {{kPi, 0.0, 0.0, ln}, {-dx, -dy, -dz, dsc}};
        const double g = -kPi / (m > 0.0 ? m : 1.0);
        return {{g * dx, g * dy, g * dz, ln}, {-dx, -dy, -dz, dsc}};
    }
    const double ss = s > 0.0 ? s : 1.0;  // s > 0 here (or NaN); keeps speculated divisions flag-free
    const double ux = rx / ss, uy = ry / ss, uz = rz / ss;
    const double kd = ux * dx + uy * dy + uz * dz;
    const double px = (dx - kd * ux) / ss, py = (dy - kd * uy) / ss, pz = (dz - kd * uz) / ss;
    const double a = rw * kd;
    return {{phi * ux, phi * uy, phi * uz, ln},
            {a * ux - dw * rx + phi * px, a * uy - dw * ry + phi * py, a * uz - dw * rz + phi * pz, dsc}};
}

// exp(½(ω + ε v)) for the pure dual quaternion of a twist [ω, v] (Dantam (84) with zero scalar parts).
inline DualQuat dq_exp_twist(Vec3 w, Vec3 v) {
    const double hx = 0.5 * w.x, hy = 0.5 * w.y, hz = 0.5 * w.z;
    const double phi = norm3(hx, hy, hz);
    const double k = 0.5 * (hx * v.x + hy * v.y + hz * v.z);
    const double sc = sinc(phi);
    const double ds = dsinc(phi) * k;
    const double hs = 0.5 * sc;
    return {{sc * hx, sc * hy, sc * hz, std::cos(phi)},
            {hs * v.x + ds * hx, hs * v.y + ds * hy, hs * v.z + ds * hz, -sc * k}};
}

// t = 2 vec(d (x) r*)/|r|**2 = s2 (r_w d_v - d_w r_v + r_v x d_v)  (Dantam 2014 eq. (78), Walker 1991 (19)/(67)).
inline Vec3 dq_translation(const DualQuat& s, double s2) {
    const Vec3 c = cross({s.r.x, s.r.y, s.r.z}, {s.d.x, s.d.y, s.d.z});
    return {s2 * (s.r.w * s.d.x - s.d.w * s.r.x + c.x), s2 * (s.r.w * s.d.y - s.d.w * s.r.y + c.y),
            s2 * (s.r.w * s.d.z - s.d.w * s.r.z + c.z)};
}

}  // namespace dualpose
