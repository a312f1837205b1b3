// The error-state filter's steps and the loop over them (eskf_run.hpp): ErrorStateEKF.run / run_recorded and the
// streaming filter.
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

// update_frame with frame j of the block, its results stored.
inline void block_frame(Filter& f, const Config& c, const Block& b, const Outputs& o, std::int64_t j) {
    const std::int64_t lo = b.offsets[j], hi = b.offsets[j + 1];
    update_frame(f, c, b.pixels + 2 * lo, b.points + 3 * lo, hi - lo, o.nis + lo, o.accepted + lo);
    if (o.XF) copy_state(f.x, f.P, o.XF + j * NX, o.PF + j * NE * NE);
}

inline void skip_frame(const Outputs& o, std::int64_t j) {
    if (o.XF) std::fill(o.XF + j * NX, o.XF + (j + 1) * NX, nan);
}

}  // namespace

void init_filter(Filter& f, const double* x, const double* P) {
    f = Filter{};
    std::copy(x, x + NX, f.x);
    std::copy(P, P + NE * NE, f.P);
}

void start(Filter& f, double t, const double* gyro, const double* accel) {
    f.t0 = f.tc = t;
    for (int i = 0; i < 3; ++i) {
        f.g0[i] = f.g_cur[i] = gyro[i];
        f.a0[i] = f.a_cur[i] = accel[i];
    }
    f.samples = 1;
}

bool predict_to_frame(Filter& f, const Config& c, double tj, double t1, const double* g1, const double* a1,
                      double* F) {
    const double w = (tj - f.t0) / (t1 - f.t0);
    double g_mid[3], a_mid[3];
    for (int i = 0; i < 3; ++i) {
        const double gj = (1.0 - w) * f.g0[i] + w * g1[i];
        const double aj = (1.0 - w) * f.a0[i] + w * a1[i];
        g_mid[i] = 0.5 * (f.g_cur[i] + gj);
        a_mid[i] = 0.5 * (f.a_cur[i] + aj);
        f.g_cur[i] = gj;
        f.a_cur[i] = aj;
    }
    const bool moved = tj > f.tc;
    if (moved) predict_transition(f.x, f.P, g_mid, a_mid, tj - f.tc, c.gravity, c.noise, F);
    f.tc = tj;
    return moved;
}

bool finish_interval(Filter& f, const Config& c, double t1, const double* g1, const double* a1, double* F) {
    const bool moved = t1 > f.tc;
    if (moved) {
        double g_mid[3], a_mid[3];
        for (int i = 0; i < 3; ++i) {
            g_mid[i] = 0.5 * (f.g_cur[i] + g1[i]);
            a_mid[i] = 0.5 * (f.a_cur[i] + a1[i]);
        }
        predict_transition(f.x, f.P, g_mid, a_mid, t1 - f.tc, c.gravity, c.noise, F);
    }
    f.t0 = f.tc = t1;
    for (int i = 0; i < 3; ++i) {
        f.g0[i] = f.g_cur[i] = g1[i];
        f.a0[i] = f.a_cur[i] = a1[i];
    }
    ++f.samples;
    return moved;
}

std::int64_t update_frame(Filter& f, const Config& c, const double* pixels, const double* points, std::int64_t m,
                          double* nis, std::int64_t* accepted) {
    return update_points(f.x, f.P, c.intr, c.q_bc, c.p_bc, pixels, points, m, c.sigma_px, c.gate, nis, accepted);
}

std::int64_t feed(Filter& f, const Config& c, const Block& b, const Outputs& o, const NodeRecord* rec,
                  std::int64_t* nodes) {
    double F[NE * NE];
    std::int64_t m = nodes ? *nodes : 0;
    std::int64_t j = 0;
    for (std::int64_t k = 0; k < b.n; ++k) {
        const double t1 = b.t[k];
        const double* g1 = b.gyro + 3 * k;
        const double* a1 = b.accel + 3 * k;
        if (f.samples == 0) {
            start(f, t1, g1, a1);
            if (rec) {
                copy_state(f.x, f.P, rec->XA, rec->PA);
                rec->TN[0] = t1;
            }
            for (; j < b.nf && b.cam_t[j] < t1; ++j) skip_frame(o, j);
            for (; j < b.nf && b.cam_t[j] == t1; ++j) {
                block_frame(f, c, b, o, j);
                if (rec) rec->frame_node[j] = 0;
            }
            if (rec) {
                copy_state(f.x, f.P, rec->XB, rec->PB);
                rec->imu_node[0] = 0;
            }
        } else {
            for (; j < b.nf && b.cam_t[j] <= t1; ++j) {
                if (predict_to_frame(f, c, b.cam_t[j], t1, g1, a1, F) && rec)
                    m = record_prediction(m, b.cam_t[j], f.x, f.P, F, *rec);
                block_frame(f, c, b, o, j);
                if (rec) {
                    copy_state(f.x, f.P, rec->XB + m * NX, rec->PB + m * NE * NE);
                    rec->frame_node[j] = m;
                }
            }
            if (finish_interval(f, c, t1, g1, a1, F) && rec) m = record_prediction(m, t1, f.x, f.P, F, *rec);
            if (rec) rec->imu_node[k] = m;
        }
        if (o.X) std::copy(f.x, f.x + NX, o.X + k * NX);
        if (o.Ps) std::copy(f.P, f.P + NE * NE, o.Ps + k * NE * NE);
    }
    if (nodes) *nodes = m;
    return j;
}

std::int64_t run(const RunArgs& a, const NodeRecord* rec) {
    Filter f;
    init_filter(f, a.x, a.P);
    if (rec)
        for (std::int64_t j = 0; j < a.b.nf; ++j) rec->frame_node[j] = -1;
    std::int64_t m = 0;
    const std::int64_t used = feed(f, a.c, a.b, a.o, rec, &m);
    for (std::int64_t j = used; j < a.b.nf; ++j) skip_frame(a.o, j);
    if (rec) {  // no transition out of the last node
        double* Fl = rec->FS + m * NE * NE;
        std::fill(Fl, Fl + NE * NE, 0.0);
        for (int i = 0; i < NE; ++i) Fl[i * NE + i] = 1.0;
    }
    copy_state(f.x, f.P, a.x, a.P);
    return m + 1;
}

}  // namespace dualpose::eskf
