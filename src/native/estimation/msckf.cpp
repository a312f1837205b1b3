// Kernels of the multi-state-constraint Kalman filter (Mourikis & Roumeliotis 2007; OpenVINS, Geneva et al. 2020),
// used by dualpose.estimation.msckf:
//
//   msckf_propagate  the IMU error-state propagation of eskf_kernels.hpp over k steps, with the states at every
//                    step, the IMU rows of the cross-covariance multiplied by the product Φ of the step transitions;
//   msckf_clone      the covariance augmented by a clone of the IMU pose (stochastic cloning);
//   msckf_select     the covariance of a subset of the states (marginalisation of a clone or of SLAM points);
//   msckf_features   per feature: Gauss–Newton triangulation on inverse depth in the anchor (first) camera, the
//                    reprojection residuals and Jacobians at the clones' first estimates (FEJ), the left-nullspace
//                    projection of the feature Jacobian by Givens rotations, and the χ² gate; the accepted rows
//                    stacked for one EKF update;
//   msckf_slam_rows  the gated update rows of the SLAM features seen in one clone;
//   msckf_update     one EKF update of the whole state (QR-compressed when the rows outnumber the states).
//
// Layouts: IMU nominal x (16,) and error (15,) as eskf_layout.hpp; clone c = [p_wb (3), q_wb (4, xyzw)] of the IMU
// pose, its error [δp (3), δθ (3)] (local: q = q̂ ⊗ Exp(δθ)) at columns 15 + 6c of the covariance.  Camera:
// q_bc, p_bc (camera axes and centre in the IMU frame); observations are normalised coordinates (X/Z, Y/Z).
#include "eskf_args.hpp"
#include "eskf_kernels.hpp"
#include "../common/dispatch.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace dualpose {
namespace {

using namespace eskf;

// y = Aᵀ v for row-major 3x3 A
inline void mul_t3(const double* A, const double* v, double* y) {
    for (int i = 0; i < 3; ++i) y[i] = A[i] * v[0] + A[3 + i] * v[1] + A[6 + i] * v[2];
}
inline void mul3(const double* A, const double* v, double* y) {
    for (int i = 0; i < 3; ++i) y[i] = A[3 * i] * v[0] + A[3 * i + 1] * v[1] + A[3 * i + 2] * v[2];
}
// C = Aᵀ B (3x3)
inline void mul_tn3(const double* A, const double* B, double* C) {
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) C[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
}
inline void mul33(const double* A, const double* B, double* C) {
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

// Solve the symmetric 3x3 system A x = b (Cramer); false when |det| is below tol · scale³.
inline bool solve3(const double* A, const double* b, double* x) {
    const double c00 = A[4] * A[8] - A[5] * A[7], c01 = A[5] * A[6] - A[3] * A[8], c02 = A[3] * A[7] - A[4] * A[6];
    const double det = A[0] * c00 + A[1] * c01 + A[2] * c02;
    const double scale = std::fabs(A[0]) + std::fabs(A[4]) + std::fabs(A[8]);
    if (!(std::fabs(det) > 1e-14 * scale * scale * scale)) return false;
    const double inv[9] = {c00, A[2] * A[7] - A[1] * A[8], A[1] * A[5] - A[2] * A[4],
                           c01, A[0] * A[8] - A[2] * A[6], A[2] * A[3] - A[0] * A[5],
                           c02, A[1] * A[6] - A[0] * A[7], A[0] * A[4] - A[1] * A[3]};
    for (int i = 0; i < 3; ++i) x[i] = (inv[3 * i] * b[0] + inv[3 * i + 1] * b[1] + inv[3 * i + 2] * b[2]) / det;
    return true;
}

struct CamPose {
    double R[9];  // R_wc
    double p[3];  // camera centre in the world
};

// Camera pose of an IMU clone [p_wb, q_wb] with the extrinsic R_bc, p_bc.
inline CamPose camera_pose(const double* clone, const double* Rbc, const double* p_bc) {
    double Rwb[9];
    rotmat_xyzw(clone[3], clone[4], clone[5], clone[6], Rwb);
    CamPose c;
    mul33(Rwb, Rbc, c.R);
    mul3(Rwb, p_bc, c.p);
    for (int i = 0; i < 3; ++i) c.p[i] += clone[i];
    return c;
}

// Outcomes of triangulate (and msckf_features' status): the point, no point (degenerate geometry), or a point whose
// depth the observations do not determine at their own precision.
constexpr int TRI_OK = 0, TRI_FAILED = -1, TRI_UNDETERMINED = -3;

// Triangulate one feature from m observations (clone indices ci, normalised uv) with camera poses cams: the linear
// midpoint solution in the anchor camera (the first observation), refined by Gauss–Newton on the inverse-depth
// parameters (α, β, ρ), p_A = [α, β, 1] / ρ.  Writes the world point and returns TRI_OK; TRI_FAILED when the geometry
// is degenerate (depth outside [min_depth, max_depth], too little baseline, or no convergence); TRI_UNDETERMINED when
// the inverse depth is not distinguishable from 0 (a point at infinity) at the pixel noise: with the Gauss–Newton
// normal matrix JᵀJ at the solution, Var(ρ) = σ² [(JᵀJ)⁻¹]_ρρ (σ the noise of a normalised coordinate), and the point
// is kept only when ρ² > min_z² Var(ρ), i.e. its relative depth σ_d / d = σ_ρ / ρ is below 1 / min_z (min_z 0: no
// test).
int triangulate(const std::vector<CamPose>& cams, const std::int64_t* ci, const double* uv, std::int64_t m,
                double min_depth, double max_depth, double min_parallax, double sigma, double min_z, double* pw) {
    const CamPose& A = cams[ci[0]];
    std::vector<double> Rac(9 * m), pac(3 * m);  // pose of camera j in the anchor: R_Aj, p_Aj
    double H[9] = {}, g[3] = {}, baseline = 0.0;
    for (std::int64_t j = 0; j < m; ++j) {
        const CamPose& C = cams[ci[j]];
        double d[3] = {C.p[0] - A.p[0], C.p[1] - A.p[1], C.p[2] - A.p[2]};
        mul_tn3(A.R, C.R, &Rac[9 * j]);
        mul_t3(A.R, d, &pac[3 * j]);
        baseline = std::max(baseline, std::sqrt(pac[3 * j] * pac[3 * j] + pac[3 * j + 1] * pac[3 * j + 1] +
                                                pac[3 * j + 2] * pac[3 * j + 2]));
        const double f[3] = {uv[2 * j], uv[2 * j + 1], 1.0};
        double b[3];
        mul3(&Rac[9 * j], f, b);
        const double nb = std::sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
        for (double& v : b) v /= nb;
        double M[9];
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) M[3 * r + c] = (r == c ? 1.0 : 0.0) - b[r] * b[c];
        for (int k = 0; k < 9; ++k) H[k] += M[k];
        double Mp[3];
        mul3(M, &pac[3 * j], Mp);
        for (int k = 0; k < 3; ++k) g[k] += Mp[k];
    }
    double pA[3];
    if (!solve3(H, g, pA) || !(pA[2] > min_depth) || !(pA[2] < max_depth)) return TRI_FAILED;
    if (baseline < min_parallax * pA[2]) return TRI_FAILED;
    double th[3] = {pA[0] / pA[2], pA[1] / pA[2], 1.0 / pA[2]};  // α, β, ρ
    double lambda = 1e-3, cost = 0.0;
    auto eval = [&](const double* t, double* JtJ, double* Jtr) {
        double c = 0.0;
        if (JtJ) std::fill(JtJ, JtJ + 9, 0.0), std::fill(Jtr, Jtr + 3, 0.0);
        for (std::int64_t j = 0; j < m; ++j) {
            const double* R = &Rac[9 * j];
            const double q[3] = {t[0] - t[2] * pac[3 * j], t[1] - t[2] * pac[3 * j + 1], 1.0 - t[2] * pac[3 * j + 2]};
            double h[3];
            mul_t3(R, q, h);  // ρ · (the point in camera j)
            if (!(h[2] > 0.0)) return -1.0;
            const double iz = 1.0 / h[2];
            const double r0 = uv[2 * j] - h[0] * iz, r1 = uv[2 * j + 1] - h[1] * iz;
            c += r0 * r0 + r1 * r1;
            if (!JtJ) continue;
            // ∂h/∂(α, β, ρ) = Rᵀ [e1, e2, −p_Aj]
            double dh[9];
            for (int i = 0; i < 3; ++i) {
                dh[3 * i] = R[i];
                dh[3 * i + 1] = R[3 + i];
                dh[3 * i + 2] = -(R[i] * pac[3 * j] + R[3 + i] * pac[3 * j + 1] + R[6 + i] * pac[3 * j + 2]);
            }
            double J[6];
            for (int c2 = 0; c2 < 3; ++c2) {
                J[c2] = iz * dh[c2] - h[0] * iz * iz * dh[6 + c2];
                J[3 + c2] = iz * dh[3 + c2] - h[1] * iz * iz * dh[6 + c2];
            }
            for (int a = 0; a < 3; ++a) {
                Jtr[a] += J[a] * r0 + J[3 + a] * r1;
                for (int b = 0; b < 3; ++b) JtJ[3 * a + b] += J[a] * J[b] + J[3 + a] * J[3 + b];
            }
        }
        return c;
    };
    double JtJ[9], Jtr[3];
    cost = eval(th, JtJ, Jtr);
    if (cost < 0.0) return TRI_FAILED;
    for (int it = 0; it < 20; ++it) {
        double Hd[9];
        std::copy(JtJ, JtJ + 9, Hd);
        for (int k = 0; k < 3; ++k) Hd[4 * k] *= 1.0 + lambda;
        double step[3];
        if (!solve3(Hd, Jtr, step)) return TRI_FAILED;
        const double cand[3] = {th[0] + step[0], th[1] + step[1], th[2] + step[2]};
        const double c2 = eval(cand, nullptr, nullptr);
        if (c2 >= 0.0 && c2 <= cost) {
            std::copy(cand, cand + 3, th);
            const double dc = cost - c2;
            cost = eval(th, JtJ, Jtr);
            lambda = std::max(lambda / 10.0, 1e-10);
            if (std::sqrt(step[0] * step[0] + step[1] * step[1] + step[2] * step[2]) < 1e-10 || dc < 1e-16) break;
        } else {
            lambda *= 10.0;
            if (lambda > 1e8) break;
        }
    }
    if (!(th[2] > 0.0)) return TRI_FAILED;
    const double depth = 1.0 / th[2];
    if (!(depth > min_depth) || !(depth < max_depth) || baseline < min_parallax * depth) return TRI_FAILED;
    if (min_z > 0.0) {  // JtJ is the normal matrix at th (evaluated after the last accepted step)
        const double det = JtJ[0] * (JtJ[4] * JtJ[8] - JtJ[5] * JtJ[7]) - JtJ[1] * (JtJ[3] * JtJ[8] - JtJ[5] * JtJ[6]) +
                           JtJ[2] * (JtJ[3] * JtJ[7] - JtJ[4] * JtJ[6]);
        const double cof = JtJ[0] * JtJ[4] - JtJ[1] * JtJ[3];  // [(JᵀJ)⁻¹]_ρρ = cof / det
        // ρ² det > min_z² σ² cof, without dividing (a singular normal matrix: undetermined)
        if (!(det > 0.0) || !(th[2] * th[2] * det > min_z * min_z * sigma * sigma * cof)) return TRI_UNDETERMINED;
    }
    const double pa[3] = {th[0] * depth, th[1] * depth, depth};
    mul3(A.R, pa, pw);
    for (int i = 0; i < 3; ++i) pw[i] += A.p[i];
    return TRI_OK;
}

// One observation (normalised uv) of the world point pw in a clone: the residual res = uv − π(p_c) at the clone's
// current pose (cl = [p_wb, q_wb], Rwb) and pw, and the Jacobians at the clone's first estimate (fe, Rf) and the
// point's first estimate pf: Hc (2x6, row-major) with respect to the clone error [δp, δθ], Hf (2x3) with respect to
// the world point.  False when the point is behind the camera at either linearisation point.
inline bool observe(const double* cl, const double* Rwb, const double* fe, const double* Rf, const double* Rbc,
                    const double* p_bc, const double* pw, const double* pf, const double* uv, double* res, double* Hc,
                    double* Hf) {
    double d[3] = {pw[0] - cl[0], pw[1] - cl[1], pw[2] - cl[2]}, pb[3], pc[3];
    mul_t3(Rwb, d, pb);
    for (int i = 0; i < 3; ++i) pb[i] -= p_bc[i];
    mul_t3(Rbc, pb, pc);
    if (!(pc[2] > 0.0)) return false;
    res[0] = uv[0] - pc[0] / pc[2];
    res[1] = uv[1] - pc[1] / pc[2];
    for (int i = 0; i < 3; ++i) d[i] = pf[i] - fe[i];
    mul_t3(Rf, d, pb);
    const double pbc[3] = {pb[0] - p_bc[0], pb[1] - p_bc[1], pb[2] - p_bc[2]};
    mul_t3(Rbc, pbc, pc);
    if (!(pc[2] > 0.0)) return false;
    const double iz = 1.0 / pc[2];
    const double Jp[6] = {iz, 0.0, -pc[0] * iz * iz, 0.0, iz, -pc[1] * iz * iz};
    double JB[6];  // ∂z/∂p_b = Jp R_bcᵀ, ∂z/∂p_w = JB R_wbᵀ
    for (int i = 0; i < 2; ++i)
        for (int k = 0; k < 3; ++k)
            JB[3 * i + k] = Jp[3 * i] * Rbc[3 * k] + Jp[3 * i + 1] * Rbc[3 * k + 1] + Jp[3 * i + 2] * Rbc[3 * k + 2];
    for (int i = 0; i < 2; ++i) {
        const double* jb = JB + 3 * i;
        for (int k = 0; k < 3; ++k) {
            Hf[3 * i + k] = jb[0] * Rf[3 * k] + jb[1] * Rf[3 * k + 1] + jb[2] * Rf[3 * k + 2];
            Hc[6 * i + k] = -Hf[3 * i + k];
        }
        Hc[6 * i + 3] = jb[1] * pb[2] - jb[2] * pb[1];  // ∂p_b/∂δθ = [p_b]×
        Hc[6 * i + 4] = jb[2] * pb[0] - jb[0] * pb[2];
        Hc[6 * i + 5] = jb[0] * pb[1] - jb[1] * pb[0];
    }
    return true;
}

// One propagation step (eskf::predict_transition's nominal state) whose transition F is evaluated at the first
// estimates x0 of the start position, velocity and attitude (FEJ; Huang, Mourikis & Roumeliotis 2010; OpenVINS'
// propagator): with R0 = R(q0) and the new state x,
//   F_θθ = R(q)ᵀ R0,   F_vθ = −[v − v0 − g dt]× R0,   F_pθ = −[p − p0 − v0 dt − ½ g dt²]× R0,
// the exact Jacobian of the trapezoidal step when x0 is the current state.  It maps the unobservable directions
// of the first estimates (global position, yaw about gravity: N_θ = R0ᵀ g, N_v = −[v0]× g, N_p = −[p0]× g; Hesch
// et al. 2014) onto those of the new state, so that propagation adds no information along them.
inline void fej_step(double* x, const double* x0, double* Pm, const double* gyro, const double* accel, double dt,
                     const double* gravity, const double* noise, double* F) {
    double w2, f2;
    step_transition(x, gyro, accel, dt, gravity, F, w2, f2);
    double R0[9], R1[9];
    rotmat_xyzw(x0[Q], x0[Q + 1], x0[Q + 2], x0[Q + 3], R0);
    rotmat_xyzw(x[Q], x[Q + 1], x[Q + 2], x[Q + 3], R1);
    double dv[3], dpos[3];
    for (int i = 0; i < 3; ++i) {
        dv[i] = x[V + i] - x0[V + i] - gravity[i] * dt;
        dpos[i] = x[P + i] - x0[P + i] - x0[V + i] * dt - 0.5 * gravity[i] * dt * dt;
    }
    const double Dv[9] = {0.0, -dv[2], dv[1], dv[2], 0.0, -dv[0], -dv[1], dv[0], 0.0};
    const double Dp[9] = {0.0, -dpos[2], dpos[1], dpos[2], 0.0, -dpos[0], -dpos[1], dpos[0], 0.0};
    double A[9], B[9], T[9];
    mul33(Dv, R0, A);
    mul33(Dp, R0, B);
    mul_tn3(R1, R0, T);
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
            F[(DV + i) * NE + DTH + j] = -A[3 * i + j];
            F[(DP + i) * NE + DTH + j] = -B[3 * i + j];
            F[(DTH + i) * NE + DTH + j] = T[3 * i + j];
        }
    congruence_sparse<NE>(F, Pm);
    add_process_noise(Pm, noise, dt, w2, f2);
}

