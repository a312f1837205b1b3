// The distorted cameras (common/camera_models.hpp) for dualpose.types.camera_models: projection, its Jacobians and
// distortion as NumPy gufuncs (one point per core, broadcasting over any leading axes), and the Newton inversion
// (undistortion, rays, ideal pixels) as one function over a C-contiguous (M, 2) array, points in blocks of
// camera::kBlock.  Parameters (8) = {fx, fy, cx, cy, d1, d2, d3, d4}.
#include "../common/args.hpp"
#include "../common/camera_models.hpp"
#include "../common/gufunc.hpp"

#include <cmath>
#include <cstdint>

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



using P8 = V<8>;

enum Model : int { RADTAN = 0, EQUI = 1 };
enum Output : int { UNDISTORTED = 0, RAY = 1, IDEAL_PIXELS = 2 };

// camera_invert(model, from_pixels, output, params, limit, src, out, valid): see camera_methods.
PyObject* camera_invert(PyObject*, PyObject* args) {
    int model, from_pixels, output;
    double limit;
    Array<double, 1> p;
    Array<double, 2> src;
    Array<double, 2, true> out;
    Array<std::int64_t, 1, true> valid;
    if (!PyArg_ParseTuple(args, "iiiO&dO&O&O&", &model, &from_pixels, &output, convert<double, 1>, &p, &limit,
                          convert<double, 2>, &src, convert<double, 2, true>, &out,
                          convert<std::int64_t, 1, true>, &valid))
        return nullptr;
    const npy_intp n = src.shape[0];
    const npy_intp width = output == RAY ? 3 : 2;
    if (p.shape[0] != 8 || src.shape[1] != 2 || out.shape[0] != n || out.shape[1] != width || valid.shape[0] != n ||
        (model != RADTAN && model != EQUI) || output < UNDISTORTED || output > IDEAL_PIXELS) {
        PyErr_SetString(PyExc_ValueError, "camera_invert: params (8,), src (M, 2), out (M, 2 or 3 for rays), valid (M,)");
        return nullptr;
    }
    const double fx = p[0], fy = p[1], cx = p[2], cy = p[3];
    const double* d = p.data + 4;
    NPY_BEGIN_ALLOW_THREADS;
    for (npy_intp i0 = 0; i0 < n; i0 += kBlock) {
        const int m = static_cast<int>(std::min<npy_intp>(kBlock, n - i0));
        double xd[kBlock][2], xy[kBlock][2], theta[kBlock], poly[kBlock];
        bool ok[kBlock];
        for (int j = 0; j < m; ++j) {
            const double* s = src.row(i0 + j);
            xd[j][0] = from_pixels ? (s[0] - cx) / fx : s[0];
            xd[j][1] = from_pixels ? (s[1] - cy) / fy : s[1];
        }
        if (model == RADTAN) {
            radtan_undistort_block(d, limit, xd, m, xy, ok);
        } else {
            equi_theta_block(d, limit, xd, m, theta, poly, ok);
        }
        for (int j = 0; j < m; ++j) {
            double* o = out.row(i0 + j);
            if (model == EQUI && output == RAY) {
                equi_ray_from_theta(theta[j], poly[j], xd[j], o);
            } else {
                if (model == EQUI) {
                    equi_undistorted_from_theta(theta[j], poly[j], xd[j], xy[j]);
                    ok[j] = ok[j] && theta[j] < 0.5 * kPi;  // normalised coordinates end at 90 degrees
                }
                if (output == RAY) {
                    const double norm = std::sqrt(xy[j][0] * xy[j][0] + xy[j][1] * xy[j][1] + 1.0);
                    o[0] = xy[j][0] / norm, o[1] = xy[j][1] / norm, o[2] = 1.0 / norm;
                } else if (output == IDEAL_PIXELS) {
                    o[0] = fx * xy[j][0] + cx, o[1] = fy * xy[j][1] + cy;
                } else {
                    o[0] = xy[j][0], o[1] = xy[j][1];
                }
            }
            valid[i0 + j] = ok[j];
            if (!ok[j])
                for (npy_intp c = 0; c < width; ++c) o[c] = kNaN;
        }
    }
    NPY_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

PyMethodDef camera_methods[] = {
    {"camera_invert", camera_invert, METH_VARARGS,
     "camera_invert(model, from_pixels, output, params, limit, src, out, valid): Newton inversion of the distortion "
     "of each row of src (M, 2) C-contiguous float64: pixels (from_pixels 1) or distorted normalised coordinates; "
     "model 0 radtan (limit: largest undistorted r**2), 1 equi (limit: largest theta); output 0 undistorted "
     "normalised (out (M, 2)), 1 unit rays (out (M, 3)), 2 ideal pinhole pixels (out (M, 2)); valid (M,) int64 1 "
     "where the point is invertible (out NaN elsewhere)."},
    {nullptr, nullptr, 0, nullptr}};

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
           add_gufunc<Gufunc<equi_project_k, In<P8, V<3>>, Out<V<2>>>>(
               m, "equi_project", "(params, point) -> pixels of the equidistant camera.") &&
           add_gufunc<Gufunc<equi_project_jac_k, In<P8, V<3>>, Out<V<2>, M<2, 3>>>>(
               m, "equi_project_jacobian", "(params, point) -> pixels, d pixels / d point (equi).") &&
           add_gufunc<Gufunc<equi_intrinsics_jac_k, In<P8, V<3>>, Out<M<2, 8>>>>(
               m, "equi_intrinsics_jacobian", "(params, point) -> d pixels / d params (equi).") &&
           add_gufunc<Gufunc<equi_distort_k, In<P8, V<2>>, Out<V<2>, M<2, 2>>>>(
               m, "equi_distort", "(params, xy) -> distorted xy, d distorted / d xy (equi).") &&
           PyModule_AddFunctions(m, camera_methods) == 0;
}

}  // namespace dualpose
