// The AHRS's causal magnetometer–gyroscope time offset: compensation and online estimate (ahrs_mag_lag.hpp).
#include "ahrs_mag_lag.hpp"

#include "../common/series.hpp"
#include "ahrs_layout.hpp"

#include <algorithm>
#include <cmath>

namespace dualpose::ahrs {

void make_lag_params(LagParams& lp, const double* params, double rate) {
    lp = LagParams{};
    lp.online = params[P_LAG_ONLINE] > 0.5;
    lp.fixed = params[P_LAG_FIXED];
    const double tau_max = lp.online ? std::max(0.0, params[P_LAG_MAX]) : 0.0;  // no candidates when fixed
    lp.box = std::max(std::int64_t{1}, static_cast<std::int64_t>(params[P_LAG_BOX]));
    lp.centre = static_cast<std::int64_t>(std::ceil(tau_max * rate)) + 1;
    lp.hist = 2 * lp.centre + 3;
    const double comp_span = std::max(tau_max, std::fabs(lp.fixed));
    lp.comp = static_cast<std::int64_t>(std::ceil(comp_span * rate)) + 2;
    lp.step = params[P_LAG_STEP] > 0.0 ? params[P_LAG_STEP] : 1.0;
    const std::int64_t half = static_cast<std::int64_t>(std::floor(tau_max / lp.step + 1e-9));
    lp.n_cand = std::min<std::int64_t>(2 * half + 1, LAG_MAX_CANDIDATES);
    lp.first = -lp.step * double((lp.n_cand - 1) / 2);
    for (std::int64_t j = 0; j < lp.n_cand; ++j) {
        const double s = -(lp.first + double(j) * lp.step) * rate;  // ω(t − τ_j) sits s samples after the centre
        const double fl = std::floor(s);
        lp.offset[j] = static_cast<std::int64_t>(fl);
        lp.frac[j] = s - fl;
    }
    lp.min_rate = params[P_LAG_MIN_RATE];
    const double tol = params[P_LAG_NORM_TOL], norm = params[P_MAG_NORM];
    lp.norm_lo = (1.0 - tol) * norm;
    lp.norm_hi = (1.0 + tol) * norm;
    lp.thin = std::max(std::int64_t{1}, static_cast<std::int64_t>(params[P_LAG_THIN]));
    lp.min_count = std::max(std::int64_t{1}, static_cast<std::int64_t>(params[P_LAG_MIN_COUNT]));
    lp.resolve = std::max(std::int64_t{1}, static_cast<std::int64_t>(std::round(0.25 * rate / double(lp.thin))));
    lp.rate = rate;
    lp.inv_box = 1.0 / double(lp.box);
}

namespace {
// τ̂ and the split of its history position, computed once per change instead of once per sample
void set_tau(LagState& ls, const LagParams& lp, double tau) {
    ls.tau = tau;
    ls.back = tau > 0.0 ? std::min(tau * lp.rate, double(lp.comp - 1)) : 0.0;
    ls.back_whole = static_cast<std::int64_t>(std::floor(ls.back));
    ls.back_frac = ls.back - double(ls.back_whole);
}

// (i + d) modulo n for 0 ≤ i < n and −n ≤ d < n (no division)
inline std::int64_t wrap(std::int64_t i, std::int64_t d, std::int64_t n) {
    std::int64_t j = i + d;
    if (j < 0) j += n;
    if (j >= n) j -= n;
    return j;
}
}  // namespace

void init_lag(LagState& ls, double* ring, const LagParams& lp) {
    ls = LagState{};
    set_tau(ls, lp, lp.online ? 0.0 : lp.fixed);
    ls.pos_box = lp.box - 1;  // the first sample goes to position 0
    ls.pos_hist = lp.hist - 1;
    ls.pos_comp = lp.comp - 1;
    std::fill(ring, ring + lag_ring_doubles(lp), 0.0);
}

void lag_ingest(LagState& ls, double* ring, const LagParams& lp, double dt, const double* gyr, const double* b,
                const double* mag) {
    const std::int64_t L = lp.box, H = lp.hist, C = lp.comp, K = lp.centre;
    double* box_w = ring;
    double* box_m = box_w + 3 * L;
    double* hist_w = box_m + 3 * L;
    double* hist_m = hist_w + 3 * H;
    double* cum = hist_m + 3 * H;
    const std::int64_t k = ls.seen++;
    // the integral of the raw rate, for Δθ of the compensation
    ls.pos_comp = wrap(ls.pos_comp, 1, C);
    for (int i = 0; i < 3; ++i) {
        ls.cum[i] += gyr[i] * dt;
        cum[3 * ls.pos_comp + i] = ls.cum[i];
    }
    if (!lp.online) return;
    // the same boxcar on ω − b and m
    const std::int64_t jb = ls.pos_box = wrap(ls.pos_box, 1, L);
    for (int i = 0; i < 3; ++i) {
        const double w = gyr[i] - b[i];
        ls.box_w[i] += w - box_w[3 * jb + i];
        box_w[3 * jb + i] = w;
        ls.box_m[i] += mag[i] - box_m[3 * jb + i];
        box_m[3 * jb + i] = mag[i];
    }
    if (k < L - 1) return;
    const std::int64_t jh = ls.pos_hist = wrap(ls.pos_hist, 1, H);  // ring position of the newest filtered sample
    for (int i = 0; i < 3; ++i) {
        hist_w[3 * jh + i] = ls.box_w[i] * lp.inv_box;
        hist_m[3 * jh + i] = ls.box_m[i] * lp.inv_box;
    }
    if (k < L + 2 * K) return;  // the oldest filtered sample needed (c − K) is not there yet
    const std::int64_t jc = wrap(jh, -(K + 1), H);  // the centre c, K + 1 filtered samples back
    const double* wc = hist_w + 3 * jc;
    const double* mc = hist_m + 3 * jc;
    const double wn = std::sqrt(wc[0] * wc[0] + wc[1] * wc[1] + wc[2] * wc[2]);
    const double mn = std::sqrt(mc[0] * mc[0] + mc[1] * mc[1] + mc[2] * mc[2]);
    if (!(wn >= lp.min_rate && mn >= lp.norm_lo && mn <= lp.norm_hi)) return;
    if (ls.informative++ % lp.thin != 0) return;
    ls.used += 1;
    const double* mp = hist_m + 3 * wrap(jc, 1, H);
    const double* mm = hist_m + 3 * wrap(jc, -1, H);
    double d[3];
    for (int i = 0; i < 3; ++i) d[i] = (mp[i] - mm[i]) / (2.0 * dt);
    // the filtered rates c − K … c + K + 1 in time order (no ring arithmetic in the candidate loop)
    double wl[3 * LAG_MAX_HIST];
    const std::int64_t n_lin = 2 * K + 2, first = wrap(jc, -K, H), head_part = std::min(n_lin, H - first);
    std::copy(hist_w + 3 * first, hist_w + 3 * (first + head_part), wl);
    std::copy(hist_w, hist_w + 3 * (n_lin - head_part), wl + 3 * head_part);
    for (std::int64_t j = 0; j < lp.n_cand; ++j) {
        const double* g0 = wl + 3 * (K + lp.offset[j]);
        const double* g1 = g0 + 3;
        const double f = lp.frac[j];
        const double wx = g0[0] + f * (g1[0] - g0[0]), wy = g0[1] + f * (g1[1] - g0[1]),
                     wz = g0[2] + f * (g1[2] - g0[2]);
        const double rx = d[0] + (wy * mc[2] - wz * mc[1]);
        const double ry = d[1] + (wz * mc[0] - wx * mc[2]);
        const double rz = d[2] + (wx * mc[1] - wy * mc[0]);
        ls.srr[j] += rx * rx + ry * ry + rz * rz;
        ls.sb[0][j] += ry * wz - rz * wy;
        ls.sb[1][j] += rz * wx - rx * wz;
        ls.sb[2][j] += rx * wy - ry * wx;
        ls.sw[0][j] += wx * wx;
        ls.sw[1][j] += wy * wy;
        ls.sw[2][j] += wz * wz;
        ls.sw[3][j] += wx * wy;
        ls.sw[4][j] += wx * wz;
        ls.sw[5][j] += wy * wz;
    }
}

void lag_solve(LagState& ls, const LagParams& lp) {
    if (!lp.online || ls.used - ls.used_at_solve < lp.resolve) return;
    ls.used_at_solve = ls.used;
    if (ls.informative < lp.min_count) {
        set_tau(ls, lp, 0.0);
        return;
    }
    double cost[LAG_MAX_CANDIDATES];
    std::int64_t best = 0;
    for (std::int64_t j = 0; j < lp.n_cand; ++j) {
        // min_h Σ |r₀ − [ω]× h|² = Σ|r₀|² − bᵀ M⁻¹ b with M = Σ [ω]×ᵀ[ω]× = tr(W) I − W, b = Σ r₀ × ω
        const double xx = ls.sw[0][j], yy = ls.sw[1][j], zz = ls.sw[2][j];
        const double xy = ls.sw[3][j], xz = ls.sw[4][j], yz = ls.sw[5][j];
        const double reg = 1e-9 * 2.0 * (xx + yy + zz);
        const double a = yy + zz + reg, e = xx + zz + reg, i = xx + yy + reg;
        const double bb = -xy, c = -xz, f = -yz;  // M = [[a, bb, c], [bb, e, f], [c, f, i]]
        const double A = e * i - f * f, B = c * f - bb * i, Cc = bb * f - c * e;
        const double E = a * i - c * c, F = bb * c - a * f, G = a * e - bb * bb;
        const double det = a * A + bb * B + c * Cc;
        const double bx = ls.sb[0][j], by = ls.sb[1][j], bz = ls.sb[2][j];
        const double q = bx * (A * bx + B * by + Cc * bz) + by * (B * bx + E * by + F * bz) +
                         bz * (Cc * bx + F * by + G * bz);
        cost[j] = det > 0.0 ? ls.srr[j] - q / det : ls.srr[j];
        if (cost[j] < cost[best]) best = j;
    }
    if (best == 0 || best == lp.n_cand - 1) {
        set_tau(ls, lp, 0.0);  // the minimum is on the edge of the range: not estimable (yet)
        return;
    }
    const double cm = cost[best - 1], c0 = cost[best], cp = cost[best + 1];
    const double den = cm - 2.0 * c0 + cp;
    const double shift = den > 0.0 ? std::clamp(0.5 * (cm - cp) / den, -0.5, 0.5) : 0.0;
    set_tau(ls, lp, lp.first + (double(best) + shift) * lp.step);
}

void lag_compensate(const LagState& ls, const double* ring, const LagParams& lp, const double* gyr,
                    const double* b, const double* mag, double* m_c) {
    const double tau = ls.tau;
    if (tau == 0.0) {
        for (int i = 0; i < 3; ++i) m_c[i] = mag[i];
        return;
    }
    double u[3];  // −Δθ, Δθ = ∫_{t−τ}^{t} (ω − b) dt
    if (tau > 0.0) {
        const std::int64_t C = lp.comp;
        const double* cum = ring + 6 * lp.box + 6 * lp.hist;
        const std::int64_t k = ls.seen - 1;  // this sample (ingested already, at pos_comp)
        // t − τ̂ in samples back from this one, within the history (before the first sample: ∫ from sample 0)
        std::int64_t nb = ls.back_whole;
        double f = ls.back_frac;  // between nb and nb + 1 samples back
        if (double(k + 1) < ls.back) {  // the first samples: the history is shorter than τ̂
            nb = k + 1;
            f = 0.0;
        }
        const bool before_first = nb + 1 > k;  // sample k − nb − 1 does not exist: cum there is 0
        const double* c0 = cum + 3 * wrap(ls.pos_comp, -nb, C);
        const double* c1 = cum + 3 * wrap(ls.pos_comp, -std::min(nb + 1, C - 1), C);
        for (int i = 0; i < 3; ++i) {
            const double a0 = nb > k ? 0.0 : c0[i];
            const double a1 = before_first ? 0.0 : c1[i];
            u[i] = -((ls.cum[i] - (a0 + f * (a1 - a0))) - b[i] * tau);
        }
    } else {
        for (int i = 0; i < 3; ++i) u[i] = -(gyr[i] - b[i]) * tau;  // the future: the current rate extrapolated
    }
    // Rodrigues: Exp(u) m = m + sinc(a) u × m + cosc2(a) u × (u × m), a = |u|.  Below a = 0.35 rad (|ω| ≤ 12 rad/s
    // at τ̂ = 30 ms) the Taylor series to a⁶, evaluated in two short chains (truncation a⁸/9! < 1e-9, relative);
    // above, the guarded functions of common/series.hpp
    const double y = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    double s, c2;
    if (y < 0.35 * 0.35) {
        const double y2 = y * y;
        s = (1.0 - y * (1.0 / 6.0)) + y2 * ((1.0 / 120.0) - y * (1.0 / 5040.0));
        c2 = (0.5 - y * (1.0 / 24.0)) + y2 * ((1.0 / 720.0) - y * (1.0 / 40320.0));
    } else {
        const double a = std::sqrt(y);
        s = sinc(a);
        c2 = cosc2(a);
    }
    const double vx = u[1] * mag[2] - u[2] * mag[1], vy = u[2] * mag[0] - u[0] * mag[2],
                 vz = u[0] * mag[1] - u[1] * mag[0];
    const double wx = u[1] * vz - u[2] * vy, wy = u[2] * vx - u[0] * vz, wz = u[0] * vy - u[1] * vx;
    m_c[0] = mag[0] + s * vx + c2 * wx;
    m_c[1] = mag[1] + s * vy + c2 * wy;
    m_c[2] = mag[2] + s * vz + c2 * wz;
}

}  // namespace dualpose::ahrs
