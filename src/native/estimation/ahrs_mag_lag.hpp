// Magnetometer–gyroscope time offset inside the AHRS, strictly causal (docs/broad.md, "Magnetometer–gyroscope time
// offset"):
//
// * compensation: the field measured at t is the field at t − τ, so it is rotated into the earth frame with the
//   orientation at t − τ, R̂(t − τ) = R̂(t) Exp(−Δθ), Δθ = ∫_{t−τ}^{t} (ω − b) dt from the gyroscope samples already
//   seen (the integral of the zero-order-hold rate the predict uses; τ < 0 extrapolates with the current rate);
// * online estimate of τ: the kinematic residual r(τ) = dm/dt + ω(t − τ) × (m − h) of a static field with a
//   hard-iron offset h (dualpose.calibration.sensor_time_offset) on causally filtered data -- the SAME boxcar
//   (moving average, linear phase: the same constant group delay for every frequency, so the relative lag of the
//   two streams is kept) on ω − b and m, dm/dt by the central difference of the filtered field, evaluated at a
//   centre K + 1 samples in the past so that ω(t − τ) for |τ| ≤ τ_max is known, the gyroscope linearly interpolated
//   at sub-sample shifts.  The residual is linear in h, so per candidate τ_j of a grid the running sums Σ|r₀|²,
//   Σ [ω]×ᵀ r₀ and Σ ω ωᵀ (r₀ = dm/dt + ω × m) determine min_h Σ|r₀ − [ω]× h|² in closed form.  Only informative
//   samples enter (|ω| ≥ min_rate, |m| within norm_tol of the rest-period field norm, every thin-th one); τ̂ is the
//   parabolic refinement of the grid minimum once min_count informative samples were seen and the minimum is
//   interior, 0 before that.
#pragma once

#include <cstdint>

namespace dualpose::ahrs {

constexpr int LAG_MAX_CANDIDATES = 61;  // grid points (±30 ms in 1 ms steps)
constexpr int LAG_MAX_HIST = 1024;      // filtered samples 2 K + 2 the candidates may reach (±30 ms up to 16.9 kHz)

// Constants of the time-offset handling (part of Params).
struct LagParams {
    std::int64_t online;                 // 1: estimate τ online; 0: τ fixed at `fixed`
    double fixed;                        // s
    std::int64_t box, hist, comp;        // ring lengths: boxcar L, filtered history H = 2K + 3, Δθ history C
    std::int64_t centre;                 // K: the residual is evaluated K + 1 samples in the past
    std::int64_t n_cand;                 // candidates (≤ LAG_MAX_CANDIDATES)
    double first, step;                  // candidate shifts τ_j = first + j step, s
    std::int64_t offset[LAG_MAX_CANDIDATES];  // floor(−τ_j · rate): ω(t − τ_j) between samples c + offset, c + offset + 1
    double frac[LAG_MAX_CANDIDATES];          // and the interpolation weight of the later one
    double min_rate, norm_lo, norm_hi;   // informative: |ω| ≥ min_rate, norm_lo ≤ |m| ≤ norm_hi
    std::int64_t thin, min_count;        // every thin-th informative sample; informative samples before τ̂ ≠ 0
    std::int64_t resolve;                // samples added to the sums between two solutions (~0.25 s of them)
    double rate, inv_box;                // 1 / dt, 1 / L
};

// What changes (part of State): the estimate, the filters' running sums and the per-candidate sufficient statistics.
struct LagState {
    double tau;                            // current τ̂ (s), used by the compensation
    double back;                           // τ̂ > 0: τ̂ / dt capped at C − 1 (samples back), split into
    std::int64_t back_whole;               //   whole samples and
    double back_frac;                      //   the fraction of the next one
    double box_w[3], box_m[3];             // boxcar sums of ω − b and m
    double cum[3];                         // ∫ ω dt of all samples so far (raw rate), rad
    std::int64_t seen;                     // samples ingested
    std::int64_t pos_box, pos_hist, pos_comp;  // ring positions of the last sample (seen − 1 modulo the lengths)
    std::int64_t informative, used, used_at_solve;
    double srr[LAG_MAX_CANDIDATES];        // Σ |r₀|²
    double sb[3][LAG_MAX_CANDIDATES];      // Σ r₀ × ω  (= Σ [ω]×ᵀ r₀)
    double sw[6][LAG_MAX_CANDIDATES];      // Σ ω ωᵀ: xx, yy, zz, xy, xz, yz
};

// Doubles of the rings this part keeps after the window's (box: 6 L, hist: 6 H, comp: 3 C).
inline std::int64_t lag_ring_doubles(const LagParams& lp) { return 6 * lp.box + 6 * lp.hist + 3 * lp.comp; }

// Whether the lengths and offsets of lp are consistent (a state restored from bytes is checked before use).
inline bool lag_params_valid(const LagParams& lp) {
    constexpr std::int64_t big = std::int64_t{1} << 30;
    if (lp.box < 1 || lp.box > big || lp.centre < 1 || 2 * lp.centre + 2 > LAG_MAX_HIST || lp.hist != 2 * lp.centre + 3 ||
        lp.comp < 2 || lp.comp > big || lp.n_cand < 0 || lp.n_cand > LAG_MAX_CANDIDATES || lp.thin < 1 ||
        lp.resolve < 1)
        return false;
    for (std::int64_t j = 0; j < lp.n_cand; ++j)
        if (lp.offset[j] < -lp.centre || lp.offset[j] + 1 > lp.centre) return false;
    return true;
}

// Fill lp from the params entries P_LAG_* (ahrs_layout.hpp); rate = 1 / dt.
void make_lag_params(LagParams& lp, const double* params, double rate);

// The state before the first sample (τ̂ = fixed value, or 0 online); the rings (lag_ring_doubles) zeroed.
void init_lag(LagState& ls, double* ring, const LagParams& lp);

// One sample: push ω (raw, rad/s) into the Δθ history; online, also filter ω − b and m and, when the centre
// sample is informative, add its residuals to every candidate's sums.
void lag_ingest(LagState& ls, double* ring, const LagParams& lp, double dt, const double* gyr, const double* b,
                const double* mag);

// Online: recompute τ̂ from the sums (grid minimum, parabolic refinement) once `resolve` samples were added to them
// since the last time.
void lag_solve(LagState& ls, const LagParams& lp);

// m_c = Exp(−Δθ) m: the field of this sample as seen with the orientation at t − τ̂ (ahrs_mag_lag.hpp's header).
// Returns m unchanged (bit for bit) when τ̂ = 0.
void lag_compensate(const LagState& ls, const double* ring, const LagParams& lp, const double* gyr,
                    const double* b, const double* mag, double* m_c);

}  // namespace dualpose::ahrs
