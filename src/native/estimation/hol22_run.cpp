// Hol's Algorithm 1 over a recording (hol22_run.hpp).
#include "hol22_run.hpp"

#include "../common/dispatch.hpp"
#include "hol22_filter.hpp"

#include <algorithm>

namespace dualpose::hol22 {

DUALPOSE_CLONES_V4
void run(const Hol22Inputs& in, double* x, double* P, double* X, double* Ps, double* nis_out, std::int64_t* acc_out) {
    constexpr double depth_floor = 1e-3;  // m
    CameraWork work;
    std::ptrdiff_t j = 0;
    while (j < in.nf && in.cam_t[j] < in.t[0]) ++j;
    double tc = in.t[0];
    for (std::ptrdiff_t k = 0; k < in.n; ++k) {
        while (j < in.nf && in.cam_t[j] <= in.t[k]) {
            time_update(x, P, in.cam_t[j] - tc, in.qdiag);
            tc = in.cam_t[j];
            const std::int64_t a = in.offsets[j], b = in.offsets[j + 1];
            camera_update(x, P, in.pixels + 2 * a, in.points + 3 * a, b - a, in.intr, in.p_bc, in.Rcb, depth_floor,
                          in.sigma_px, in.gate, nis_out + a, acc_out + a, work);
            ++j;
        }
        time_update(x, P, in.t[k] - tc, in.qdiag);
        tc = in.t[k];
        imu_update(x, P, in.accel + 3 * k, in.gyro + 3 * k, in.gravity, in.R_imu);
        std::copy(x, x + N, X + k * N);
        std::copy(P, P + N * N, Ps + k * N * N);
    }
}

}  // namespace dualpose::hol22
