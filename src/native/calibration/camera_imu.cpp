// The reprojection part of the camera-IMU calibration batch (dualpose.calibration.camera_imu, docs/euroc.md): for
// every frame, the robust (Huber, IRLS) normal-equation block of its target corners over
// [phi, p, v of the frame state (9), eps, p_bc (6), tau (1)] -- the 16 x 16 block J^T W J, the gradient J^T W r and
// the frame's robust cost -- summed corner by corner without forming the per-corner Jacobians in memory.  The same
// equations as _Problem.reprojection / normal_equations (the NumPy path, which the tests compare against):
//
//   y = R_n^T (X - p_n - v_n d),  x_b = E_n^T y,  x_c = R_bc^T (x_b - p_bc),  r = pi(x_c) - u   (d = tau - tau_ref)
//
// with E_n = Exp(omega_n d) given, pi the radial-tangential camera (common/camera_models.hpp) and the Huber weight
// at `huber` sigma of each corner's sigma.  Corners behind the camera (z <= 1e-3) or with weight 0 are left out.
// And the block-tridiagonal Cholesky factor and solve of the batch's frame band (one s x s step per frame).
#include "../common/args.hpp"
#include "../common/camera_models.hpp"

#include <cmath>
#include <cstdint>
#include <vector>

namespace dualpose {

namespace {

constexpr int kCols = 16;

inline void mat3t_vec(const double* A, const double* x, double* out) {  // A^T x, A row-major 3x3
    for (int i = 0; i < 3; ++i) out[i] = A[i] * x[0] + A[3 + i] * x[1] + A[6 + i] * x[2];
}

inline void row_times(const double* a, const double* M, double* out) {  // a^T M (1x3 times 3x3)
    for (int j = 0; j < 3; ++j) out[j] = a[0] * M[j] + a[1] * M[3 + j] + a[2] * M[6 + j];
}

inline void cross(const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

PyObject* camera_imu_reprojection(PyObject*, PyObject* args) {
    Array<double, 1> params, R_bc, p_bc;
    Array<double, 3> R, E, pts, pix;
    Array<double, 2> p, v, omega, weight, sigma;
    double d, huber;
    int jacobians;
    Array<double, 3, true> H;
    Array<double, 2, true> g;
    Array<double, 1, true> cost;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&O&O&O&O&O&ddiO&O&O&", convert<double, 1>, &params,
                          convert<double, 3>, &R, convert<double, 2>, &p, convert<double, 2>, &v,
                          convert<double, 2>, &omega, convert<double, 3>, &E, convert<double, 1>, &R_bc,
                          convert<double, 1>, &p_bc, convert<double, 3>, &pts, convert<double, 3>, &pix,
                          convert<double, 2>, &weight, convert<double, 2>, &sigma, &d, &huber, &jacobians,
                          convert<double, 3, true>, &H, convert<double, 2, true>, &g, convert<double, 1, true>, &cost))
        return nullptr;
    const npy_intp n = pts.shape[0], m = pts.shape[1];
    const bool shapes = params.shape[0] == 8 && R.shape[0] == n && R.shape[1] == 3 && R.shape[2] == 3 &&
                        p.shape[0] == n && p.shape[1] == 3 && v.shape[0] == n && v.shape[1] == 3 &&
                        omega.shape[0] == n && omega.shape[1] == 3 && E.shape[0] == n && E.shape[1] == 3 &&
                        E.shape[2] == 3 && R_bc.shape[0] == 9 && p_bc.shape[0] == 3 && pts.shape[2] == 3 &&
                        pix.shape[0] == n && pix.shape[1] == m && pix.shape[2] == 2 && weight.shape[0] == n &&
                        weight.shape[1] == m && sigma.shape[0] == n && sigma.shape[1] == m && cost.shape[0] == n &&
                        (!jacobians || (H.shape[0] == n && H.shape[1] == kCols && H.shape[2] == kCols &&
                                        g.shape[0] == n && g.shape[1] == kCols));
    if (!shapes) {
        PyErr_SetString(PyExc_ValueError,
                        "camera_imu_reprojection: params (8,), R (N, 3, 3), p, v, omega (N, 3), E (N, 3, 3), R_bc (9,), "
                        "p_bc (3,), points (N, M, 3), pixels (N, M, 2), weight, sigma (N, M), H (N, 16, 16), "
                        "g (N, 16), cost (N,)");
        return nullptr;
    }
    const double* cam = params.data;
    const double* Rbc = R_bc.data;
    NPY_BEGIN_ALLOW_THREADS;
    for (npy_intp k = 0; k < n; ++k) {
        const double* Rn = R.data + 9 * k;
        const double* En = E.data + 9 * k;
        const double* pk = p.data + 3 * k;
        const double* vk = v.data + 3 * k;
        const double* wk = omega.data + 3 * k;
        double A[9], Bt[9], ART[9];  // A = R_bc^T E^T, Bt = R_bc^T, ART = A R_n^T
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                Bt[3 * i + j] = Rbc[3 * j + i];
                double s = 0.0;
                for (int l = 0; l < 3; ++l) s += Rbc[3 * l + i] * En[3 * j + l];
                A[3 * i + j] = s;
            }
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                double s = 0.0;
                for (int l = 0; l < 3; ++l) s += A[3 * i + l] * Rn[3 * j + l];
                ART[3 * i + j] = s;
            }
        double vb[3], Evb[3], c0[3];
        mat3t_vec(Rn, vk, vb);
        mat3t_vec(En, vb, Evb);  // E^T v_b
        for (int i = 0; i < 3; ++i) c0[i] = pk[i] + vk[i] * d;
        double h[kCols][kCols] = {}, gk[kCols] = {}, ck = 0.0;
        for (npy_intp j = 0; j < m; ++j) {
            const double wt = weight(k, j);
            if (wt <= 0.0) continue;
            const double* X = pts.data + 3 * (k * m + j);
            double dx[3] = {X[0] - c0[0], X[1] - c0[1], X[2] - c0[2]}, y[3], xb[3], xr[3], xc[3];
            mat3t_vec(Rn, dx, y);
            mat3t_vec(En, y, xb);
            for (int i = 0; i < 3; ++i) xr[i] = xb[i] - p_bc[i];
            mat3t_vec(Rbc, xr, xc);
            if (!(xc[2] > 1e-3)) continue;
            double o[2], D[6];
            camera::radtan_point(cam + 4, xc, o, jacobians ? D : nullptr, nullptr);
            const double* u = pix.data + 2 * (k * m + j);
            const double r[2] = {cam[0] * o[0] + cam[2] - u[0], cam[1] * o[1] + cam[3] - u[1]};
            const double sg = sigma(k, j);
            const double s = std::sqrt(r[0] * r[0] + r[1] * r[1]) / sg;
            const double w = s <= huber ? 1.0 : huber / std::fmax(s, 1e-300);
            ck += wt * (s <= huber ? s * s : 2.0 * huber * s - huber * huber);
            if (!jacobians) continue;
            for (int c = 0; c < 3; ++c) D[c] *= cam[0], D[3 + c] *= cam[1];
            const double sw = std::sqrt(w * wt) / sg;
            double dtau[3], t1[3];
            cross(xb, wk, t1);
            for (int i = 0; i < 3; ++i) dtau[i] = t1[i] - Evb[i];
            for (int a = 0; a < 2; ++a) {
                const double* Da = D + 3 * a;
                double DA[3], DART[3], DB[3], J[kCols];
                row_times(Da, A, DA);
                row_times(Da, ART, DART);
                row_times(Da, Bt, DB);
                cross(DA, y, J);
                for (int c = 0; c < 3; ++c) J[3 + c] = -DART[c], J[6 + c] = -DART[c] * d;
                cross(DB, xr, J + 9);
                for (int c = 0; c < 3; ++c) J[12 + c] = -DB[c];
                J[15] = DB[0] * dtau[0] + DB[1] * dtau[1] + DB[2] * dtau[2];
                const double rr = r[a] * sw;
                for (int i = 0; i < kCols; ++i) {
                    J[i] *= sw;
                    gk[i] += J[i] * rr;
                }
                for (int i = 0; i < kCols; ++i)
                    for (int l = i; l < kCols; ++l) h[i][l] += J[i] * J[l];
            }
        }
        cost[k] = ck;
        if (!jacobians) continue;
        double* Hk = H.data + k * kCols * kCols;
        for (int i = 0; i < kCols; ++i) {
            g(k, i) = gk[i];
            for (int l = i; l < kCols; ++l) Hk[i * kCols + l] = Hk[l * kCols + i] = h[i][l];
        }
    }
    NPY_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}


