// Rest detection and the gyroscope-bias update at rest, inside the AHRS's per-sample step (ahrs_run.cpp):
// docs/broad.md, "Rest detector and bias update".
//
// Detector: the trailing window of n samples of the raw gyroscope and accelerometer (a ring of (n, 6) doubles with
// running sums) is quiet when the variance of each sensor over the window, pooled over the three axes, is at most
// its threshold (a margin times the per-sample noise variance measured at rest; dualpose.estimation.ahrs).  The sums
// are recomputed exactly from the ring every time it wraps, so rounding cannot accumulate.
//
// Update: while the window is quiet, every `stride` samples the window's mean rate z measures the bias,
// z = b + v, H = [0₃ₓ₃, I₃] in the error state [δθ, δb], v = white + offset: the white part ~ N(0, σ²/n I) with σ²
// the gyroscope's per-sample noise variance, and an offset ~ N(0, c I) common to the whole spell: the residual
// rotation of a "still" object and the difference between the bias at rest and in motion (c = (0.02 °/s)²; the role
// of VQF's rest-bias σ, Laidig & Seel 2023; docs/broad.md, "Rest detector and bias update").  A spell of L quiet samples carries the information I(L) = L / (σ² + c L) per axis, which saturates
// at 1/c however long the rest; the k-th update of a spell, whose window reaches L_k = n + (k − 1) stride samples,
// carries the increment I(L_k) − I(L_{k−1}) (L_0 = 0), i.e. the noise
//   r_k = (σ² + c L_k)(σ² + c L_{k−1}) / (σ² (L_k − L_{k−1})),
// which for c = 0 is σ²/n for the first window and σ²/stride after it (consecutive windows share n − stride
// samples: the overlap accounting of the accelerometer update).  χ²(3)-gated (no release: a
// rejected window is a rotation the detector cannot see, e.g. a slow constant turn about the vertical, not a bias),
// Joseph form, then injection and reset; the gain on δθ follows from the cross-covariance (a bias error found at
// rest also corrects the attitude error it has caused).
#pragma once

#include "ahrs_filter.hpp"
#include "ahrs_layout.hpp"

#include <algorithm>
#include <cstdint>

