// dualpose._native's AHRS smoother part (add_ahrs_smoother): ahrs_smooth, the offline Rauch–Tung–Striebel smoother
// over the AHRS's error-state model (Rauch, Tung & Striebel 1965; Särkkä 2013, "Bayesian Filtering and Smoothing",
// Thm 8.2; the global attitude chart after Solà 2017, §7), used by dualpose.estimation.ahrs.smoother.
//
// Forward: the AHRS's own per-sample step (ahrs_run.cpp), unchanged, with a PredictRecord that keeps the state right
// after each prediction: x_{k+1|k} = (q_{k+1|k}, b_{k|k}), P_{k+1|k} and the rotation R̂_k of F_k = [[I, −R̂_k dt],
// [0, I]] (global error q = Exp(δθ) ⊗ q̂).  The filtered x_{k|k}, P_{k|k} are the state after step k's updates.
//
// Backward, for k = n − 2 … 0 (at k = n − 1 the smoother is the filter):
//   μ = x^s_{k+1} ⊖ x_{k+1|k} = [Log(q^s_{k+1} ⊗ q_{k+1|k}*), b^s_{k+1} − b_{k+1|k}]     (global chart)
//   Σ = J_l⁻¹(μ_θ) P^s_{k+1} J_l⁻ᵀ(μ_θ)       (P^s_{k+1}, in the chart of x^s_{k+1}, re-expressed in that of x_{k+1|k})
//   G = P_{k|k} F_kᵀ P_{k+1|k}⁻¹ (a solve),   δ = G μ,   S = P_{k|k} + G (Σ − P_{k+1|k}) Gᵀ
//   x^s_k = x_{k|k} ⊕ δ = (Exp(δ_θ) ⊗ q_{k|k}, b_{k|k} + δ_b),   P^s_k = J_l(δ_θ) S J_lᵀ(δ_θ)
// with the SO(3) left Jacobian J_l(φ) = J_r(−φ) (Solà 2017 eq. 183–186): Exp(δ) ⊗ Exp(φ) ≈ Exp(φ + J_l⁻¹(φ) δ).
// The update of the AHRS measures a 3 s window mean; the smoother treats it as a measurement of the state at its
// update time (the filter's own approximation: the window is rotated with every correction).
#include "ahrs_filter.hpp"
#include "ahrs_run.hpp"
#include "eskf_args.hpp"
#include "smoother_kernels.hpp"

#include <cstdint>
#include <vector>

