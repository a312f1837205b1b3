// Contiguous row loops of the hot algebra kernels (see rows.hpp): compiled for the x86-64 baseline and, with GCC on
// x86-64, cloned for AVX2 with the clone picked at load time (GCC's function multiversioning, target_clones).  No
// FMA in any clone, so every clone rounds as the baseline.  There is no AVX-512 clone: GCC 12's SLP vectoriser fuses
// the alternating +/- lanes of the Hamilton product into vfmsubadd (an FMA) on zmm registers even under
// -ffp-contract=off, which changes the last bit; AVX2 without the FMA extension has no fused instruction to pick.
#include "rows.hpp"

#include <algorithm>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DUALPOSE_CLONES __attribute__((target_clones("default", "avx2")))
#else
#define DUALPOSE_CLONES
#endif

namespace dualpose {

namespace {
constexpr npy_intp kBlock = 128;

// s2[i] = 2/|q_i|**2 for the rows of one block; true when every squared norm was in [1e-280, 1e280].
inline bool ordinary_scales(const double* q, npy_intp stride, npy_intp m, double* s2) {
    bool ok = true;
    for (npy_intp i = 0; i < m; ++i) {
        const double* r = q + stride * i;
        const double n2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3];
        const bool ordinary = (n2 >= kTiny) & (n2 <= kHuge);
        ok &= ordinary;
        s2[i] = 2.0 / (ordinary ? n2 : 1.0);  // no division by zero (a floating-point flag NumPy would report)
    }
    return ok;
}
}  // namespace

DUALPOSE_CLONES void quat_mul_rows(const double* p, const double* q, double* o, npy_intp n) {
    for (npy_intp i = 0; i < n; ++i) quat_mul_row(p + 4 * i, q + 4 * i, o + 4 * i);
}

DUALPOSE_CLONES int quat_rotate_rows(const double* q, const double* v, double* o, npy_intp n) {
    int flagged = 0;
    double s2[kBlock];
    for (npy_intp i0 = 0; i0 < n; i0 += kBlock) {
        const npy_intp m = std::min(kBlock, n - i0);
        const double* qb = q + 4 * i0;
        const double* vb = v + 3 * i0;
        double* ob = o + 3 * i0;
        if (ordinary_scales(qb, 4, m, s2)) {
            for (npy_intp i = 0; i < m; ++i) store(ob + 3 * i, rotate(load4(qb + 4 * i), load3(vb + 3 * i), s2[i]));
        } else {
            flagged = 1;
            for (npy_intp i = 0; i < m; ++i) quat_rotate_row(qb + 4 * i, vb + 3 * i, ob + 3 * i);
        }
    }
    return flagged;
}

DUALPOSE_CLONES int dualquat_mul_rows(const double* a, const double* b, double* o, npy_intp n) {
    for (npy_intp i = 0; i < n; ++i) dualquat_mul_row(a + 8 * i, b + 8 * i, o + 8 * i);
    return 0;
}

DUALPOSE_CLONES int dualquat_transform_rows(const double* s, const double* p, double* o, npy_intp n) {
    int flagged = 0;
    double s2[kBlock];
    for (npy_intp i0 = 0; i0 < n; i0 += kBlock) {
        const npy_intp m = std::min(kBlock, n - i0);
        const double* sb = s + 8 * i0;
        const double* pb = p + 3 * i0;
        double* ob = o + 3 * i0;
        if (ordinary_scales(sb, 8, m, s2)) {
            for (npy_intp i = 0; i < m; ++i)
                store(ob + 3 * i, transform_point(load8(sb + 8 * i), load3(pb + 3 * i), s2[i]));
        } else {
            flagged = 1;
            for (npy_intp i = 0; i < m; ++i) dualquat_transform_row(sb + 8 * i, pb + 3 * i, ob + 3 * i);
        }
    }
    return flagged;
}

}  // namespace dualpose
