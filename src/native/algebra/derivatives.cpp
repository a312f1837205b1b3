// Quaternion calculus (Dantam 2014 §II-I, II-J, III-C, III-D): the kernels behind dualpose.algebra.derivatives.
// ``body`` is a float flag: 0 space frame, 1 body frame.
#include "../common/gufunc.hpp"
#include "../common/lie.hpp"
#include "parts.hpp"

#include <cmath>

namespace dualpose {

namespace {

Quat pure(const double* w) { return {w[0], w[1], w[2], 0.0}; }

// Dantam 2014 eq. (46): ½ ω (x) q (space) or ½ q (x) ω (body)
void quat_derivative(const double* q, const double* w, const double* body, double* o) {
    const Quat r = body[0] == 0.0 ? qmul(pure(w), load4(q)) : qmul(load4(q), pure(w));
    store(o, scale(0.5, r));
}

// Dantam 2014 eq. (47): 2 vec(q̇ (x) q*) / |q|² (space) or 2 vec(q* (x) q̇) / |q|² (body)
void omega_from_quat_derivative(const double* q, const double* qd, const double* body, double* o) {
    const double s2 = inv_norm2_scale(load4(q));
    const Quat c = conj(load4(q));
    const Quat r = body[0] == 0.0 ? qmul(load4(qd), c) : qmul(c, load4(qd));
    store(o, Vec3{s2 * r.x, s2 * r.y, s2 * r.z});
}

// Dantam 2014 eq. (48): ½ (ω̇ (x) q + ω (x) q̇) with q̇ = ½ ω (x) q (space); mirrored for the body frame
void quat_second_derivative(const double* q, const double* w, const double* wd, const double* body, double* o) {
    Quat a, b;
    if (body[0] == 0.0) {
        a = qmul(pure(wd), load4(q));
        b = qmul(pure(w), qmul(pure(w), load4(q)));
    } else {
        a = qmul(load4(q), pure(wd));
        b = qmul(qmul(load4(q), pure(w)), pure(w));
    }
    store(o, Quat{0.5 * a.x + 0.25 * b.x, 0.5 * a.y + 0.25 * b.y, 0.5 * a.z + 0.25 * b.z, 0.5 * a.w + 0.25 * b.w});
}

// d/dt of 2 vec(q̇ (x) q*)/|q|²; for |q| = 1 this is Dantam 2014 eq. (49): ω̇ = 2 vec(q̈ (x) q*)
void angular_acceleration_from_quat(const double* q, const double* qd, const double* qdd, const double* body,
                                    double* o) {
    const double s2 = inv_norm2_scale(load4(q));
    const Quat c = conj(load4(q));
    Quat a, b;
    if (body[0] == 0.0) {
        a = qmul(load4(qdd), c);
        b = qmul(load4(qd), c);
    } else {
        a = qmul(c, load4(qdd));
        b = qmul(c, load4(qd));
    }
    const double k = s2 * (q[0] * qd[0] + q[1] * qd[1] + q[2] * qd[2] + q[3] * qd[3]);
    store(o, Vec3{s2 * (a.x - k * b.x), s2 * (a.y - k * b.y), s2 * (a.z - k * b.z)});
}

// Dantam 2014 eqs. (32)-(37) times e^w, plus ẇ e^q
void quat_exp_derivative(const double* q, const double* qd, double* o) {
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const double ph = norm3(x, y, z);
    const double e = std::exp(w);
    const double sc = sinc(ph);
    const double ds = dsinc(ph);
    const double vd = x * qd[0] + y * qd[1] + z * qd[2];
    const double wd = qd[3];
    const double f = wd * sc + ds * vd;
    store(o, Quat{e * (sc * qd[0] + f * x), e * (sc * qd[1] + f * y), e * (sc * qd[2] + f * z),
                  e * (wd * std::cos(ph) - vd * sc)});
}

void quat_exp_jacobian(const double* q, double* o) {
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    const double ph = norm3(x, y, z);
    const double e = std::exp(w);
    const double sc = e * sinc(ph);
    const double ds = e * dsinc(ph);
    so3_fill(x, y, z, sc, 0.0, ds, o, 4);
    o[3] = sc * x, o[7] = sc * y, o[11] = sc * z;
    o[12] = -sc * x, o[13] = -sc * y, o[14] = -sc * z;
    o[15] = e * std::cos(ph);
}

void quat_log_jacobian(const double* q, double* o) {
    const LogJacTerms k = log_jac_terms(load4(q));
    so3_fill(k.ux, k.uy, k.uz, k.g, 0.0, k.a / k.n, o, 4);
    o[3] = -k.ux / k.n, o[7] = -k.uy / k.n, o[11] = -k.uz / k.n;
    o[12] = k.ux / k.n, o[13] = k.uy / k.n, o[14] = k.uz / k.n;
    o[15] = k.wh / k.n;
}

void quat_log_derivative(const double* q, const double* qd, double* o) {
    const LogJacTerms k = log_jac_terms(load4(q));
    const double uv = k.ux * qd[0] + k.uy * qd[1] + k.uz * qd[2];
    const double f = (k.a * uv - qd[3]) / k.n;
    store(o, Quat{k.g * qd[0] + f * k.ux, k.g * qd[1] + f * k.uy, k.g * qd[2] + f * k.uz, (uv + k.wh * qd[3]) / k.n});
}

// Dantam 2014 eqs. (54)-(57) with y = v/2, ẏ = v̇/2, φ = |y|
void quat_derivative_from_rotvec_rate(const double* v, const double* vd, double* o) {
    const double yx = 0.5 * v[0], yy = 0.5 * v[1], yz = 0.5 * v[2];
    const double dx = 0.5 * vd[0], dy = 0.5 * vd[1], dz = 0.5 * vd[2];
    const double ph = norm3(yx, yy, yz);
    const double sc = sinc(ph);
    const double yd = yx * dx + yy * dy + yz * dz;
    const double f = dsinc(ph) * yd;
    store(o, Quat{sc * dx + f * yx, sc * dy + f * yy, sc * dz + f * yz, -yd * sc});
}

using Q = V<4>;
using V3 = V<3>;

}  // namespace

bool add_derivative_gufuncs(PyObject* m) {
    return add_gufunc<Gufunc<quat_derivative, In<Q, V3, S>, Out<Q>>>(m, "quat_derivative", "q̇ from ω.") &&
           add_gufunc<Gufunc<omega_from_quat_derivative, In<Q, Q, S>, Out<V3>>>(m, "omega_from_quat_derivative",
                                                                                "ω from q̇.") &&
           add_gufunc<Gufunc<quat_second_derivative, In<Q, V3, V3, S>, Out<Q>>>(m, "quat_second_derivative",
                                                                                "q̈ from ω, ω̇.") &&
           add_gufunc<Gufunc<angular_acceleration_from_quat, In<Q, Q, Q, S>, Out<V3>>>(
               m, "angular_acceleration_from_quat", "ω̇ from q, q̇, q̈.") &&
           add_gufunc<Gufunc<quat_exp_derivative, In<Q, Q>, Out<Q>>>(m, "quat_exp_derivative", "d/dt e^q.") &&
           add_gufunc<Gufunc<quat_exp_jacobian, In<Q>, Out<M<4, 4>>>>(m, "quat_exp_jacobian", "∂ e^q / ∂q.") &&
           add_gufunc<Gufunc<quat_log_jacobian, In<Q>, Out<M<4, 4>>>>(m, "quat_log_jacobian", "∂ ln q / ∂q.") &&
           add_gufunc<Gufunc<quat_log_derivative, In<Q, Q>, Out<Q>>>(m, "quat_log_derivative", "d/dt ln q.") &&
           add_gufunc<Gufunc<quat_derivative_from_rotvec_rate, In<V3, V3>, Out<Q>>>(
               m, "quat_derivative_from_rotvec_rate", "q̇ from a rotation vector and its rate.");
}

}  // namespace dualpose