// msckf_propagate(x, x0, P, gyro (k, 3), accel (k, 3), dt (k,), gravity, noise, X (k, 16)): k steps of the ESKF
// prediction with constant input per step, in place on x (16,) and the covariance P (n, n), n >= 15, whose first 15
// rows and columns are the IMU error and the others states that do not move (clones, points, the time offset); the
// transitions at first estimates (fej_step): x0 (16,) those of the start (the state before the last update), then
// each step's own start; the IMU rows of the cross-covariance are multiplied by the product Φ of the step
// transitions (P_IO <- Φ P_IO), X[i] the state after step i.
PyObject* py_propagate(PyObject*, PyObject* args) {
    Array<double, 1, true> x;
    Array<double, 2, true> Pm, X;
    Array<double, 2> gyro, accel;
    Array<double, 1> x0, dt, gravity, noise;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&O&O&:msckf_propagate", convert<double, 1, true>, &x,
                          convert<double, 1>, &x0, convert<double, 2, true>, &Pm, convert<double, 2>, &gyro,
                          convert<double, 2>, &accel, convert<double, 1>, &dt, convert<double, 1>, &gravity,
                          convert<double, 1>, &noise, convert<double, 2, true>, &X))
        return nullptr;
    const npy_intp k = dt.shape[0], n = Pm.shape[0];
    if (!shape_is("x", x, {NX}) || !shape_is("x0", x0, {NX}) || !shape_is("P", Pm, {n, n}) ||
        !shape_is("gyro", gyro, {k, 3}) || !shape_is("accel", accel, {k, 3}) ||
        !shape_is("gravity", gravity, {3}) || !shape_is("noise", noise, {6}) || !shape_is("X", X, {k, NX}))
        return nullptr;
    if (n < NE) {
        PyErr_SetString(PyExc_ValueError, "P must have at least 15 rows (the IMU error first)");
        return nullptr;
    }
    double F[NE * NE], T[NE * NE], Phi[NE * NE], Pii[NE * NE], start[NX];
    Py_BEGIN_ALLOW_THREADS;
    std::fill(Phi, Phi + NE * NE, 0.0);
    for (int i = 0; i < NE; ++i) Phi[i * (NE + 1)] = 1.0;
    for (int i = 0; i < NE; ++i) std::copy(Pm.row(i), Pm.row(i) + NE, Pii + NE * i);
    std::copy(x0.data, x0.data + NX, start);
    for (npy_intp s = 0; s < k; ++s) {
        fej_step(x.data, start, Pii, gyro.row(s), accel.row(s), dt[s], gravity.data, noise.data, F);
        std::copy(x.data, x.data + NX, start);
        mul_sparse_left<NE, NE, NE>(F, Phi, T);
        std::copy(T, T + NE * NE, Phi);
        std::copy(x.data, x.data + NX, X.row(s));
    }
    symmetrize<NE>(Pii);
    for (int i = 0; i < NE; ++i) std::copy(Pii + NE * i, Pii + NE * i + NE, Pm.row(i));
    if (k > 0 && n > NE) {  // P_IO <- Φ P_IO and its transpose
        std::vector<double> C(NE * (n - NE));
        for (int i = 0; i < NE; ++i) {
            double* c = &C[i * (n - NE)];
            for (int q = 0; q < NE; ++q) {
                const double f = Phi[i * NE + q];
                const double* pr = Pm.row(q) + NE;
                for (npy_intp j = 0; j < n - NE; ++j) c[j] += f * pr[j];
            }
        }
        for (int i = 0; i < NE; ++i) {
            std::copy(&C[i * (n - NE)], &C[(i + 1) * (n - NE)], Pm.row(i) + NE);
            for (npy_intp j = 0; j < n - NE; ++j) Pm(NE + j, i) = C[i * (n - NE) + j];
        }
    }
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

