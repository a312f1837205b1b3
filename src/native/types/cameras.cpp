// The distorted cameras (common/camera_models.hpp) as NumPy gufuncs for dualpose.types.camera_models: projection,
// its Jacobians, distortion and Newton undistortion, one point per core, broadcasting over any leading axes.
// Parameters (8) = {fx, fy, cx, cy, d1, d2, d3, d4}; ``limit`` () the invertible region's bound (radtan: largest
// undistorted r²; equi: largest θ); ``valid`` () 1.0 or 0.0.
#include "../common/camera_models.hpp"
#include "../common/gufunc.hpp"

namespace dualpose {

namespace {

using namespace camera;

// Pixels of distorted normalised o.
inline void to_pixels(const double* p, const double* o, double* px) {
    px[0] = p[0] * o[0] + p[2];
    px[1] = p[1] * o[1] + p[3];
}

// d pixel / d point (2x3) from d distorted / d point, and d pixel / d parameters (2x8) from d distorted / d d.
inline void scale_rows(const double* p, double* J3) {
    for (int c = 0; c < 3; ++c) {
        J3[c] *= p[0];
        J3[3 + c] *= p[1];
    }
}

inline void intrinsics_rows(const double* p, const double* o, const double* Jk, double* Jp) {
    for (int c = 0; c < 8; ++c) Jp[c] = Jp[8 + c] = 0.0;
    Jp[0] = o[0];
    Jp[8 + 1] = o[1];
    Jp[2] = 1.0;
    Jp[8 + 3] = 1.0;
    for (int c = 0; c < 4; ++c) {
        Jp[4 + c] = p[0] * Jk[c];
        Jp[8 + 4 + c] = p[1] * Jk[4 + c];
    }
}

// ------------------------------------------------------------------ radtan
void radtan_project_k(const double* p, const double* P, double* px) {
    double o[2];
    radtan_point(p + 4, P, o, nullptr, nullptr);
    to_pixels(p, o, px);
}

void radtan_project_jac_k(const double* p, const double* P, double* px, double* J3) {
    double o[2];
    radtan_point(p + 4, P, o, J3, nullptr);
    to_pixels(p, o, px);
    scale_rows(p, J3);
}

void radtan_intrinsics_jac_k(const double* p, const double* P, double* Jp) {
    double o[2], Jk[8];
    radtan_point(p + 4, P, o, nullptr, Jk);
    intrinsics_rows(p, o, Jk, Jp);
}

void radtan_distort_k(const double* p, const double* xy, double* o, double* J) {
    radtan_distort(p + 4, xy[0], xy[1], o, J, nullptr);
}

void radtan_undistort_k(const double* p, const double* limit, const double* xd, double* xy, double* valid) {
    valid[0] = radtan_undistort(p + 4, limit[0], xd, xy) ? 1.0 : 0.0;
}

// ------------------------------------------------------------------ equidistant
void equi_project_k(const double* p, const double* P, double* px) {
    double o[2];
    equi_point(p + 4, P[0], P[1], P[2], o, nullptr, nullptr);
    to_pixels(p, o, px);
}

void equi_project_jac_k(const double* p, const double* P, double* px, double* J3) {
    double o[2];
    equi_point(p + 4, P[0], P[1], P[2], o, J3, nullptr);
    to_pixels(p, o, px);
    scale_rows(p, J3);
}

void equi_intrinsics_jac_k(const double* p, const double* P, double* Jp) {
    double o[2], Jk[8];
    equi_point(p + 4, P[0], P[1], P[2], o, nullptr, Jk);
    intrinsics_rows(p, o, Jk, Jp);
}

void equi_distort_k(const double* p, const double* xy, double* o, double* J) {
    double J3[6];
    equi_point(p + 4, xy[0], xy[1], 1.0, o, J3, nullptr);
    J[0] = J3[0];
    J[1] = J3[1];
    J[2] = J3[3];
    J[3] = J3[4];
}

void equi_undistort_k(const double* p, const double* limit, const double* xd, double* xy, double* valid) {
    valid[0] = equi_undistort(p + 4, limit[0], xd, xy) ? 1.0 : 0.0;
}

void equi_bearing_k(const double* p, const double* limit, const double* xd, double* ray, double* valid) {
    valid[0] = equi_bearing(p + 4, limit[0], xd, ray) ? 1.0 : 0.0;
}

using P8 = V<8>;

}  // namespace

bool add_camera_gufuncs(PyObject* m) {
    return add_gufunc<Gufunc<radtan_project_k, In<P8, V<3>>, Out<V<2>>>>(
               m, "radtan_project", "(params, point) -> pixels of the radial-tangential camera.") &&
           add_gufunc<Gufunc<radtan_project_jac_k, In<P8, V<3>>, Out<V<2>, M<2, 3>>>>(
               m, "radtan_project_jacobian", "(params, point) -> pixels, d pixels / d point (radtan).") &&
           add_gufunc<Gufunc<radtan_intrinsics_jac_k, In<P8, V<3>>, Out<M<2, 8>>>>(
               m, "radtan_intrinsics_jacobian", "(params, point) -> d pixels / d params (radtan).") &&
           add_gufunc<Gufunc<radtan_distort_k, In<P8, V<2>>, Out<V<2>, M<2, 2>>>>(
               m, "radtan_distort", "(params, xy) -> distorted xy, d distorted / d xy (radtan).") &&
           add_gufunc<Gufunc<radtan_undistort_k, In<P8, S, V<2>>, Out<V<2>, S>>>(
               m, "radtan_undistort", "(params, max_r2, xy_d) -> xy, valid (radtan, Newton).") &&
           add_gufunc<Gufunc<equi_project_k, In<P8, V<3>>, Out<V<2>>>>(
               m, "equi_project", "(params, point) -> pixels of the equidistant camera.") &&
           add_gufunc<Gufunc<equi_project_jac_k, In<P8, V<3>>, Out<V<2>, M<2, 3>>>>(
               m, "equi_project_jacobian", "(params, point) -> pixels, d pixels / d point (equi).") &&
           add_gufunc<Gufunc<equi_intrinsics_jac_k, In<P8, V<3>>, Out<M<2, 8>>>>(
               m, "equi_intrinsics_jacobian", "(params, point) -> d pixels / d params (equi).") &&
           add_gufunc<Gufunc<equi_distort_k, In<P8, V<2>>, Out<V<2>, M<2, 2>>>>(
               m, "equi_distort", "(params, xy) -> distorted xy, d distorted / d xy (equi).") &&
           add_gufunc<Gufunc<equi_undistort_k, In<P8, S, V<2>>, Out<V<2>, S>>>(
               m, "equi_undistort", "(params, max_theta, xy_d) -> xy, valid (equi, Newton on theta).") &&
           add_gufunc<Gufunc<equi_bearing_k, In<P8, S, V<2>>, Out<V<3>, S>>>(
               m, "equi_bearing", "(params, max_theta, xy_d) -> unit ray, valid (equi, Newton on theta).");
}

}  // namespace dualpose
