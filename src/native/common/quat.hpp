// Scalar quaternion formulas (xyzw, Hamilton product): the one copy every kernel uses.
// Plain + - * / and libm sqrt/sin/cos only (no fast-math, no FMA contraction: see CMakeLists.txt), in the same
// order as the numba kernels they replace, so the results agree to the last bit where the tests compare them.
#pragma once

#include <cmath>

namespace dualpose {

struct Vec3 {
    double x, y, z;
};
struct Quat {
    double x, y, z, w;
};

// a (x) b, Hamilton (Dantam 2014 eq. (17)), for any quaternion-like struct QT with members x, y, z, w of an
// arithmetic type (double, or GCC vectors holding one component of several rows: vectorised loops evaluate the same
// expression lane by lane).
template <class QT>
inline QT qmul_t(const QT& a, const QT& b) {
    return {a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y, a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
            a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w, a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z};
}
inline Quat qmul(Quat a, Quat b) { return qmul_t(a, b); }

// o = a (x) b on 4-element buffers; o may not alias a or b.
inline void qmul(const double* a, const double* b, double* o) {
    const Quat r = qmul(Quat{a[0], a[1], a[2], a[3]}, Quat{b[0], b[1], b[2], b[3]});
    o[0] = r.x;
    o[1] = r.y;
    o[2] = r.z;
    o[3] = r.w;
}

// Rotation matrix (3x3, row-major) of a unit quaternion (qx, qy, qz, qw) (Dantam 2014 eq. (108)).
inline void rotmat_xyzw(double qx, double qy, double qz, double qw, double* out) {
    out[0] = 1.0 - 2.0 * (qy * qy + qz * qz);
    out[1] = 2.0 * (qx * qy - qz * qw);
    out[2] = 2.0 * (qx * qz + qy * qw);
    out[3] = 2.0 * (qx * qy + qz * qw);
    out[4] = 1.0 - 2.0 * (qx * qx + qz * qz);
    out[5] = 2.0 * (qy * qz - qx * qw);
    out[6] = 2.0 * (qx * qz - qy * qw);
    out[7] = 2.0 * (qy * qz + qx * qw);
    out[8] = 1.0 - 2.0 * (qx * qx + qy * qy);
}

// q <- normalize(q (x) Exp(r)) for a rotation vector r (radians); q (4,) xyzw.  The local-error injection of the
// error-state filters (Solà 2017 eq. 282), with the Taylor series of sin(a/2)/a and cos(a/2) below a = 1e-4.
inline void quat_mul_exp_inplace(double* q, double rx, double ry, double rz) {
    const double a2 = rx * rx + ry * ry + rz * rz;
    const double a = std::sqrt(a2);
    double s, c;
    if (a < 1e-4) {
        s = 0.5 - a2 / 48.0;
        c = 1.0 - a2 / 8.0;
    } else {
        s = std::sin(0.5 * a) / a;
        c = std::cos(0.5 * a);
    }
    const double bx = s * rx, by = s * ry, bz = s * rz, bw = c;
    const double ax = q[0], ay = q[1], az = q[2], aw = q[3];
    const double x = aw * bx + bw * ax + ay * bz - az * by;
    const double y = aw * by + bw * ay + az * bx - ax * bz;
    const double z = aw * bz + bw * az + ax * by - ay * bx;
    const double w = aw * bw - ax * bx - ay * by - az * bz;
    const double n = std::sqrt(x * x + y * y + z * z + w * w);
    q[0] = x / n;
    q[1] = y / n;
    q[2] = z / n;
    q[3] = w / n;
}

}  // namespace dualpose