// msckf_clone(P (n, n), rows (6,), k, u (U,), Pout (n + 6, n + 6)): the covariance with a clone of the pose error
// J δx (rows: the IMU error's [δp, δθ] rows) inserted at row and column k (15 + 6C, after the clones).  With the
// time offset (the last state; U = 6) the clone is the pose at t_cam + t̂_d and its error gains u δt_d,
// u = [v_w, ω_b]: J P becomes J P + u P_(n-1), and the clone block (J P Jᵀ + …) its symmetric part.  U = 0: no
// time offset.
PyObject* py_clone(PyObject*, PyObject* args) {
    Array<double, 2> Pm;
    Array<std::int64_t, 1> rows;
    Array<double, 1> u;
    Array<double, 2, true> out;
    Py_ssize_t k;
    if (!PyArg_ParseTuple(args, "O&O&nO&O&:msckf_clone", convert<double, 2>, &Pm, convert<std::int64_t, 1>, &rows,
                          &k, convert<double, 1>, &u, convert<double, 2, true>, &out))
        return nullptr;
    const npy_intp n = Pm.shape[0], N = n + 6, nu = u.shape[0];
    if (!shape_is("P", Pm, {n, n}) || !shape_is("rows", rows, {6}) || !shape_is("Pout", out, {N, N}))
        return nullptr;
    if (nu != 0 && nu != 6) {
        PyErr_SetString(PyExc_ValueError, "u must have shape (0,) or (6,)");
        return nullptr;
    }
    if (k < 0 || k > n) {
        PyErr_SetString(PyExc_ValueError, "k must be within [0, len(P)]");
        return nullptr;
    }
    for (int i = 0; i < 6; ++i)
        if (rows[i] < 0 || rows[i] >= n) {
            PyErr_SetString(PyExc_ValueError, "rows must index P");
            return nullptr;
        }
    Py_BEGIN_ALLOW_THREADS;
    auto o = [&](npy_intp j) { return j < k ? j : j + 6; };  // old index -> new index
    for (npy_intp i = 0; i < n; ++i) {
        const double* pr = Pm.row(i);
        double* orow = out.row(o(i));
        std::copy(pr, pr + k, orow);
        std::copy(pr + k, pr + n, orow + k + 6);
    }
    std::vector<double> JP(6 * n);
    for (int i = 0; i < 6; ++i) {
        const double* pr = Pm.row(rows[i]);
        const double* pl = Pm.row(n - 1);
        for (npy_intp j = 0; j < n; ++j) JP[i * n + j] = nu ? pr[j] + u[i] * pl[j] : pr[j];
    }
    double B[36];
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j < 6; ++j)
            B[6 * i + j] = nu ? JP[i * n + rows[j]] + JP[i * n + n - 1] * u[j] : JP[i * n + rows[j]];
    for (int i = 0; i < 6; ++i) {
        for (npy_intp j = 0; j < n; ++j) out(k + i, o(j)) = out(o(j), k + i) = JP[i * n + j];
        for (int j = 0; j < 6; ++j) out(k + i, k + j) = 0.5 * (B[6 * i + j] + B[6 * j + i]);
    }
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

