// The AHRS one sample at a time (step) and over a whole recording (run, a loop over step; ahrs_run.hpp):
// the earth-frame low-pass of the specific force and sliding-window mean of the field, χ²-gated accelerometer
// (inclination) and magnetometer (heading) updates in Joseph form.
#include "ahrs_run.hpp"

#include "../common/kutil.hpp"
#include "ahrs_filter.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace dualpose::ahrs {

namespace {
constexpr double CHI2_2_LO = 0.0506356, CHI2_2_HI = 7.3777589;    // two-sided 95% band of χ²(2)
constexpr double CHI2_1_LO = 0.000982069, CHI2_1_HI = 5.0238862;  // two-sided 95% band of χ²(1)

// The positive semidefinite part of a symmetric 2×2 matrix x = (xx, xy, yy), in place: its eigenvalues clipped at
// zero, l₁ ≥ l₂, with the spectral projectors (x − l₂ I)/(l₁ − l₂) and (l₁ I − x)/(l₁ − l₂) (no trigonometry); a
// multiple of the identity (l₁ = l₂ to rounding) becomes max(l, 0) I.
inline void psd_part_2x2(double* x) {
    const double m = 0.5 * (x[0] + x[2]), h = 0.5 * (x[0] - x[2]);
    const double d = std::sqrt(h * h + x[1] * x[1]);
    const double l1 = m + d, l2 = m - d;
    if (l2 >= 0.0) return;  // already semidefinite
    if (l1 <= 0.0) {
        x[0] = x[1] = x[2] = 0.0;
        return;
    }
    // l₁ > 0 > l₂: the part along l₁'s eigenvector, l₁ (x − l₂ I) / (l₁ − l₂)
    const double f = l1 / (l1 - l2);
    x[0] = f * (x[0] - l2);
    x[1] = f * x[1];
    x[2] = f * (x[2] - l2);
}
}  // namespace

Params make_params(const double* params, const double* Ha, const double* Hm, double dt) {
    Params p{};
    p.dt = dt;
    p.gyr_var = params[P_GYR_VAR];
    p.bias_var = params[P_BIAS_VAR];
    p.acc_var = params[P_ACC_VAR];
    p.grav = params[P_GRAVITY];
    p.mag_var = params[P_MAG_VAR];
    p.mag_norm = params[P_MAG_NORM];
    p.mag_dip = params[P_MAG_DIP];
    p.use_mag = params[P_USE_MAG] > 0.5;
    p.acc_gate = params[P_ACC_GATE];
    p.mag_gate = params[P_MAG_GATE];
    p.n_win = std::max(std::int64_t{1}, static_cast<std::int64_t>(params[P_WINDOW]));
    p.scale_var = params[P_GYR_SCALE_VAR];
    p.stride = std::max(std::int64_t{1}, std::min(p.n_win, static_cast<std::int64_t>(params[P_STRIDE])));
    p.overlap = double(p.n_win) / double(p.stride);
    p.acc_alpha = std::min(1.0, params[P_ACC_ADAPT] * p.stride);  // forgetting factors are per sample
    p.mag_alpha = std::min(1.0, params[P_MAG_ADAPT] * p.stride);
    p.release = std::max(1.0, params[P_GATE_RELEASE] / p.stride);  // the gates count updates
    for (int i = 0; i < 2 * NE; ++i) p.Ha[i] = Ha[i];
    for (int i = 0; i < NE; ++i) p.Hm[i] = Hm[i];
    p.acc_lp = butterworth_lowpass(0.5 * double(p.n_win) * dt, dt);
    make_lag_params(p.lag, params, 1.0 / dt);
    p.rest = make_rest_params(params, p.stride);
    const double dg = params[P_ACC_SCALE] * p.grav;  // the accelerometer's own error of a specific force ≈ g
    p.acc_tol = 2.0 * dg;
    p.acc_clip = std::max(0.0, params[P_ACC_CLIP]);
    p.acc_dev_alpha = std::min(1.0, dt / 1.0);
    p.acc_cal_var = dg * dg / 3.0;
    const double motion_time = params[P_ACC_MOTION_TIME];
    p.acc_motion_alpha = motion_time > 0.0 ? std::min(1.0, double(p.stride) * dt / motion_time) : 1.0;
    p.acc_adapt_matrix = params[P_ACC_ADAPT_MATRIX] > 0.5 ? 1 : 0;
    p.acc_adapt_rest_hold = params[P_ACC_ADAPT_REST_HOLD] > 0.5 ? 1 : 0;
    // the low-pass's poles have real part −1/τ (τ its DC delay, n_win dt / 2): what it holds of an input that has
    // stopped decays as exp(−t/τ), its variance as exp(−2t/τ), per update exp(−2 stride dt / τ)
    p.acc_fade = std::exp(-4.0 * double(p.stride) / double(p.n_win));
    return p;
}

