// The loop of ErrorStateEKF.run / run_recorded (see eskf_run.hpp).
#include "eskf_run.hpp"

#include "eskf_kernels.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dualpose::eskf {

namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

inline void copy_state(const double* x, const double* P, double* xo, double* Po) {
    std::copy(x, x + NX, xo);
    std::copy(P, P + NE * NE, Po);
}

// Store the transition out of node m and open node m + 1 (prior = posterior = the predicted state).
inline std::int64_t record_prediction(std::int64_t m, double tn, const double* x, const double* P, const double* F,
                                      const NodeRecord& r) {
    std::copy(F, F + NE * NE, r.FS + m * NE * NE);
    ++m;
    copy_state(x, P, r.XA + m * NX, r.PA + m * NE * NE);
    copy_state(x, P, r.XB + m * NX, r.PB + m * NE * NE);
    r.TN[m] = tn;
    return m;
}

inline void update_frame(const RunArgs& a, std::int64_t j) {
    const std::int64_t lo = a.offsets[j], hi = a.offsets[j + 1];
    update_points(a.x, a.P, a.intr, a.q_bc, a.p_bc, a.pixels + 2 * lo, a.points + 3 * lo, hi - lo, a.sigma_px,
                  a.gate, a.nis_out + lo, a.accepted_out + lo);
    copy_state(a.x, a.P, a.XF + j * NX, a.PF + j * NE * NE);
}

}  // namespace

std::int64_t run(const RunArgs& a, const NodeRecord* rec) {
    const std::int64_t n = a.n, nf = a.nf;
    const double* t = a.t;
    const double* cam_t = a.cam_t;
    double* x = a.x;
    double* P = a.P;
    double F[NE * NE];
    std::int64_t m = 0;
    if (rec) {
        copy_state(x, P, rec->XA, rec->PA);
        rec->TN[0] = t[0];
        for (std::int64_t j = 0; j < nf; ++j) rec->frame_node[j] = -1;
    }
    std::int64_t j = 0;
    for (; j < nf && cam_t[j] < t[0]; ++j) std::fill(a.XF + j * NX, a.XF + (j + 1) * NX, nan);
    for (; j < nf && cam_t[j] == t[0]; ++j) {
        update_frame(a, j);
        if (rec) rec->frame_node[j] = 0;
    }
    copy_state(x, P, a.X, a.Ps);
    if (rec) {
        copy_state(x, P, rec->XB, rec->PB);
        rec->imu_node[0] = 0;
    }
    double g_cur[3], a_cur[3], g_mid[3], a_mid[3];
    for (std::int64_t k = 0; k + 1 < n; ++k) {
        const double t0 = t[k], t1 = t[k + 1];
        double tc = t0;
        const double* g0 = a.gyro + 3 * k;
        const double* a0 = a.accel + 3 * k;
        const double* g1 = g0 + 3;
        const double* a1 = a0 + 3;
        for (int i = 0; i < 3; ++i) {
            g_cur[i] = g0[i];
            a_cur[i] = a0[i];
        }
        for (; j < nf && cam_t[j] <= t1; ++j) {
            const double tj = cam_t[j];
            const double w = (tj - t0) / (t1 - t0);
            for (int i = 0; i < 3; ++i) {
                const double gj = (1.0 - w) * g0[i] + w * g1[i];
                const double aj = (1.0 - w) * a0[i] + w * a1[i];
                g_mid[i] = 0.5 * (g_cur[i] + gj);
                a_mid[i] = 0.5 * (a_cur[i] + aj);
                g_cur[i] = gj;
                a_cur[i] = aj;
            }
            if (tj > tc) {
                predict_transition(x, P, g_mid, a_mid, tj - tc, a.gravity, a.noise, F);
                if (rec) m = record_prediction(m, tj, x, P, F, *rec);
            }
            tc = tj;
            update_frame(a, j);
            if (rec) {
                copy_state(x, P, rec->XB + m * NX, rec->PB + m * NE * NE);
                rec->frame_node[j] = m;
            }
        }
        if (t1 > tc) {
            for (int i = 0; i < 3; ++i) {
                g_mid[i] = 0.5 * (g_cur[i] + g1[i]);
                a_mid[i] = 0.5 * (a_cur[i] + a1[i]);
            }
            predict_transition(x, P, g_mid, a_mid, t1 - tc, a.gravity, a.noise, F);
            if (rec) m = record_prediction(m, t1, x, P, F, *rec);
        }
        copy_state(x, P, a.X + (k + 1) * NX, a.Ps + (k + 1) * NE * NE);
        if (rec) rec->imu_node[k + 1] = m;
    }
    for (; j < nf; ++j) std::fill(a.XF + j * NX, a.XF + (j + 1) * NX, nan);
    if (rec) {  // no transition out of the last node
        double* Fl = rec->FS + m * NE * NE;
        std::fill(Fl, Fl + NE * NE, 0.0);
        for (int i = 0; i < NE; ++i) Fl[i * NE + i] = 1.0;
    }
    return m + 1;
}

}  // namespace dualpose::eskf