// msckf_select(P (n, n), keep (k,), Pout (k, k)): Pout = P[keep][:, keep] (marginalising the states not kept).
PyObject* py_select(PyObject*, PyObject* args) {
    Array<double, 2> Pm;
    Array<std::int64_t, 1> keep;
    Array<double, 2, true> out;
    if (!PyArg_ParseTuple(args, "O&O&O&:msckf_select", convert<double, 2>, &Pm, convert<std::int64_t, 1>, &keep,
                          convert<double, 2, true>, &out))
        return nullptr;
    const npy_intp n = Pm.shape[0], k = keep.shape[0];
    if (!shape_is("P", Pm, {n, n}) || !shape_is("Pout", out, {k, k})) return nullptr;
    for (npy_intp i = 0; i < k; ++i)
        if (keep[i] < 0 || keep[i] >= n) {
            PyErr_SetString(PyExc_ValueError, "keep must index P");
            return nullptr;
        }
    Py_BEGIN_ALLOW_THREADS;
    for (npy_intp i = 0; i < k; ++i) {
        const double* pr = Pm.row(keep[i]);
        double* orow = out.row(i);
        for (npy_intp j = 0; j < k; ++j) orow[j] = pr[keep[j]];
    }
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

// msckf_features(clones (C, 7), clones_fej (C, 7), q_bc, p_bc, offsets (G + 1,), obs_clone (M,), obs_uv (M, 2), P
// (n, n), sigma, chi2 (D,), limits (4,) = [min_depth, max_depth, min_parallax, min_depth_z], H (R, n), r (R,), rvar (R,),
// status (G,), nis (G,), points (G, 3), top (G, 3, n + 4)) -> rows: the stacked nullspace-projected rows of the accepted features (rvar
// their prior variances (H P Hᵀ)_ii, without the noise) (status 1 accepted, 0 rejected by the gate, -1 triangulation
// failed, -2 too few observations, -3 depth undetermined at the noise sigma: see triangulate, min_depth_z); chi2[d] the gate for d degrees of freedom; points the triangulated world points
// (NaN where none); top the three rows the nullspace projection sets aside, which determine the point (delayed
// initialisation): per feature [H_x1 (3, n) | R (3, 3) upper triangular | r1 (3, 1)] (the Givens-rotated H_x, H_f and
// residual), for every triangulated feature.  P (n, n) may carry other states after the clones (landmarks, the time
// offset: n >= 15 + 6C); their columns of H are zero.
PyObject* py_features(PyObject*, PyObject* args) {
    Array<double, 2> clones, fej, uv, Pm;
    Array<double, 1> q_bc, p_bc, chi2, limits;
    Array<std::int64_t, 1> offsets, oc;
    Array<double, 2, true> Hout;
    Array<double, 1, true> rout, rvar, nis;
    Array<double, 2, true> points;
    Array<double, 3, true> top;
    Array<std::int64_t, 1, true> status;
    double sigma;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&O&dO&O&O&O&O&O&O&O&O&:msckf_features", convert<double, 2>, &clones,
                          convert<double, 2>, &fej, convert<double, 1>, &q_bc, convert<double, 1>, &p_bc,
                          convert<std::int64_t, 1>, &offsets, convert<std::int64_t, 1>, &oc, convert<double, 2>, &uv,
                          convert<double, 2>, &Pm, &sigma, convert<double, 1>, &chi2, convert<double, 1>, &limits,
                          convert<double, 2, true>, &Hout, convert<double, 1, true>, &rout,
                          convert<double, 1, true>, &rvar, convert<std::int64_t, 1, true>, &status, convert<double, 1, true>, &nis,
                          convert<double, 2, true>, &points, convert<double, 3, true>, &top))
        return nullptr;
    const npy_intp nc = clones.shape[0], n = Pm.shape[0], g = offsets.shape[0] - 1, m_all = oc.shape[0];
    if (!shape_is("clones", clones, {-1, 7}) || !shape_is("clones_fej", fej, {nc, 7}) ||
        !shape_is("q_bc", q_bc, {4}) || !shape_is("p_bc", p_bc, {3}) || !shape_is("obs_uv", uv, {m_all, 2}) ||
        !shape_is("P", Pm, {n, n}) || !shape_is("limits", limits, {4}) || !shape_is("points", points, {g, 3}) ||
        !shape_is("top", top, {g, 3, n + 4}) ||
        !shape_is("H", Hout, {-1, n}) || !shape_is("r", rout, {Hout.shape[0]}) ||
        !shape_is("rvar", rvar, {Hout.shape[0]}) || !shape_is("status", status, {g}) ||
        !shape_is("nis", nis, {g}))
        return nullptr;
    if (n < NE + 6 * nc) {
        PyErr_SetString(PyExc_ValueError, "P must have at least 15 + 6C rows (IMU, C clones, then any other states)");
        return nullptr;
    }
    if (chi2.shape[0] < 1) {  // the gate reads chi2[min(dof, D - 1)]
        PyErr_SetString(PyExc_ValueError, "chi2 must have shape (D,) with D >= 1; got (0,)");
        return nullptr;
    }
    for (npy_intp f = 0; f <= g; ++f)
        if (offsets[f] < 0 || offsets[f] > m_all || (f < g && offsets[f] > offsets[f + 1])) {
            PyErr_SetString(PyExc_ValueError, "offsets must be nondecreasing within [0, len(obs_clone)]");
            return nullptr;
        }
    for (npy_intp j = 0; j < m_all; ++j)
        if (oc[j] < 0 || oc[j] >= nc) {
            PyErr_SetString(PyExc_ValueError, "obs_clone must index the clones");
            return nullptr;
        }
    const npy_intp rows_cap = Hout.shape[0];
    npy_intp rows = 0;
    Py_BEGIN_ALLOW_THREADS;
    double Rbc[9];
    rotmat_xyzw(q_bc[0], q_bc[1], q_bc[2], q_bc[3], Rbc);
    std::vector<CamPose> cams(nc);
    std::vector<double> Rwb_fej(9 * nc), Rwb(9 * nc);
    for (npy_intp c = 0; c < nc; ++c) {
        cams[c] = camera_pose(clones.row(c), Rbc, p_bc.data);
        const double* q = fej.row(c) + 3;
        rotmat_xyzw(q[0], q[1], q[2], q[3], &Rwb_fej[9 * c]);
        const double* q2 = clones.row(c) + 3;
        rotmat_xyzw(q2[0], q2[1], q2[2], q2[3], &Rwb[9 * c]);
    }
    std::vector<double> Hx, Hf, res, H0, HP, S, diag;
    std::vector<int> piv;
    const double s2 = sigma * sigma;
    for (npy_intp f = 0; f < g; ++f) {
        const npy_intp a = offsets[f], m = offsets[f + 1] - a;
        nis[f] = NAN;
        if (m < 2) {
            status[f] = -2;
            continue;
        }
        double* pw = points.row(f);
        pw[0] = pw[1] = pw[2] = NAN;
        const int tri = triangulate(cams, oc.data + a, uv.data + 2 * a, m, limits[0], limits[1], limits[2], sigma,
                                    limits[3], pw);
        if (tri != TRI_OK) {
            status[f] = tri;
            continue;
        }
        const npy_intp nr = 2 * m;
        Hx.assign(nr * n, 0.0);
        Hf.assign(nr * 3, 0.0);
        res.assign(nr, 0.0);
        bool ok = true;
        for (npy_intp j = 0; j < m && ok; ++j) {
            const npy_intp c = oc[a + j];
            double Hc[12], Hfj[6];
            ok = observe(clones.row(c), &Rwb[9 * c], fej.row(c), &Rwb_fej[9 * c], Rbc, p_bc.data, pw, pw,
                         uv.row(a + j), &res[2 * j], Hc, Hfj);
            for (int i = 0; i < 2 && ok; ++i) {
                std::copy(Hc + 6 * i, Hc + 6 * i + 6, &Hx[(2 * j + i) * n + NE + 6 * c]);
                std::copy(Hfj + 3 * i, Hfj + 3 * i + 3, &Hf[(2 * j + i) * 3]);
            }
        }
        if (!ok) {
            status[f] = -1;
            continue;
        }
        // left-nullspace projection: Givens rotations zero H_f below its diagonal, applied to H_x and r alike
        for (int c = 0; c < 3; ++c)
            for (npy_intp k = nr - 1; k > c; --k) {
                const double aa = Hf[(k - 1) * 3 + c], bb = Hf[k * 3 + c];
                if (bb == 0.0) continue;
                const double rr = std::hypot(aa, bb), cs = aa / rr, sn = bb / rr;
                for (int cc = c; cc < 3; ++cc) {
                    const double u = Hf[(k - 1) * 3 + cc], v = Hf[k * 3 + cc];
                    Hf[(k - 1) * 3 + cc] = cs * u + sn * v;
                    Hf[k * 3 + cc] = -sn * u + cs * v;
                }
                double* h1 = &Hx[(k - 1) * n];
                double* h2 = &Hx[k * n];
                for (npy_intp cc = NE; cc < n; ++cc) {
                    const double u = h1[cc], v = h2[cc];
                    h1[cc] = cs * u + sn * v;
                    h2[cc] = -sn * u + cs * v;
                }
                const double u = res[k - 1], v = res[k];
                res[k - 1] = cs * u + sn * v;
                res[k] = -sn * u + cs * v;
            }
        for (int i = 0; i < 3; ++i) {  // the rows that determine the feature: [H_x1 | R | r1]
            double* t = top.row(f) + i * (n + 4);
            std::copy(&Hx[i * n], &Hx[i * n] + n, t);
            std::copy(&Hf[i * 3], &Hf[i * 3] + 3, t + n);
            t[n + 3] = res[i];
        }
        const npy_intp dof = nr - 3;
        if (dof < 1) {
            status[f] = -2;
            continue;
        }
        const double* h0 = &Hx[3 * n];
        const double* r0 = &res[3];
        // χ² gate: S = H0 P H0ᵀ + σ² I
        HP.assign(dof * n, 0.0);
        for (npy_intp i = 0; i < dof; ++i)
            for (npy_intp k = NE; k < n; ++k) {
                const double h = h0[i * n + k];
                if (h == 0.0) continue;
                const double* prow = Pm.row(k);
                double* o = &HP[i * n];
                for (npy_intp jj = 0; jj < n; ++jj) o[jj] += h * prow[jj];
            }
        S.assign(dof * dof, 0.0);
        for (npy_intp i = 0; i < dof; ++i)
            for (npy_intp jj = 0; jj < dof; ++jj) {
                double s = 0.0;
                for (npy_intp k = NE; k < n; ++k) s += HP[i * n + k] * h0[jj * n + k];
                S[i * dof + jj] = s + (i == jj ? s2 : 0.0);
            }
        diag.resize(dof);
        for (npy_intp i = 0; i < dof; ++i) diag[i] = S[i * dof + i] - s2;
        piv.assign(dof, 0);
        std::vector<double> y(r0, r0 + dof);
        if (!lu_factor<0>(S.data(), static_cast<int>(dof), piv.data())) {
            status[f] = -1;
            continue;
        }
        lu_solve<0, 1>(S.data(), piv.data(), static_cast<int>(dof), y.data(), 1);
        double q = 0.0;
        for (npy_intp i = 0; i < dof; ++i) q += r0[i] * y[i];
        nis[f] = q;
        const double gate = dof < chi2.shape[0] ? chi2[dof] : chi2[chi2.shape[0] - 1];
        if (!(q <= gate) || rows + dof > rows_cap) {
            status[f] = 0;
            continue;
        }
        status[f] = 1;
        std::copy(h0, h0 + dof * n, Hout.row(rows));
        std::copy(r0, r0 + dof, rout.data + rows);
        std::copy(diag.begin(), diag.end(), rvar.data + rows);
        rows += dof;
    }
    Py_END_ALLOW_THREADS;
    return PyLong_FromSsize_t(rows);
}