void init_state(State& s, double* ring, const Params& p, const double* q, const double* b, const double* P) {
    s = State{};
    for (int i = 0; i < 4; ++i) s.q[i] = q[i];
    for (int i = 0; i < 3; ++i) s.b[i] = b[i];
    for (int i = 0; i < NE * NE; ++i) s.P[i] = P[i];
    for (int i = 0; i < 9; ++i) s.Cm[i] = i % 4 == 0 ? 1.0 : 0.0;
    std::fill(ring, ring + 4 * p.n_win, 0.0);
    init_lag(s.lag, ring + 4 * p.n_win, p.lag);
    init_rest(s.rest, ring + 4 * p.n_win + lag_ring_doubles(p.lag), p.rest);
    s.stats[S_MAG_LAG] = s.lag.tau;
}

void step(State& s, double* ring, const Params& p, const double* gyr, const double* acc, const double* mag,
          PredictRecord* record) {
    // the names of the whole-recording loop this body was written for
    const double dt = p.dt, gyr_var = p.gyr_var, bias_var = p.bias_var, acc_var = p.acc_var, grav = p.grav;
    const double mag_var = p.mag_var, mag_norm = p.mag_norm, mag_dip = p.mag_dip;
    const bool use_mag = p.use_mag != 0;
    const double acc_gate = p.acc_gate, mag_gate = p.mag_gate, scale_var = p.scale_var;
    const std::int64_t n_win = p.n_win, stride = p.stride;
    const double overlap = p.overlap, acc_alpha = p.acc_alpha, mag_alpha = p.mag_alpha, release = p.release;
    const double *Ha = p.Ha, *Hm = p.Hm;
    double *q = s.q, *b = s.b, *P = s.P, *mag_sum = s.mag_sum, *Cm = s.Cm, *stats = s.stats;
    double &mag_dist_sum = s.mag_dist_sum, &mag_dist = s.mag_dist, &acc_extra = s.acc_extra, &mag_extra = s.mag_extra;
    std::int64_t &head = s.head, &filled = s.filled, &since = s.since, &acc_closed = s.acc_closed,
                 &mag_closed = s.mag_closed;
    double* ring_m = ring;
    double* ring_d = ring + 3 * n_win;
    double R[9], v[3], dx[NE], mag_mean[3], acc_mean[3];
    double Ka[NE * 2], PH[NE * 2], Km[NE];

    // ---- predict: gyroscope as input (global error: δθ̇ = −R δb + R n_g)
    const double* g = gyr;
    predict(q, b, P, g[0], g[1], g[2], dt, gyr_var, bias_var, scale_var, R);
    if (record != nullptr) record_prediction(*record, q, b, P, R);
    rotmat_xyzw(q[0], q[1], q[2], q[3], R);

    // ---- specific force and field rotated into the estimated earth frame and kept in the "uncorrected" frame
    // (C⁻¹ R̂ v), so that a later correction rotates all past samples at once (current frame = C · uncorrected):
    // the specific force through the 2nd-order low-pass (a linear filter, so its state rotates with them), the
    // field into the sliding window
    const double ax = acc[0], ay = acc[1], az = acc[2];
    for (int i = 0; i < 3; ++i) v[i] = R[3 * i] * ax + R[3 * i + 1] * ay + R[3 * i + 2] * az;
    double ea[3];
    for (int i = 0; i < 3; ++i) ea[i] = Cm[i] * v[0] + Cm[3 + i] * v[1] + Cm[6 + i] * v[2];
    if (p.acc_clip > 0.0) {
        if (filled == 0) {
            s.acc_dev_ms = 3.0 * acc_var;
        } else {
            // an impulse (a tap, a shock: milliseconds, up to tens of g) enters the low-pass at most k running RMS
            // (time constant 1 s, of the clipped changes) away from its last output; a Gaussian change of that RMS
            // exceeds k = 5 with probability < 1e-15, and a sustained acceleration raises the RMS within tens of ms
            // (a step k times the RMS grows it by the factor 1 + α(k² − 1) per sample) and passes
            const double d0 = ea[0] - s.acc_out[0], d1 = ea[1] - s.acc_out[1], d2 = ea[2] - s.acc_out[2];
            double dn2 = d0 * d0 + d1 * d1 + d2 * d2;
            const double lim2 = p.acc_clip * p.acc_clip * s.acc_dev_ms;
            if (dn2 > lim2) {
                const double f = std::sqrt(lim2 / dn2);
                ea[0] = s.acc_out[0] + f * d0;
                ea[1] = s.acc_out[1] + f * d1;
                ea[2] = s.acc_out[2] + f * d2;
                dn2 = lim2;
            }
            s.acc_dev_ms += p.acc_dev_alpha * (dn2 - s.acc_dev_ms);
        }
    }
    for (int i = 0; i < 3; ++i) {
        acc_mean[i] = lowpass_step(p.acc_lp, s.acc_lp + 2 * i, ea[i], filled == 0);
        s.acc_out[i] = acc_mean[i];
    }
    double* ring_lag = ring + 4 * n_win;
    if (use_mag) {
        // the field at t is the field at t − τ̂: seen with the orientation at t − τ̂ (ahrs_mag_lag.hpp)
        double mc[3];
        lag_ingest(s.lag, ring_lag, p.lag, dt, gyr, b, mag);
        lag_compensate(s.lag, ring_lag, p.lag, gyr, b, mag, mc);
        const double mx = mc[0], my = mc[1], mz = mc[2];
        for (int i = 0; i < 3; ++i) v[i] = R[3 * i] * mx + R[3 * i + 1] * my + R[3 * i + 2] * mz;
        // disturbance lower bound of this sample: change of the field's magnitude and dip from the reference
        const double hs = std::sqrt(v[0] * v[0] + v[1] * v[1]);
        const double dn = std::sqrt(mx * mx + my * my + mz * mz) - mag_norm;
        const double dd = mag_norm * (std::atan2(-v[2], hs) - mag_dip);
        const double dist = dn * dn + dd * dd;
        mag_dist_sum += dist - ring_d[head];
        ring_d[head] = dist;
        for (int i = 0; i < 3; ++i) {
            const double e = Cm[i] * v[0] + Cm[3 + i] * v[1] + Cm[6 + i] * v[2];
            mag_sum[i] += e - ring_m[3 * head + i];
            ring_m[3 * head + i] = e;
        }
    }
    head = head + 1 < n_win ? head + 1 : 0;
    filled = std::min(filled + 1, n_win);
    since += 1;
    const bool window_done = filled == n_win && since >= stride;
    if (window_done) {
        since = 0;
        for (int i = 0; i < 3; ++i)
            v[i] = Cm[3 * i] * acc_mean[0] + Cm[3 * i + 1] * acc_mean[1] + Cm[3 * i + 2] * acc_mean[2];
        mag_dist = std::max(mag_dist_sum / n_win, 0.0);
        // |filtered a_lin| >= | |filtered R a| - g | - 2δg: that much unmodelled acceleration is certainly present
        // (g is the magnitude the accelerometer read at rest; its magnitude error, at most δg there and δg now, can
        // account for 2δg of the difference by itself)
        const double a_norm = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        const double dev = std::max(std::fabs(a_norm - grav) - p.acc_tol, 0.0);
        // the update needs the variance of the filtered linear acceleration along each horizontal axis, and dev is
        // one realisation of it along the vertical, independent of the horizontal ones: in oscillating motion it
        // passes zero twice a cycle, when the horizontal components need not (circular motion: exactly when they
        // peak), and the gain would jump there.  Its running mean square over the low-pass's own delay (the time
        // scale on which the filtered acceleration changes) estimates that variance instead
        if (p.acc_motion_alpha < 1.0)
            s.acc_motion_ms += p.acc_motion_alpha * (dev * dev - s.acc_motion_ms);
        else
            s.acc_motion_ms = dev * dev;  // acc_motion_time 0: the bound of this update alone
        // at rest (the rest detector's window quiet since its last bias update) the body does not accelerate: the
        // innovations say nothing about the filtered linear acceleration of the motion, which the estimate below
        // describes, so it is held for the motion to come; and what the low-pass still holds of the motion's
        // acceleration dies out as its impulse response does, so the estimate enters the noise with that share
        const bool hold = p.acc_adapt_rest_hold != 0 && s.rest.quiet != 0;
        for (int i = 0; i < NE; ++i)
            for (int c = 0; c < 2; ++c) {
                double t = 0.0;
                for (int m = 0; m < NE; ++m) t += P[i * NE + m] * Ha[c * NE + m];
                PH[i * 2 + c] = t;
            }
        // innovation-based (Sage-Husa / Mehra) estimate of the unmodelled acceleration's covariance in the estimated
        // horizontal plane, E[ν νᵀ] = H P Hᵀ + R: the positive semidefinite part of each update's
        // ν νᵀ − H P Hᵀ − (σ²/N + (δg)²/3) I (rank one at most: ν νᵀ minus a definite matrix) into a running mean.
        // Hand motion is not isotropic: the hand moves along a direction, and what the low-pass lets through lies
        // along it, so the accelerometer is distrusted along that direction and not across it
        // (docs/broad.md, "Twelve trials", (e)).  acc_adapt_matrix false: one variance for both axes,
        // r̂ <- (1 − α) r̂ + α max(νᵀν/2 − tr(HPHᵀ)/2 − σ²/N − (δg)²/3, 0)
        if (acc_alpha > 0.0 && !hold) {
            if (p.acc_adapt_matrix != 0) {
                double hph[3] = {0.0, 0.0, 0.0};  // H P Hᵀ (xx, xy, yy)
                for (int m = 0; m < NE; ++m) {
                    hph[0] += Ha[m] * PH[m * 2];
                    hph[1] += Ha[m] * PH[m * 2 + 1];
                    hph[2] += Ha[NE + m] * PH[m * 2 + 1];
                }
                const double w = acc_var / n_win + p.acc_cal_var;
                double x[3] = {v[0] * v[0] - hph[0] - w, v[0] * v[1] - hph[1], v[1] * v[1] - hph[2] - w};
                psd_part_2x2(x);
                for (int i = 0; i < 3; ++i) s.acc_extra_m[i] = (1.0 - acc_alpha) * s.acc_extra_m[i] + acc_alpha * x[i];
            } else {
                double hph = 0.0;  // tr(H P Hᵀ) / 2
                for (int i = 0; i < 2; ++i)
                    for (int j = 0; j < NE; ++j)
                        for (int m = 0; m < NE; ++m) hph += 0.5 * Ha[i * NE + j] * P[j * NE + m] * Ha[i * NE + m];
                acc_extra = (1.0 - acc_alpha) * acc_extra +
                            acc_alpha * std::max(0.5 * (v[0] * v[0] + v[1] * v[1]) - hph - acc_var / n_win - p.acc_cal_var, 0.0);
            }
        }
        // white noise, the accelerometer's own direction error (δg)²/3 per axis, the acceleration bound's mean
        // square and the innovation-based estimate; consecutive updates share samples: each carries 1/overlap of a
        // window's information (the low-pass averages white noise as the n_win-sample boxcar does: same
        // noise-equivalent bandwidth).  rm = (xx, xy, yy) of the noise matrix
        double rm[3];
        s.acc_extra_fade = hold ? s.acc_extra_fade * p.acc_fade : 1.0;
        if (p.acc_adapt_matrix != 0) {
            const double base = acc_var / n_win + p.acc_cal_var + s.acc_motion_ms;
            const double f = s.acc_extra_fade;
            rm[0] = (base + f * s.acc_extra_m[0]) * overlap;
            rm[1] = f * s.acc_extra_m[1] * overlap;
            rm[2] = (base + f * s.acc_extra_m[2]) * overlap;
        } else {
            const double extra = s.acc_extra_fade * acc_extra;
            rm[0] = rm[2] = (acc_var / n_win + p.acc_cal_var + s.acc_motion_ms + extra) * overlap;
            rm[1] = 0.0;
        }
        // S = H P Hᵀ + R
        double s00 = rm[0], s01 = rm[1], s11 = rm[2];
        for (int m = 0; m < NE; ++m) {
            s00 += Ha[m] * PH[m * 2];
            s01 += Ha[m] * PH[m * 2 + 1];
            s11 += Ha[NE + m] * PH[m * 2 + 1];
        }
        const double det = s00 * s11 - s01 * s01;
        const double i00 = s11 / det, i01 = -s01 / det, i11 = s00 / det;
        const double nis = v[0] * (i00 * v[0] + i01 * v[1]) + v[1] * (i01 * v[0] + i11 * v[1]);
        if (nis > acc_gate && acc_closed < release) {
            acc_closed += 1;
            stats[S_ACC_REJECTED] += 1.0;
        } else {
            if (nis <= acc_gate) acc_closed = 0;  // after a release the gate stays open until one fits again
            stats[S_ACC_NIS_SUM] += nis;
            if (CHI2_2_LO <= nis && nis <= CHI2_2_HI) stats[S_ACC_INSIDE] += 1.0;
            for (int i = 0; i < NE; ++i) {
                const double ph0 = PH[i * 2], ph1 = PH[i * 2 + 1];
                Ka[i * 2] = ph0 * i00 + ph1 * i01;
                Ka[i * 2 + 1] = ph0 * i01 + ph1 * i11;
            }
            Ka[(D_ATTITUDE + 2) * 2] = 0.0;  // the accelerometer never corrects heading
            Ka[(D_ATTITUDE + 2) * 2 + 1] = 0.0;
            for (int i = 0; i < NE; ++i) dx[i] = Ka[i * 2] * v[0] + Ka[i * 2 + 1] * v[1];
            const double Rm[4] = {rm[0], rm[1], rm[1], rm[2]};
            joseph_rows<NE, 2>(P, Ka, Ha, Rm);
            inject_and_reset(q, b, P, dx);
            left_rotate_inplace(Cm, dx);
        }
    }

    // ---- magnetometer (9D): heading of the horizontal part of the field averaged in the earth frame over the
    // same window (inclination-decoupled), with the field's per-sample disturbance level accumulated alongside
    if (use_mag && window_done) {
        for (int i = 0; i < 3; ++i)
            mag_mean[i] = (Cm[3 * i] * mag_sum[0] + Cm[3 * i + 1] * mag_sum[1] + Cm[3 * i + 2] * mag_sum[2]) / n_win;
        double h;
        const double psi = heading_of_field(mag_mean, &h, 1e-3 * mag_norm);
        if (std::isnan(psi)) {
            stats[S_MAG_SKIPPED] += 1.0;
        } else {
            const double r0 = (mag_var / n_win + mag_dist) / (h * h) * overlap;
            for (int i = 0; i < NE; ++i) {
                double t = 0.0;
                for (int m = 0; m < NE; ++m) t += P[i * NE + m] * Hm[m];
                Km[i] = t;  // P Hᵀ for now
            }
            double hph = 0.0;
            for (int m = 0; m < NE; ++m) hph += Hm[m] * Km[m];
            if (mag_alpha > 0.0)
                mag_extra = (1.0 - mag_alpha) * mag_extra + mag_alpha * std::max(psi * psi - hph - r0, 0.0);
            const double r = r0 + mag_extra;
            const double s = hph + r;
            const double nis = psi * psi / s;
            if (nis > mag_gate && mag_closed < release) {
                mag_closed += 1;
                stats[S_MAG_REJECTED] += 1.0;
            } else {
                if (nis <= mag_gate) mag_closed = 0;
                stats[S_MAG_NIS_SUM] += nis;
                if (CHI2_1_LO <= nis && nis <= CHI2_1_HI) stats[S_MAG_INSIDE] += 1.0;
                for (int i = 0; i < NE; ++i) Km[i] /= s;
                Km[D_ATTITUDE] = 0.0;  // the magnetometer never corrects inclination
                Km[D_ATTITUDE + 1] = 0.0;
                for (int i = 0; i < NE; ++i) dx[i] = Km[i] * psi;
                joseph_update<1>(P, Km, Hm, r);
                inject_and_reset(q, b, P, dx);
                left_rotate_inplace(Cm, dx);
            }
        }
        lag_solve(s.lag, p.lag);  // a new τ̂ for the samples that follow
        stats[S_MAG_LAG] = s.lag.tau;
        stats[S_MAG_LAG_SAMPLES] = double(s.lag.informative);
    }

    // ---- rest: gyroscope and accelerometer quiet over the trailing window -> the window's mean rate measures b
    if (p.rest.n > 0) {
        const bool quiet = rest_ingest(s.rest, ring_lag + lag_ring_doubles(p.lag), p.rest, gyr, acc);
        rest_update(s.rest, p.rest, quiet, stride, q, b, P, Cm, stats);
    }
}

