// Four rows at a time in GCC vector types: whole-row loads, in-register transposes to one vector per component and
// back.  The row loops (rows.cpp) evaluate the scalar kernels' own formulas (the *_t / *_lanes templates of
// common/) on these vectors; IEEE arithmetic is lane-wise, so every lane rounds as the scalar kernel.  The compiler
// lowers a 4 x double vector to one ymm register with AVX2 and to two xmm registers on the x86-64 baseline.
#pragma once

#include <cstring>

// The helpers below pass 32-byte vectors by value; they are always inlined, so the note that the AVX calling
// convention differs from the baseline's (-Wpsabi) does not concern them.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace dualpose {
namespace lanes {

typedef double v4 __attribute__((vector_size(32)));
typedef long long m4 __attribute__((vector_size(32)));

struct Q4 {
    v4 x, y, z, w;
};
struct DQ4 {
    Q4 r, d;
};

inline __attribute__((always_inline)) v4 load(const double* p) {
    v4 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline __attribute__((always_inline)) void store(double* p, v4 v) { std::memcpy(p, &v, sizeof v); }

// 4 x 4 transpose: lane k of the result's component j is lane j of row k.
inline __attribute__((always_inline)) Q4 transpose(v4 r0, v4 r1, v4 r2, v4 r3) {
    const v4 t0 = __builtin_shuffle(r0, r1, m4{0, 4, 2, 6}), t1 = __builtin_shuffle(r0, r1, m4{1, 5, 3, 7});
    const v4 t2 = __builtin_shuffle(r2, r3, m4{0, 4, 2, 6}), t3 = __builtin_shuffle(r2, r3, m4{1, 5, 3, 7});
    return {__builtin_shuffle(t0, t2, m4{0, 1, 4, 5}), __builtin_shuffle(t1, t3, m4{0, 1, 4, 5}),
            __builtin_shuffle(t0, t2, m4{2, 3, 6, 7}), __builtin_shuffle(t1, t3, m4{2, 3, 6, 7})};
}

// Four rows of 4 doubles, `stride` doubles apart -> one vector per component.
inline __attribute__((always_inline)) Q4 split4(const double* p, long stride) {
    return transpose(load(p), load(p + stride), load(p + 2 * stride), load(p + 3 * stride));
}

// Inverse of split4.
inline __attribute__((always_inline)) void join4(const Q4& q, double* p, long stride) {
    const Q4 r = transpose(q.x, q.y, q.z, q.w);
    store(p, r.x);
    store(p + stride, r.y);
    store(p + 2 * stride, r.z);
    store(p + 3 * stride, r.w);
}

// Four rows of 3 doubles (12 consecutive doubles) -> x, y, z vectors.
inline __attribute__((always_inline)) void split3(const double* p, v4& x, v4& y, v4& z) {
    const v4 a = load(p), b = load(p + 4), c = load(p + 8);  // x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3
    x = __builtin_shuffle(__builtin_shuffle(a, b, m4{0, 3, 6, 0}), c, m4{0, 1, 2, 5});
    y = __builtin_shuffle(__builtin_shuffle(a, b, m4{1, 4, 7, 0}), c, m4{0, 1, 2, 6});
    z = __builtin_shuffle(__builtin_shuffle(a, b, m4{2, 5, 0, 0}), c, m4{0, 1, 4, 7});
}

// Inverse of split3.
inline __attribute__((always_inline)) void join3(v4 x, v4 y, v4 z, double* p) {
    store(p, __builtin_shuffle(__builtin_shuffle(x, y, m4{0, 4, 1, 0}), z, m4{0, 1, 4, 2}));      // x0 y0 z0 x1
    store(p + 4, __builtin_shuffle(__builtin_shuffle(x, y, m4{5, 2, 6, 0}), z, m4{0, 5, 1, 2}));  // y1 z1 x2 y2
    store(p + 8, __builtin_shuffle(__builtin_shuffle(x, y, m4{3, 7, 0, 0}), z, m4{6, 0, 1, 7}));  // z2 x3 y3 z3
}

// True when every lane of the comparison mask is set.
inline __attribute__((always_inline)) bool all(m4 m) { return (m[0] & m[1] & m[2] & m[3]) != 0; }

}  // namespace lanes
}  // namespace dualpose
