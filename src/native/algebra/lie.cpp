// SO(3)/SE(3) gufuncs: the kernels behind dualpose.algebra.lie (twists are [ω, v]).  Flags are float scalars:
// sgn (+1 left Jacobian, -1 right Jacobian: the right Jacobian is the left one at the negated argument), inv (0 the
// Jacobian, 1 its inverse).  Every removable singularity goes through the guarded series (common/series.hpp).
#include "../common/gufunc.hpp"
#include "../common/lie.hpp"
#include "parts.hpp"

#include <cmath>

namespace dualpose {

namespace {

void so3_jacobian(const double* phi, const double* sgn, const double* inv, double* o) {
    const Vec3 p = {sgn[0] * phi[0], sgn[0] * phi[1], sgn[0] * phi[2]};
    so3_fill(p, so3_coeffs(norm3(p), inv[0]), o, 3);
}

void so3_jacobian_apply(const double* phi, const double* u, const double* sgn, const double* inv, double* o) {
    const Vec3 p = {sgn[0] * phi[0], sgn[0] * phi[1], sgn[0] * phi[2]};
    store(o, so3_apply(p, so3_coeffs(norm3(p), inv[0]), load3(u)));
}

// Rodrigues: R = cos θ I + sinc θ Φ + cosc2 θ φφᵀ
void so3_exp(const double* phi, double* o) {
    const Vec3 p = load3(phi);
    const double th = norm3(p);
    so3_fill(p, {std::cos(th), sinc(th), cosc2(th)}, o, 3);
}

void se3_exp(const double* xi, double* r, double* t) {
    const Vec3 w = load3(xi);
    const double th = norm3(w);
    so3_fill(w, {std::cos(th), sinc(th), cosc2(th)}, r, 3);
    store(t, so3_apply(w, so3_coeffs(th, 0.0), load3(xi + 3)));
}

// [[J, 0], [Q, J]] or [[J⁻¹, 0], [−J⁻¹ Q J⁻¹, J⁻¹]], J = J_l(ω), at sgn * xi (Barfoot 2017, eqs. (7.85)-(7.86))
void se3_jacobian(const double* xi, const double* sgn, const double* invp, double* o) {
    const double s = sgn[0], inv = invp[0];
    const Vec3 w = {s * xi[0], s * xi[1], s * xi[2]};
    const Vec3 v = {s * xi[3], s * xi[4], s * xi[5]};
    const double th = norm3(w);
    const double c1 = sinc3(th), c2 = cosc4(th), c3 = se3c(th);
    const So3Coeffs k = so3_coeffs(th, inv);
    so3_fill(w, k, o, 6, 0, 0);
    so3_fill(w, k, o, 6, 3, 3);
    for (int j = 0; j < 3; ++j) {
        o[0 * 6 + 3 + j] = o[1 * 6 + 3 + j] = o[2 * 6 + 3 + j] = 0.0;
        Vec3 x = {o[0 * 6 + j], o[1 * 6 + j], o[2 * 6 + j]};  // column j of J (or J⁻¹)
        if (inv == 0.0) x = {j == 0 ? 1.0 : 0.0, j == 1 ? 1.0 : 0.0, j == 2 ? 1.0 : 0.0};
        Vec3 y = barfoot_q_apply(w, v, c1, c2, c3, x);
        if (inv != 0.0) {
            y = so3_apply(w, k, y);
            y = {-y.x, -y.y, -y.z};
        }
        o[3 * 6 + j] = y.x;
        o[4 * 6 + j] = y.y;
        o[5 * 6 + j] = y.z;
    }
}

// [[R, 0], [t× R, R]] for [ω, v] twists; R normalizes q (2/|q|² scale)
void se3_adjoint(const double* q, const double* t, double* o) {
    const Mat3 m = rotmat(load4(q));
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) o[6 * i + j] = m(i, j);
    for (int j = 0; j < 3; ++j) {
        const Vec3 r = {o[0 * 6 + j], o[1 * 6 + j], o[2 * 6 + j]};
        const Vec3 c = cross(load3(t), r);
        o[3 * 6 + j] = c.x;
        o[4 * 6 + j] = c.y;
        o[5 * 6 + j] = c.z;
        o[3 * 6 + 3 + j] = r.x;
        o[4 * 6 + 3 + j] = r.y;
        o[5 * 6 + 3 + j] = r.z;
        o[0 * 6 + 3 + j] = o[1 * 6 + 3 + j] = o[2 * 6 + 3 + j] = 0.0;
    }
}

using V3 = V<3>;
using M3 = M<3, 3>;
using M6 = M<6, 6>;

}  // namespace

bool add_lie_gufuncs(PyObject* m) {
    return add_gufunc<Gufunc<so3_jacobian, In<V3, S, S>, Out<M3>>>(m, "so3_jacobian",
                                                                   "SO(3) left/right Jacobian or its inverse.") &&
           add_gufunc<Gufunc<so3_jacobian_apply, In<V3, V3, S, S>, Out<V3>>>(m, "so3_jacobian_apply",
                                                                             "SO(3) Jacobian (or inverse) times u.") &&
           add_gufunc<Gufunc<so3_exp, In<V3>, Out<M3>>>(m, "so3_exp", "Rodrigues' rotation matrix.") &&
           add_gufunc<Gufunc<se3_exp, In<V<6>>, Out<M3, V3>>>(m, "se3_exp", "SE(3) exponential as (R, t).") &&
           add_gufunc<Gufunc<se3_jacobian, In<V<6>, S, S>, Out<M6>>>(m, "se3_jacobian",
                                                                     "SE(3) left/right Jacobian or its inverse.") &&
           add_gufunc<Gufunc<se3_adjoint, In<V<4>, V3>, Out<M6>>>(m, "se3_adjoint", "SE(3) adjoint of (q, t).") &&
           add_implicit_gufuncs(m) && add_derivative_gufuncs(m);
}

}  // namespace dualpose