// msckf_slam_rows(clones (C, 7), clones_fej (C, 7), q_bc, p_bc, points (L, 3), points_fej (L, 3), idx (k,), clone,
// uv (k, 2), P (n, n), sigma, gate, H (2k, n), r (2k,), status (k,), r_all (2k,), rvar (2k,)) -> (rows, front):
// the observations uv of the SLAM features idx (world points at columns 15 + 6C + 3l of P, n >= 15 + 6C + 3L) in the
// clone `clone`: per feature the two rows (residual at the current estimates, Jacobians at the first estimates of
// the clone and the point, as msckf_features), its NIS rᵀ (H P Hᵀ + σ² I)⁻¹ r against `gate`; the accepted rows
// stacked in H and r (rows of them), status 1 accepted, 0 gated, -1 behind the camera; r_all and rvar the residuals
// and prior variances (H P Hᵀ)_ii of the features in front of the camera (2 · front entries), before the gate.
PyObject* py_slam_rows(PyObject*, PyObject* args) {
    Array<double, 2> clones, fej, pts, pts_fej, uv, Pm;
    Array<double, 1> q_bc, p_bc;
    Array<std::int64_t, 1> idx;
    Array<double, 2, true> Hout;
    Array<double, 1, true> rout, rall, rvar;
    Array<std::int64_t, 1, true> status;
    Py_ssize_t clone;
    double sigma, gate;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&nO&O&ddO&O&O&O&O&:msckf_slam_rows", convert<double, 2>, &clones,
                          convert<double, 2>, &fej, convert<double, 1>, &q_bc, convert<double, 1>, &p_bc,
                          convert<double, 2>, &pts, convert<double, 2>, &pts_fej, convert<std::int64_t, 1>, &idx,
                          &clone, convert<double, 2>, &uv, convert<double, 2>, &Pm, &sigma, &gate,
                          convert<double, 2, true>, &Hout, convert<double, 1, true>, &rout,
                          convert<std::int64_t, 1, true>, &status, convert<double, 1, true>, &rall,
                          convert<double, 1, true>, &rvar))
        return nullptr;
    const npy_intp nc = clones.shape[0], nl = pts.shape[0], k = idx.shape[0], n = Pm.shape[0];
    if (!shape_is("clones", clones, {-1, 7}) || !shape_is("clones_fej", fej, {nc, 7}) ||
        !shape_is("q_bc", q_bc, {4}) || !shape_is("p_bc", p_bc, {3}) || !shape_is("points", pts, {-1, 3}) ||
        !shape_is("points_fej", pts_fej, {nl, 3}) || !shape_is("uv", uv, {k, 2}) || !shape_is("P", Pm, {n, n}) ||
        !shape_is("H", Hout, {2 * k, n}) || !shape_is("r", rout, {2 * k}) || !shape_is("status", status, {k}) ||
        !shape_is("r_all", rall, {2 * k}) || !shape_is("rvar", rvar, {2 * k}))
        return nullptr;
    if (n < NE + 6 * nc + 3 * nl) {
        PyErr_SetString(PyExc_ValueError, "P must have at least 15 + 6C + 3L rows (IMU, clones, points)");
        return nullptr;
    }
    if (clone < 0 || clone >= nc) {
        PyErr_SetString(PyExc_ValueError, "clone must index the clones");
        return nullptr;
    }
    for (npy_intp j = 0; j < k; ++j)
        if (idx[j] < 0 || idx[j] >= nl) {
            PyErr_SetString(PyExc_ValueError, "idx must index the points");
            return nullptr;
        }
    npy_intp rows = 0, front = 0;
    Py_BEGIN_ALLOW_THREADS;
    double Rbc[9], Rwb[9], Rf[9];
    rotmat_xyzw(q_bc[0], q_bc[1], q_bc[2], q_bc[3], Rbc);
    const double* cl = clones.row(clone);
    const double* fe = fej.row(clone);
    rotmat_xyzw(cl[3], cl[4], cl[5], cl[6], Rwb);
    rotmat_xyzw(fe[3], fe[4], fe[5], fe[6], Rf);
    const double s2 = sigma * sigma;
    for (npy_intp j = 0; j < k; ++j) {
        const npy_intp l = idx[j];
        double res[2], Hc[12], Hf[6];
        if (!observe(cl, Rwb, fe, Rf, Rbc, p_bc.data, pts.row(l), pts_fej.row(l), uv.row(j), res, Hc, Hf)) {
            status[j] = -1;
            continue;
        }
        npy_intp cols[9];
        double Hs[18];  // 2 x 9 over cols
        for (int i = 0; i < 6; ++i) cols[i] = NE + 6 * clone + i;
        for (int i = 0; i < 3; ++i) cols[6 + i] = NE + 6 * nc + 3 * l + i;
        for (int i = 0; i < 2; ++i) {
            std::copy(Hc + 6 * i, Hc + 6 * i + 6, Hs + 9 * i);
            std::copy(Hf + 3 * i, Hf + 3 * i + 3, Hs + 9 * i + 6);
        }
        double HP[18] = {};
        for (int i = 0; i < 2; ++i)
            for (int b = 0; b < 9; ++b) {
                double acc = 0.0;
                for (int a = 0; a < 9; ++a) acc += Hs[9 * i + a] * Pm(cols[a], cols[b]);
                HP[9 * i + b] = acc;
            }
        double S[4];
        for (int i = 0; i < 2; ++i)
            for (int jj = 0; jj < 2; ++jj) {
                double acc = 0.0;
                for (int b = 0; b < 9; ++b) acc += HP[9 * i + b] * Hs[9 * jj + b];
                S[2 * i + jj] = acc;
            }
        rall[2 * front] = res[0];
        rall[2 * front + 1] = res[1];
        rvar[2 * front] = S[0];
        rvar[2 * front + 1] = S[3];
        ++front;
        S[0] += s2;
        S[3] += s2;
        const double det = S[0] * S[3] - S[1] * S[2];
        const double q = (S[3] * res[0] * res[0] - (S[1] + S[2]) * res[0] * res[1] + S[0] * res[1] * res[1]) / det;
        if (!(det > 0.0) || !(q <= gate)) {
            status[j] = 0;
            continue;
        }
        status[j] = 1;
        for (int i = 0; i < 2; ++i) {
            double* h = Hout.row(rows + i);
            std::fill(h, h + n, 0.0);
            for (int a = 0; a < 9; ++a) h[cols[a]] = Hs[9 * i + a];
            rout[rows + i] = res[i];
        }
        rows += 2;
    }
    Py_END_ALLOW_THREADS;
    return Py_BuildValue("nn", rows, front);
}

