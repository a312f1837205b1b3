// Dual-quaternion gufuncs: the kernels behind dualpose.algebra.dualquat.  Layout [r_x, r_y, r_z, r_w, d_x, d_y,
// d_z, d_w] (real part then dual part, each xyzw, Hamilton), d = ½ t (x) r for a rigid transform.  Kernels write
// NaN where a real part that must be nonzero is zero; the wrappers turn that into a ValueError.  Fused kernels
// (pow, sclerp, twist) use the helpers of common/dualquat.hpp, so they round as the stand-alone ones.
#include "../common/dualquat.hpp"
#include "../common/gufunc.hpp"
#include "rows.hpp"

#include <algorithm>
#include <cmath>

namespace dualpose {

namespace {

void fill_nan(double* o, int k) { std::fill(o, o + k, kNaN); }

// |S| = sqrt(S S*) = |r| + ε (r·d)/|r|
void dualquat_norm(const double* s, double* o) {
    double n = norm4(load4(s));
    if (n == 0.0) n = kNaN;
    o[0] = n;
    o[1] = (s[0] / n) * s[4] + (s[1] / n) * s[5] + (s[2] / n) * s[6] + (s[3] / n) * s[7];
}

void dualquat_normalize(const double* s, double* o) { store(o, dq_normalize(load8(s))); }

// flip BOTH parts with the real part (the dual part is ½ t (x) r: flipping r alone negates t)
void dualquat_canonical(const double* s, double* o) {
    const DualQuat d = load8(s);
    store(o, flip_sign(d.r) ? neg(d) : d);
}

// Dantam 2014 eqs. (76)-(77): r = q/|q|, d = ½ t (x) r
void dualquat_from_qt(const double* q, const double* t, double* o) {
    const Quat u = ordinary_magnitude(load4(q));  // exact 2**e rescaling of extreme magnitudes
    double n = norm4(u);
    if (n == 0.0) n = kNaN;
    const Quat r = {u.x / n, u.y / n, u.z / n, u.w / n};
    store(o, r);
    store(o + 4, scale(0.5, qmul(Quat{t[0], t[1], t[2], 0.0}, r)));
}

void qt_from_dualquat(const double* s0, double* q, double* t) {
    const int e = extreme_exponent(load4(s0));  // (q, t) do not depend on the scale: exact 2**e rescaling
    const DualQuat x = e == 0 ? load8(s0) : DualQuat{ldexp4(load4(s0), e), ldexp4(load4(s0 + 4), e)};
    const double s[8] = {x.r.x, x.r.y, x.r.z, x.r.w, x.d.x, x.d.y, x.d.z, x.d.w};
    double n = norm4(x.r);
    if (n == 0.0) n = kNaN;
    const DualQuat u = {{s[0] / n, s[1] / n, s[2] / n, s[3] / n}, {s[4] / n, s[5] / n, s[6] / n, s[7] / n}};
    store(q, u.r);
    store(t, dq_translation(u, 2.0));
}

// Walker 1991 eqs. (17)-(19) / Dantam 2014 eqs. (108)-(109), scaled by 2/|r|**2 (non-unit r normalized)
void matrix_from_dualquat(const double* s, double* o) {
    DualQuat d = load8(s);
    const Scale u = unit_scale(d.r);
    if (u.c != 1.0) d = scale(u.c, d);
    const Mat3 m = rotmat(d.r);
    const Vec3 t = dq_translation(d, u.s2);
    const double tv[3] = {t.x, t.y, t.z};
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) o[4 * i + j] = m(i, j);
        o[4 * i + 3] = tv[i];
    }
    o[12] = o[13] = o[14] = 0.0;
    o[15] = 1.0;
}

// Walker 1991 eq. (25): s = ½ t (x) r; r is already a unit quaternion
void dualquat_from_rt(const double* m, const double* r, double* o) {
    const Quat q = load4(r);
    store(o, q);
    store(o + 4, scale(0.5, qmul(Quat{m[3], m[7], m[11], 0.0}, q)));
}

void dualquat_exp(const double* s, double* o) { store(o, dq_exp(load8(s))); }
void dualquat_log(const double* s, double* o) { store(o, dq_log(load8(s))); }

// S**t = exp(t ln S), principal logarithm, no canonicalisation.  The rotation angle of exp(t ln S) is |t| phi
// with phi = atan2(|r_v|, r_w) (pi on the negative real axis); it is passed in rather than recomputed as
// |t (phi/|r_v|) r_v| (three more roundings, amplified by t).
void dualquat_pow(const double* s, const double* tp, double* o) {
    const DualQuat d = load8(s);
    if (is_zero4(d.r)) return fill_nan(o, 8);
    const double t = tp[0];
    const DualQuat a = dq_log(d);
    const double phi = std::fabs(t) * std::atan2(norm3(s[0], s[1], s[2]), s[3]);
    store(o, dq_exp_angle(phi, scale(t, a)));
}