namespace {
void normalise3(double* v) {
    const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; ++i) v[i] /= n;
}
}  // namespace

void rest_run(std::ptrdiff_t n, const double* gyr, const double* acc, const double* mag, bool use_mag, double* sums,
              double* out_q, double* out_b) {
    for (std::ptrdiff_t k = 0; k < n; ++k) {
        for (int i = 0; i < 3; ++i) {
            sums[i] += gyr[3 * k + i];
            sums[3 + i] += acc[3 * k + i];
            sums[6 + i] += mag[3 * k + i];
        }
        sums[9] += 1.0;
        for (int i = 0; i < 3; ++i) out_b[3 * k + i] = sums[i] / sums[9];
        // rows east, north, up: the earth axes in body coordinates (dualpose.estimation.ahrs.initial_orientation)
        double M[9];
        double *e = M, *nn = M + 3, *u = M + 6;
        for (int i = 0; i < 3; ++i) u[i] = sums[3 + i];
        normalise3(u);
        const double* m = sums + 6;
        if (use_mag) {
            e[0] = m[1] * u[2] - m[2] * u[1];
            e[1] = m[2] * u[0] - m[0] * u[2];
            e[2] = m[0] * u[1] - m[1] * u[0];
        } else {
            for (int i = 0; i < 3; ++i) e[i] = (i == 0 ? 1.0 : 0.0) - u[0] * u[i];
        }
        const double en = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        const double mn = use_mag ? std::sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]) : 1.0;
        if (!(en > 1e-9 * std::max(1.0, mn))) {  // degenerate: field (or x axis) parallel to gravity
            e[0] = u[2];
            e[1] = 0.0;
            e[2] = -u[0];
        }
        normalise3(e);
        nn[0] = u[1] * e[2] - u[2] * e[1];
        nn[1] = u[2] * e[0] - u[0] * e[2];
        nn[2] = u[0] * e[1] - u[1] * e[0];
        store(out_q + 4 * k, quat_of_rotmat(M));  // as dualpose.quat_from_matrix
    }
}

