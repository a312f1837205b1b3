// Quaternion gufuncs (xyzw, Hamilton): the kernels behind dualpose.algebra.quat.  Kernels write NaN where an
// argument that must be nonzero is zero; the Python wrappers turn that into a ValueError.
#include "../common/gufunc.hpp"
#include "../common/kutil.hpp"
#include "../common/lie.hpp"
#include "../common/series.hpp"
#include "rows.hpp"

#include <algorithm>
#include <cmath>

namespace dualpose {

static void quat_norm(const double* q, double* o) { o[0] = norm4(load4(q)); }

static void quat_normalize(const double* q, double* o) {
    const Quat u = ordinary_magnitude(load4(q));  // exact 2**e rescaling of extreme magnitudes
    double n = norm4(u);
    if (n == 0.0) n = kNaN;
    store(o, Quat{u.x / n, u.y / n, u.z / n, u.w / n});
}

static void quat_canonical(const double* q, double* o) {
    const Quat v = load4(q);
    store(o, flip_sign(v) ? neg(v) : v);
}

// Dantam 2014 eqs. (22)-(23).
static void quat_exp(const double* q, double* o) {
    const double th = norm3(q[0], q[1], q[2]);
    const double ew = std::exp(q[3]);
    const double f = ew * sinc(th);
    store(o, Quat{f * q[0], f * q[1], f * q[2], ew * std::cos(th)});
}

// Dantam 2014 eqs. (25)-(28); at q_v = 0, q_w < 0 the axis x is chosen (any axis is a logarithm).  A zero q gives
// atan2c(0, 0) = NaN in the vector part (the wrapper raises).
static void quat_log(const double* q, double* o) { store(o, quat_log_any(load4(q))); }

// Dantam 2014 eq. (30): q**t = exp(t ln q), principal logarithm.
static void quat_pow(const double* q, const double* tp, double* o) {
    const double x = q[0], y = q[1], z = q[2], w = q[3], t = tp[0];
    const double n = norm4(x, y, z, w);
    if (n == 0.0) {
        store(o, Quat{kNaN, kNaN, kNaN, kNaN});
        return;
    }
    const double s = norm3(x, y, z);
    const double phi = std::atan2(s, w);
    const double nt = std::pow(n, t);
    if (s == 0.0 && w < 0.0) {  // ln q = (pi, 0, 0, ln n): axis x, as in quat_log
        store(o, Quat{nt * std::sin(t * kPi), 0.0, 0.0, nt * std::cos(t * kPi)});
        return;
    }
    const double a = nt * t * atan2c(s, w) * sinc(t * phi);
    store(o, Quat{a * x, a * y, a * z, nt * std::cos(t * phi)});
}

// Dantam 2014 eq. (50): q = (sin(|v|/2) v/|v|, cos(|v|/2)).
static void quat_from_rotvec(const double* v, double* o) { store(o, quat_exp_rotvec(Vec3{v[0], v[1], v[2]})); }

// Dantam 2014 eqs. (51)-(53) with the atan2 angle; the sign is chosen so the angle is in [0, pi].
static void rotvec_from_quat(const double* q, double* o) { store(o, rotvec_of_quat(load4(q))); }

static void quat_from_axis_angle(const double* axis, const double* angle, double* o) {
    double n = norm3(axis[0], axis[1], axis[2]);
    if (n == 0.0) n = kNaN;
    const double h = 0.5 * angle[0];
    const double f = std::sin(h) / n;
    store(o, Quat{f * axis[0], f * axis[1], f * axis[2], std::cos(h)});
}

static void axis_angle_from_quat(const double* q, double* axis, double* angle) {
    Quat v = ordinary_magnitude(load4(q));  // scale-invariant: exact 2**e rescaling of extreme magnitudes
    if (v.w < 0.0) v = neg(v);
    const double s = norm3(v.x, v.y, v.z);
    if (s == 0.0) {
        if (v.w == 0.0) {
            axis[0] = axis[1] = axis[2] = angle[0] = kNaN;
            return;
        }
        store(axis, Vec3{1.0, 0.0, 0.0});
        angle[0] = 0.0;
        return;
    }
    store(axis, Vec3{v.x / s, v.y / s, v.z / s});
    angle[0] = 2.0 * std::atan2(s, v.w);
}

// Dantam 2014 eq. (108) / Walker 1991 eq. (4), scaled by 2/|q|**2 so non-unit input is normalized.
static void matrix_from_quat(const double* q, double* o) {
    const Mat3 m = rotmat(load4(q));
    std::copy(m.m, m.m + 9, o);
}

// Largest accepted |R^T R - I| entry (docs/conventions.md, "Rotation matrices"): files rounded to 6-7 digits pass,
// scaled, sheared or singular matrices do not.  Exported as QUAT_FROM_MATRIX_ORTHOGONALITY_TOL.
constexpr double kOrthogonalityTol = 1e-5;

// Shepperd's method (quat_of_rotmat) for a rotation; NaN (the wrapper raises) for a matrix that is not one:
// max |R^T R - I| > kOrthogonalityTol or det R <= 0 (a reflection).
static void quat_from_matrix(const double* r, double* o) {
    const double a0 = r[0], a1 = r[3], a2 = r[6];  // columns
    const double b0 = r[1], b1 = r[4], b2 = r[7];
    const double c0 = r[2], c1 = r[5], c2 = r[8];
    const double g = std::max({std::fabs(a0 * a0 + a1 * a1 + a2 * a2 - 1.0), std::fabs(b0 * b0 + b1 * b1 + b2 * b2 - 1.0),
                               std::fabs(c0 * c0 + c1 * c1 + c2 * c2 - 1.0), std::fabs(a0 * b0 + a1 * b1 + a2 * b2),
                               std::fabs(a0 * c0 + a1 * c1 + a2 * c2), std::fabs(b0 * c0 + b1 * c1 + b2 * c2)});
    const double det = a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0);
    if (!(g <= kOrthogonalityTol && det > 0.0)) {
        store(o, Quat{kNaN, kNaN, kNaN, kNaN});
        return;
    }
    store(o, quat_of_rotmat(r));
}