void dualquat_from_twist(const double* xi, double* o) { store(o, dq_exp_twist(load3(xi), load3(xi + 3))); }

// normalize, canonicalise (r_w >= 0 so |ω| <= pi), then 2 ln S; the scalar parts are 0 for a unit S
void twist_from_dualquat(const double* s, double* o) {
    const DualQuat d0 = load8(s);
    if (is_zero4(d0.r)) return fill_nan(o, 6);
    DualQuat d = dq_normalize(d0);
    if (flip_sign(d.r)) d = neg(d);
    const DualQuat a = dq_log(d);
    store(o, Vec3{2.0 * a.r.x, 2.0 * a.r.y, 2.0 * a.r.z});
    store(o + 3, Vec3{2.0 * a.d.x, 2.0 * a.d.y, 2.0 * a.d.z});
}

// s0 (x) (canonical(s0* (x) s1))**t: the shortest screw from s0 to s1; inputs normalized
void dualquat_sclerp(const double* s0, const double* s1, const double* tp, double* o) {
    const DualQuat x0 = load8(s0), x1 = load8(s1);
    if (is_zero4(x0.r) || is_zero4(x1.r)) return fill_nan(o, 8);
    const double t = tp[0];
    const DualQuat a = dq_normalize(x0), b = dq_normalize(x1);
    DualQuat c = dq_mul({conj(a.r), conj(a.d)}, b);
    if (flip_sign(c.r)) c = neg(c);
    const DualQuat e = dq_exp(scale(t, dq_log(c)));
    store(o, dq_mul(a, e));
}

// Walker 1991 eqs. (11)-(12): r = [sin(θ/2) n, cos(θ/2)], s = [(d/2) cos(θ/2) n + sin(θ/2) p x n, -(d/2) sin(θ/2)]
void dualquat_from_screw(const double* axis, const double* p, const double* dist, const double* theta, double* o) {
    if (axis[0] == 0.0 && axis[1] == 0.0 && axis[2] == 0.0) return fill_nan(o, 8);
    const double n = norm3(axis[0], axis[1], axis[2]);
    const Vec3 u = {axis[0] / n, axis[1] / n, axis[2] / n};
    const double h = 0.5 * theta[0];
    const double sh = std::sin(h), ch = std::cos(h);
    const double hd = 0.5 * dist[0];
    const Vec3 m = cross(load3(p), u);
    store(o, Quat{sh * u.x, sh * u.y, sh * u.z, ch});
    const double a = hd * ch;
    store(o + 4, Quat{a * u.x + sh * m.x, a * u.y + sh * m.y, a * u.z + sh * m.z, -hd * sh});
}

// Walker 1991 Appendix 3 in stable form, on the normalized, canonical (r_w >= 0) dual quaternion:
// θ = 2 atan2(|r_v|, r_w), n = r_v/|r_v|, d/2 = r_w (n·s_v) - s_w |r_v|, p = (r_v x s_v)/|r_v|**2 (the foot ⊥ n)
void screw_from_dualquat(const double* s, double* axis, double* point, double* dist, double* theta) {
    const DualQuat d0 = load8(s);
    if (is_zero4(d0.r)) {
        fill_nan(axis, 3);
        fill_nan(point, 3);
        dist[0] = theta[0] = kNaN;
        return;
    }
    DualQuat d = dq_normalize(d0);
    if (flip_sign(d.r)) d = neg(d);
    const double sv = norm3(d.r.x, d.r.y, d.r.z);
    if (sv == 0.0) {  // pure translation (r = [0, 0, 0, 1]): t = 2 s_v; the identity gets axis x
        store(point, Vec3{0.0, 0.0, 0.0});
        theta[0] = 0.0;
        const double tx = 2.0 * d.d.x, ty = 2.0 * d.d.y, tz = 2.0 * d.d.z;
        const double tn = norm3(tx, ty, tz);
        if (tn == 0.0) {
            store(axis, Vec3{1.0, 0.0, 0.0});
            dist[0] = 0.0;
        } else {
            const double tn_ = tn > 0.0 ? tn : 1.0;
            store(axis, Vec3{tx / tn_, ty / tn_, tz / tn_});
            dist[0] = tn;
        }
        return;
    }
    const Vec3 u = {d.r.x / sv, d.r.y / sv, d.r.z / sv};
    store(axis, u);
    theta[0] = 2.0 * std::atan2(sv, d.r.w);
    dist[0] = 2.0 * (d.r.w * (u.x * d.d.x + u.y * d.d.y + u.z * d.d.z) - d.d.w * sv);
    const Vec3 c = cross(u, {d.d.x, d.d.y, d.d.z});
    store(point, Vec3{c.x / sv, c.y / sv, c.z / sv});
}

