// Layouts of the orientation-only filter (AHRS, dualpose.estimation.ahrs): the one C++ definition of the error-state
// offsets (equal to dualpose.estimation.state.AHRS_ERROR, checked by tests/estimation/ahrs/test_ahrs.py) and of the
// params / stats indices of ahrs_run (the Python side reads these from dualpose._native).
#pragma once

namespace dualpose::ahrs {

// error state δx = [δθ (3, global: q = Exp(δθ) ⊗ q̂), δb (3)]
constexpr int D_ATTITUDE = 0;
constexpr int D_GYRO_BIAS = 3;
constexpr int ERROR_DIM = 6;

// params indices
constexpr int P_GYR_VAR = 0;         // gyroscope white-noise density², rad²/s
constexpr int P_BIAS_VAR = 1;        // gyroscope bias random-walk density², rad²/s³
constexpr int P_ACC_VAR = 2;         // accelerometer per-sample noise variance, (m/s²)²
constexpr int P_GRAVITY = 3;         // local |g| (m/s²)
constexpr int P_MAG_VAR = 4;         // magnetometer per-sample noise variance, µT²
constexpr int P_MAG_NORM = 5;        // reference field magnitude, µT
constexpr int P_MAG_DIP = 6;         // reference dip angle, rad (positive: field points below the horizon)
constexpr int P_USE_MAG = 7;         // 1.0: 9D, 0.0: 6D
constexpr int P_ACC_GATE = 8;        // χ²(2) rejection threshold of the accelerometer innovation
constexpr int P_MAG_GATE = 9;        // χ²(1) rejection threshold of the heading innovation
constexpr int P_GATE_RELEASE = 10;   // samples of uninterrupted rejection after which a gate opens again
constexpr int P_ACC_ADAPT = 11;      // forgetting factor α (per sample) of the acceleration-noise estimate
constexpr int P_MAG_ADAPT = 12;      // same for the heading noise
constexpr int P_WINDOW = 13;         // samples averaged (in the earth frame) per update
constexpr int P_GYR_SCALE_VAR = 14;  // gyroscope scale-factor / misalignment variance ε² times 1 s
constexpr int P_STRIDE = 15;         // samples between updates (≤ window; windows overlap when smaller)
// magnetometer–gyroscope time offset (ahrs_mag_lag.hpp)
constexpr int P_LAG_ONLINE = 16;     // 1.0: estimate τ online; 0.0: fixed at P_LAG_FIXED
constexpr int P_LAG_FIXED = 17;      // fixed lag of the magnetometer behind the gyroscope, s (0: no compensation)
constexpr int P_LAG_BOX = 18;        // boxcar length (samples) of the causal low-pass on ω − b and m
constexpr int P_LAG_MAX = 19;        // search range ±τ_max, s
constexpr int P_LAG_STEP = 20;       // grid step, s
constexpr int P_LAG_MIN_RATE = 21;   // informative samples: filtered |ω| ≥ this, rad/s
constexpr int P_LAG_NORM_TOL = 22;   // ... and |m| within this fraction of P_MAG_NORM
constexpr int P_LAG_THIN = 23;       // every thin-th informative sample enters the sums
constexpr int P_LAG_MIN_COUNT = 24;  // informative samples needed before τ̂ ≠ 0
constexpr int P_ACC_SCALE = 25;      // accelerometer relative error δ (scale factor / misalignment)
// rest detector and gyroscope-bias update (ahrs_rest.hpp)
constexpr int P_REST_WINDOW = 26;    // samples of the trailing window that must be quiet (0: no rest detection)
constexpr int P_REST_GYR_TH = 27;    // threshold of the window's gyroscope variance (pooled over axes), rad²/s²
constexpr int P_REST_ACC_TH = 28;    // same for the accelerometer, (m/s²)²
constexpr int P_REST_GYR_VAR = 29;   // gyroscope per-sample noise variance of the bias measurement, rad²/s²
constexpr int P_REST_GATE = 30;      // χ²(3) rejection threshold of the bias innovation
constexpr int P_REST_SKIP = 31;      // leading samples not seen by the detector (the initial rest period)
constexpr int P_REST_OFFSET_VAR = 32;  // variance of the bias at rest minus the bias in motion, rad²/s² (per axis)
constexpr int P_ACC_CLIP = 33;       // k of the accelerometer's impulse clipping (ahrs_run.cpp; 0: off)
constexpr int P_ACC_MOTION_TIME = 34;  // s, time constant of the running mean of the acceleration bound² (0: none)
constexpr int P_ACC_ADAPT_MATRIX = 35;  // 1.0: the innovation-based estimate is a 2×2 covariance; 0.0: one variance
constexpr int P_ACC_ADAPT_REST_HOLD = 36;  // 1.0: held at rest, fading out of the noise with the low-pass's memory
constexpr int N_PARAMS = 37;

// stats indices
constexpr int S_ACC_REJECTED = 0;
constexpr int S_MAG_REJECTED = 1;
constexpr int S_ACC_NIS_SUM = 2;
constexpr int S_MAG_NIS_SUM = 3;
constexpr int S_ACC_INSIDE = 4;  // accepted updates with NIS inside the two-sided 95% χ² band
constexpr int S_MAG_INSIDE = 5;
constexpr int S_MAG_SKIPPED = 6;  // updates with a degenerate (vertical) field
constexpr int S_MAG_LAG = 7;          // current magnetometer lag τ̂ used by the compensation, s (not a counter)
constexpr int S_MAG_LAG_SAMPLES = 8;  // informative samples seen by the online estimate (not thinned)
constexpr int S_REST_SAMPLES = 9;     // samples flagged at rest by the detector
constexpr int S_REST_UPDATES = 10;    // accepted gyroscope-bias updates at rest
constexpr int S_REST_REJECTED = 11;   // bias updates rejected by the χ² gate
constexpr int N_STATS = 12;

// Every constant above, for the module's integer constants (prefixed AHRS_).
#define DUALPOSE_AHRS_CONSTANTS(X)                                                                            \
    X(D_ATTITUDE) X(D_GYRO_BIAS) X(ERROR_DIM) X(P_GYR_VAR) X(P_BIAS_VAR) X(P_ACC_VAR) X(P_GRAVITY) X(P_MAG_VAR) \
        X(P_MAG_NORM) X(P_MAG_DIP) X(P_USE_MAG) X(P_ACC_GATE) X(P_MAG_GATE) X(P_GATE_RELEASE) X(P_ACC_ADAPT)    \
            X(P_MAG_ADAPT) X(P_WINDOW) X(P_GYR_SCALE_VAR) X(P_STRIDE) X(P_LAG_ONLINE) X(P_LAG_FIXED)            \
                X(P_LAG_BOX) X(P_LAG_MAX) X(P_LAG_STEP) X(P_LAG_MIN_RATE) X(P_LAG_NORM_TOL) X(P_LAG_THIN)       \
                    X(P_LAG_MIN_COUNT) X(P_ACC_SCALE) X(P_REST_WINDOW) X(P_REST_GYR_TH) X(P_REST_ACC_TH)        \
                        X(P_REST_GYR_VAR) X(P_REST_GATE) X(P_REST_SKIP) X(P_REST_OFFSET_VAR) X(P_ACC_CLIP) X(P_ACC_MOTION_TIME) X(P_ACC_ADAPT_MATRIX) X(P_ACC_ADAPT_REST_HOLD) X(N_PARAMS) X(S_ACC_REJECTED)           \
                            X(S_MAG_REJECTED) X(S_ACC_NIS_SUM) X(S_MAG_NIS_SUM) X(S_ACC_INSIDE) X(S_MAG_INSIDE) \
                                X(S_MAG_SKIPPED) X(S_MAG_LAG) X(S_MAG_LAG_SAMPLES) X(S_REST_SAMPLES)            \
                                    X(S_REST_UPDATES) X(S_REST_REJECTED) X(N_STATS)

}  // namespace dualpose::ahrs