namespace dualpose {

namespace ahrs {

namespace {

// S <- J S Jᵀ in place for J = diag(A, I₃) (6, 6): a change of the attitude chart, A (3, 3); symmetrised.
void congruence_attitude(double* S, const double* A) {
    double T[NE * NE];
    for (int i = 0; i < NE; ++i)
        for (int j = 0; j < NE; ++j) {
            double s = S[i * NE + j];
            if (i < 3) {
                s = 0.0;
                for (int k = 0; k < 3; ++k) s += A[3 * i + k] * S[k * NE + j];
            }
            T[i * NE + j] = s;
        }
    for (int i = 0; i < NE; ++i)
        for (int j = 0; j < NE; ++j) {
            double s = T[i * NE + j];
            if (j < 3) {
                s = 0.0;
                for (int k = 0; k < 3; ++k) s += T[i * NE + k] * A[3 * j + k];
            }
            S[i * NE + j] = s;
        }
    symmetrize<NE>(S);
}

// out (3, 3) = J_l(φ) (inverse = 0) or J_l⁻¹(φ) (inverse = 1); J_l(φ) = J_r(−φ).
void left_jacobian(const double* phi, double inverse, double* out) {
    const double m[3] = {-phi[0], -phi[1], -phi[2]};
    smoother::right_jacobian(m, inverse, out);
}

// out (3,) = Log(a ⊗ b*), the global rotation vector taking b to a (angle in [0, π]); a, b (4,) xyzw.
void log_global(const double* a, const double* b, double* out) {
    store(out, rotvec_of_quat(qmul(load4(a), Quat{-b[0], -b[1], -b[2], b[3]})));
}

}  // namespace

// The forward filter over n samples (run's loop, keeping P_{k|k} and the predictions) and the backward pass above.
// gyr, acc, mag (n, 3); q (4,), b (3,), P (6, 6) the initial state, replaced by the filter's final one; params, Ha,
// Hm as for run; out_q (n, 4), out_b (n, 3), out_P (n, 6, 6) the filtered states; stats (N_STATS,) accumulated;
// sm_q (n, 4), sm_b (n, 3), sm_P (n, 6, 6) the smoothed ones.
smoother::Status smooth(std::ptrdiff_t n, const double* gyr, const double* acc, const double* mag, double dt,
                        double* q, double* b, double* P, const double* params, const double* Ha, const double* Hm,
                        double* out_q, double* out_b, double* out_P, double* stats, double* sm_q, double* sm_b,
                        double* sm_P) {
    constexpr int nn = NE * NE;
    const Params p = make_params(params, Ha, Hm, dt);
    State s;
    std::vector<double> ring(ring_doubles(p));
    std::vector<PredictRecord> rec(static_cast<std::size_t>(n));
    init_state(s, ring.data(), p, q, b, P);
    for (int i = 0; i < S_MAG_LAG; ++i) s.stats[i] = stats[i];  // the counters accumulate; τ̂ is the state's
    for (std::ptrdiff_t k = 0; k < n; ++k) {
        step(s, ring.data(), p, gyr + 3 * k, acc + 3 * k, mag + 3 * k, &rec[k]);
        for (int i = 0; i < 4; ++i) out_q[4 * k + i] = s.q[i];
        for (int i = 0; i < 3; ++i) out_b[3 * k + i] = s.b[i];
        for (int i = 0; i < nn; ++i) out_P[nn * k + i] = s.P[i];
    }
    for (int i = 0; i < 4; ++i) q[i] = s.q[i];
    for (int i = 0; i < 3; ++i) b[i] = s.b[i];
    for (int i = 0; i < nn; ++i) P[i] = s.P[i];
    for (int i = 0; i < N_STATS; ++i) stats[i] = s.stats[i];
    if (n == 0) return smoother::Status::ok;

    const std::ptrdiff_t last = n - 1;
    for (int i = 0; i < 4; ++i) sm_q[4 * last + i] = out_q[4 * last + i];
    for (int i = 0; i < 3; ++i) sm_b[3 * last + i] = out_b[3 * last + i];
    for (int i = 0; i < nn; ++i) sm_P[nn * last + i] = out_P[nn * last + i];
    double mu[NE], d[NE], S[nn], F[nn], A[9];
    smoother::StepWork w(NE);
    for (std::ptrdiff_t k = n - 2; k >= 0; --k) {
        const PredictRecord& r = rec[k + 1];  // the prediction k → k + 1
        log_global(sm_q + 4 * (k + 1), r.q, mu);
        for (int i = 0; i < 3; ++i) mu[D_GYRO_BIAS + i] = sm_b[3 * (k + 1) + i] - r.b[i];
        for (int i = 0; i < nn; ++i) S[i] = sm_P[nn * (k + 1) + i];
        left_jacobian(mu, 1.0, A);
        congruence_attitude(S, A);
        for (int i = 0; i < nn; ++i) F[i] = i % (NE + 1) == 0 ? 1.0 : 0.0;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) F[i * NE + D_GYRO_BIAS + j] = -r.R[3 * i + j] * dt;
        double* Ps = sm_P + nn * k;
        const smoother::Status st = smoother::rts_step<NE>(out_P + nn * k, r.P, F, mu, S, d, Ps, w);
        if (st != smoother::Status::ok) return st;
        double* qs = sm_q + 4 * k;
        for (int i = 0; i < 4; ++i) qs[i] = out_q[4 * k + i];
        exp_mul_quat_inplace(qs, d[0], d[1], d[2]);
        for (int i = 0; i < 3; ++i) sm_b[3 * k + i] = out_b[3 * k + i] + d[D_GYRO_BIAS + i];
        left_jacobian(d, 0.0, A);
        congruence_attitude(Ps, A);
    }
    return smoother::Status::ok;
}

}  // namespace ahrs