DualQuat twist_step(const double* xi, double dt) {
    return dq_exp_twist({xi[0] * dt, xi[1] * dt, xi[2] * dt}, {xi[3] * dt, xi[4] * dt, xi[5] * dt});
}

// Dantam 2014 eq. (102): exp(Ω dt/2) (x) s, Ω = [ω, v_s] a spatial twist
void dualquat_integrate_space(const double* s, const double* xi, const double* dt, double* o) {
    store(o, dq_mul(twist_step(xi, dt[0]), load8(s)));
}

// s (x) exp(Ω_b dt/2), Ω_b = [ω_b, v_b] a body twist
void dualquat_integrate_body(const double* s, const double* xi, const double* dt, double* o) {
    store(o, dq_mul(load8(s), twist_step(xi, dt[0])));
}

using D = V<8>;
using Q = V<4>;
using V3 = V<3>;
using V6 = V<6>;

}  // namespace

bool add_dualquat_gufuncs(PyObject* m) {
    return add_gufunc<Gufunc<dualquat_mul_row, In<D, D>, Out<D>, dualquat_mul_rows>>(m, "dualquat_mul",
                                                                                     "(a + ε b)(c + ε d).") &&
           add_gufunc<Gufunc<dualquat_conj_row, In<D>, Out<D>, dualquat_conj_rows>>(
               m, "dualquat_conj", "S [-1, -1, -1, 1, -1, -1, -1, 1], as NumPy.") &&
           add_gufunc<Gufunc<dualquat_inv_row, In<D>, Out<D>, dualquat_inv_rows>>(
               m, "dualquat_inv", "S^-1 (NaN for a zero real part).") &&
           add_gufunc<Gufunc<dualquat_norm, In<D>, Out<V<2>>>>(m, "dualquat_norm", "Dual-number norm [|r|, r.d/|r|].") &&
           add_gufunc<Gufunc<dualquat_normalize, In<D>, Out<D>>>(m, "dualquat_normalize", "S/|S|.") &&
           add_gufunc<Gufunc<dualquat_canonical, In<D>, Out<D>>>(m, "dualquat_canonical", "Sign representative.") &&
           add_gufunc<Gufunc<dualquat_from_qt, In<Q, V3>, Out<D>>>(m, "dualquat_from_qt", "[q/|q|, ½ t (x) q/|q|].") &&
           add_gufunc<Gufunc<qt_from_dualquat, In<D>, Out<Q, V3>>>(m, "qt_from_dualquat", "(r/|r|, t).") &&
           add_gufunc<Gufunc<matrix_from_dualquat, In<D>, Out<M<4, 4>>>>(m, "matrix_from_dualquat",
                                                                         "Homogeneous 4x4 matrix.") &&
           add_gufunc<Gufunc<dualquat_from_rt, In<M<4, 4>, Q>, Out<D>>>(m, "dualquat_from_rt",
                                                                        "[r, ½ t (x) r] from a 4x4 matrix's t.") &&
           add_gufunc<Gufunc<dualquat_transform_row, In<D, V3>, Out<V3>, dualquat_transform_rows>>(
               m, "dualquat_transform", "R p + t.") &&
           add_gufunc<Gufunc<dualquat_exp, In<D>, Out<D>>>(m, "dualquat_exp", "Dual-quaternion exponential.") &&
           add_gufunc<Gufunc<dualquat_log, In<D>, Out<D>>>(m, "dualquat_log", "Principal dual-quaternion logarithm.") &&
           add_gufunc<Gufunc<dualquat_pow, In<D, S>, Out<D>>>(m, "dualquat_pow", "S**t.") &&
           add_gufunc<Gufunc<dualquat_from_twist, In<V6>, Out<D>>>(m, "dualquat_from_twist", "exp(½(ω + ε v)).") &&
           add_gufunc<Gufunc<twist_from_dualquat, In<D>, Out<V6>>>(m, "twist_from_dualquat", "2 ln S, |ω| <= pi.") &&
           add_gufunc<Gufunc<dualquat_sclerp, In<D, D, S>, Out<D>>>(m, "dualquat_sclerp", "Screw interpolation.") &&
           add_gufunc<Gufunc<dualquat_from_screw, In<V3, V3, S, S>, Out<D>>>(m, "dualquat_from_screw",
                                                                             "Dual quaternion of a screw.") &&
           add_gufunc<Gufunc<screw_from_dualquat, In<D>, Out<V3, V3, S, S>>>(m, "screw_from_dualquat",
                                                                             "Screw (axis, point, d, θ).") &&
           add_gufunc<Gufunc<dualquat_integrate_space, In<D, V6, S>, Out<D>>>(m, "dualquat_integrate_space",
                                                                                   "exp(Ω dt/2) (x) s.") &&
           add_gufunc<Gufunc<dualquat_integrate_body, In<D, V6, S>, Out<D>>>(m, "dualquat_integrate_body",
                                                                             "s (x) exp(Ω_b dt/2).");
}

}  // namespace dualpose
