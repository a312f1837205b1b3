// Hol's Algorithm 1 (Hol 2008) one IMU sample / camera frame at a time (the steps) and over a recording (run, a loop
// over the steps): dualpose.estimation.hol22.Hol22EKF.run and the streaming filter
// dualpose.estimation.hol22.Hol22Stream (docs/fusion.md, "Streaming").
#pragma once

#include "hol22_layout.hpp"
#include "sensor_block.hpp"

#include <cstddef>
#include <cstdint>

namespace dualpose::hol22 {

// Constants of one filter (set once).
struct Config {
    double qdiag[DIM];                  // process noise spectral densities (diagonal of Q / T)
    double gravity[3], R_imu[36];       // g^e, m/s²; accelerometer + gyroscope noise (6, 6)
    double scale2[2];                   // [ε_g², ε_a²] · rate · 1 s: added to R_imu's gyro / accel diagonal × |z|²
    double intr[4], p_bc[3], Rcb[9];    // camera [fx, fy, cx, cy], camera centre in body, R^{cb} (3, 3)
    double sigma_px, gate;              // pixel σ, χ²(2) gate
};

// Everything that changes (trivially copyable).
struct Filter {
    double x[DIM], P[DIM * DIM];        // state (hol22_layout.hpp) and covariance
    double tc, t_imu;                   // time of the state; of the last IMU sample, s
    std::int64_t started, samples;      // whether the clock has started; IMU samples filtered
};

// The filter at x (22,), P (22, 22) before its first sample (clock not started).
void init_filter(Filter& f, const double* x, const double* P);

// A camera frame at tj (time update from tc, eq. 9, then the camera update, eq. 11c; an unstarted clock starts at
// tj); nis (m,), acc (m,) written.
void frame_step(Filter& f, const Config& c, double tj, const double* pixels, const double* points, std::int64_t m,
                double* nis, std::int64_t* acc);

// An IMU sample at t (time update from tc, then the accelerometer and gyroscope update, eq. 11a-b; an unstarted
// clock starts at t).
void imu_step(Filter& f, const Config& c, double t, const double* gyro, const double* accel);

// Filter a block from f: for each IMU sample, first every frame up to its time (frames before the first sample of
// an unstarted filter are skipped: their NIS stays as given), then the sample.  X (n, 22), Ps (n, 22, 22) (either
// may be null) receive the state and covariance after each IMU update; nis (M,), acc (M,) the camera NIS and 1/0.
// Frames after the last sample are left: returns the number of frames consumed.
std::int64_t feed(Filter& f, const Config& c, const SensorBlock& b, double* X, double* Ps, double* nis,
                  std::int64_t* acc);

// Hol's Algorithm 1 over a recording from x (22,), P (22, 22) (updated in place): feed from an unstarted filter
// (its clock starts at t[0]; frames after t[-1] are skipped).
void run(const SensorBlock& b, const Config& c, double* x, double* P, double* X, double* Ps, double* nis,
         std::int64_t* acc);

// The saved stream: one contiguous byte buffer [StreamHeader | Config | Filter].  STREAM_VERSION changes whenever
// the layout does.
constexpr std::uint64_t STREAM_MAGIC = 0x3132484c4f504455ULL;  // "UDPOLH21" little-endian
constexpr std::uint64_t STREAM_VERSION = 2;  // 2: Config.scale2
struct StreamHeader {
    std::uint64_t magic, version, size, reserved;
};
struct Stream {
    StreamHeader h;
    Config c;
    Filter f;
};

}  // namespace dualpose::hol22
