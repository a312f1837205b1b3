// Hol's Algorithm 1: the steps and the loop over them (hol22_run.hpp).
#include "hol22_run.hpp"

#include "../common/dispatch.hpp"
#include "hol22_filter.hpp"

#include <algorithm>

namespace dualpose::hol22 {

namespace {
constexpr double depth_floor = 1e-3;  // m
}  // namespace

void init_filter(Filter& f, const double* x, const double* P) {
    f = Filter{};
    std::copy(x, x + N, f.x);
    std::copy(P, P + N * N, f.P);
}

DUALPOSE_CLONES_V4
void frame_step(Filter& f, const Config& c, double tj, const double* pixels, const double* points, std::int64_t m,
                double* nis, std::int64_t* acc) {
    CameraWork work;
    if (!f.started) {
        f.tc = tj;
        f.started = 1;
    }
    time_update(f.x, f.P, tj - f.tc, c.qdiag);
    f.tc = tj;
    camera_update(f.x, f.P, pixels, points, m, c.intr, c.p_bc, c.Rcb, depth_floor, c.sigma_px, c.gate, nis, acc,
                  work);
}

DUALPOSE_CLONES_V4
void imu_step(Filter& f, const Config& c, double t, const double* gyro, const double* accel) {
    if (!f.started) {
        f.tc = t;
        f.started = 1;
    }
    time_update(f.x, f.P, t - f.tc, c.qdiag);
    f.tc = t;
    if (c.scale2[0] != 0.0 || c.scale2[1] != 0.0) {  // scale-factor noise ∝ the measured signal (ImuNoise)
        double R[36];
        for (int i = 0; i < 36; ++i) R[i] = c.R_imu[i];
        const double a2 = accel[0] * accel[0] + accel[1] * accel[1] + accel[2] * accel[2];
        const double w2 = gyro[0] * gyro[0] + gyro[1] * gyro[1] + gyro[2] * gyro[2];
        for (int i = 0; i < 3; ++i) {
            R[7 * i] += c.scale2[1] * a2;
            R[7 * (3 + i)] += c.scale2[0] * w2;
        }
        imu_update(f.x, f.P, accel, gyro, c.gravity, R);
    } else {
        imu_update(f.x, f.P, accel, gyro, c.gravity, c.R_imu);
    }
    f.t_imu = t;
    ++f.samples;
}

std::int64_t feed(Filter& f, const Config& c, const SensorBlock& b, double* X, double* Ps, double* nis,
                  std::int64_t* acc) {
    std::int64_t j = 0;
    if (!f.started && b.n > 0)
        while (j < b.nf && b.cam_t[j] < b.t[0]) ++j;
    for (std::int64_t k = 0; k < b.n; ++k) {
        for (; j < b.nf && b.cam_t[j] <= b.t[k]; ++j) {
            const std::int64_t lo = b.offsets[j], hi = b.offsets[j + 1];
            frame_step(f, c, b.cam_t[j], b.pixels + 2 * lo, b.points + 3 * lo, hi - lo, nis + lo, acc + lo);
        }
        imu_step(f, c, b.t[k], b.gyro + 3 * k, b.accel + 3 * k);
        if (X) std::copy(f.x, f.x + N, X + k * N);
        if (Ps) std::copy(f.P, f.P + N * N, Ps + k * N * N);
    }
    return j;
}

void run(const SensorBlock& b, const Config& c, double* x, double* P, double* X, double* Ps, double* nis,
         std::int64_t* acc) {
    Filter f;
    init_filter(f, x, P);
    feed(f, c, b, X, Ps, nis, acc);
    std::copy(f.x, f.x + N, x);
    std::copy(f.P, f.P + N * N, P);
}

}  // namespace dualpose::hol22
