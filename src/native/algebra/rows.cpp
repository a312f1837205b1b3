// Contiguous row loops of the hot algebra kernels (see rows.hpp).  Each loop is one template on F (fused
// multiply-add or not), instantiated twice: unfused, compiled for the x86-64 baseline and cloned for AVX2 with the
// clone picked at load time (GCC's function multiversioning, target_clones; no FMA in any clone, so every clone rounds
// as the baseline), and fused, compiled for AVX2 with FMA (DUALPOSE_TARGET_FUSED).  The row loops run the fused
// instantiation on a CPU with FMA and AVX2 (kFused) and the unfused one on any other.
//
// On a CPU with AVX-512F the loops take blocks of eight rows in 512-bit registers first (the *_rows8 templates, fused
// or not as the rest, compiled for AVX-512F only and chosen at run time): explicit vector code with no scalar
// floating-point arithmetic, so the vectoriser has nothing to contract and -ffp-contract=off keeps every multiply and
// add that is not an explicit fused one separate; the last n mod 8 rows, and any block of eight with a row outside
// the ordinary range, go to the four-row loops.  (The conjugates need no such code: the compiler vectorises their loops
// itself.)
#include "rows.hpp"

#include "../common/dispatch.hpp"
#include "lanes.hpp"

#if DUALPOSE_HAVE_AVX512
#include <immintrin.h>
#endif

#define DUALPOSE_CLONES DUALPOSE_CLONES_AVX2