// Dantam 2014 eq. (58): p (x) (p* (x) q)**t along the shorter arc; inputs normalized.
static void quat_slerp(const double* p, const double* q, const double* tp, double* o) {
    const double t = tp[0];
    const Quat pu = ordinary_magnitude(load4(p)), qu = ordinary_magnitude(load4(q));
    const double np_ = norm4(pu), nq = norm4(qu);
    if (np_ == 0.0 || nq == 0.0) {
        store(o, Quat{kNaN, kNaN, kNaN, kNaN});
        return;
    }
    const Quat a = {pu.x / np_, pu.y / np_, pu.z / np_, pu.w / np_};
    const Quat b = {qu.x / nq, qu.y / nq, qu.z / nq, qu.w / nq};
    Quat r = qmul(conj(a), b);
    if (r.w < 0.0) r = neg(r);
    const double s = norm3(r.x, r.y, r.z);
    const double phi = std::atan2(s, r.w);
    const double f = s > 0.0 ? t * atan2c(s, r.w) * sinc(t * phi) : t;
    store(o, qmul(a, Quat{f * r.x, f * r.y, f * r.z, std::cos(t * phi)}));
}


// Rotation angle between two orientations, 4 atan2(min(|p-q|,|p+q|), max(...)) in [0, pi] (Dantam 2014
// eq. (42) gives the angle between the 4-vectors; the rotation angle is twice it).  p/|p| -+ q/|q| are formed
// without dividing the components first: with a = q - p, b = q + p (exact when p ~ +-q) and
// k = (|q| - |p|)/(|p||q|) from |q|**2 - |p|**2 = a.b, p/|p| - q/|q| = q k - a/|p| and p/|p| + q/|q| = b/|p| - q k,
// so the smaller of the two keeps full relative accuracy even when |p|, |q| are not exactly 1 in float64.
static void quat_angle(const double* pp, const double* qq, double* o) {
    // each input exactly rescaled by the power of two of its largest component (the angle is scale-invariant, the
    // difference form below is most accurate for norms near 1, and the result is exactly the same at every scale)
    const Quat pu = pow2_unit(load4(pp)), qu = pow2_unit(load4(qq));
    const double p[4] = {pu.x, pu.y, pu.z, pu.w}, q[4] = {qu.x, qu.y, qu.z, qu.w};
    const double np_ = norm4(pu), nq = norm4(qu);
    if (np_ == 0.0 || nq == 0.0) {
        o[0] = kNaN;
        return;
    }
    double a[4], b[4];
    for (int k = 0; k < 4; ++k) {
        a[k] = q[k] - p[k];
        b[k] = q[k] + p[k];
    }
    const double k = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]) / ((np_ + nq) * np_ * nq);
    const double d = norm4(q[0] * k - a[0] / np_, q[1] * k - a[1] / np_, q[2] * k - a[2] / np_, q[3] * k - a[3] / np_);
    const double s = norm4(b[0] / np_ - q[0] * k, b[1] / np_ - q[1] * k, b[2] / np_ - q[2] * k, b[3] / np_ - q[3] * k);
    o[0] = 4.0 * std::atan2(s < d ? s : d, s > d ? s : d);
}

// exp(omega dt / 2) as a quaternion (Dantam 2014 eq. (50) on the rotation vector omega dt).
static Quat half_exp(const double* w, double dt) { return quat_exp_rotvec(Vec3{w[0] * dt, w[1] * dt, w[2] * dt}); }