namespace dualpose::ahrs {

struct RestParams {
    std::int64_t n, skip, stride;   // window length (0: off), leading samples not seen, samples between updates
    double gyr_th, acc_th;          // thresholds of the pooled window variances
    double white, offset, gate;     // per-sample white-noise variance σ², rest-offset variance c, χ²(3) gate
};

struct RestState {
    double sum[6], sq[2];           // window sums of gyr, acc (3 each) and of their squares (pooled per sensor)
    std::int64_t seen, head, filled, since;  // samples seen, ring position, samples in the window, since an update
    std::int64_t quiet;             // 1 while the window has been quiet since the last update of this spell
    std::int64_t spell;             // updates (accepted or not) made in the current quiet spell
};

inline RestParams make_rest_params(const double* params, std::int64_t stride) {
    RestParams rp{};
    rp.n = std::max(std::int64_t{0}, static_cast<std::int64_t>(params[P_REST_WINDOW]));
    rp.skip = std::max(std::int64_t{0}, static_cast<std::int64_t>(params[P_REST_SKIP]));
    rp.gyr_th = params[P_REST_GYR_TH];
    rp.acc_th = params[P_REST_ACC_TH];
    rp.gate = params[P_REST_GATE];
    rp.white = params[P_REST_GYR_VAR];
    rp.offset = std::max(0.0, params[P_REST_OFFSET_VAR]);
    rp.stride = std::max(std::int64_t{1}, std::min(stride, std::max(rp.n, std::int64_t{1})));
    return rp;
}

// Noise of the k-th bias update (k ≥ 1) of a quiet spell (see above): r_k = (σ² + c L_k)(σ² + c L_{k−1}) /
// (σ² (L_k − L_{k−1})), L_0 = 0, L_k = n + (k − 1) stride.
inline double rest_noise(const RestParams& rp, std::int64_t k) {
    const double lk = double(rp.n + (k - 1) * rp.stride);
    const double lp = k > 1 ? lk - double(rp.stride) : 0.0;
    return (rp.white + rp.offset * lk) * (rp.white + rp.offset * lp) / (rp.white * (lk - lp));
}

inline std::int64_t rest_ring_doubles(const RestParams& rp) { return 6 * rp.n; }

inline bool rest_params_valid(const RestParams& rp) { return rp.n >= 0 && rp.n <= (std::int64_t{1} << 36); }

inline void init_rest(RestState& rs, double* ring, const RestParams& rp) {
    rs = RestState{};
    std::fill(ring, ring + rest_ring_doubles(rp), 0.0);
}

// One sample into the window; true when the window is full and quiet.
inline bool rest_ingest(RestState& rs, double* ring, const RestParams& rp, const double* gyr, const double* acc) {
    if (rp.n == 0 || rs.seen++ < rp.skip) return false;
    double* slot = ring + 6 * rs.head;
    for (int i = 0; i < 3; ++i) {
        rs.sum[i] += gyr[i] - slot[i];
        rs.sum[3 + i] += acc[i] - slot[3 + i];
        rs.sq[0] += gyr[i] * gyr[i] - slot[i] * slot[i];
        rs.sq[1] += acc[i] * acc[i] - slot[3 + i] * slot[3 + i];
        slot[i] = gyr[i];
        slot[3 + i] = acc[i];
    }
    rs.filled = std::min(rs.filled + 1, rp.n);
    if (++rs.head == rp.n) {  // wrapped: the sums afresh from the ring
        rs.head = 0;
        for (int i = 0; i < 6; ++i) rs.sum[i] = 0.0;
        rs.sq[0] = rs.sq[1] = 0.0;
        for (std::int64_t k = 0; k < rp.n; ++k)
            for (int i = 0; i < 6; ++i) {
                const double x = ring[6 * k + i];
                rs.sum[i] += x;
                rs.sq[i / 3] += x * x;
            }
    }
    if (rs.filled < rp.n) return false;
    const double inv = 1.0 / double(rp.n);
    double var[2];
    for (int s = 0; s < 2; ++s) {
        double m2 = 0.0;
        for (int i = 0; i < 3; ++i) m2 += rs.sum[3 * s + i] * rs.sum[3 * s + i];
        var[s] = (rs.sq[s] - m2 * inv) * inv / 3.0;
    }
    return var[0] <= rp.gyr_th && var[1] <= rp.acc_th;
}

// The bias update at rest (see above) on q, b, P and the accumulated corrections Cm; counters into stats.
inline void rest_update(RestState& rs, const RestParams& rp, bool quiet, std::int64_t stride, double* q, double* b,
                        double* P, double* Cm, double* stats) {
    if (!quiet) {
        rs.quiet = 0;
        rs.since = 0;
        rs.spell = 0;
        return;
    }
    stats[S_REST_SAMPLES] += 1.0;
    if (rs.quiet && ++rs.since < stride) return;
    const double r = rest_noise(rp, ++rs.spell);
    rs.quiet = 1;
    rs.since = 0;
    constexpr int B = D_GYRO_BIAS;
    const double inv = 1.0 / double(rp.n);
    double v[3], S[9], Si[9], K[NE * 3], H[3 * NE] = {}, dx[NE];
    for (int i = 0; i < 3; ++i) v[i] = rs.sum[i] * inv - b[i];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) S[3 * i + j] = P[(B + i) * NE + B + j] + (i == j ? r : 0.0);
    // S⁻¹ by cofactors (S symmetric positive definite)
    Si[0] = S[4] * S[8] - S[5] * S[7];
    Si[1] = S[2] * S[7] - S[1] * S[8];
    Si[2] = S[1] * S[5] - S[2] * S[4];
    Si[4] = S[0] * S[8] - S[2] * S[6];
    Si[5] = S[2] * S[3] - S[0] * S[5];
    Si[8] = S[0] * S[4] - S[1] * S[3];
    const double det = S[0] * Si[0] + S[1] * Si[1] + S[2] * Si[2];
    for (int k : {0, 1, 2, 4, 5, 8}) Si[k] /= det;
    Si[3] = Si[1];
    Si[6] = Si[2];
    Si[7] = Si[5];
    double nis = 0.0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) nis += v[i] * Si[3 * i + j] * v[j];
    if (!(nis <= rp.gate)) {
        stats[S_REST_REJECTED] += 1.0;
        return;
    }
    stats[S_REST_UPDATES] += 1.0;
    for (int i = 0; i < NE; ++i)  // K = P Hᵀ S⁻¹, P Hᵀ = P[:, B:B+3]
        for (int j = 0; j < 3; ++j) {
            double t = 0.0;
            for (int m = 0; m < 3; ++m) t += P[i * NE + B + m] * Si[3 * m + j];
            K[3 * i + j] = t;
        }
    for (int i = 0; i < 3; ++i) H[i * NE + B + i] = 1.0;
    for (int i = 0; i < NE; ++i) dx[i] = K[3 * i] * v[0] + K[3 * i + 1] * v[1] + K[3 * i + 2] * v[2];
    joseph_update<3>(P, K, H, r);
    inject_and_reset(q, b, P, dx);
    left_rotate_inplace(Cm, dx);
}

}  // namespace dualpose::ahrs
