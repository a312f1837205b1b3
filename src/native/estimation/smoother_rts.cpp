// The backward passes of the RTS smoother (see smoother_kernels.hpp).
#include "smoother_kernels.hpp"

#include <algorithm>

namespace dualpose::smoother {

Status rts_linear(const Stacks& s) {
    const std::int64_t K = s.K;
    const int n = s.n;
    const std::int64_t nn = std::int64_t(n) * n;
    std::copy(s.x_post + (K - 1) * n, s.x_post + K * n, s.x_smooth + (K - 1) * n);
    std::copy(s.P_post + (K - 1) * nn, s.P_post + K * nn, s.P_smooth + (K - 1) * nn);
    std::vector<double> mu(n), d(n);
    StepWork w(n);
    for (std::int64_t i = K - 2; i >= 0; --i) {
        for (int j = 0; j < n; ++j) mu[j] = s.x_smooth[(i + 1) * n + j] - s.x_prior[(i + 1) * n + j];
        const double *Pb = s.P_post + i * nn, *Pa = s.P_prior + (i + 1) * nn, *F = s.F + i * nn;
        const double* S = s.P_smooth + (i + 1) * nn;
        const Status st = n == NE ? rts_step<NE>(Pb, Pa, F, mu.data(), S, d.data(), s.P_smooth + i * nn, w)
                                  : rts_step(Pb, Pa, F, mu.data(), S, d.data(), s.P_smooth + i * nn, w);
        if (st != Status::ok) return st;
        for (int j = 0; j < n; ++j) s.x_smooth[i * n + j] = s.x_post[i * n + j] + d[j];
    }
    return Status::ok;
}

Status rts_error_state(const Stacks& s) {
    const std::int64_t K = s.K;
    constexpr std::int64_t nn = NE * NE;
    std::copy(s.x_post + (K - 1) * NX, s.x_post + K * NX, s.x_smooth + (K - 1) * NX);
    std::copy(s.P_post + (K - 1) * nn, s.P_post + K * nn, s.P_smooth + (K - 1) * nn);
    double mu[NE], d[NE], S[NE * NE], A[9];
    StepWork w(NE);
    for (std::int64_t i = K - 2; i >= 0; --i) {
        boxminus(s.x_smooth + (i + 1) * NX, s.x_prior + (i + 1) * NX, mu);
        std::copy(s.P_smooth + (i + 1) * nn, s.P_smooth + (i + 2) * nn, S);
        right_jacobian(mu + DTH, 1.0, A);
        congruence_attitude(S, A);
        double* Ps = s.P_smooth + i * nn;
        const Status st = rts_step<NE>(s.P_post + i * nn, s.P_prior + (i + 1) * nn, s.F + i * nn, mu, S, d, Ps, w);
        if (st != Status::ok) return st;
        boxplus(s.x_post + i * NX, d, s.x_smooth + i * NX);
        right_jacobian(d + DTH, 0.0, A);
        congruence_attitude(Ps, A);
    }
    return Status::ok;
}

}  // namespace dualpose::smoother