namespace {

PyObject* ahrs_smooth(PyObject*, PyObject* args) {
    Array<double, 2> gyr, acc, mag, Ha, Hm;
    Array<double, 1> params;
    Array<double, 1, true> q, b, stats;
    Array<double, 2, true> P, out_q, out_b, sm_q, sm_b;
    Array<double, 3, true> out_P, sm_P;
    double dt;
    if (!PyArg_ParseTuple(args, "O&O&O&dO&O&O&O&O&O&O&O&O&O&O&O&O&:ahrs_smooth", convert<double, 2>, &gyr,
                          convert<double, 2>, &acc, convert<double, 2>, &mag, &dt, convert<double, 1, true>, &q,
                          convert<double, 1, true>, &b, convert<double, 2, true>, &P, convert<double, 1>, &params,
                          convert<double, 2>, &Ha, convert<double, 2>, &Hm, convert<double, 2, true>, &out_q,
                          convert<double, 2, true>, &out_b, convert<double, 3, true>, &out_P,
                          convert<double, 1, true>, &stats, convert<double, 2, true>, &sm_q,
                          convert<double, 2, true>, &sm_b, convert<double, 3, true>, &sm_P))
        return nullptr;
    constexpr npy_intp ne = ahrs::NE;
    const npy_intp n = gyr.shape[0];
    if (!shape_is("gyr", gyr, {n, 3}) || !shape_is("acc", acc, {n, 3}) || !shape_is("mag", mag, {n, 3}) ||
        !shape_is("q", q, {4}) || !shape_is("b", b, {3}) || !shape_is("P", P, {ne, ne}) ||
        !shape_is("params", params, {ahrs::N_PARAMS}) || !shape_is("Ha", Ha, {2, ne}) ||
        !shape_is("Hm", Hm, {1, ne}) || !shape_is("out_q", out_q, {n, 4}) || !shape_is("out_b", out_b, {n, 3}) ||
        !shape_is("out_P", out_P, {n, ne, ne}) || !shape_is("stats", stats, {ahrs::N_STATS}) ||
        !shape_is("smooth_q", sm_q, {n, 4}) || !shape_is("smooth_b", sm_b, {n, 3}) ||
        !shape_is("smooth_P", sm_P, {n, ne, ne}))
        return nullptr;
    smoother::Status st;
    Py_BEGIN_ALLOW_THREADS;
    st = ahrs::smooth(n, gyr.data, acc.data, mag.data, dt, q.data, b.data, P.data, params.data, Ha.data, Hm.data,
                      out_q.data, out_b.data, out_P.data, stats.data, sm_q.data, sm_b.data, sm_P.data);
    Py_END_ALLOW_THREADS;
    if (st == smoother::Status::not_finite) return raise_linalg_error(not_finite_message);
    if (st == smoother::Status::singular) return raise_linalg_error(singular_message);
    Py_RETURN_NONE;
}

PyMethodDef methods[] = {
    {"ahrs_smooth", ahrs_smooth, METH_VARARGS,
     "ahrs_smooth(gyr, acc, mag, dt, q, b, P, params, Ha, Hm, out_q, out_b, out_P, stats, smooth_q, smooth_b, "
     "smooth_P): the AHRS over a recording (as ahrs_run; out_P (n, 6, 6) the filtered covariances) followed by the "
     "RTS backward pass (smooth_*); raises numpy.linalg.LinAlgError on a singular predicted covariance.  The GIL is "
     "released."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_ahrs_smoother(PyObject* m) { return PyModule_AddFunctions(m, methods) == 0; }

}  // namespace dualpose