// Block Cholesky of the symmetric positive definite block-tridiagonal A (diagonal blocks D (N, s, s), super-diagonal
// blocks U (N - 1, s, s)), each diagonal damped as D_ii (1 + lam): A = L L^T with L block lower bidiagonal, stored as
// Linv (N, s, s) the inverses of L's diagonal blocks and Lsub (N - 1, s, s) its sub-diagonal blocks
// (Lsub_i = U_i^T Linv_i^T).  Returns False (and leaves the outputs partly written) when a pivot is not positive.
bool band_factor(const double* D, const double* U, npy_intp n, int s, double lam, double* Linv, double* Lsub) {
    std::vector<double> d(s * s), L(s * s);
    for (npy_intp i = 0; i < n; ++i) {
        const double* Di = D + i * s * s;
        for (int a = 0; a < s * s; ++a) d[a] = Di[a];
        for (int a = 0; a < s; ++a) d[a * s + a] *= 1.0 + lam;
        if (i > 0) {  // d -= Lsub_{i-1} Lsub_{i-1}^T
            const double* S = Lsub + (i - 1) * s * s;
            for (int a = 0; a < s; ++a)
                for (int b = 0; b <= a; ++b) {
                    double acc = 0.0;
                    for (int c = 0; c < s; ++c) acc += S[a * s + c] * S[b * s + c];
                    d[a * s + b] -= acc;
                }
        }
        for (int a = 0; a < s; ++a) {  // Cholesky (lower triangle of d)
            for (int b = 0; b <= a; ++b) {
                double acc = d[a * s + b];
                for (int c = 0; c < b; ++c) acc -= L[a * s + c] * L[b * s + c];
                if (a == b) {
                    if (!(acc > 0.0)) return false;
                    L[a * s + a] = std::sqrt(acc);
                } else {
                    L[a * s + b] = acc / L[b * s + b];
                }
            }
            for (int b = a + 1; b < s; ++b) L[a * s + b] = 0.0;
        }
        double* Li = Linv + i * s * s;  // inverse of the lower-triangular L
        for (int a = 0; a < s * s; ++a) Li[a] = 0.0;
        for (int col = 0; col < s; ++col) {
            Li[col * s + col] = 1.0 / L[col * s + col];
            for (int a = col + 1; a < s; ++a) {
                double acc = 0.0;
                for (int c = col; c < a; ++c) acc -= L[a * s + c] * Li[c * s + col];
                Li[a * s + col] = acc / L[a * s + a];
            }
        }
        if (i + 1 < n) {  // Lsub_i = U_i^T Linv_i^T: (a, b) = sum_c U[c, a] Linv[b, c]
            const double* Ui = U + i * s * s;
            double* S = Lsub + i * s * s;
            for (int a = 0; a < s; ++a)
                for (int b = 0; b < s; ++b) {
                    double acc = 0.0;
                    for (int c = 0; c <= b; ++c) acc += Ui[c * s + a] * Li[b * s + c];
                    S[a * s + b] = acc;
                }
        }
    }
    return true;
}

