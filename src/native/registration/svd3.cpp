// One-sided Jacobi SVD of a 3x3 matrix (see svd3.hpp).
#include "svd3.hpp"

#include <cmath>

namespace dualpose::reg {

namespace {

// Unit vector orthogonal to the unit vector a (the coordinate axis least aligned with a, orthogonalised).
void orthogonal_unit(const double* a, double* o) {
    int k = 0;
    for (int i = 1; i < 3; ++i)
        if (std::fabs(a[i]) < std::fabs(a[k])) k = i;
    double e[3] = {0.0, 0.0, 0.0};
    e[k] = 1.0;
    const double d = a[k];
    double n2 = 0.0;
    for (int i = 0; i < 3; ++i) {
        o[i] = e[i] - d * a[i];
        n2 += o[i] * o[i];
    }
    const double n = std::sqrt(n2);
    for (int i = 0; i < 3; ++i) o[i] /= n;
}

}  // namespace

void svd3(const double* h, double* u, double* sig, double* v) {
    double m = 0.0;
    for (int i = 0; i < 9; ++i) m = std::fmax(m, std::fabs(h[i]));
    const double inv = m > 0.0 ? 1.0 / m : 0.0;
    // columns of the working matrix a = H V / m, and of V (stored column-major while working)
    double a[3][3], vc[3][3];
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) {
            a[c][r] = h[r * 3 + c] * inv;
            vc[c][r] = r == c ? 1.0 : 0.0;
        }
    constexpr int pairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
    for (int sweep = 0; sweep < 60; ++sweep) {
        bool rotated = false;
        for (const auto& pq : pairs) {
            const int p = pq[0], q = pq[1];
            double alpha = 0.0, beta = 0.0, gamma = 0.0;
            for (int r = 0; r < 3; ++r) {
                alpha += a[p][r] * a[p][r];
                beta += a[q][r] * a[q][r];
                gamma += a[p][r] * a[q][r];
            }
            if (gamma == 0.0 || std::fabs(gamma) <= 4.4e-16 * std::sqrt(alpha * beta)) continue;
            rotated = true;
            const double zeta = (beta - alpha) / (2.0 * gamma);
            const double t = (zeta >= 0.0 ? 1.0 : -1.0) / (std::fabs(zeta) + std::sqrt(1.0 + zeta * zeta));
            const double c = 1.0 / std::sqrt(1.0 + t * t);
            const double s = c * t;
            for (int r = 0; r < 3; ++r) {
                const double ap = a[p][r], aq = a[q][r];
                a[p][r] = c * ap - s * aq;
                a[q][r] = s * ap + c * aq;
                const double vp = vc[p][r], vq = vc[q][r];
                vc[p][r] = c * vp - s * vq;
                vc[q][r] = s * vp + c * vq;
            }
        }
        if (!rotated) break;
    }
    double s[3];
    for (int c = 0; c < 3; ++c) s[c] = std::sqrt(a[c][0] * a[c][0] + a[c][1] * a[c][1] + a[c][2] * a[c][2]);
    int order[3] = {0, 1, 2};
    for (int i = 1; i < 3; ++i)
        for (int j = i; j > 0 && s[order[j]] > s[order[j - 1]]; --j) {
            const int o = order[j];
            order[j] = order[j - 1];
            order[j - 1] = o;
        }
    // U from the columns of H V: u1 = a1/s1, u2 = a2 orthogonalised against u1 and normalised, u3 = ±u1 × u2 with
    // the sign of a3 (so U is orthonormal to rounding).  A singular value below 1e-150 of the scaled matrix (its
    // squares underflow, the column is rounding noise) leaves its column to complete the orthonormal basis.
    constexpr double tiny = 1e-150;
    double uc[3][3], ac[3][3];
    for (int k = 0; k < 3; ++k) {
        const int c = order[k];
        sig[k] = s[c] * m;
        for (int r = 0; r < 3; ++r) {
            v[r * 3 + k] = vc[c][r];
            ac[k][r] = a[c][r];
        }
    }
    const double s1 = s[order[0]], s2 = s[order[1]];
    if (s1 > tiny) {
        for (int r = 0; r < 3; ++r) uc[0][r] = ac[0][r] / s1;
    } else {
        uc[0][0] = 1.0, uc[0][1] = 0.0, uc[0][2] = 0.0;
    }
    bool have2 = false;
    if (s2 > tiny) {
        const double p = uc[0][0] * ac[1][0] + uc[0][1] * ac[1][1] + uc[0][2] * ac[1][2];
        for (int r = 0; r < 3; ++r) uc[1][r] = ac[1][r] - p * uc[0][r];
        const double n = std::sqrt(uc[1][0] * uc[1][0] + uc[1][1] * uc[1][1] + uc[1][2] * uc[1][2]);
        if (n > tiny) {
            for (int r = 0; r < 3; ++r) uc[1][r] /= n;
            have2 = true;
        }
    }
    if (!have2) orthogonal_unit(uc[0], uc[1]);
    uc[2][0] = uc[0][1] * uc[1][2] - uc[0][2] * uc[1][1];
    uc[2][1] = uc[0][2] * uc[1][0] - uc[0][0] * uc[1][2];
    uc[2][2] = uc[0][0] * uc[1][1] - uc[0][1] * uc[1][0];
    if (uc[2][0] * ac[2][0] + uc[2][1] * ac[2][1] + uc[2][2] * ac[2][2] < 0.0)
        for (int r = 0; r < 3; ++r) uc[2][r] = -uc[2][r];
    for (int k = 0; k < 3; ++k)
        for (int r = 0; r < 3; ++r) u[r * 3 + k] = uc[k][r];
}

}  // namespace dualpose::reg
