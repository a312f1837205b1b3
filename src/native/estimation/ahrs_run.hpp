// The AHRS one sample at a time (step) and over a whole recording (run, a loop over step): docs/broad.md; the model
// in dualpose.estimation.ahrs's module docstring; the streaming interface in dualpose.estimation.ahrs.stream.
#pragma once

#include "ahrs_filter.hpp"
#include "ahrs_layout.hpp"
#include "ahrs_mag_lag.hpp"
#include "ahrs_rest.hpp"

#include <cstddef>
#include <cstdint>

namespace dualpose::ahrs {

// Constants of one filter: the params vector (ahrs_layout.hpp) and what follows from it, set once by make_params.
struct Params {
    double dt;  // sampling interval, s
    double gyr_var, bias_var, acc_var, grav, mag_var, mag_norm, mag_dip, acc_gate, mag_gate, scale_var;
    double overlap, acc_alpha, mag_alpha, release;
    double acc_clip;     // k: changes from the low-pass's last output beyond k × their running RMS are clipped (0: off)
    double acc_dev_alpha;  // forgetting factor (per sample) of that running mean square
    double acc_tol;      // magnitude error the accelerometer can make by itself, vs. the rest magnitude: 2 δ g (m/s²)
    double acc_cal_var;  // per-axis variance of its direction error: (δ g)² / 3 (m/s²)²
    double acc_motion_alpha;  // forgetting factor (per update) of the acceleration bound's mean square (1: none)
    std::int64_t acc_adapt_matrix;     // 1: the innovation-based estimate is a 2×2 covariance; 0: one variance
    std::int64_t acc_adapt_rest_hold;  // 1: held at rest, entering the noise with a fading share
    double acc_fade;           // per update at rest: the low-pass's energy decay exp(−2 stride dt / τ)
    double Ha[2 * ERROR_DIM], Hm[ERROR_DIM];  // measurement Jacobians (2, 6) and (1, 6)
    LowPass2 acc_lp;                          // the specific force's earth-frame low-pass (tau = window / 2)
    std::int64_t n_win, stride, use_mag;
    LagParams lag;    // magnetometer–gyroscope time offset (ahrs_mag_lag.hpp)
    RestParams rest;  // rest detector and bias update (ahrs_rest.hpp)
};

// Everything that changes from sample to sample (trivially copyable: a byte copy saves and restores it).  The ring
// buffers (ring_doubles(p): the field's sliding window ring_m (n_win, 3) and ring_d (n_win,), then the time offset's
// rings, lag_ring_doubles, and the rest detector's, rest_ring_doubles) are kept by the caller, next to the state.
struct State {
    double q[4], b[3], P[ERROR_DIM * ERROR_DIM];  // nominal state (xyzw, rad/s) and error covariance
    double acc_lp[6];                             // low-pass state of the specific force, (3, 2) (uncorrected frame)
    double acc_out[3];                            // the low-pass's last output (uncorrected frame)
    double acc_dev_ms;                            // running mean square of the (clipped) change from it, (m/s²)²
    double acc_motion_ms;                         // running mean square of the filtered acceleration's bound, (m/s²)²
    double mag_sum[3];                            // field window sum (uncorrected frame)
    double Cm[9];                                 // accumulated corrections: current earth frame = Cm · uncorrected
    double mag_dist_sum, mag_dist;                // window sum / mean of the field's disturbance lower bound
    double acc_extra, mag_extra;                  // adaptive-noise estimates (acc_extra: one variance per axis)
    double acc_extra_m[3];                        // ... or the 2×2 covariance (xx, xy, yy), (m/s²)²
    double acc_extra_fade;                        // share of it still inside the low-pass at rest (1 in motion)
    double stats[N_STATS];                        // counters (ahrs_layout.hpp)
    std::int64_t head, filled, since;             // ring position, samples in the window, samples since an update
    std::int64_t acc_closed, mag_closed;          // gate counters
    LagState lag;                                 // magnetometer–gyroscope time offset (ahrs_mag_lag.hpp)
    RestState rest;                               // rest detector (ahrs_rest.hpp)
};

// Doubles of the ring buffers that follow the state: the field's window (n_win, 3) and its disturbance level (n_win,), then the time
// offset's rings (ahrs_mag_lag.hpp), then the rest detector's window (ahrs_rest.hpp).
inline std::int64_t ring_doubles(const Params& p) {
    return 4 * p.n_win + lag_ring_doubles(p.lag) + rest_ring_doubles(p.rest);
}

// The constants of params (N_PARAMS,), Ha (2, 6), Hm (1, 6) and dt.
Params make_params(const double* params, const double* Ha, const double* Hm, double dt);

// The state before the first sample: q (4,), b (3,), P (6, 6) copied, everything else empty; ring (ring_doubles)
// zeroed.
void init_state(State& s, double* ring, const Params& p, const double* q, const double* b, const double* P);

// What the offline smoother (ahrs_smoother.cpp) needs from one step: the state right after the prediction, before
// this sample's updates (q, b, P = P_{k|k−1}), and the rotation R̂ of the state before it, which enters the
// transition F = [[I, −R̂ dt], [0, I]] of the global attitude error.
struct PredictRecord {
    double q[4], b[3], P[ERROR_DIM * ERROR_DIM], R[9];
};
inline void record_prediction(PredictRecord& r, const double* q, const double* b, const double* P, const double* R) {
    for (int i = 0; i < 4; ++i) r.q[i] = q[i];
    for (int i = 0; i < 3; ++i) r.b[i] = b[i];
    for (int i = 0; i < ERROR_DIM * ERROR_DIM; ++i) r.P[i] = P[i];
    for (int i = 0; i < 9; ++i) r.R[i] = R[i];
}

// One sample: predict q <- q ⊗ Exp((ω − b) dt), P <- F P Fᵀ + Q; low-pass R̂ a and accumulate R̂(t − τ̂) m in the
// sliding window; every stride samples the accelerometer update of inclination and (9D) the magnetometer heading
// update, χ²-gated, with adaptive noise, and (online) a new τ̂; while the rest detector's window is quiet, every
// stride samples the gyroscope-bias update (ahrs_rest.hpp).  gyr, acc, mag (3,) rad/s, m/s², µT (mag unused in
// 6D).  record (optional) receives the prediction (PredictRecord); nullptr in the filter's own run and stream paths.
void step(State& s, double* ring, const Params& p, const double* gyr, const double* acc, const double* mag,
          PredictRecord* record = nullptr);

// Run the filter over n samples; q (4,), b (3,), P (6, 6) are the initial state, updated in place.
// gyr, acc, mag (n, 3); params (N_PARAMS,); Ha (2, 6) and Hm (1, 6) the measurement Jacobians of
// dualpose.estimation.ahrs.accelerometer_jacobian and heading_jacobian; out_q (n, 4), out_b (n, 3) receive the
// state after the updates of sample k; stats (N_STATS,) accumulates the counters.  A loop over step.
void run(std::ptrdiff_t n, const double* gyr, const double* acc, const double* mag, double dt, double* q, double* b,
         double* P, const double* params, const double* Ha, const double* Hm, double* out_q, double* out_b,
         double* stats);

// The causal outputs inside the rest period, before the filter can be initialised: sums (10,) = running sums of gyr,
// acc, mag (3 each) and the sample count, updated with each of the n samples; out_q (n, 4) receives the orientation
// of the running mean specific force and field (the initial orientation's construction, dualpose.estimation.ahrs.
// initial_orientation; 6D: body x projected on the horizontal is east), out_b (n, 3) the running mean rate.
void rest_run(std::ptrdiff_t n, const double* gyr, const double* acc, const double* mag, bool use_mag, double* sums,
              double* out_q, double* out_b);

// The saved stream: one contiguous byte buffer [StreamHeader | Params | State | ring (ring_doubles(p) doubles)], so
// that a byte copy saves it and restores it.  STREAM_VERSION changes whenever the layout does (2: the time offset's
// parameters, state and rings, and n_ring in the header; 3: the accelerometer's own error in Params; 4: the rest
// detector's parameters, state and ring; 5: the rest-offset variance and the accelerometer's impulse clipping in
// Params, the spell count and the clipping's last output and running mean square in State; 6: the running mean
// square of the filtered linear acceleration's bound in State, its forgetting factor in Params; 7: the 2×2
// innovation-based covariance and its share at rest in State, its two switches and the share's decay in Params).
constexpr std::uint64_t STREAM_MAGIC = 0x3153524841504455ULL;  // "UDPAHRS1" little-endian
constexpr std::uint64_t STREAM_VERSION = 7;
struct StreamHeader {
    std::uint64_t magic, version, size, n_win, n_ring;  // size: total bytes of the buffer; n_ring = ring_doubles
};
struct Stream {
    StreamHeader h;
    Params p;
    State s;
    double* ring() { return reinterpret_cast<double*>(this + 1); }
};
static_assert(sizeof(Stream) % sizeof(double) == 0, "the ring must follow the state aligned");

inline std::size_t stream_bytes(std::int64_t n_ring) {
    return sizeof(Stream) + static_cast<std::size_t>(n_ring) * sizeof(double);
}

}  // namespace dualpose::ahrs