// The arithmetic of msckf_update (below) on raw arrays: x (16,), clones (nc, 7), landmarks lm (nl, 3), extra (ne,), P
// (n, n), H (m, n) and r (m,) (both overwritten by the QR compression when m > n); nis <- rᵀ S⁻¹ r; false when S is
// not positive definite.  Cloned for AVX2 and AVX-512 (dispatch.hpp): every clone rounds as the baseline (the
// vectorised loops are elementwise; no reduction is reordered, no FMA).
DUALPOSE_CLONES_V4
bool msckf_update_core(double* x, double* clones_p, double* lm_p, double* extra_p, double* Pp, double* H, double* r,
                       npy_intp nc, npy_intp nl, npy_intp ne, npy_intp m, double sigma, double& nis) {
    const npy_intp n0 = NE + 6 * nc + 3 * nl, n = n0 + ne;
    const npy_intp m_all = m;
    auto Prow = [&](npy_intp i) { return Pp + i * n; };
    bool ok = true;
    double* h = H;
    // the first column that can be nonzero: feature rows leave the IMU columns zero
    npy_intp c0 = NE;
    for (npy_intp i = 0; i < m && c0 > 0; ++i)
        for (npy_intp k = 0; k < NE; ++k)
            if (h[i * n + k] != 0.0) {
                c0 = 0;
                break;
            }
    if (m > n) {  // Householder QR on the transposed columns c0..n (contiguous), then T back into the top rows of H
        const npy_intp nw = n - c0;
        std::vector<double> Ht(nw * m), v(m);
        for (npy_intp i = 0; i < m; ++i)
            for (npy_intp j = 0; j < nw; ++j) Ht[j * m + i] = h[i * n + c0 + j];
        for (npy_intp k = 0; k < nw; ++k) {
            double* col = &Ht[k * m];
            double norm = 0.0;
            for (npy_intp i = k; i < m; ++i) norm += col[i] * col[i];
            norm = std::sqrt(norm);
            if (norm == 0.0) continue;
            const double alpha = col[k] > 0 ? -norm : norm;
            for (npy_intp i = k; i < m; ++i) v[i] = col[i];
            v[k] -= alpha;
            double vv = 0.0;
            for (npy_intp i = k; i < m; ++i) vv += v[i] * v[i];
            if (vv == 0.0) continue;
            const double beta = 2.0 / vv;
            for (npy_intp j = k; j < nw; ++j) {
                double* cj = &Ht[j * m];
                double d = 0.0;
                for (npy_intp i = k; i < m; ++i) d += v[i] * cj[i];
                d *= beta;
                for (npy_intp i = k; i < m; ++i) cj[i] -= d * v[i];
            }
            double d = 0.0;
            for (npy_intp i = k; i < m; ++i) d += v[i] * r[i];
            d *= beta;
            for (npy_intp i = k; i < m; ++i) r[i] -= d * v[i];
        }
        m = nw;  // the rows below nw are zero in H: they carry no information
        for (npy_intp i = 0; i < m; ++i) {
            for (npy_intp k = 0; k < c0; ++k) h[i * n + k] = 0.0;
            for (npy_intp j = 0; j < nw; ++j) h[i * n + c0 + j] = Ht[j * m_all + i];
        }
    }
    // W (m, n) = H P (P symmetric: W_j = Σ_k h_jk P_k, over the nonzero h_jk only: a SLAM feature's rows have 9,
    // an MSCKF feature's those of its clones);  S = H P Hᵀ + σ² I = W Hᵀ over the same nonzeros
    std::vector<double> W(m * n, 0.0), S(m * m), L;
    std::vector<npy_intp> nzc;
    std::vector<npy_intp> nz_off(m + 1, 0);
    for (npy_intp j = 0; j < m; ++j) {
        const double* hr = h + j * n;
        double* wr = &W[j * n];
        for (npy_intp k = c0; k < n; ++k) {
            const double hk = hr[k];
            if (hk == 0.0) continue;
            nzc.push_back(k);
            const double* pr = Prow(k);
            for (npy_intp i = 0; i < n; ++i) wr[i] += hk * pr[i];
        }
        nz_off[j + 1] = static_cast<npy_intp>(nzc.size());
    }
    // S_i = Σ_k h_ik (Wᵀ)_k over the nonzeros of row i in increasing k: each S_ij sums in the order of a dot product
    // of the two rows, as axpys over the rows of Wᵀ (vectorised; no chain of dependent additions)
    std::vector<double> Wt((n - c0) * m);
    for (npy_intp j = 0; j < m; ++j)
        for (npy_intp k = c0; k < n; ++k) Wt[(k - c0) * m + j] = W[j * n + k];
    std::fill(S.begin(), S.end(), 0.0);
    for (npy_intp i = 0; i < m; ++i) {
        const double* hr = h + i * n;
        double* sr = &S[i * m];
        for (npy_intp q = nz_off[i]; q < nz_off[i + 1]; ++q) {
            const double hk = hr[nzc[q]];
            const double* wt = &Wt[(nzc[q] - c0) * m];
            for (npy_intp j = 0; j < m; ++j) sr[j] += hk * wt[j];
        }
    }
    for (npy_intp i = 0; i < m; ++i) {  // symmetrise (rounding) and add the noise
        for (npy_intp j = 0; j < i; ++j) S[i * m + j] = S[j * m + i] = 0.5 * (S[i * m + j] + S[j * m + i]);
        S[i * m + i] += sigma * sigma;
    }
    // Cholesky S = L Lᵀ (lower, in place)
    L = S;
    for (npy_intp j = 0; j < m && ok; ++j) {
        double d = L[j * m + j];
        for (npy_intp k = 0; k < j; ++k) d -= L[j * m + k] * L[j * m + k];
        if (!(d > 0.0)) {
            ok = false;
            break;
        }
        d = std::sqrt(d);
        L[j * m + j] = d;
        for (npy_intp i = j + 1; i < m; ++i) {
            double s = L[i * m + j];
            for (npy_intp k = 0; k < j; ++k) s -= L[i * m + k] * L[j * m + k];
            L[i * m + j] = s / d;
        }
    }
    if (ok) {
        // W = L⁻¹ (H P) (m, n), y = L⁻¹ r: then P <- P − Wᵀ W, δx = Wᵀ y, NIS = yᵀ y
        // (forward substitution by blocks of four rows: the rows above a block are applied to its four rows in one
        // pass, reading each once; every row still takes its terms in increasing k, as one row at a time would)
        std::vector<double> y(r, r + m);
        auto sub = [&](npy_intp j, npy_intp k) {  // row j -= L_jk row k
            const double l = L[j * m + k];
            if (l == 0.0) return;
            for (npy_intp i = 0; i < n; ++i) W[j * n + i] -= l * W[k * n + i];
            y[j] -= l * y[k];
        };
        for (npy_intp jb = 0; jb < m; jb += 4) {
            const npy_intp je = std::min<npy_intp>(jb + 4, m);
            for (npy_intp k = 0; k < jb; ++k) {
                const double* lk = &L[k];
                if (je - jb < 4 || lk[jb * m] == 0.0 || lk[(jb + 1) * m] == 0.0 || lk[(jb + 2) * m] == 0.0 ||
                    lk[(jb + 3) * m] == 0.0) {
                    for (npy_intp j = jb; j < je; ++j) sub(j, k);
                    continue;
                }
                const double l0 = lk[jb * m], l1 = lk[(jb + 1) * m], l2 = lk[(jb + 2) * m], l3 = lk[(jb + 3) * m];
                const double* wk = &W[k * n];
                double *w0 = &W[jb * n], *w1 = w0 + n, *w2 = w1 + n, *w3 = w2 + n;
                for (npy_intp i = 0; i < n; ++i) {
                    const double v = wk[i];
                    w0[i] -= l0 * v;
                    w1[i] -= l1 * v;
                    w2[i] -= l2 * v;
                    w3[i] -= l3 * v;
                }
                y[jb] -= l0 * y[k];
                y[jb + 1] -= l1 * y[k];
                y[jb + 2] -= l2 * y[k];
                y[jb + 3] -= l3 * y[k];
            }
            for (npy_intp j = jb; j < je; ++j) {
                for (npy_intp k = jb; k < j; ++k) sub(j, k);
                const double d = L[j * m + j];
                for (npy_intp i = 0; i < n; ++i) W[j * n + i] /= d;
                y[j] /= d;
            }
        }
        std::vector<double> dx(n, 0.0);
        for (npy_intp j = 0; j < m; ++j) {
            nis += y[j] * y[j];
            for (npy_intp i = 0; i < n; ++i) dx[i] += W[j * n + i] * y[j];
        }
        // P −= Wᵀ W, upper triangle, four rows of W per pass over P (P is read and written m/4 times, not m), then
        // mirrored by 8 x 8 tiles (whole cache lines written, not a column at a time)
        npy_intp j = 0;
        for (; j + 4 <= m; j += 4) {
            const double *w0 = &W[j * n], *w1 = w0 + n, *w2 = w1 + n, *w3 = w2 + n;
            for (npy_intp i = 0; i < n; ++i) {
                const double a0 = w0[i], a1 = w1[i], a2 = w2[i], a3 = w3[i];
                if (a0 == 0.0 && a1 == 0.0 && a2 == 0.0 && a3 == 0.0) continue;
                double* pr = Prow(i);
                for (npy_intp k = i; k < n; ++k) pr[k] -= (a0 * w0[k] + a1 * w1[k]) + (a2 * w2[k] + a3 * w3[k]);
            }
        }
        for (; j < m; ++j) {
            const double* w = &W[j * n];
            for (npy_intp i = 0; i < n; ++i) {
                const double wi = w[i];
                if (wi == 0.0) continue;
                double* pr = Prow(i);
                for (npy_intp k = i; k < n; ++k) pr[k] -= wi * w[k];
            }
        }
        constexpr npy_intp tile = 8;
        for (npy_intp ib = 0; ib < n; ib += tile)
            for (npy_intp kb = ib; kb < n; kb += tile) {
                const npy_intp ie = std::min(ib + tile, n), ke = std::min(kb + tile, n);
                for (npy_intp k = kb; k < ke; ++k) {
                    double* dst = Prow(k);
                    for (npy_intp i = ib; i < ie && i < k; ++i) dst[i] = Pp[i * n + k];
                }
            }
        for (int i = 0; i < 3; ++i) {
            x[P + i] += dx[DP + i];
            x[V + i] += dx[DV + i];
            x[BG + i] += dx[DBG + i];
            x[BA + i] += dx[DBA + i];
        }
        quat_mul_exp_inplace(x + Q, dx[DTH], dx[DTH + 1], dx[DTH + 2]);
        for (npy_intp c = 0; c < nc; ++c) {
            double* cl = clones_p + 7 * c;
            const double* d = &dx[NE + 6 * c];
            for (int i = 0; i < 3; ++i) cl[i] += d[i];
            quat_mul_exp_inplace(cl + 3, d[3], d[4], d[5]);
        }
        for (npy_intp l = 0; l < nl; ++l)
            for (int i = 0; i < 3; ++i) lm_p[3 * l + i] += dx[NE + 6 * nc + 3 * l + i];
        for (npy_intp e = 0; e < ne; ++e) extra_p[e] += dx[n0 + e];
    }
    return ok;
}