namespace dualpose {

const bool kFused = cpu_has_fused();

// The four-row loops, unfused (baseline and AVX2 clones) and fused (compiled for FMA), defined below.
#define DUALPOSE_ROWS4_DECL(name, ...) \
    int name##_rows4(__VA_ARGS__);      \
    int name##_rows4_fused(__VA_ARGS__);
DUALPOSE_ROWS4_DECL(quat_rotate, const double* q, const double* v, double* o, npy_intp n)
DUALPOSE_ROWS4_DECL(dualquat_transform, const double* s, const double* p, double* o, npy_intp n)
DUALPOSE_ROWS4_DECL(quat_inv, const double* q, double* o, npy_intp n)
DUALPOSE_ROWS4_DECL(dualquat_inv, const double* s, double* o, npy_intp n)
#undef DUALPOSE_ROWS4_DECL

namespace {
using lanes::v4;
using lanes::v8;

// The row kernels' magnitude test (common/kutil.hpp ordinary_sum) on one row and on four rows in lanes: the sum
// of the absolute components over 8, so no extreme value is squared before the test.  As the scalar test, it raises
// no floating-point flag for a NaN (a NaN lane is compared as 0: an ordered comparison with a NaN would raise the
// invalid flag, and NumPy would warn).
bool ordinary(const double* r) { return ordinary_sum(abs_sum(r[0], r[1], r[2], r[3])); }
DUALPOSE_ROW v4 vabs(v4 x) { return (v4)((lanes::m4)x & 0x7fffffffffffffffLL); }
DUALPOSE_ROW bool ordinary(const lanes::Q4& a) {
    v4 s = vabs(a.x) * 0.125 + vabs(a.y) * 0.125 + vabs(a.z) * 0.125 + vabs(a.w) * 0.125;
    s = (v4)((lanes::m4)s & (s == s));
    return lanes::all((s >= kOrdinaryLo) & (s <= kOrdinaryHi));
}

#if DUALPOSE_HAVE_AVX512
DUALPOSE_TARGET_AVX512 DUALPOSE_ROW v8 vabs(v8 x) { return (v8)((lanes::m8)x & 0x7fffffffffffffffLL); }
// ordinary(Q4) on eight rows: quiet comparisons (false for NaN, no flag) into mask registers, tested as a whole
// (the vector extension's all-lanes test would move each lane to a general register).
DUALPOSE_TARGET_AVX512 DUALPOSE_ROW bool ordinary8(v8 x, v8 y, v8 z, v8 w) {
    const __m512d s = (__m512d)(vabs(x) * 0.125 + vabs(y) * 0.125 + vabs(z) * 0.125 + vabs(w) * 0.125);
    const __mmask8 lo = _mm512_cmp_pd_mask(s, _mm512_set1_pd(kOrdinaryLo), _CMP_GE_OQ);
    return _mm512_mask_cmp_pd_mask(lo, s, _mm512_set1_pd(kOrdinaryHi), _CMP_LE_OQ) == 0xff;
}
#endif

// Blocks of four rows in lanes (loaded before stored, so o may be p or q), then the last n mod 4 rows.
template <bool F>
DUALPOSE_ROW int quat_mul_rows4_t(const double* p, const double* q, double* o, npy_intp n) {
    npy_intp i = 0;
    for (; i + 4 <= n; i += 4)
        lanes::join4(qmul_f<F>(lanes::split4(p + 4 * i, 4), lanes::split4(q + 4 * i, 4)), o + 4 * i, 4);
    for (; i < n; ++i) quat_mul_row_f<F>(p + 4 * i, q + 4 * i, o + 4 * i);
    return 0;
}

template <bool F>
DUALPOSE_ROW int dualquat_mul_rows4_t(const double* a, const double* b, double* o, npy_intp n) {
    npy_intp i = 0;
    for (; i + 4 <= n; i += 4) {
        const double *pa = a + 8 * i, *pb = b + 8 * i;
        const lanes::Q4 xr = lanes::split4(pa, 8), xd = lanes::split4(pa + 4, 8);
        const lanes::Q4 yr = lanes::split4(pb, 8), yd = lanes::split4(pb + 4, 8);
        // the row kernel's formula on the three products (one struct per product keeps GCC from copying the vectors
        // through memory and general registers)
        const lanes::Q4 r = qmul_f<F>(xr, yr), e = qmul_f<F>(xr, yd), f = qmul_f<F>(xd, yr);
        lanes::join4(r, o + 8 * i, 8);
        lanes::join4(lanes::Q4{e.x + f.x, e.y + f.y, e.z + f.z, e.w + f.w}, o + 8 * i + 4, 8);
    }
    for (; i < n; ++i) dualquat_mul_row_f<F>(a + 8 * i, b + 8 * i, o + 8 * i);
    return 0;
}

// The kernels that need 2/|q|**2 or 1/|q|**2 (the rotation, the transform and the inverses), one struct each: the
// operands, the row's quaternion that is tested (the first four doubles of the first operand's row), the row kernel,
// and a block of four (on AVX-512 also eight) rows in lanes, computed and stored when every row's magnitude is
// ordinary (common/kutil.hpp ordinary_sum), else left to the row kernel (false).  A block's inputs are all loaded
// before its outputs are stored, so an output may be an input (out=).  rows4 and rows8 below run them.
template <bool F>
struct Rotate {
    const double *q, *v;
    double* o;
    const double* tested(npy_intp i) const { return q + 4 * i; }
    DUALPOSE_ROW void row(npy_intp i) const { quat_rotate_row_f<F>(q + 4 * i, v + 3 * i, o + 3 * i); }
    DUALPOSE_ROW bool block4(npy_intp i) const {
        const lanes::Q4 a = lanes::split4(q + 4 * i, 4);
        v4 vx, vy, vz, ox, oy, oz;
        lanes::split3(v + 3 * i, vx, vy, vz);
        if (!ordinary(a)) return false;
        const v4 n2 = a.x * a.x + a.y * a.y + a.z * a.z + a.w * a.w;
        rotate_f<F>(a.x, a.y, a.z, a.w, vx, vy, vz, 2.0 / n2, ox, oy, oz);
        lanes::join3(ox, oy, oz, o + 3 * i);
        return true;
    }
#if DUALPOSE_HAVE_AVX512
    int fallback8(npy_intp i) const {
        return (F ? quat_rotate_rows4_fused : quat_rotate_rows4)(q + 4 * i, v + 3 * i, o + 3 * i, 8);
    }
    DUALPOSE_TARGET_AVX512 DUALPOSE_ROW bool block8(npy_intp i) const {  // two rows of 4 per 512-bit load
        v8 c[4], vx, vy, vz, ox, oy, oz;
        lanes::split4x8(q + 4 * i, c);
        lanes::split3x8(v + 3 * i, vx, vy, vz);
        if (!ordinary8(c[0], c[1], c[2], c[3])) return false;
        const v8 n2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3];
        rotate_f<F>(c[0], c[1], c[2], c[3], vx, vy, vz, 2.0 / n2, ox, oy, oz);
        lanes::join3x8(ox, oy, oz, o + 3 * i);
        return true;
    }
#endif
};

template <bool F>
struct Transform {
    const double *s, *p;
    double* o;
    const double* tested(npy_intp i) const { return s + 8 * i; }
    DUALPOSE_ROW void row(npy_intp i) const { dualquat_transform_row_f<F>(s + 8 * i, p + 3 * i, o + 3 * i); }
    DUALPOSE_ROW bool block4(npy_intp i) const {
        const lanes::Q4 r = lanes::split4(s + 8 * i, 8), d = lanes::split4(s + 8 * i + 4, 8);
        v4 px, py, pz, ox, oy, oz;
        lanes::split3(p + 3 * i, px, py, pz);
        if (!ordinary(r)) return false;
        const v4 n2 = r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w;
        transform_f<F>(r.x, r.y, r.z, r.w, d.x, d.y, d.z, d.w, px, py, pz, 2.0 / n2, ox, oy, oz);
        lanes::join3(ox, oy, oz, o + 3 * i);
        return true;
    }
#if DUALPOSE_HAVE_AVX512
    int fallback8(npy_intp i) const {
        return (F ? dualquat_transform_rows4_fused : dualquat_transform_rows4)(s + 8 * i, p + 3 * i, o + 3 * i, 8);
    }
    DUALPOSE_TARGET_AVX512 DUALPOSE_ROW bool block8(npy_intp i) const {
        v8 c[8], px, py, pz, ox, oy, oz;
        lanes::split8x8(s + 8 * i, c);
        lanes::split3x8(p + 3 * i, px, py, pz);
        if (!ordinary8(c[0], c[1], c[2], c[3])) return false;
        const v8 n2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2] + c[3] * c[3];
        transform_f<F>(c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], px, py, pz, 2.0 / n2, ox, oy, oz);
        lanes::join3x8(ox, oy, oz, o + 3 * i);
        return true;
    }
