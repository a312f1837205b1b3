// Implicit dual quaternions (q, t) (Dantam 2014 §V): the kernels behind dualpose.algebra.implicit.
#include "../common/gufunc.hpp"
#include "../common/lie.hpp"
#include "parts.hpp"
#include "rows.hpp"

#include <cmath>

namespace dualpose {

namespace {

Vec3 add(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }

// Dantam 2014 eqs. (104)-(105); the rotation part is quat_mul's (rows.hpp), bit for bit.
void qt_mul(const double* q1, const double* t1, const double* q2, const double* t2, double* qo, double* to) {
    quat_mul_row(q1, q2, qo);
    store(to, add(rotate_any(load4(q1), load3(t2)), load3(t1)));
}

// Dantam 2014 eq. (106)
void qt_transform(const double* q, const double* t, const double* p, double* o) {
    store(o, add(rotate_any(load4(q), load3(p)), load3(t)));
}

// Dantam 2014 §V-C: (q*, -rot(q*, t))
void qt_conj(const double* q, const double* t, double* qo, double* to) {
    const Quat c = conj(load4(q));
    const Vec3 r = rotate_any(c, load3(t));
    store(qo, c);
    store(to, Vec3{-r.x, -r.y, -r.z});
}

// q = exp(ω/2) (Dantam 2014 eq. (50)), t = J_l(ω) v
void qt_from_twist(const double* xi, double* qo, double* to) {
    const Vec3 w = load3(xi);
    const double th = norm3(w);
    const double h = 0.5 * th;
    const double f = 0.5 * sinc(h);
    store(qo, Quat{f * w.x, f * w.y, f * w.z, std::cos(h)});
    store(to, so3_apply(w, so3_coeffs(th, 0.0), load3(xi + 3)));
}

// ω = 2 ln(±q) with |ω| <= π (Dantam 2014 eqs. (51)-(53)), v = J_l(ω)⁻¹ t
void twist_from_qt(const double* q, const double* t, double* o) {
    Quat v = ordinary_magnitude(load4(q));  // ω does not depend on the scale of q: exact 2**e rescaling
    if (v.w < 0.0) v = neg(v);
    const double s = norm3(v.x, v.y, v.z);
    if (s == 0.0 && v.w == 0.0) {
        for (int i = 0; i < 6; ++i) o[i] = kNaN;
        return;
    }
    const double f = 2.0 * atan2c(s, v.w);
    const Vec3 w = {f * v.x, f * v.y, f * v.z};
    store(o, w);
    store(o + 3, so3_apply(w, so3_coeffs(norm3(w), 1.0), load3(t)));
}

// Dantam 2014 eq. (107) applied to the normalized rotation u = q1/|q1| (the map qt_mul uses)
void qt_mul_derivative(const double* q1, const double* /*t1*/, const double* q1d, const double* t1d, const double* q2,
                       const double* t2, const double* q2d, const double* t2d, double* qo, double* to) {
    const Quat a = qmul(load4(q1d), load4(q2)), b = qmul(load4(q1), load4(q2d));
    store(qo, Quat{a.x + b.x, a.y + b.y, a.z + b.z, a.w + b.w});
    const double n = norm4(load4(q1));
    if (n == 0.0) {
        to[0] = to[1] = to[2] = kNaN;
        return;
    }
    const Quat u = {q1[0] / n, q1[1] / n, q1[2] / n, q1[3] / n};
    const double k = u.x * q1d[0] + u.y * q1d[1] + u.z * q1d[2] + u.w * q1d[3];
    const Quat d = {(q1d[0] - k * u.x) / n, (q1d[1] - k * u.y) / n, (q1d[2] - k * u.z) / n, (q1d[3] - k * u.w) / n};
    const Vec3 r = rotate(u, load3(t2d), 2.0);
    const Vec3 s = qvec_sandwich(d, load3(t2), u);
    to[0] = t1d[0] + r.x + 2.0 * s.x;
    to[1] = t1d[1] + r.y + 2.0 * s.y;
    to[2] = t1d[2] + r.z + 2.0 * s.z;
}

using Q = V<4>;
using V3 = V<3>;

}  // namespace

bool add_implicit_gufuncs(PyObject* m) {
    return add_gufunc<Gufunc<qt_mul, In<Q, V3, Q, V3>, Out<Q, V3>>>(m, "qt_mul", "(q1, t1) (x) (q2, t2).") &&
           add_gufunc<Gufunc<qt_transform, In<Q, V3, V3>, Out<V3>>>(m, "qt_transform", "R(q) p + t.") &&
           add_gufunc<Gufunc<qt_conj, In<Q, V3>, Out<Q, V3>>>(m, "qt_conj", "(q*, -R(q*) t).") &&
           add_gufunc<Gufunc<qt_from_twist, In<V<6>>, Out<Q, V3>>>(m, "qt_from_twist", "(exp(ω/2), J_l(ω) v).") &&
           add_gufunc<Gufunc<twist_from_qt, In<Q, V3>, Out<V<6>>>>(m, "twist_from_qt", "[2 ln(±q), J_l⁻¹ t].") &&
           add_gufunc<Gufunc<qt_mul_derivative, In<Q, V3, Q, V3, Q, V3, Q, V3>, Out<Q, V3>>>(
               m, "qt_mul_derivative", "Derivative of qt_mul (Dantam 2014 eq. (107)).");
}

}  // namespace dualpose
