// Hol's Algorithm 1 over a whole recording (Hol 2008; dualpose.estimation.hol22.Hol22EKF.run).
#pragma once

#include <cstddef>
#include <cstdint>

namespace dualpose::hol22 {

// For each IMU time t[k], first every camera frame up to it (time update to the frame time, camera update), then
// the time update to t[k] and the IMU update.  cam_t (nf,) is on the IMU clock; frames before t[0] are skipped
// (their NIS stays as given).  Frame j owns correspondences offsets[j] .. offsets[j + 1] of pixels (M, 2) and
// points (M, 3).  x (22,), P (22, 22) are updated in place; X (n, 22), Ps (n, 22, 22) receive the state and
// covariance after each IMU update; nis_out (M,), acc_out (M,) the camera NIS and 1/0.
struct Hol22Inputs {
    std::ptrdiff_t n, nf;
    const double *t, *gyro, *accel, *cam_t;
    const std::int64_t* offsets;
    const double *pixels, *points, *qdiag, *gravity, *R_imu, *intr, *p_bc, *Rcb;
    double sigma_px, gate;
};

void run(const Hol22Inputs& in, double* x, double* P, double* X, double* Ps, double* nis_out, std::int64_t* acc_out);

}  // namespace dualpose::hol22
