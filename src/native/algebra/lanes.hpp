// Four (or eight) rows at a time in GCC vector types: whole-row loads, in-register transposes to one vector per
// component and back.  The row loops (rows.cpp) evaluate the row kernels' own formulas (the *_f templates of rows.hpp)
// on these vectors; IEEE arithmetic is lane-wise, so every lane rounds as the row kernel.  The compiler
// lowers a 4 x double vector to one ymm register with AVX2 and to two xmm registers on the x86-64 baseline; the
// 8 x double vectors are used only in functions compiled for AVX-512 (one zmm register).
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

// Eight rows at a time, for the AVX-512 loops (rows.cpp): one 512-bit register per component.  The same in-register
// transposes, one stage wider.
typedef double v8 __attribute__((vector_size(64)));
typedef long long m8 __attribute__((vector_size(64)));

struct Q8 {
    v8 x, y, z, w;
};

inline __attribute__((always_inline)) v8 load8(const double* p) {
    v8 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline __attribute__((always_inline)) void store8(double* p, v8 v) { std::memcpy(p, &v, sizeof v); }

// 8 x 8 transpose in place: lane j of r[k] becomes lane k of r[j] (pairs of rows, then pairs of pairs, then halves).
inline __attribute__((always_inline)) void transpose8(v8* r) {
    v8 t[8], u[8];
    for (int k = 0; k < 8; k += 2) {
        t[k] = __builtin_shuffle(r[k], r[k + 1], m8{0, 8, 2, 10, 4, 12, 6, 14});      // components 0 2 4 6 of two rows
        t[k + 1] = __builtin_shuffle(r[k], r[k + 1], m8{1, 9, 3, 11, 5, 13, 7, 15});  // components 1 3 5 7
    }
    for (int b = 0; b < 8; b += 4) {  // four rows: components (0, 4), (1, 5), (2, 6), (3, 7)
        u[b] = __builtin_shuffle(t[b], t[b + 2], m8{0, 1, 8, 9, 4, 5, 12, 13});
        u[b + 1] = __builtin_shuffle(t[b + 1], t[b + 3], m8{0, 1, 8, 9, 4, 5, 12, 13});
        u[b + 2] = __builtin_shuffle(t[b], t[b + 2], m8{2, 3, 10, 11, 6, 7, 14, 15});
        u[b + 3] = __builtin_shuffle(t[b + 1], t[b + 3], m8{2, 3, 10, 11, 6, 7, 14, 15});
    }
    for (int c = 0; c < 4; ++c) {
        r[c] = __builtin_shuffle(u[c], u[4 + c], m8{0, 1, 2, 3, 8, 9, 10, 11});
        r[c + 4] = __builtin_shuffle(u[c], u[4 + c], m8{4, 5, 6, 7, 12, 13, 14, 15});
    }
}

// Eight rows of 8 doubles (64 consecutive doubles) -> one vector per component; and back.
inline __attribute__((always_inline)) void split8x8(const double* p, v8* c) {
    for (int k = 0; k < 8; ++k) c[k] = load8(p + 8 * k);
    transpose8(c);
}
inline __attribute__((always_inline)) void join8x8(v8* c, double* p) {
    transpose8(c);
    for (int k = 0; k < 8; ++k) store8(p + 8 * k, c[k]);
}

// Eight rows of 4 doubles (32 consecutive doubles, two rows a load) -> c[0..3] = x, y, z, w.
inline __attribute__((always_inline)) void split4x8(const double* p, v8* c) {
    const v8 a = load8(p), b = load8(p + 8), e = load8(p + 16), f = load8(p + 24);
    const v8 t0 = __builtin_shuffle(a, b, m8{0, 8, 2, 10, 4, 12, 6, 14});  // x0 x2 z0 z2 x1 x3 z1 z3
    const v8 t1 = __builtin_shuffle(a, b, m8{1, 9, 3, 11, 5, 13, 7, 15});  // y0 y2 w0 w2 y1 y3 w1 w3
    const v8 t2 = __builtin_shuffle(e, f, m8{0, 8, 2, 10, 4, 12, 6, 14});  // rows 4..7 alike
    const v8 t3 = __builtin_shuffle(e, f, m8{1, 9, 3, 11, 5, 13, 7, 15});
    c[0] = __builtin_shuffle(t0, t2, m8{0, 4, 1, 5, 8, 12, 9, 13});
    c[1] = __builtin_shuffle(t1, t3, m8{0, 4, 1, 5, 8, 12, 9, 13});
    c[2] = __builtin_shuffle(t0, t2, m8{2, 6, 3, 7, 10, 14, 11, 15});
    c[3] = __builtin_shuffle(t1, t3, m8{2, 6, 3, 7, 10, 14, 11, 15});
}

// Inverse of split4x8.
inline __attribute__((always_inline)) void join4x8(const v8* c, double* p) {
    const v8 t0 = __builtin_shuffle(c[0], c[2], m8{0, 2, 8, 10, 1, 3, 9, 11});    // x0 x2 z0 z2 x1 x3 z1 z3
    const v8 t1 = __builtin_shuffle(c[1], c[3], m8{0, 2, 8, 10, 1, 3, 9, 11});    // y0 y2 w0 w2 y1 y3 w1 w3
    const v8 t2 = __builtin_shuffle(c[0], c[2], m8{4, 6, 12, 14, 5, 7, 13, 15});  // rows 4..7 alike
    const v8 t3 = __builtin_shuffle(c[1], c[3], m8{4, 6, 12, 14, 5, 7, 13, 15});
    store8(p, __builtin_shuffle(t0, t1, m8{0, 8, 2, 10, 4, 12, 6, 14}));
    store8(p + 8, __builtin_shuffle(t0, t1, m8{1, 9, 3, 11, 5, 13, 7, 15}));
    store8(p + 16, __builtin_shuffle(t2, t3, m8{0, 8, 2, 10, 4, 12, 6, 14}));
    store8(p + 24, __builtin_shuffle(t2, t3, m8{1, 9, 3, 11, 5, 13, 7, 15}));
}

// Eight rows of 3 doubles (24 consecutive doubles) -> x, y, z vectors.
inline __attribute__((always_inline)) void split3x8(const double* p, v8& x, v8& y, v8& z) {
    const v8 a = load8(p), b = load8(p + 8), c = load8(p + 16);  // x0 y0 z0 x1 y1 z1 x2 y2 | z2 x3 .. x5 | y5 .. z7
    x = __builtin_shuffle(__builtin_shuffle(a, b, m8{0, 3, 6, 9, 12, 15, 0, 0}), c, m8{0, 1, 2, 3, 4, 5, 10, 13});
    y = __builtin_shuffle(__builtin_shuffle(a, b, m8{1, 4, 7, 10, 13, 0, 0, 0}), c, m8{0, 1, 2, 3, 4, 8, 11, 14});
    z = __builtin_shuffle(__builtin_shuffle(a, b, m8{2, 5, 8, 11, 14, 0, 0, 0}), c, m8{0, 1, 2, 3, 4, 9, 12, 15});
}

// Inverse of split3x8.
inline __attribute__((always_inline)) void join3x8(v8 x, v8 y, v8 z, double* p) {
    store8(p, __builtin_shuffle(__builtin_shuffle(x, y, m8{0, 8, 0, 1, 9, 0, 2, 10}), z, m8{0, 1, 8, 3, 4, 9, 6, 7}));
    store8(p + 8,
           __builtin_shuffle(__builtin_shuffle(x, y, m8{0, 3, 11, 0, 4, 12, 0, 5}), z, m8{10, 1, 2, 11, 4, 5, 12, 7}));
    store8(p + 16,
           __builtin_shuffle(__builtin_shuffle(x, y, m8{13, 0, 6, 14, 0, 7, 15, 0}), z, m8{0, 13, 2, 3, 14, 5, 6, 15}));
}

// True when every lane of the comparison mask is set.
inline __attribute__((always_inline)) bool all(m8 m) {
    return (m[0] & m[1] & m[2] & m[3] & m[4] & m[5] & m[6] & m[7]) != 0;
}

}  // namespace lanes
}  // namespace dualpose