#endif
};

template <bool F>
struct QuatInv {
    const double* q;
    double* o;
    const double* tested(npy_intp i) const { return q + 4 * i; }
    DUALPOSE_ROW void row(npy_intp i) const { quat_inv_row_f<F>(q + 4 * i, o + 4 * i); }
    DUALPOSE_ROW bool block4(npy_intp i) const {
        const lanes::Q4 a = lanes::split4(q + 4 * i, 4);
        if (!ordinary(a)) return false;
        lanes::join4(inv_ordinary_f<F>(a), o + 4 * i, 4);
        return true;
    }
#if DUALPOSE_HAVE_AVX512
    int fallback8(npy_intp i) const {
        return (F ? quat_inv_rows4_fused : quat_inv_rows4)(q + 4 * i, o + 4 * i, 8);
    }
    DUALPOSE_TARGET_AVX512 DUALPOSE_ROW bool block8(npy_intp i) const {
        v8 c[4];
        lanes::split4x8(q + 4 * i, c);
        if (!ordinary8(c[0], c[1], c[2], c[3])) return false;
        const lanes::Q8 r = inv_ordinary_f<F>(lanes::Q8{c[0], c[1], c[2], c[3]});
        const v8 x[4] = {r.x, r.y, r.z, r.w};
        lanes::join4x8(x, o + 4 * i);
        return true;
    }
#endif
};