// msckf_update(x (16,), clones (C, 7), landmarks (L, 3), extra (E,), P (n, n), H (m, n), r (m,), sigma) -> nis: the
// EKF update with r = H δx + e, e ~ N(0, σ² I), of the IMU state, the clones, the landmarks (world points, additive
// error at columns 15 + 6C + 3l) and E scalar states after them (additive; the camera time offset; n = 15 + 6C + 3L
// + E), in place.  When m > n the rows are first compressed by a
// Householder QR (H = Q T, r <- Q₁ᵀ r; Mourikis & Roumeliotis 2007 §III-D).  P <- P − P Hᵀ S⁻¹ H P (symmetrised),
// then δx = P Hᵀ S⁻¹ r is injected (IMU: additive blocks, q ⊗ Exp(δθ); clones: p + δp, q ⊗ Exp(δθ)).  Returns the
// NIS rᵀ S⁻¹ r, or raises numpy's LinAlgError if S is not positive definite.
PyObject* py_update(PyObject*, PyObject* args) {
    Array<double, 1, true> x, r, extra;
    Array<double, 2, true> clones, lm, Pm, H;
    double sigma;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&d:msckf_update", convert<double, 1, true>, &x,
                          convert<double, 2, true>, &clones, convert<double, 2, true>, &lm,
                          convert<double, 1, true>, &extra, convert<double, 2, true>, &Pm,
                          convert<double, 2, true>, &H, convert<double, 1, true>, &r, &sigma))
        return nullptr;
    const npy_intp nc = clones.shape[0], nl = lm.shape[0], ne = extra.shape[0], n0 = NE + 6 * nc + 3 * nl, n = n0 + ne;
    const npy_intp m = H.shape[0];
    if (!shape_is("x", x, {NX}) || !shape_is("clones", clones, {-1, 7}) || !shape_is("landmarks", lm, {-1, 3}) ||
        !shape_is("P", Pm, {n, n}) ||
        !shape_is("H", H, {-1, n}) || !shape_is("r", r, {m}))
        return nullptr;
    double nis = 0.0;
    bool ok;
    Py_BEGIN_ALLOW_THREADS;
    ok = msckf_update_core(x.data, clones.data, lm.data, extra.data, Pm.data, H.data, r.data, nc, nl, ne, m, sigma,
                           nis);
    Py_END_ALLOW_THREADS;
    if (!ok) return raise_linalg_error("the innovation covariance is not positive definite");
    return PyFloat_FromDouble(nis);
}

