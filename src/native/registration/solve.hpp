// The pose-from-correspondences solver (Walker 1991 §3.2 on centred data, Horn 1987, Arun 1987 / Umeyama 1991) for
// B independent problems; the result rows have the layout of row.hpp.
#pragma once

#include <cstdint>

namespace dualpose::reg {

enum Method : int { DQ = 0, HORN = 1, SVD = 2 };

// Problem b: model p0[b] -> measured p1[b] (npt x 3) with point weights beta[b] (npt), model n0[b] -> measured
// n1[b] (ndir x 3) with direction weights alpha[b] (ndir); all C-contiguous.
struct Problems {
    const double *p0, *p1, *beta, *n0, *n1, *alpha;
    std::int64_t nprob, npt, ndir;
};

// out: nprob rows of row::ROW_SIZE doubles.
void solve_batch(const Problems& pr, int method, bool want_scale, double* out);

}  // namespace dualpose::reg