// Solve A x = b with the factor of band_factor; b and x (N, s, q).
void band_solve(const double* Linv, const double* Lsub, npy_intp n, int s, npy_intp q, const double* b, double* x) {
    std::vector<double> y(n * s * q), t(s * q);
    for (npy_intp i = 0; i < n; ++i) {  // forward: y_i = Linv_i (b_i - Lsub_{i-1} y_{i-1})
        for (npy_intp a = 0; a < s * q; ++a) t[a] = b[i * s * q + a];
        if (i > 0) {
            const double* S = Lsub + (i - 1) * s * s;
            const double* yp = y.data() + (i - 1) * s * q;
            for (int a = 0; a < s; ++a)
                for (int c = 0; c < s; ++c) {
                    const double f = S[a * s + c];
                    for (npy_intp k = 0; k < q; ++k) t[a * q + k] -= f * yp[c * q + k];
                }
        }
        const double* Li = Linv + i * s * s;
        double* yi = y.data() + i * s * q;
        for (int a = 0; a < s; ++a) {
            for (npy_intp k = 0; k < q; ++k) yi[a * q + k] = 0.0;
            for (int c = 0; c <= a; ++c) {
                const double f = Li[a * s + c];
                for (npy_intp k = 0; k < q; ++k) yi[a * q + k] += f * t[c * q + k];
            }
        }
    }
    for (npy_intp i = n - 1; i >= 0; --i) {  // backward: x_i = Linv_i^T (y_i - Lsub_i^T x_{i+1})
        for (npy_intp a = 0; a < s * q; ++a) t[a] = y[i * s * q + a];
        if (i + 1 < n) {
            const double* S = Lsub + i * s * s;
            const double* xn = x + (i + 1) * s * q;
            for (int c = 0; c < s; ++c)
                for (int a = 0; a < s; ++a) {
                    const double f = S[c * s + a];
                    for (npy_intp k = 0; k < q; ++k) t[a * q + k] -= f * xn[c * q + k];
                }
        }
        const double* Li = Linv + i * s * s;
        double* xi = x + i * s * q;
        for (int a = 0; a < s; ++a) {
            for (npy_intp k = 0; k < q; ++k) xi[a * q + k] = 0.0;
            for (int c = a; c < s; ++c) {
                const double f = Li[c * s + a];
                for (npy_intp k = 0; k < q; ++k) xi[a * q + k] += f * t[c * q + k];
            }
        }
    }
}