template <bool F>
struct DualQuatInv {
    const double* s;
    double* o;
    const double* tested(npy_intp i) const { return s + 8 * i; }
    DUALPOSE_ROW void row(npy_intp i) const { dualquat_inv_row_f<F>(s + 8 * i, o + 8 * i); }
    DUALPOSE_ROW bool block4(npy_intp i) const {
        const lanes::Q4 r = lanes::split4(s + 8 * i, 8);
        if (!ordinary(r)) return false;
        lanes::Q4 oi, od;
        dq_inv_ordinary_f<F>(r, lanes::split4(s + 8 * i + 4, 8), oi, od);
        lanes::join4(oi, o + 8 * i, 8);
        lanes::join4(od, o + 8 * i + 4, 8);
        return true;
    }
#if DUALPOSE_HAVE_AVX512
    int fallback8(npy_intp i) const {
        return (F ? dualquat_inv_rows4_fused : dualquat_inv_rows4)(s + 8 * i, o + 8 * i, 8);
    }
    DUALPOSE_TARGET_AVX512 DUALPOSE_ROW bool block8(npy_intp i) const {
        v8 c[8];
        lanes::split8x8(s + 8 * i, c);
        if (!ordinary8(c[0], c[1], c[2], c[3])) return false;
        lanes::Q8 r, d;
        dq_inv_ordinary_f<F>(lanes::Q8{c[0], c[1], c[2], c[3]}, lanes::Q8{c[4], c[5], c[6], c[7]}, r, d);
        v8 x[8] = {r.x, r.y, r.z, r.w, d.x, d.y, d.z, d.w};
        lanes::join8x8(x, o + 8 * i);
        return true;
    }
#endif
};

// Blocks of four rows, each in lanes or (a row out of the ordinary range) by the row kernel, then the last n mod 4
// rows by the row kernel; nonzero when a row was out of the ordinary range.
template <class K>
DUALPOSE_ROW int rows4(const K& k, npy_intp n) {
    int flagged = 0;
    npy_intp i = 0;
    for (; i + 4 <= n; i += 4) {
        if (k.block4(i)) continue;
        flagged = 1;
        for (npy_intp j = i; j < i + 4; ++j) k.row(j);
    }
    for (; i < n; ++i) {
        flagged |= !ordinary(k.tested(i));
        k.row(i);
    }
    return flagged;
}
template <bool F>
DUALPOSE_ROW int quat_rotate_rows4_t(const double* q, const double* v, double* o, npy_intp n) {
    return rows4(Rotate<F>{q, v, o}, n);
}
template <bool F>
DUALPOSE_ROW int dualquat_transform_rows4_t(const double* s, const double* p, double* o, npy_intp n) {
    return rows4(Transform<F>{s, p, o}, n);
}
template <bool F>
DUALPOSE_ROW int quat_inv_rows4_t(const double* q, double* o, npy_intp n) {
    return rows4(QuatInv<F>{q, o}, n);
}
template <bool F>
DUALPOSE_ROW int dualquat_inv_rows4_t(const double* s, double* o, npy_intp n) {
    return rows4(DualQuatInv<F>{s, o}, n);
}
}  // namespace

// The unfused loops (baseline and AVX2 clones), the fused loops and the fused row kernels (compiled for FMA).
#define DUALPOSE_BOTH_INSTANTIATIONS(name, params, args)                            \
    DUALPOSE_CLONES int name##_rows4 params { return name##_rows4_t<false> args; } \
    DUALPOSE_TARGET_FUSED int name##_rows4_fused params { return name##_rows4_t<true> args; }
DUALPOSE_BOTH_INSTANTIATIONS(quat_mul, (const double* p, const double* q, double* o, npy_intp n), (p, q, o, n))
DUALPOSE_BOTH_INSTANTIATIONS(quat_rotate, (const double* q, const double* v, double* o, npy_intp n), (q, v, o, n))
DUALPOSE_BOTH_INSTANTIATIONS(dualquat_mul, (const double* a, const double* b, double* o, npy_intp n), (a, b, o, n))
DUALPOSE_BOTH_INSTANTIATIONS(dualquat_transform, (const double* s, const double* p, double* o, npy_intp n),
                             (s, p, o, n))
DUALPOSE_BOTH_INSTANTIATIONS(quat_inv, (const double* q, double* o, npy_intp n), (q, o, n))
DUALPOSE_BOTH_INSTANTIATIONS(dualquat_inv, (const double* s, double* o, npy_intp n), (s, o, n))
#undef DUALPOSE_BOTH_INSTANTIATIONS

