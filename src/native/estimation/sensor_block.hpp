// A block of a camera–IMU recording as the filters' loops read it (ErrorStateEKF.run, Hol22EKF.run and the streaming
// filters' blocks): IMU samples, and camera frames whose correspondences are rows of two shared arrays.
#pragma once

#include <cstdint>

namespace dualpose {

// All arrays C-contiguous.  Frame j owns correspondences offsets[j] .. offsets[j + 1] of pixels and points; cam_t is
// on the IMU clock.
struct SensorBlock {
    std::int64_t n, nf;                     // IMU samples N, camera frames F
    const double *t, *gyro, *accel;         // (N,) s, (N, 3) rad/s, (N, 3) m/s²
    const double* cam_t;                    // (F,) s
    const std::int64_t* offsets;            // (F + 1,)
    const double *pixels, *points;          // (M, 2) px, (M, 3) m
};

}  // namespace dualpose