PyObject* block_tridiagonal_factor(PyObject*, PyObject* args) {
    Array<double, 3> D, U;
    double lam;
    Array<double, 3, true> Linv, Lsub;
    if (!PyArg_ParseTuple(args, "O&O&dO&O&", convert<double, 3>, &D, convert<double, 3>, &U, &lam,
                          convert<double, 3, true>, &Linv, convert<double, 3, true>, &Lsub))
        return nullptr;
    const npy_intp n = D.shape[0];
    const npy_intp s = D.shape[1];
    if (n < 1 || D.shape[2] != s || U.shape[0] != n - 1 || U.shape[1] != s || U.shape[2] != s ||
        Linv.shape[0] != n || Linv.shape[1] != s || Linv.shape[2] != s || Lsub.shape[0] != n - 1 ||
        Lsub.shape[1] != s || Lsub.shape[2] != s) {
        PyErr_SetString(PyExc_ValueError, "block_tridiagonal_factor: D (N, s, s), U (N - 1, s, s), Linv (N, s, s), "
                                          "Lsub (N - 1, s, s), N >= 1");
        return nullptr;
    }
    bool ok;
    NPY_BEGIN_ALLOW_THREADS;
    ok = band_factor(D.data, U.data, n, static_cast<int>(s), lam, Linv.data, Lsub.data);
    NPY_END_ALLOW_THREADS;
    if (ok) Py_RETURN_TRUE;
    Py_RETURN_FALSE;
}

PyObject* block_tridiagonal_solve(PyObject*, PyObject* args) {
    Array<double, 3> Linv, Lsub, b;
    Array<double, 3, true> x;
    if (!PyArg_ParseTuple(args, "O&O&O&O&", convert<double, 3>, &Linv, convert<double, 3>, &Lsub,
                          convert<double, 3>, &b, convert<double, 3, true>, &x))
        return nullptr;
    const npy_intp n = Linv.shape[0], s = Linv.shape[1], q = b.shape[2];
    if (n < 1 || Linv.shape[2] != s || Lsub.shape[0] != n - 1 || Lsub.shape[1] != s || Lsub.shape[2] != s ||
        b.shape[0] != n || b.shape[1] != s || x.shape[0] != n || x.shape[1] != s || x.shape[2] != q) {
        PyErr_SetString(PyExc_ValueError, "block_tridiagonal_solve: Linv (N, s, s), Lsub (N - 1, s, s), b and x "
                                          "(N, s, q)");
        return nullptr;
    }
    NPY_BEGIN_ALLOW_THREADS;
    band_solve(Linv.data, Lsub.data, n, static_cast<int>(s), q, b.data, x.data);
    NPY_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

PyMethodDef camera_imu_methods[] = {
    {"camera_imu_reprojection", camera_imu_reprojection, METH_VARARGS,
     "camera_imu_reprojection(params, R, p, v, omega, E, R_bc, p_bc, points, pixels, weight, sigma, d, huber, "
     "jacobians, H, g, cost): the Huber-weighted reprojection normal-equation blocks of the camera-IMU batch per "
     "frame (radtan camera params (8,), frame states R (N, 3, 3) R_wb, p, v, omega (N, 3), E (N, 3, 3) = "
     "Exp(omega d), R_bc (9,) row-major, p_bc (3,), padded corners points (N, M, 3), pixels (N, M, 2), weight "
     "(N, M) 0 or 1, sigma (N, M) px, d = tau - tau_ref, huber in sigma): H (N, 16, 16) J^T W J and g (N, 16) "
     "J^T W r over [phi, p, v, eps, p_bc, tau] (only with jacobians 1), cost (N,) the robust cost."},
    {"block_tridiagonal_factor", block_tridiagonal_factor, METH_VARARGS,
     "block_tridiagonal_factor(D, U, lam, Linv, Lsub) -> ok: block Cholesky of the block-tridiagonal matrix with diagonal "
     "blocks D (N, s, s) (damped by 1 + lam on the diagonal) and super-diagonal blocks U (N - 1, s, s): writes the "
     "inverses of the factor's diagonal blocks Linv (N, s, s) and its sub-diagonal blocks Lsub (N - 1, s, s); "
     "returns False when the matrix is not positive definite."},
    {"block_tridiagonal_solve", block_tridiagonal_solve, METH_VARARGS,
     "block_tridiagonal_solve(Linv, Lsub, b, x): x (N, s, q) = A^-1 b (N, s, q) with the factor of "
     "block_tridiagonal_factor."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_camera_imu(PyObject* m) { return PyModule_AddFunctions(m, camera_imu_methods) == 0; }

}  // namespace dualpose
