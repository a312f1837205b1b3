// The error-state filter one IMU sample / camera frame at a time (the steps) and over a whole recording (run, a loop
// over the steps): dualpose.estimation.eskf.ErrorStateEKF.run, optionally recording every filter node for the RTS
// smoother, and the streaming filter dualpose.estimation.eskf.EskfStream (docs/fusion.md, "Streaming").
#pragma once

#include "eskf_layout.hpp"
#include "sensor_block.hpp"

#include <cstdint>

namespace dualpose::eskf {

// Constants of one filter (set once).
struct Config {
    double gravity[3], noise[6];     // world gravity, m/s²; [σ_g², σ_a², σ_bg², σ_ba², ε_g², ε_a²] (eskf_kernels)
    double intr[4], q_bc[4], p_bc[3];  // camera [fx, fy, cx, cy], camera→body rotation xyzw, camera centre in body
    double sigma_px, gate;           // pixel σ, χ²(2) gate
};

// Everything that changes from sample to sample (trivially copyable: a byte copy saves and restores it).  The IMU
// input is taken as linear between samples: the interval from the last sample (t0, g0, a0) to the next one is
// split at every camera time, tc / g_cur / a_cur being the time and the interpolated input reached so far.
struct Filter {
    double x[NX], P[NE * NE];                   // nominal state and error covariance
    double t0, tc;                              // last IMU time; time reached inside the interval after it, s
    double g0[3], a0[3], g_cur[3], a_cur[3];    // last IMU sample; input interpolated at tc
    std::int64_t samples;                       // IMU samples filtered (0: the clock has not started)
};

// The filter at x (16,), P (15, 15) before its first sample.
void init_filter(Filter& f, const double* x, const double* P);

// The first IMU sample (t, gyro, accel): the clock starts at t, nothing is predicted.
void start(Filter& f, double t, const double* gyro, const double* accel);

// Predict from tc to the camera time tj (tc <= tj <= t1; nothing when tj == tc), the input interpolated linearly
// between the last sample and the next one (t1, g1, a1); the transition of the step goes to F (15, 15).  Returns
// whether it predicted.
bool predict_to_frame(Filter& f, const Config& c, double tj, double t1, const double* g1, const double* a1,
                      double* F);

// Predict from tc to the next IMU sample (t1, g1, a1) (nothing when t1 == tc), which becomes the last sample;
// the transition goes to F.  Returns whether it predicted.
bool finish_interval(Filter& f, const Config& c, double t1, const double* g1, const double* a1, double* F);

// The camera update with m correspondences at the current time (update_points of eskf_kernels.hpp); nis (m,),
// accepted (m,) written; returns the number accepted.
std::int64_t update_frame(Filter& f, const Config& c, const double* pixels, const double* points, std::int64_t m,
                          double* nis, std::int64_t* accepted);

// A block of the stream (shapes as in ErrorStateEKF.run).
using Block = SensorBlock;

// Where a block's results go; X, Ps, XF (with PF) may be null (not stored).
struct Outputs {
    double *X, *Ps;                         // (N, 16), (N, 15, 15): state after each IMU sample
    double *XF, *PF;                        // (F, 16), (F, 15, 15): state after each camera update (NaN: skipped)
    double* nis;                            // (M,)
    std::int64_t* accepted;                 // (M,)
};

// The node record of run (capacity N + F nodes).
struct NodeRecord {
    double *XA, *PA, *XB, *PB, *FS, *TN;    // (K, 16), (K, 15, 15), (K, 16), (K, 15, 15), (K, 15, 15), (K,)
    std::int64_t *imu_node, *frame_node;    // (N,), (F,)
};

// Filter a block from f: for each IMU sample, first the frames up to its time (predict_to_frame, update_frame),
// then finish_interval (start for the very first sample, after which frames before it are skipped and frames at
// its time updated).  Frames after the last sample are left: returns the number of frames consumed.  With rec
// (the whole-recording run only), also stores every node; *nodes receives the index of the last node.
std::int64_t feed(Filter& f, const Config& c, const Block& b, const Outputs& o, const NodeRecord* rec,
                  std::int64_t* nodes);

// The arguments of run: the recording, x (16,) and P (15, 15) updated in place, the configuration and outputs.
struct RunArgs {
    Block b;
    double *x, *P;
    Config c;
    Outputs o;
};

// Filter a whole stream from x, P (a loop over the steps, through feed); with rec, also store every filter node.
// Returns the number of nodes (1 + the number of predictions).  Frames before t[0] or after t[-1] are skipped
// (their XF row is NaN).
std::int64_t run(const RunArgs& a, const NodeRecord* rec);

// The saved stream: one contiguous byte buffer [StreamHeader | Config | Filter], so that a byte copy saves it and
// restores it.  STREAM_VERSION changes whenever the layout does.
constexpr std::uint64_t STREAM_MAGIC = 0x31464b5345504455ULL;  // "UDPESKF1" little-endian
constexpr std::uint64_t STREAM_VERSION = 2;  // 2: noise (6,) with the scale-factor terms
struct StreamHeader {
    std::uint64_t magic, version, size, reserved;  // size: total bytes of the buffer
};
struct Stream {
    StreamHeader h;
    Config c;
    Filter f;
};

}  // namespace dualpose::eskf
