// The whole-recording loop of the error-state filter (dualpose.estimation.eskf.ErrorStateEKF.run), optionally
// recording every filter node for the RTS smoother.
#pragma once

#include <cstdint>

namespace dualpose::eskf {

// The stream and the outputs of run (shapes as in ErrorStateEKF.run; all C-contiguous).
struct RunArgs {
    std::int64_t n, nf;                     // IMU samples N, camera frames F
    const double *t, *gyro, *accel;         // (N,), (N, 3), (N, 3)
    const double* cam_t;                    // (F,) on the IMU clock
    const std::int64_t* offsets;            // (F + 1,)
    const double *pixels, *points;          // (M, 2), (M, 3)
    double *x, *P;                          // (16,), (15, 15) in place
    const double *gravity, *noise;          // (3,), (4,)
    const double *intr, *q_bc, *p_bc;       // (4,), (4,), (3,)
    double sigma_px, gate;
    double *X, *Ps, *XF, *PF;               // (N, 16), (N, 15, 15), (F, 16), (F, 15, 15)
    double* nis_out;                        // (M,)
    std::int64_t* accepted_out;             // (M,)
};

// The node record of run_recorded (capacity N + F nodes).
struct NodeRecord {
    double *XA, *PA, *XB, *PB, *FS, *TN;    // (K, 16), (K, 15, 15), (K, 16), (K, 15, 15), (K, 15, 15), (K,)
    std::int64_t *imu_node, *frame_node;    // (N,), (F,)
};

// Filter a whole stream; with rec, also store every filter node.  Returns the number of nodes (1 + the number of
// predictions).  The IMU input is taken as linear between samples: each step uses the mean of the (interpolated)
// measurements at its two ends, and a step is split exactly at every camera time; frames before t[0] or after
// t[-1] are skipped (their XF row is NaN).
std::int64_t run(const RunArgs& a, const NodeRecord* rec);

}  // namespace dualpose::eskf
