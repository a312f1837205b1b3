// Distorted pinhole cameras, one point at a time: radial-tangential (OpenCV / Kalibr "radtan") and equidistant
// (Kannala-Brandt, OpenCV fisheye, Kalibr "equi").  The equations and conventions are those of
// dualpose.types.camera_models (docs/cameras.md); these scalar formulas are what its methods run (the gufuncs of
// types/cameras.cpp) and what any kernel that projects through a distorted camera calls.
//
// Parameters p[8] = {fx, fy, cx, cy, d1, d2, d3, d4}: radtan d = {k1, k2, p1, p2}, equi d = {k1, k2, k3, k4}.
// Matrices are row-major: d pixel / d point (2x3), d pixel / d p (2x8), d distorted / d undistorted (2x2).
#pragma once

#include "series.hpp"

#include <algorithm>
#include <cmath>

namespace dualpose {
namespace camera {

constexpr double kUndistortTolerance = 1e-12;  // largest accepted residual |distort(x) - x_d| (max norm)
constexpr int kUndistortMaxIterations = 50;
constexpr double kStepDone = 1e-14;  // a Newton step below this ends the iteration

// ---------------------------------------------------------------------------------------------- radtan

// Distorted normalised (o[0], o[1]) of (x, y); J (2x2) d/d(x, y) and Jk (2x4) d/d(k1, k2, p1, p2) when not null.
inline void radtan_distort(const double* d, double x, double y, double* o, double* J, double* Jk) {
    const double k1 = d[0], k2 = d[1], p1 = d[2], p2 = d[3];
    const double x2 = x * x, y2 = y * y, xy = x * y;
    const double r2 = x2 + y2;
    const double radial = 1.0 + r2 * (k1 + k2 * r2);
    o[0] = x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2);
    o[1] = y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy;
    if (J != nullptr) {
        const double dr = 2.0 * (k1 + 2.0 * k2 * r2);
        J[0] = radial + x2 * dr + 2.0 * p1 * y + 6.0 * p2 * x;
        J[1] = xy * dr + 2.0 * p1 * x + 2.0 * p2 * y;
        J[2] = J[1];
        J[3] = radial + y2 * dr + 6.0 * p1 * y + 2.0 * p2 * x;
    }
    if (Jk != nullptr) {
        Jk[0] = x * r2;
        Jk[1] = x * r2 * r2;
        Jk[2] = 2.0 * xy;
        Jk[3] = r2 + 2.0 * x2;
        Jk[4] = y * r2;
        Jk[5] = y * r2 * r2;
        Jk[6] = r2 + 2.0 * y2;
        Jk[7] = 2.0 * xy;
    }
}

// Distorted normalised o (2) of the camera-frame point P (Z > 0); J3 (2x3) d/dP and Jk (2x4) when not null.
inline void radtan_point(const double* d, const double* P, double* o, double* J3, double* Jk) {
    const double iz = 1.0 / P[2];
    const double x = P[0] * iz, y = P[1] * iz;
    if (J3 == nullptr) {
        radtan_distort(d, x, y, o, nullptr, Jk);
        return;
    }
    double J[4];
    radtan_distort(d, x, y, o, J, Jk);
    for (int r = 0; r < 2; ++r) {
        J3[3 * r + 0] = J[2 * r + 0] * iz;
        J3[3 * r + 1] = J[2 * r + 1] * iz;
        J3[3 * r + 2] = -(J[2 * r + 0] * x + J[2 * r + 1] * y) * iz;
    }
}

// One Newton step on the 2x2 Jacobian towards distort(x, y) = xd; returns the step's size (max norm; NaN at a
// singular Jacobian).
inline double radtan_newton_step(const double* d, const double* xd, double& x, double& y) {
    double o[2], J[4];
    radtan_distort(d, x, y, o, J, nullptr);
    const double ex = o[0] - xd[0], ey = o[1] - xd[1];
    const double det = J[0] * J[3] - J[1] * J[2];
    const double sx = (J[3] * ex - J[1] * ey) / det;
    const double sy = (J[0] * ey - J[2] * ex) / det;
    x -= sx;
    y -= sy;
    return std::max(std::fabs(sx), std::fabs(sy));
}

// Whether (x, y) undistorts xd: residual within kUndistortTolerance, positive Jacobian determinant, r² < max_r2.
inline bool radtan_inverse_valid(const double* d, double max_r2, const double* xd, double x, double y) {
    double o[2], J[4];
    radtan_distort(d, x, y, o, J, nullptr);
    const double resid = std::max(std::fabs(o[0] - xd[0]), std::fabs(o[1] - xd[1]));
    return resid <= kUndistortTolerance && J[0] * J[3] - J[1] * J[2] > 0.0 && x * x + y * y < max_r2;
}

// ---------------------------------------------------------------------------------------------- equidistant

// θ_d/θ = 1 + k1 θ² + ... + k4 θ⁸ and dθ_d/dθ = 1 + 3 k1 θ² + ... + 9 k4 θ⁸ at θ² = t2.
inline void equi_poly(const double* k, double t2, double* poly, double* dpoly) {
    *poly = 1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
    *dpoly = 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
}

// o = θ_d (X, Y)/ρ with θ = atan2(ρ, Z), ρ = |(X, Y)|; J3 (2x3) d/d(X, Y, Z) and Jk (2x4) d/d(k1..k4) when not
// null.  θ_d/ρ = atan2c(ρ, Z) (θ_d/θ) through the guarded series at ρ = 0; d/d(X, Y) = s I + c n nᵀ with n the unit
// direction of (X, Y) and c = θ_d'(θ) Z/(ρ² + Z²) - s, which vanishes at ρ = 0.
inline void equi_point(const double* k, double X, double Y, double Z, double* o, double* J3, double* Jk) {
    const double rho = std::hypot(X, Y);
    const double a = atan2c(rho, Z);
    const double theta = rho * a;
    const double t2 = theta * theta;
    double poly, dpoly;
    equi_poly(k, t2, &poly, &dpoly);
    const double s = a * poly;
    o[0] = X * s;
    o[1] = Y * s;
    if (J3 != nullptr) {
        const double q = rho * rho + Z * Z;
        const double c = dpoly * Z / q - s;
        const double nx = rho > 0.0 ? X / rho : 0.0;
        const double ny = rho > 0.0 ? Y / rho : 0.0;
        const double dz = -dpoly / q;
        J3[0] = s + c * nx * nx;
        J3[1] = c * nx * ny;
        J3[2] = X * dz;
        J3[3] = J3[1];
        J3[4] = s + c * ny * ny;
        J3[5] = Y * dz;
    }
    if (Jk != nullptr) {
        double power = a * t2;  // θ^(2i+1)/ρ
        for (int i = 0; i < 4; ++i) {
            Jk[i] = X * power;
            Jk[4 + i] = Y * power;
            power = power * t2;
        }
    }
}

// One Newton step on θ_d(θ) = rd, clamped to [0, max_theta]; returns the step's size.
inline double equi_newton_step(const double* k, double max_theta, double rd, double& theta) {
    double poly, dpoly;
    equi_poly(k, theta * theta, &poly, &dpoly);
    const double step = (theta * poly - rd) / dpoly;
    theta = std::min(std::max(theta - step, 0.0), max_theta);
    return std::fabs(step);
}

// Whether θ solves θ_d(θ) = rd within kUndistortTolerance below max_theta; *poly = θ_d/θ at θ.
inline bool equi_inverse_valid(const double* k, double max_theta, double rd, double theta, double* poly) {
    double dpoly;
    equi_poly(k, theta * theta, poly, &dpoly);
    return std::fabs(theta * *poly - rd) <= kUndistortTolerance && theta < max_theta;
}

// Undistorted normalised xy = tan θ n = xd (sinc θ / cos θ)/(θ_d/θ) of xd at θ.
inline void equi_undistorted_from_theta(double theta, double poly, const double* xd, double* xy) {
    const double f = sinc(theta) / (std::cos(theta) * poly);
    xy[0] = xd[0] * f;
    xy[1] = xd[1] * f;
}

// Unit ray (sin θ n, cos θ) = (xd sinc θ/(θ_d/θ), cos θ) of xd at θ.
inline void equi_ray_from_theta(double theta, double poly, const double* xd, double* ray) {
    const double f = sinc(theta) / poly;
    ray[0] = xd[0] * f;
    ray[1] = xd[1] * f;
    ray[2] = std::cos(theta);
}

// ---------------------------------------------------------------------------------------------- inversion

// Points inverted together: their Newton iterations are independent, so the CPU overlaps them.
constexpr int kBlock = 8;

// Runs step(j) for the m <= kBlock points of a block in lockstep, each point until its own step is below kStepDone
// (a NaN step ends it too) or kUndistortMaxIterations: point for point the iteration of a single-point loop.
template <class Step>
inline void newton_block(int m, Step step) {
    bool active[kBlock];
    for (int j = 0; j < m; ++j) active[j] = true;
    for (int it = 0; it < kUndistortMaxIterations; ++it) {
        bool any = false;
        for (int j = 0; j < m; ++j) {
            if (!active[j]) continue;
            active[j] = step(j) > kStepDone;
            any |= active[j];
        }
        if (!any) break;
    }
}

// Undistorted normalised xy[j] of distorted normalised xd[j] (j < m): Newton from xy = xd; ok[j] radtan_inverse_valid.
inline void radtan_undistort_block(const double* d, double max_r2, const double (*xd)[2], int m, double (*xy)[2],
                                   bool* ok) {
    for (int j = 0; j < m; ++j) xy[j][0] = xd[j][0], xy[j][1] = xd[j][1];
    newton_block(m, [&](int j) { return radtan_newton_step(d, xd[j], xy[j][0], xy[j][1]); });
    for (int j = 0; j < m; ++j) ok[j] = radtan_inverse_valid(d, max_r2, xd[j], xy[j][0], xy[j][1]);
}

// θ[j] of distorted normalised xd[j] (j < m): Newton on θ_d(θ) = |xd| from θ = min(|xd|, max_theta); poly[j] = θ_d/θ
// there; ok[j] equi_inverse_valid.
inline void equi_theta_block(const double* k, double max_theta, const double (*xd)[2], int m, double* theta,
                             double* poly, bool* ok) {
    double rd[kBlock];
    for (int j = 0; j < m; ++j) {
        rd[j] = std::hypot(xd[j][0], xd[j][1]);
        theta[j] = std::min(rd[j], max_theta);
    }
    newton_block(m, [&](int j) { return equi_newton_step(k, max_theta, rd[j], theta[j]); });
    for (int j = 0; j < m; ++j) ok[j] = equi_inverse_valid(k, max_theta, rd[j], theta[j], &poly[j]);
}

}  // namespace camera
}  // namespace dualpose