// Dantam 2014 eq. (62): q1 = exp(omega dt / 2) (x) q0, omega in the space (world) frame.
static void quat_integrate_space(const double* q, const double* w, const double* dt, double* o) {
    store(o, qmul(half_exp(w, dt[0]), load4(q)));
}

// q1 = q0 (x) exp(omega dt / 2), omega in the body frame.
static void quat_integrate_body(const double* q, const double* w, const double* dt, double* o) {
    store(o, qmul(load4(q), half_exp(w, dt[0])));
}

using Q = V<4>;
using V3 = V<3>;

bool add_quat_gufuncs(PyObject* m) {
    return add_gufunc<Gufunc<quat_mul_row, In<Q, Q>, Out<Q>, quat_mul_rows>>(m, "quat_mul",
                                                                                "Hamilton product p (x) q, xyzw.") &&
           add_gufunc<Gufunc<quat_conj_row, In<Q>, Out<Q>, quat_conj_rows>>(m, "quat_conj",
                                                                            "q [-1, -1, -1, 1], as NumPy.") &&
           add_gufunc<Gufunc<quat_norm, In<Q>, Out<S>>>(m, "quat_norm", "|q| without under/overflow.") &&
           add_gufunc<Gufunc<quat_normalize, In<Q>, Out<Q>>>(m, "quat_normalize", "q/|q| (NaN for zero).") &&
           add_gufunc<Gufunc<quat_inv_row, In<Q>, Out<Q>, quat_inv_rows>>(m, "quat_inv",
                                                                          "q*/|q|**2 (NaN for zero).") &&
           add_gufunc<Gufunc<quat_canonical, In<Q>, Out<Q>>>(m, "quat_canonical", "Sign representative, w > 0.") &&
           add_gufunc<Gufunc<quat_exp, In<Q>, Out<Q>>>(m, "quat_exp", "Quaternion exponential.") &&
           add_gufunc<Gufunc<quat_log, In<Q>, Out<Q>>>(m, "quat_log", "Principal quaternion logarithm.") &&
           add_gufunc<Gufunc<quat_pow, In<Q, S>, Out<Q>>>(m, "quat_pow", "q**t, principal logarithm.") &&
           add_gufunc<Gufunc<quat_rotate_row, In<Q, V3>, Out<V3>, quat_rotate_rows>>(m, "quat_rotate",
                                                                                      "R(q/|q|) v.") &&
           add_gufunc<Gufunc<quat_from_rotvec, In<V3>, Out<Q>>>(m, "quat_from_rotvec", "exp(v/2).") &&
           add_gufunc<Gufunc<rotvec_from_quat, In<Q>, Out<V3>>>(m, "rotvec_from_quat", "2 ln(+-q), angle in [0, pi].") &&
           add_gufunc<Gufunc<quat_from_axis_angle, In<V3, S>, Out<Q>>>(m, "quat_from_axis_angle",
                                                                       "Quaternion of an axis and angle.") &&
           add_gufunc<Gufunc<axis_angle_from_quat, In<Q>, Out<V3, S>>>(m, "axis_angle_from_quat",
                                                                       "Axis and angle in [0, pi].") &&
           add_gufunc<Gufunc<matrix_from_quat, In<Q>, Out<M<3, 3>>>>(m, "matrix_from_quat", "Rotation matrix.") &&
           add_gufunc<Gufunc<quat_from_matrix, In<M<3, 3>>, Out<Q>>>(m, "quat_from_matrix", "Shepperd's method.") &&
           PyModule_AddObject(m, "QUAT_FROM_MATRIX_ORTHOGONALITY_TOL", PyFloat_FromDouble(kOrthogonalityTol)) == 0 &&
           // whether the hot kernels use fused multiply-adds on this CPU (rows.hpp)
           PyModule_AddObject(m, "FUSED_MULTIPLY_ADD", PyBool_FromLong(kFused)) == 0 &&
           add_gufunc<Gufunc<quat_slerp, In<Q, Q, S>, Out<Q>>>(m, "quat_slerp", "Shortest-arc slerp.") &&
           add_gufunc<Gufunc<quat_angle, In<Q, Q>, Out<S>>>(m, "quat_angle", "Rotation angle between p and q.") &&
           add_gufunc<Gufunc<quat_integrate_space, In<Q, V3, S>, Out<Q>>>(m, "quat_integrate_space",
                                                                          "exp(omega dt/2) (x) q.") &&
           add_gufunc<Gufunc<quat_integrate_body, In<Q, V3, S>, Out<Q>>>(m, "quat_integrate_body",
                                                                         "q (x) exp(omega dt/2).");
}

}  // namespace dualpose
