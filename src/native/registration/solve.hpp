// The pose-from-correspondences solver (Walker 1991 §3.2 on centred data, Horn 1987, Arun 1987 / Umeyama 1991) for
// B independent problems; the result rows have the layout of row.hpp.
#pragma once

#include "isa.hpp"

#include <cstdint>

namespace dualpose::reg {

enum Method : int { DQ = 0, HORN = 1, SVD = 2 };

// Problem b: model p0[b] -> measured p1[b] (npt x 3) with point weights beta[b] (npt), model n0[b] -> measured
// n1[b] (ndir x 3) with direction weights alpha[b] (ndir); all C-contiguous.
struct Problems {
    const double *p0, *p1, *beta, *n0, *n1, *alpha;
    std::int64_t nprob, npt, ndir;
};

// out: nprob rows of row::ROW_SIZE doubles; returns the index of the first problem whose row holds a BAD_INPUT code
// (a non-finite input or overflowing moments), or -1.  Runs the x86-64-v4 build of the solver where the CPU has it (see
// solve_x86_64_v4.cpp), else the baseline build; both round identically (no FMA contraction).
std::int64_t solve_batch(const Problems& pr, int method, bool want_scale, double* out);

// The solver of one instruction-set build on plain arguments (the builds' Problems types are distinct):
// in = (p0, p1, beta, n0, n1, alpha), dims = (nprob, npt, ndir).
std::int64_t solve_raw(const double* const* in, const std::int64_t* dims, int method, bool want_scale, double* out);

}  // namespace dualpose::reg

#if DUALPOSE_HAVE_X86_64_V4
namespace dualpose_x86_64_v4::reg {
std::int64_t solve_raw(const double* const* in, const std::int64_t* dims, int method, bool want_scale, double* out);
}  // namespace dualpose_x86_64_v4::reg
#endif