void run(std::ptrdiff_t n, const double* gyr, const double* acc, const double* mag, double dt, double* q, double* b,
         double* P, const double* params, const double* Ha, const double* Hm, double* out_q, double* out_b,
         double* stats) {
    const Params p = make_params(params, Ha, Hm, dt);
    State s;
    std::vector<double> ring(ring_doubles(p));
    init_state(s, ring.data(), p, q, b, P);
    for (int i = 0; i < S_MAG_LAG; ++i) s.stats[i] = stats[i];  // the counters accumulate; τ̂ is the state's
    for (std::ptrdiff_t k = 0; k < n; ++k) {
        step(s, ring.data(), p, gyr + 3 * k, acc + 3 * k, mag + 3 * k);
        for (int i = 0; i < 4; ++i) out_q[4 * k + i] = s.q[i];
        for (int i = 0; i < 3; ++i) out_b[3 * k + i] = s.b[i];
    }
    for (int i = 0; i < 4; ++i) q[i] = s.q[i];
    for (int i = 0; i < 3; ++i) b[i] = s.b[i];
    for (int i = 0; i < NE * NE; ++i) P[i] = s.P[i];
    for (int i = 0; i < N_STATS; ++i) stats[i] = s.stats[i];
}

}  // namespace dualpose::ahrs
