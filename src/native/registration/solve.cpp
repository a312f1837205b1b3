// The registration solver for a batch of problems (see solve.hpp), ported from the numba solve_batch.
//
// Blocks of BLOCK problems in three phases: (1) each problem's moments, its symmetric 4x4 matrix and that
// matrix's characteristic polynomial; (2) largest_roots, the Newton iterations for the two largest roots of every
// polynomial of the block as one loop across the problems (one problem's iterations are a chain of dependent
// divisions; the problems of a block are independent, so that loop vectorises); (3) each eigenvector read off the
// adjugate (closed_form_vector, or the Jacobi fallback) and the result row.
#include "solve.hpp"

#include "../common/kutil.hpp"
#include "../common/quat.hpp"
#include "eigen4.hpp"
#include "row.hpp"
#include "svd3.hpp"

#include <cmath>

namespace dualpose::reg {

namespace {

// relative tolerance on the eigen gap below which the optimal rotation is reported as not unique
constexpr double GAP_RTOL = 1e-9;
// problems solved together (the block tables stay in the L1 cache)
constexpr int BLOCK = 32;

// What phase 1 keeps of a problem for phase 3.
struct Staged {
    Sym4 a;               // the 4x4 matrix that decides the rotation
    double s[9];          // second moments s = Σβ p̃' p⁰'ᵀ + Σα ñ n⁰ᵀ (row-major)
    double ax, ay, az;    // model centroid
    double bx, by, bz;    // measured centroid
    double ss0, bw, tol;  // Σβ|p⁰'|², Walker's 4Σβ, the gap tolerance
    double h[6];          // Walker's C3 as (h, d)
    int e;                // the moments are of the centred points times 2**e (POINT_EXPONENT)
    bool skip;            // a non-finite input: the row holds only the code
};

// Characteristic polynomials and roots of a block, one entry per problem (vectorised by largest_roots).
struct Roots {
    double c3[BLOCK], c2[BLOCK], c1[BLOCK], c0[BLOCK], l1[BLOCK], l2[BLOCK], scale[BLOCK];
};

// 1 + index into BAD_INPUT_NAMES of the first of problem b's inputs holding NaN or infinity, else
// N_BAD_INPUT_NAMES + 1 (all finite: the moments overflowed).
int first_bad_input(const Problems& pr, std::int64_t b) {
    const double* p0 = pr.p0 + b * pr.npt * 3;
    const double* p1 = pr.p1 + b * pr.npt * 3;
    for (std::int64_t k = 0; k < pr.npt * 3; ++k) {
        if (!std::isfinite(p0[k])) return 1;
        if (!std::isfinite(p1[k])) return 2;
    }
    const double* n0 = pr.n0 + b * pr.ndir * 3;
    const double* n1 = pr.n1 + b * pr.ndir * 3;
    for (std::int64_t k = 0; k < pr.ndir * 3; ++k) {
        if (!std::isfinite(n0[k])) return 3;
        if (!std::isfinite(n1[k])) return 4;
    }
    return row::N_BAD_INPUT_NAMES + 1;
}

// s + x1 x0ᵀ for the 3x3 s (row-major).
inline void add_outer(double* s, double x1, double y1, double z1, double x0, double y0, double z0) {
    s[0] = s[0] + x1 * x0, s[1] = s[1] + x1 * y0, s[2] = s[2] + x1 * z0;
    s[3] = s[3] + y1 * x0, s[4] = s[4] + y1 * y0, s[5] = s[5] + y1 * z0;
    s[6] = s[6] + z1 * x0, s[7] = s[7] + z1 * y0, s[8] = s[8] + z1 * z0;
}

// Horn's (1987) N in xyzw order: N = [[H + Hᵀ - tr(H) I, Δ], [Δᵀ, tr H]] with H = sᵀ = Σ model' measured'ᵀ and
// Δ = (H23 - H32, H31 - H13, H12 - H21), so that qᵀ N q = Σ measured' · R model'.  For pure quaternions Walker's
// Σ Q(a)ᵀ W(b) is the same matrix of s = Σ a bᵀ.
inline Sym4 horn_matrix(const double* s) {
    const double tr = s[0] + s[4] + s[8];
    return {s[0] + s[0] - tr, s[1] + s[3], s[2] + s[6], s[7] - s[5], s[4] + s[4] - tr,
            s[5] + s[7],      s[2] - s[6], s[8] + s[8] - tr, s[3] - s[1], tr};
}

// Walker's A (eq. (47)) from Horn's N and C3; also tr(C3ᵀ C3) / (4 bw) (the trace of the PSD C3 term, 0 without
// points).  Position quaternions ½[p; 0] with weights 4β make Walker's error (31) equal to the documented cost;
// direction quaternions [n; 0] keep weights α.  C1 = -2 N (eq. (35)), C2 = bw I with bw = Σ 4β (eq. (36)),
// C3 = 4 (W(g0) - Q(g1)) (eq. (37)) with the centred sums g0 = Σβ p⁰', g1 = Σβ p̃' (~0; kept so that the solve is
// Walker's, rounding residue and all), i.e. C3 = [[-[h]×, d], [-dᵀ, 0]] with h = 4 (g0 + g1), d = 4 (g0 - g1);
// then A = ½ (C3ᵀ (2 C2)⁻¹ C3 - C1 - C1ᵀ) = 2 N + C3ᵀ C3 / (4 bw).
inline Sym4 walker_matrix(const Sym4& n, const double* hd, double bw, double* c3_trace) {
    Sym4 a = {n.a00 + n.a00, n.a01 + n.a01, n.a02 + n.a02, n.a03 + n.a03, n.a11 + n.a11,
              n.a12 + n.a12, n.a13 + n.a13, n.a22 + n.a22, n.a23 + n.a23, n.a33 + n.a33};
    *c3_trace = 0.0;
    if (!(bw > 0.0)) return a;
    const double hx = hd[0], hy = hd[1], hz = hd[2], dx = hd[3], dy = hd[4], dz = hd[5];
    const double k4 = 1.0 / (4.0 * bw);
    const double t00 = hz * hz + hy * hy + dx * dx, t11 = hz * hz + hx * hx + dy * dy;
    const double t22 = hy * hy + hx * hx + dz * dz, t33 = dx * dx + dy * dy + dz * dz;
    a.a00 = a.a00 + k4 * t00, a.a01 = a.a01 + k4 * (dx * dy - hx * hy), a.a02 = a.a02 + k4 * (dx * dz - hx * hz);
    a.a03 = a.a03 + k4 * (hy * dz - hz * dy);
    a.a11 = a.a11 + k4 * t11, a.a12 = a.a12 + k4 * (dy * dz - hy * hz), a.a13 = a.a13 + k4 * (hz * dx - hx * dz);
    a.a22 = a.a22 + k4 * t22, a.a23 = a.a23 + k4 * (hx * dy - hy * dx);
    a.a33 = a.a33 + k4 * t33;
    *c3_trace = k4 * (t00 + t11 + t22 + t33);
    return a;
}

// Walker's centred translation (~0): s = -(C2 + C2ᵀ)⁻¹ C3 r (eq. (45)), t = 2 vec(W(r)ᵀ s) (eq. (19)).
inline void walker_translation(double x, double y, double z, double w, const double* hd, double bw, double* t) {
    const double hx = hd[0], hy = hd[1], hz = hd[2], dx = hd[3], dy = hd[4], dz = hd[5];
    const double k2 = -1.0 / (2.0 * bw);
    const double sx = k2 * (hz * y - hy * z + dx * w);
    const double sy = k2 * (-hz * x + hx * z + dy * w);
    const double sz = k2 * (hy * x - hx * y + dz * w);
    const double sw = k2 * (-dx * x - dy * y - dz * z);
    // W(r)ᵀ s = s (x) r*
    const double rx = -x, ry = -y, rz = -z, rw = w;
    t[0] = 2.0 * (sw * rx + rw * sx + sy * rz - sz * ry);
    t[1] = 2.0 * (sw * ry + rw * sy + sz * rx - sx * rz);
    t[2] = 2.0 * (sw * rz + rw * sz + sx * ry - sy * rx);
}

// Arun / Kabsch with Umeyama's reflection guard: H = U S Vᵀ (H = sᵀ), R = V diag(1, 1, d) Uᵀ,
// d = sign det(V Uᵀ).  Writes the quaternion of R (xyzw) and σ1 >= σ2 >= σ3; returns d.
double svd_rotation(const double* s, double* q, double* sig) {
    const double h[9] = {s[0], s[3], s[6], s[1], s[4], s[7], s[2], s[5], s[8]};
    double u[9], v[9];
    svd3(h, u, sig, v);
    double vut[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) vut[i * 3 + j] = v[i * 3 + 0] * u[j * 3 + 0] + v[i * 3 + 1] * u[j * 3 + 1] +
                                                     v[i * 3 + 2] * u[j * 3 + 2];
    const double d = det3(vut[0], vut[1], vut[2], vut[3], vut[4], vut[5], vut[6], vut[7], vut[8]) >= 0.0 ? 1.0 : -1.0;
    double r[9];
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            r[i * 3 + j] = v[i * 3 + 0] * u[j * 3 + 0] + v[i * 3 + 1] * u[j * 3 + 1] + d * v[i * 3 + 2] * u[j * 3 + 2];
    store(q, quat_of_rotmat(r));
    return d;
}

// Second moments of problem b's data, the centred points multiplied by f (a power of two) and the direction
// weights by f2 = f**2: s = Σ β (f p̃')(f p⁰')ᵀ + Σ f2 α ñ n⁰ᵀ, Σβ|f p⁰'|², Σβ|f p̃'|², the centred sums g0, g1
// and Σ f2 α.
struct Moments {
    double s[9], ss0, ss1, g0[3], g1[3], asum;
};
Moments moments(const Problems& pr, std::int64_t b, double ax, double ay, double az, double bx, double by, double bz,
                double f, double f2) {
    const std::int64_t npt = pr.npt, ndir = pr.ndir;
    const double* p0 = pr.p0 + b * npt * 3;
    const double* p1 = pr.p1 + b * npt * 3;
    const double* beta = pr.beta + b * npt;
    double s[9] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0};  // local: kept in registers (no aliasing with inputs)
    double ss0 = 0.0, ss1 = 0.0;  // Σβ |p0'|², Σβ |p1'|²
    double g0x = 0.0, g0y = 0.0, g0z = 0.0, g1x = 0.0, g1y = 0.0, g1z = 0.0;
    for (std::int64_t k = 0; k < npt; ++k) {
        const double bk = beta[k];
        const double x0 = (p0[3 * k] - ax) * f, y0 = (p0[3 * k + 1] - ay) * f, z0 = (p0[3 * k + 2] - az) * f;
        const double d1x = (p1[3 * k] - bx) * f, d1y = (p1[3 * k + 1] - by) * f, d1z = (p1[3 * k + 2] - bz) * f;
        ss0 += bk * (x0 * x0 + y0 * y0 + z0 * z0);
        ss1 += bk * (d1x * d1x + d1y * d1y + d1z * d1z);
        g0x += bk * x0;
        g0y += bk * y0;
        g0z += bk * z0;
        g1x += bk * d1x;
        g1y += bk * d1y;
        g1z += bk * d1z;
        add_outer(s, bk * d1x, bk * d1y, bk * d1z, x0, y0, z0);
    }
    const double* n0 = pr.n0 + b * ndir * 3;
    const double* n1 = pr.n1 + b * ndir * 3;
    const double* alpha = pr.alpha + b * ndir;
    double asum = 0.0;
    for (std::int64_t k = 0; k < ndir; ++k) {
        const double ak = alpha[k] * f2;
        asum += ak;
        add_outer(s, ak * n1[3 * k], ak * n1[3 * k + 1], ak * n1[3 * k + 2], n0[3 * k], n0[3 * k + 1], n0[3 * k + 2]);
    }
    Moments m;
    for (int i = 0; i < 9; ++i) m.s[i] = s[i];
    m.ss0 = ss0, m.ss1 = ss1, m.asum = asum;
    m.g0[0] = g0x, m.g0[1] = g0y, m.g0[2] = g0z, m.g1[0] = g1x, m.g1[1] = g1y, m.g1[2] = g1z;
    return m;
}

// Phase 1 for problem b: the row zeroed, the staged data, the polynomial (or the skip with the input code).
void stage(const Problems& pr, std::int64_t b, int method, Staged& st, Roots& rt, int j, double* out) {
    for (int i = 0; i < row::ROW_SIZE; ++i) out[i] = 0.0;
    const std::int64_t npt = pr.npt, ndir = pr.ndir;
    const double* p0 = pr.p0 + b * npt * 3;
    const double* p1 = pr.p1 + b * npt * 3;
    const double* beta = pr.beta + b * npt;
    // weighted centroids (the translation is recovered at the end: t = c1 - s R c0)
    double wsum = 0.0, ax = 0.0, ay = 0.0, az = 0.0, bx = 0.0, by = 0.0, bz = 0.0;
    for (std::int64_t k = 0; k < npt; ++k) {
        const double bk = beta[k];
        wsum += bk;
        ax += bk * p0[3 * k];
        ay += bk * p0[3 * k + 1];
        az += bk * p0[3 * k + 2];
        bx += bk * p1[3 * k];
        by += bk * p1[3 * k + 1];
        bz += bk * p1[3 * k + 2];
    }
    if (wsum > 0.0) ax = ax / wsum, ay = ay / wsum, az = az / wsum, bx = bx / wsum, by = by / wsum, bz = bz / wsum;
    // second moments of the centred data: s = Σ β p̃' p⁰'ᵀ + Σ α ñ n⁰ᵀ (a = measured, b = model), and the centred
    // sums g0 = Σβ p⁰', g1 = Σβ p̃' (Walker's C3)
    Moments mo = moments(pr, b, ax, ay, az, bx, by, bz, 1.0, 1.0);
    // Scale normalisation: when the squared spread leaves [1e-30, 1e30] (the characteristic polynomial of the 4x4
    // matrix holds its fourth powers, products of them lose digits below ~1e-50: points scaled by 1e-160
    // underflow to a zero cost and an identity rotation, by 1e80 overflow it), solve on the centred points times 2**e, e the power of two bringing the largest centred
    // coordinate near 1 (exact: no rounding), and the direction weights times 2**(2e) so the minimiser is
    // unchanged; ordinary spreads keep e = 0 and bit-identical results.
    int e = 0;
    const double spread2 = mo.ss0 + mo.ss1;
    if (std::isfinite(ax + ay + az + bx + by + bz) && !(spread2 >= 1e-30 && spread2 <= 1e30) && npt > 0) {
        double m = 0.0;
        for (std::int64_t k = 0; k < npt; ++k) {
            m = pymax(m, pymax(std::fabs(p0[3 * k] - ax), pymax(std::fabs(p0[3 * k + 1] - ay), std::fabs(p0[3 * k + 2] - az))));
            m = pymax(m, pymax(std::fabs(p1[3 * k] - bx), pymax(std::fabs(p1[3 * k + 1] - by), std::fabs(p1[3 * k + 2] - bz))));
        }
        if (m > 0.0 && std::isfinite(m)) {
            int em;
            std::frexp(m, &em);
            // the direction weights times 2**(2e) stay below 2**900 (finite), and 2**e a normal double
            const double* alpha = pr.alpha + b * pr.ndir;
            double amax = 0.0;
            for (std::int64_t k = 0; k < pr.ndir; ++k) amax = pymax(amax, alpha[k]);
            int ea = 0;
            if (amax > 0.0) std::frexp(amax, &ea);
            const int hi = amax > 0.0 ? (900 - ea) / 2 : 1000;
            e = -em < -1000 ? -1000 : -em;
            e = e > 1000 ? 1000 : (e > hi ? hi : e);
            if (e != 0) mo = moments(pr, b, ax, ay, az, bx, by, bz, std::ldexp(1.0, e), std::ldexp(1.0, 2 * e));
        }
    }
    out[row::POINT_EXPONENT] = e;
    double* s = mo.s;
    const double ss0 = mo.ss0, ss1 = mo.ss1, asum = mo.asum;
    const double g0x = mo.g0[0], g0y = mo.g0[1], g0z = mo.g0[2], g1x = mo.g1[0], g1y = mo.g1[1], g1z = mo.g1[2];
    // a NaN or infinity anywhere in the inputs makes these sums non-finite (0·inf and inf - inf are NaN): only then
    // look for the culprit; finite inputs whose moments overflow get their own code
    const double chk = ax + ay + az + bx + by + bz + ss0 + ss1 + s[0] + s[1] + s[2] + s[3] + s[4] + s[5] + s[6] +
                       s[7] + s[8];
    if (!std::isfinite(chk)) {
        out[row::BAD_INPUT] = first_bad_input(pr, b);
        st.skip = true;
        rt.c3[j] = rt.c2[j] = rt.c1[j] = rt.c0[j] = rt.l1[j] = rt.l2[j] = rt.scale[j] = 0.0;
        return;
    }
    // E = const - 2 Σ(measured · R model): the largest possible |λ| of Horn's N is const / 2
    const double cst = ss0 + ss1 + 2.0 * asum;
    Sym4 a = horn_matrix(s);
    double hd[6];
    hd[0] = 4.0 * (g0x + g1x), hd[1] = 4.0 * (g0y + g1y), hd[2] = 4.0 * (g0z + g1z);
    hd[3] = 4.0 * (g0x - g1x), hd[4] = 4.0 * (g0y - g1y), hd[5] = 4.0 * (g0z - g1z);
    const double bw = 4.0 * wsum;
    double tol, bound;
    if (method == DQ) {
        double c3_trace;
        a = walker_matrix(a, hd, bw, &c3_trace);
        tol = GAP_RTOL * 2.0 * pymax(cst, 1e-300);
        // λ1(A) <= const (the cost is >= 0) + the largest eigenvalue of the PSD C3 term (<= its trace)
        bound = cst * (1.0 + 1e-12) + c3_trace;
    } else {
        tol = GAP_RTOL * pymax(cst, 1e-300);
        bound = 0.5 * cst * (1.0 + 1e-12);
    }
    const CharPoly cp = char_poly(a, bound);
    rt.c3[j] = cp.c3, rt.c2[j] = cp.c2, rt.c1[j] = cp.c1, rt.c0[j] = cp.c0;
    rt.l1[j] = cp.start, rt.scale[j] = cp.scale;  // largest_roots sets l2
    st.a = a;
    for (int i = 0; i < 9; ++i) st.s[i] = s[i];
    for (int i = 0; i < 6; ++i) st.h[i] = hd[i];
    st.ax = ax, st.ay = ay, st.az = az, st.bx = bx, st.by = by, st.bz = bz;
    st.ss0 = ss0, st.bw = bw, st.tol = tol;
    st.e = e;
    st.skip = false;
}

// Phase 3 for problem b: eigenvector, translation, scale, cost.
void finish(const Problems& pr, std::int64_t b, int method, bool want_scale, const Staged& st, const Roots& rt,
            int j, double* out) {
    const double tol = st.tol;
    double l1 = rt.l1[j], l2 = rt.l2[j];
    const TopVector tv = closed_form_vector(st.a, rt.c3[j], rt.c2[j], l1, l2, rt.scale[j]);
    double x, y, z, w, l3, l4;
    int unique;
    if (tv.ok) {
        x = tv.x, y = tv.y, z = tv.z, w = tv.w, l3 = tv.l3, l4 = tv.l4;
        unique = l1 - l2 > tol ? 1 : 0;
    } else {
        double q[4], ev[4];
        unique = jacobi_top(st.a, tol, q, ev);
        x = q[0], y = q[1], z = q[2], w = q[3], l1 = ev[0], l2 = ev[1], l3 = ev[2], l4 = ev[3];
    }
    double gap = l1 - l2;
    double tdq[3] = {0.0, 0.0, 0.0};
    const double bw = st.bw;
    if (method == DQ && bw > 0.0) walker_translation(x, y, z, w, st.h, bw, tdq);
    double sig[3] = {0.0, 0.0, 0.0};
    if (method == SVD) {
        double q[4];
        const double d = svd_rotation(st.s, q, sig);
        out[row::REFLECTION] = d;
        gap = 2.0 * (sig[1] + d * sig[2]);
        unique = gap > tol ? 1 : 0;
        if (unique == 1) x = q[0], y = q[1], z = q[2], w = q[3];
    }
    // back to the input's units (moments scale by 2**(2e), Walker's centred translation by 2**e; exact)
    const int e = st.e, e2 = -2 * st.e;
    if (e != 0) {
        for (int i = 0; i < 3; ++i) tdq[i] = std::ldexp(tdq[i], -e), sig[i] = std::ldexp(sig[i], e2);
        gap = std::ldexp(gap, e2), l1 = std::ldexp(l1, e2), l2 = std::ldexp(l2, e2);
        l3 = std::ldexp(l3, e2), l4 = std::ldexp(l4, e2);
    }
    if (method == SVD)
        out[row::SINGULAR_AT] = sig[0], out[row::SINGULAR_AT + 1] = sig[1], out[row::SINGULAR_AT + 2] = sig[2];
    out[row::EIGEN_GAP] = gap;
    out[row::UNIQUE] = unique;
    out[row::EIGENVALUES_AT] = l1, out[row::EIGENVALUES_AT + 1] = l2;
    out[row::EIGENVALUES_AT + 2] = l3, out[row::EIGENVALUES_AT + 3] = l4;
    out[row::CLOSED_FORM] = tv.ok ? 1.0 : 0.0;
    out[row::GAP_TOLERANCE] = e != 0 ? std::ldexp(tol, e2) : tol;
    out[row::QUAT_AT] = x, out[row::QUAT_AT + 1] = y, out[row::QUAT_AT + 2] = z, out[row::QUAT_AT + 3] = w;
    // every path above returns a unit quaternion: R = I + 2w[v]x + 2[v]x² (Dantam 2014 eq. (108))
    double m[9];
    rotmat_xyzw(x, y, z, w, m);
    const double ax = st.ax, ay = st.ay, az = st.az, bx = st.bx, by = st.by, bz = st.bz;
    const double* s = st.s;
    // scale (Umeyama 1991 eq. (42)): measured ≈ s R model + t, s = Σβ p̃'·R p⁰' / Σβ |p⁰'|²
    double scale = 1.0;
    if (want_scale && st.ss0 > 0.0)
        scale = (s[0] * m[0] + s[1] * m[1] + s[2] * m[2] + s[3] * m[3] + s[4] * m[4] + s[5] * m[5] + s[6] * m[6] +
                 s[7] * m[7] + s[8] * m[8]) /
                st.ss0;
    out[row::SCALE] = scale;
    // translation: t = c1 - s R c0 (+ Walker's centred t, ~0)
    out[row::TRANSLATION_AT] = bx - scale * (m[0] * ax + m[1] * ay + m[2] * az) + tdq[0];
    out[row::TRANSLATION_AT + 1] = by - scale * (m[3] * ax + m[4] * ay + m[5] * az) + tdq[1];
    out[row::TRANSLATION_AT + 2] = bz - scale * (m[6] * ax + m[7] * ay + m[8] * az) + tdq[2];
    // cost from residuals of the centred data (no cancellation at large offsets)
    const std::int64_t npt = pr.npt, ndir = pr.ndir;
    const double* p0 = pr.p0 + b * npt * 3;
    const double* p1 = pr.p1 + b * npt * 3;
    const double* beta = pr.beta + b * npt;
    double cost = 0.0;
    for (std::int64_t k = 0; k < npt; ++k) {
        const double x0 = p0[3 * k] - ax, y0 = p0[3 * k + 1] - ay, z0 = p0[3 * k + 2] - az;
        const double rx = scale * (m[0] * x0 + m[1] * y0 + m[2] * z0) + tdq[0] - (p1[3 * k] - bx);
        const double ry = scale * (m[3] * x0 + m[4] * y0 + m[5] * z0) + tdq[1] - (p1[3 * k + 1] - by);
        const double rz = scale * (m[6] * x0 + m[7] * y0 + m[8] * z0) + tdq[2] - (p1[3 * k + 2] - bz);
        cost += beta[k] * (rx * rx + ry * ry + rz * rz);
    }
    out[row::POINT_COST] = cost;
    const double* n0 = pr.n0 + b * ndir * 3;
    const double* n1 = pr.n1 + b * ndir * 3;
    const double* alpha = pr.alpha + b * ndir;
    for (std::int64_t k = 0; k < ndir; ++k) {
        const double x0 = n0[3 * k], y0 = n0[3 * k + 1], z0 = n0[3 * k + 2];
        const double rx = m[0] * x0 + m[1] * y0 + m[2] * z0 - n1[3 * k];
        const double ry = m[3] * x0 + m[4] * y0 + m[5] * z0 - n1[3 * k + 1];
        const double rz = m[6] * x0 + m[7] * y0 + m[8] * z0 - n1[3 * k + 2];
        cost += alpha[k] * (rx * rx + ry * ry + rz * rz);
    }
    out[row::COST] = cost;
}

}  // namespace

