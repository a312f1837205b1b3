// Scalar quaternion formulas (xyzw, Hamilton product): the one copy every kernel uses.
#pragma once

namespace dualpose {

// a (x) b  (Dantam 2014 eq. (17)); out may alias neither a nor b.
inline void qmul(const double* a, const double* b, double* o) {
    const double ax = a[0], ay = a[1], az = a[2], aw = a[3];
    const double bx = b[0], by = b[1], bz = b[2], bw = b[3];
    o[0] = aw * bx + ax * bw + ay * bz - az * by;
    o[1] = aw * by - ax * bz + ay * bw + az * bx;
    o[2] = aw * bz + ax * by - ay * bx + az * bw;
    o[3] = aw * bw - ax * bx - ay * by - az * bz;
}

}  // namespace dualpose