DUALPOSE_TARGET_FUSED void quat_mul_row_fused(const double* p, const double* q, double* o) {
    quat_mul_row_f<true>(p, q, o);
}
DUALPOSE_TARGET_FUSED void quat_rotate_row_fused(const double* q, const double* v, double* o) {
    quat_rotate_row_f<true>(q, v, o);
}
DUALPOSE_TARGET_FUSED void dualquat_mul_row_fused(const double* a, const double* b, double* o) {
    dualquat_mul_row_f<true>(a, b, o);
}
DUALPOSE_TARGET_FUSED void dualquat_transform_row_fused(const double* s, const double* p, double* o) {
    dualquat_transform_row_f<true>(s, p, o);
}
DUALPOSE_TARGET_FUSED void quat_inv_row_fused(const double* q, double* o) { quat_inv_row_f<true>(q, o); }
DUALPOSE_TARGET_FUSED void dualquat_inv_row_fused(const double* s, double* o) { dualquat_inv_row_f<true>(s, o); }

#if DUALPOSE_HAVE_AVX512
namespace {
const bool kAvx512 = cpu_has_avx512f();

// Blocks of eight rows (all loaded before any is stored); returns the rows done, a multiple of 8.
template <bool F>
DUALPOSE_TARGET_AVX512 npy_intp quat_mul_rows8(const double* p, const double* q, double* o, npy_intp n) {
    npy_intp i = 0;
    for (; i + 8 <= n; i += 8) {
        v8 x[4], y[4];
        lanes::split4x8(p + 4 * i, x);
        lanes::split4x8(q + 4 * i, y);
        const lanes::Q8 r = qmul_f<F>(lanes::Q8{x[0], x[1], x[2], x[3]}, lanes::Q8{y[0], y[1], y[2], y[3]});
        const v8 c[4] = {r.x, r.y, r.z, r.w};
        lanes::join4x8(c, o + 4 * i);
    }
    return i;
}

// As quat_mul_rows8.
template <bool F>
DUALPOSE_TARGET_AVX512 npy_intp dualquat_mul_rows8(const double* a, const double* b, double* o, npy_intp n) {
    npy_intp i = 0;
    for (; i + 8 <= n; i += 8) {
        v8 x[8], y[8];
        lanes::split8x8(a + 8 * i, x);
        lanes::split8x8(b + 8 * i, y);
        const lanes::Q8 xr{x[0], x[1], x[2], x[3]}, xd{x[4], x[5], x[6], x[7]};
        const lanes::Q8 yr{y[0], y[1], y[2], y[3]}, yd{y[4], y[5], y[6], y[7]};
        const lanes::Q8 r = qmul_f<F>(xr, yr), e = qmul_f<F>(xr, yd), f = qmul_f<F>(xd, yr);
        v8 c[8] = {r.x, r.y, r.z, r.w, e.x + f.x, e.y + f.y, e.z + f.z, e.w + f.w};
        lanes::join8x8(c, o + 8 * i);
    }
    return i;
}

// Blocks of eight rows of a kernel struct above (a block with a row out of the ordinary range goes to the four-row
// loop, compiled on its own: see the top of this file); *flagged is set when a row was out of it.  Returns the rows
// done, a multiple of 8.
template <class K>
DUALPOSE_TARGET_AVX512 npy_intp rows8(const K& k, npy_intp n, int* flagged) {
    npy_intp i = 0;
    for (; i + 8 <= n; i += 8)
        if (!k.block8(i)) *flagged |= k.fallback8(i);
    return i;
}
template <bool F>
DUALPOSE_TARGET_AVX512 npy_intp quat_rotate_rows8(const double* q, const double* v, double* o, npy_intp n,
                                                  int* flagged) {
    return rows8(Rotate<F>{q, v, o}, n, flagged);
}
template <bool F>
DUALPOSE_TARGET_AVX512 npy_intp dualquat_transform_rows8(const double* s, const double* p, double* o, npy_intp n,
                                                         int* flagged) {
    return rows8(Transform<F>{s, p, o}, n, flagged);
}
template <bool F>
DUALPOSE_TARGET_AVX512 npy_intp quat_inv_rows8(const double* q, double* o, npy_intp n, int* flagged) {
    return rows8(QuatInv<F>{q, o}, n, flagged);
}
template <bool F>
DUALPOSE_TARGET_AVX512 npy_intp dualquat_inv_rows8(const double* s, double* o, npy_intp n, int* flagged) {
    return rows8(DualQuatInv<F>{s, o}, n, flagged);
}
}  // namespace
#endif