PyMethodDef methods[] = {
    {"msckf_propagate", py_propagate, METH_VARARGS,
     "msckf_propagate(x, x0, P, gyro, accel, dt, gravity, noise, X): k ESKF prediction steps in place on x (16,) "
     "and P (n, n) (IMU error first, the other states static), X (k, 16) the state after every step."},
    {"msckf_clone", py_clone, METH_VARARGS,
     "msckf_clone(P, rows, k, u, Pout): the covariance P (n, n) with a clone of the IMU pose error (rows (6,)) "
     "inserted at row and column k into Pout (n + 6, n + 6); u (6,) = [v_w, ω_b] with the time offset last in P, "
     "(0,) without."},
    {"msckf_select", py_select, METH_VARARGS,
     "msckf_select(P, keep, Pout): Pout (k, k) = P[keep][:, keep], keep (k,) int64."},
    {"msckf_features", py_features, METH_VARARGS,
     "msckf_features(clones, clones_fej, q_bc, p_bc, offsets, obs_clone, obs_uv, P, sigma, chi2, limits, H, r, rvar, "
     "status, nis, points, top) -> rows: triangulate, linearise (FEJ), nullspace-project and gate every feature; "
     "the accepted rows stacked in H (R, n) and r (R,), their prior variances (H P Hᵀ)_ii in rvar (R,), the "
     "triangulated points in points (G, 3), the rows that determine each point in top (G, 3, n + 4)."},
    {"msckf_slam_rows", py_slam_rows, METH_VARARGS,
     "msckf_slam_rows(clones, clones_fej, q_bc, p_bc, points, points_fej, idx, clone, uv, P, sigma, gate, H, r, status, "
     "r_all, rvar) -> (rows, front): the gated update rows of SLAM features observed in one clone (FEJ Jacobians), "
     "and the residuals and prior variances of those in front of the camera."},
    {"msckf_update", py_update, METH_VARARGS,
     "msckf_update(x, clones, landmarks, extra, P, H, r, sigma) -> nis: EKF update (QR-compressed when H has more rows "
     "than columns) of the IMU state x (16,), the clones (C, 7), the landmarks (L, 3), the scalar states extra (E,) "
     "and P (15 + 6C + 3L + E, same) in place, noise sigma² I."},
    {nullptr, nullptr, 0, nullptr},
};

}  // namespace

bool add_msckf(PyObject* m) { return PyModule_AddFunctions(m, methods) == 0; }

}  // namespace dualpose
