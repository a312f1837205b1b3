// The N-sample rotation-vector and screw-vector updates and their exponentials (Adv. Mech. Eng. 2019, "Research on
// the rigid body pose estimation using dual quaternions", eqs. (17)-(21) and (25)-(31); docs/inertial.md §2).
// Quaternions xyzw (Hamilton); dual quaternions [real xyzw, dual xyzw] with dual = ½ t (x) real; screw vectors
// [σ, σ′].  The arithmetic is the algebra's (common/kutil.hpp, lie.hpp, series.hpp).
#pragma once

#include "../common/kutil.hpp"
#include "../common/lie.hpp"
#include "../common/series.hpp"

#include <cmath>
#include <cstdint>

namespace dualpose::inertial {

// A rotation / screw vector: σ, and σ′ (zero for width 3).
struct Screw {
    Vec3 s, t;
};

// Rotation / screw vector of update k from the rows x[k n : k n + n] of width W (3: [θ]; 6: [θ, u]):
// Σ x_i + sgn Σ_{i<j} kmat[i, j] x_i × x_j (the dual cross product for width 6), plus sgn cprev x_{kn−1} × x_{kn}
// (one-plus-previous; x_{−1} = 0).
template <int W>
inline Screw update_vector(const double* x, std::int64_t k, int n, const double* kmat, double cprev, double sgn) {
    const std::int64_t base = k * n;
    double sx = 0.0, sy = 0.0, sz = 0.0, tx = 0.0, ty = 0.0, tz = 0.0;
    for (int i = 0; i < n; ++i) {
        const double* r = x + (base + i) * W;
        sx += r[0];
        sy += r[1];
        sz += r[2];
        if constexpr (W == 6) {
            tx += r[3];
            ty += r[4];
            tz += r[5];
        }
    }
    for (int i = 0; i < n + 1; ++i) {
        for (int j = i + 1; j < n + 1; ++j) {
            // i == 0 is the previous sample (coefficient cprev, paired with the first sample only)
            double c;
            if (i == 0)
                c = (j == 1 && base > 0) ? cprev : 0.0;
            else
                c = kmat[(i - 1) * n + (j - 1)];
            if (c == 0.0) continue;
            c *= sgn;
            const double* a = x + (base + i - 1) * W;
            const double* b = x + (base + j - 1) * W;
            const Vec3 cr = cross({a[0], a[1], a[2]}, {b[0], b[1], b[2]});
            sx += c * cr.x;
            sy += c * cr.y;
            sz += c * cr.z;
            if constexpr (W == 6) {
                const Vec3 e = cross({a[0], a[1], a[2]}, {b[3], b[4], b[5]});
                const Vec3 f = cross({a[3], a[4], a[5]}, {b[0], b[1], b[2]});
                tx += c * (e.x + f.x);
                ty += c * (e.y + f.y);
                tz += c * (e.z + f.z);
            }
        }
    }
    return {{sx, sy, sz}, {tx, ty, tz}};
}

// exp(Φ̂/2) for the screw vector Φ̂ = σ + εσ′: r = exp(σ/2), dual = ½ Δt (x) r with Δt = J_l(σ) σ′.
inline DualQuat screw_half_exp(const Screw& v) {
    const Quat r = quat_exp_rotvec(v.s);
    const Vec3 d = so3_apply(v.s, so3_coeffs(norm3(v.s), 0.0), v.t);
    return {r, qmul(Quat{0.5 * d.x, 0.5 * d.y, 0.5 * d.z, 0.0}, r)};
}

}  // namespace dualpose::inertial