const volatile double kMinusOne = -1.0, kPlusOne = 1.0;

// The sign pattern read once, then a loop the compiler vectorises (elementwise: o may be q).
DUALPOSE_CLONES void quat_conj_rows(const double* q, double* o, npy_intp n) {
    const double m = kMinusOne, p = kPlusOne;
    for (npy_intp i = 0; i < 4 * n; i += 4) {
        o[i] = q[i] * m;
        o[i + 1] = q[i + 1] * m;
        o[i + 2] = q[i + 2] * m;
        o[i + 3] = q[i + 3] * p;
    }
}
DUALPOSE_CLONES void dualquat_conj_rows(const double* s, double* o, npy_intp n) { quat_conj_rows(s, o, 2 * n); }

// The row loops: the eight-row blocks (AVX-512), then the four-row loop on the rest, fused or not (kFused).
#if DUALPOSE_HAVE_AVX512
#define DUALPOSE_BLOCKS8(name, ...) \
    if (kAvx512) i = kFused ? name##_rows8<true>(__VA_ARGS__) : name##_rows8<false>(__VA_ARGS__)
#else
#define DUALPOSE_BLOCKS8(name, ...)
#endif
#define DUALPOSE_ROWS4(name, ...) (kFused ? name##_rows4_fused(__VA_ARGS__) : name##_rows4(__VA_ARGS__))

int quat_mul_rows(const double* p, const double* q, double* o, npy_intp n) {
    npy_intp i = 0;
    DUALPOSE_BLOCKS8(quat_mul, p, q, o, n);
    return DUALPOSE_ROWS4(quat_mul, p + 4 * i, q + 4 * i, o + 4 * i, n - i);
}

int quat_rotate_rows(const double* q, const double* v, double* o, npy_intp n) {
    int flagged = 0;
    npy_intp i = 0;
    DUALPOSE_BLOCKS8(quat_rotate, q, v, o, n, &flagged);
    return DUALPOSE_ROWS4(quat_rotate, q + 4 * i, v + 3 * i, o + 3 * i, n - i) | flagged;
}

int dualquat_mul_rows(const double* a, const double* b, double* o, npy_intp n) {
    npy_intp i = 0;
    DUALPOSE_BLOCKS8(dualquat_mul, a, b, o, n);
    return DUALPOSE_ROWS4(dualquat_mul, a + 8 * i, b + 8 * i, o + 8 * i, n - i);
}

int dualquat_transform_rows(const double* s, const double* p, double* o, npy_intp n) {
    int flagged = 0;
    npy_intp i = 0;
    DUALPOSE_BLOCKS8(dualquat_transform, s, p, o, n, &flagged);
    return DUALPOSE_ROWS4(dualquat_transform, s + 8 * i, p + 3 * i, o + 3 * i, n - i) | flagged;
}

int quat_inv_rows(const double* q, double* o, npy_intp n) {
    int flagged = 0;
    npy_intp i = 0;
    DUALPOSE_BLOCKS8(quat_inv, q, o, n, &flagged);
    return DUALPOSE_ROWS4(quat_inv, q + 4 * i, o + 4 * i, n - i) | flagged;
}

int dualquat_inv_rows(const double* s, double* o, npy_intp n) {
    int flagged = 0;
    npy_intp i = 0;
    DUALPOSE_BLOCKS8(dualquat_inv, s, o, n, &flagged);
    return DUALPOSE_ROWS4(dualquat_inv, s + 8 * i, o + 8 * i, n - i) | flagged;
}
#undef DUALPOSE_BLOCKS8
#undef DUALPOSE_ROWS4

}  // namespace dualpose
