// The symmetric 4x4 eigen-solvers of the registration kernels (see eigen4.hpp).
#include "eigen4.hpp"

#include "../common/dispatch.hpp"

#include <cmath>

namespace dualpose::reg {

void jacobi_eigh4(double* a, double* v) {
    constexpr int n = 4;
    auto A = [a](int i, int j) -> double& { return a[i * n + j]; };
    auto V = [v](int i, int j) -> double& { return v[i * n + j]; };
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) V(i, j) = i == j ? 1.0 : 0.0;
    double total = 0.0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) total += A(i, j) * A(i, j);
    if (total == 0.0) return;
    for (int sweep = 0; sweep < 40; ++sweep) {
        double off = 0.0;
        for (int p = 0; p < n - 1; ++p)
            for (int q = p + 1; q < n; ++q) off += A(p, q) * A(p, q);
        if (off <= 1e-36 * total) return;
        for (int p = 0; p < n - 1; ++p) {
            for (int q = p + 1; q < n; ++q) {
                const double apq = A(p, q);
                if (apq == 0.0) continue;
                const double theta = (A(q, q) - A(p, p)) / (2.0 * apq);
                double t;
                if (std::fabs(theta) > 1e150) {
                    t = 0.5 / theta;
                } else {
                    t = 1.0 / (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
                    if (theta < 0.0) t = -t;
                }
                const double c = 1.0 / std::sqrt(t * t + 1.0);
                const double s = t * c;
                for (int k = 0; k < n; ++k) {  // columns p, q
                    const double akp = A(k, p), akq = A(k, q);
                    A(k, p) = c * akp - s * akq;
                    A(k, q) = s * akp + c * akq;
                }
                for (int k = 0; k < n; ++k) {  // rows p, q
                    const double apk = A(p, k), aqk = A(q, k);
                    A(p, k) = c * apk - s * aqk;
                    A(q, k) = s * apk + c * aqk;
                }
                A(p, q) = 0.0;
                A(q, p) = 0.0;
                for (int k = 0; k < n; ++k) {
                    const double vkp = V(k, p), vkq = V(k, q);
                    V(k, p) = c * vkp - s * vkq;
                    V(k, q) = s * vkp + c * vkq;
                }
            }
        }
    }
}

int jacobi_top(const Sym4& m, double tol, double* q, double* eigenvalues) {
    double a[16] = {m.a00, m.a01, m.a02, m.a03, m.a01, m.a11, m.a12, m.a13,
                    m.a02, m.a12, m.a22, m.a23, m.a03, m.a13, m.a23, m.a33};
    double v[16];
    jacobi_eigh4(a, v);
    auto diag = [&a](int i) { return a[i * 4 + i]; };
    // indices of the diagonal sorted by decreasing value (insertion sort)
    int order[4] = {0, 1, 2, 3};
    for (int i = 1; i < 4; ++i)
        for (int j = i; j > 0 && diag(order[j]) > diag(order[j - 1]); --j) {
            const int o = order[j];
            order[j] = order[j - 1];
            order[j - 1] = o;
        }
    const double top = diag(order[0]);
    const int unique = top - diag(order[1]) > tol ? 1 : 0;
    for (int i = 0; i < 4; ++i) q[i] = v[i * 4 + order[0]];
    if (unique == 0) {
        double px = 0.0, py = 0.0, pz = 0.0, pw = 0.0;
        for (int k = 0; k < 4; ++k) {
            const int col = order[k];
            if (top - diag(col) <= tol) {
                const double w = v[3 * 4 + col];
                px += w * v[0 * 4 + col];
                py += w * v[1 * 4 + col];
                pz += w * v[2 * 4 + col];
                pw += w * v[3 * 4 + col];
            }
        }
        const double nrm = std::sqrt(px * px + py * py + pz * pz + pw * pw);
        if (nrm > 1e-6) q[0] = px / nrm, q[1] = py / nrm, q[2] = pz / nrm, q[3] = pw / nrm;
    }
    double nrm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (flip_sign({q[0], q[1], q[2], q[3]})) nrm = -nrm;
    for (int i = 0; i < 4; ++i) q[i] /= nrm;
    for (int i = 0; i < 4; ++i) eigenvalues[i] = diag(order[i]);
    return unique;
}

// Newton sweeps across the block (one step per problem per sweep): the loops vectorise, so wider instruction sets
// are chosen at run time (in the baseline build; solve_x86_64_v4.cpp compiles its own copy for x86-64-v4).
#ifndef DUALPOSE_ISA_VARIANT
DUALPOSE_CLONES_V4
#endif
void largest_roots(
    const double* c3, const double* c2, const double* c1, const double* c0, const double* scale, double* l1,
    double* l2, int m) {
    for (int it = 0; it < 100; ++it) {
        int moving = 0;
        for (int j = 0; j < m; ++j) {
            const double lam = l1[j];
            const double f = (((lam + c3[j]) * lam + c2[j]) * lam + c1[j]) * lam + c0[j];
            const double df = ((4.0 * lam + 3.0 * c3[j]) * lam + 2.0 * c2[j]) * lam + c1[j];
            const double step = (f > 0.0) & (df > 0.0) ? f / df : 0.0;
            l1[j] = lam - step;
            moving += step > 1e-15 * scale[j] ? 1 : 0;
        }
        if (moving == 0) break;
    }
    // λ2: the largest root of the deflated cubic λ³ + b2 λ² + b1 λ + b0 = poly / (λ - λ1), from the
    // Laguerre-Samuelson bound (mean + √2 x standard deviation of the cubic's roots) when the cubic and its first
    // two derivatives are positive there (which places it above every root), else from λ1
    for (int j = 0; j < m; ++j) {
        const double r = l1[j];
        const double b2 = c3[j] + r;
        const double b1 = c2[j] + r * b2;
        const double b0 = c1[j] + r * b1;
        const double mu = -b2 / 3.0;
        const double u = mu + std::sqrt(pymax(2.0 * ((b2 * b2 - 2.0 * b1) / 3.0 - mu * mu), 0.0));
        const double f = ((u + b2) * u + b1) * u + b0;
        const double df = (3.0 * u + 2.0 * b2) * u + b1;
        l2[j] = (u < r) & (f > 0.0) & (df > 0.0) & (3.0 * u + b2 > 0.0) ? u : r;
    }
    for (int it = 0; it < 100; ++it) {
        int moving = 0;
        for (int j = 0; j < m; ++j) {
            const double r = l1[j];
            const double b2 = c3[j] + r;
            const double b1 = c2[j] + r * b2;
            const double b0 = c1[j] + r * b1;
            const double lam = l2[j];
            const double f = ((lam + b2) * lam + b1) * lam + b0;
            const double df = (3.0 * lam + 2.0 * b2) * lam + b1;
            const double step = (f > 0.0) & (df > 0.0) ? f / df : 0.0;
            l2[j] = lam - step;
            moving += step > 1e-15 * scale[j] ? 1 : 0;
        }
        if (moving == 0) break;
    }
}

}  // namespace dualpose::reg
