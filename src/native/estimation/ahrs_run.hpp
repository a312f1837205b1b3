// The AHRS over a whole recording (docs/broad.md; the model in dualpose.estimation.ahrs's module docstring).
#pragma once

#include <cstddef>

namespace dualpose::ahrs {

// Run the filter over n samples; q (4,), b (3,), P (6, 6) are the initial state, updated in place.
//
// Per sample k: predict q <- q ⊗ Exp((ω_k − b) dt), P <- F P Fᵀ + Q; accumulate R̂ a_k and R̂ m_k in the sliding
// window; every stride samples the accelerometer update of inclination and (9D) the magnetometer heading update.
// gyr, acc, mag (n, 3); params (N_PARAMS,); Ha (2, 6) and Hm (1, 6) the measurement Jacobians of
// dualpose.estimation.ahrs.accelerometer_jacobian and heading_jacobian; out_q (n, 4), out_b (n, 3) receive the
// state after the updates of sample k; stats (N_STATS,) accumulates the counters.
void run(std::ptrdiff_t n, const double* gyr, const double* acc, const double* mag, double dt, double* q, double* b,
         double* P, const double* params, const double* Ha, const double* Hm, double* out_q, double* out_b,
         double* stats);

}  // namespace dualpose::ahrs