// The three phases over blocks of BLOCK problems (this translation unit's instruction set); returns the index of
// the first problem with a non-zero BAD_INPUT code, or -1.
static std::int64_t solve_blocks(const Problems& pr, int method, bool want_scale, double* out) {
    Staged blk[BLOCK];
    Roots rt;
    std::int64_t first_bad = -1;
    for (std::int64_t start = 0; start < pr.nprob; start += BLOCK) {
        const int nblk = static_cast<int>(pr.nprob - start < BLOCK ? pr.nprob - start : BLOCK);
        for (int j = 0; j < nblk; ++j)  // phase 1
            stage(pr, start + j, method, blk[j], rt, j, out + (start + j) * row::ROW_SIZE);
        largest_roots(rt.c3, rt.c2, rt.c1, rt.c0, rt.scale, rt.l1, rt.l2, nblk);  // phase 2
        for (int j = 0; j < nblk; ++j) {  // phase 3
            if (!blk[j].skip)
                finish(pr, start + j, method, want_scale, blk[j], rt, j, out + (start + j) * row::ROW_SIZE);
            else if (first_bad < 0)
                first_bad = start + j;
        }
    }
    return first_bad;
}

std::int64_t solve_raw(const double* const* in, const std::int64_t* dims, int method, bool want_scale,
                       double* out) {
    return solve_blocks(Problems{in[0], in[1], in[2], in[3], in[4], in[5], dims[0], dims[1], dims[2]}, method, want_scale,
                 out);
}

#ifndef DUALPOSE_ISA_VARIANT
std::int64_t solve_batch(const Problems& pr, int method, bool want_scale, double* out) {
#if DUALPOSE_HAVE_X86_64_V4
    static const bool v4 = (__builtin_cpu_init(), __builtin_cpu_supports("x86-64-v4"));
    if (v4) {
        const double* in[6] = {pr.p0, pr.p1, pr.beta, pr.n0, pr.n1, pr.alpha};
        const std::int64_t dims[3] = {pr.nprob, pr.npt, pr.ndir};
        return dualpose_x86_64_v4::reg::solve_raw(in, dims, method, want_scale, out);
    }
#endif
    return solve_blocks(pr, method, want_scale, out);
}
#endif

}  // namespace dualpose::reg
