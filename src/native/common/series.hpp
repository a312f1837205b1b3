// Guarded series for every removable singularity (the C++ side of dualpose.algebra.series, which documents the
// table of functions, cutoffs and the callers).  Each is a Horner polynomial in x**2 below its own cutoff (exact
// rational Taylor coefficients rounded once to float64: series.taylor_coefficients, truncated where the first
// omitted term is below 2**-56 of the value at the cutoff; tests/algebra/test_native_series.py checks these
// literals against series.py) and a closed form that is accurate above it.  All are even in x and evaluated on |x|.
#pragma once

#include "kutil.hpp"

#include <cmath>
#include <cstddef>

namespace dualpose {
namespace series_coefficients {
inline constexpr double C_SINC[8] = {
    0x1.0000000000000p+0, -0x1.5555555555555p-3, 0x1.1111111111111p-7, -0x1.a01a01a01a01ap-13,
    0x1.71de3a556c734p-19, -0x1.ae64567f544e4p-26, 0x1.6124613a86d09p-33, -0x1.ae7f3e733b81fp-41};
inline constexpr double C_COSC2[9] = {
    0x1.0000000000000p-1, -0x1.5555555555555p-5, 0x1.6c16c16c16c17p-10, -0x1.a01a01a01a01ap-16,
    0x1.27e4fb7789f5cp-22, -0x1.1eed8eff8d898p-29, 0x1.93974a8c07c9dp-37, -0x1.ae7f3e733b81fp-45,
    0x1.6827863b97d97p-53};
inline constexpr double C_SINC3[13] = {
    0x1.5555555555555p-3, -0x1.1111111111111p-7, 0x1.a01a01a01a01ap-13, -0x1.71de3a556c734p-19,
    0x1.ae64567f544e4p-26, -0x1.6124613a86d09p-33, 0x1.ae7f3e733b81fp-41, -0x1.952c77030ad4ap-49,
    0x1.2f49b46814157p-57, -0x1.71b8ef6dcf572p-66, 0x1.761b41316381ap-75, -0x1.3f3ccdd165fa9p-84,
    0x1.d1ab1c2dccea3p-94};
inline constexpr double C_DSINC[12] = {
    -0x1.5555555555555p-2, 0x1.1111111111111p-5, -0x1.3813813813814p-10, 0x1.71de3a556c734p-16,
    -0x1.0cfeb60f94b0ep-22, 0x1.08db48ebe51c7p-29, -0x1.78af56a4d411bp-37, 0x1.952c77030ad4ap-45,
    -0x1.5532eaf516982p-53, 0x1.ce272b49432cep-62, -0x1.0132bcd1f4692p-70, 0x1.dedb34ba18f7dp-80};
inline constexpr double C_COSC4[14] = {
    0x1.5555555555555p-5, -0x1.6c16c16c16c17p-10, 0x1.a01a01a01a01ap-16, -0x1.27e4fb7789f5cp-22,
    0x1.1eed8eff8d898p-29, -0x1.93974a8c07c9dp-37, 0x1.ae7f3e733b81fp-45, -0x1.6827863b97d97p-53,
    0x1.e542ba4020225p-62, -0x1.0ce396db7f853p-70, 0x1.f2cf01972f578p-80, -0x1.88e85fc6a4e5ap-89,
    0x1.0a18a2635085dp-98, -0x1.3932c5047d60ep-108};
inline constexpr double C_SE3C[15] = {
    0x1.1111111111111p-7, -0x1.a01a01a01a01ap-12, 0x1.1566abc011567p-17, -0x1.ae64567f544e4p-24,
    0x1.b96d79892884cp-31, -0x1.42df6ed66ca17p-38, 0x1.6286e822a97a1p-46, -0x1.2f49b46814157p-54,
    0x1.9ff00d5b89420p-63, -0x1.d3a2117dbc620p-72, 0x1.b6f39affec388p-81, -0x1.5d40552259afap-90,
    0x1.dd235824d701ap-100, -0x1.1ae388a937705p-109, 0x1.25e912f8f3c7dp-119};
inline constexpr double C_JINV[21] = {
    0x1.5555555555555p-4, 0x1.6c16c16c16c17p-10, 0x1.1566abc011567p-15, 0x1.bbd779334ef0bp-21,
    0x1.66a8f2bf70ebep-26, 0x1.22805d644267fp-31, 0x1.d6db2c4e09162p-37, 0x1.7da4e1f79955cp-42,
    0x1.355871d652e9ep-47, 0x1.f57d968caacf1p-53, 0x1.967e1f09c376fp-58, 0x1.497d9033a2b5cp-63,
    0x1.0b132d7c6ad06p-68, 0x1.b0f72d59f1c16p-74, 0x1.5ef2da4cca26dp-79, 0x1.1c77df96de38bp-84,
    0x1.cd299de521b62p-90, 0x1.75cde656574a7p-95, 0x1.2efe8db3b4adfp-100, 0x1.eb322904761ffp-106,
    0x1.8e25ff9328464p-111};
}  // namespace series_coefficients

// sum_k c[k] y**k by Horner's rule (the leading c[N-1] is the first accumulator: y is finite below every cutoff).
template <std::size_t N>
inline double horner(const double (&c)[N], double y) {
    double acc = c[N - 1];
    for (std::size_t i = N - 1; i-- > 0;) acc = acc * y + c[i];
    return acc;
}

// sin(x)/x; Dantam 2014 eq. (23).  Cutoff 0.5.
inline double sinc(double x) {
    x = std::fabs(x);
    if (x < 0.5) return horner(series_coefficients::C_SINC, x * x);
    return std::sin(x) / x;
}

// (1 - cos x)/x**2, as sinc(x/2)**2 / 2 above the cutoff 1.0 (no cancellation).
inline double cosc2(double x) {
    x = std::fabs(x);
    if (x < 1.0) return horner(series_coefficients::C_COSC2, x * x);
    const double h = std::sin(0.5 * x) / x;
    return 2.0 * h * h;
}

// (x - sin x)/x**3.  Cutoff 3.0.
inline double sinc3(double x) {
    x = std::fabs(x);
    if (x < 3.0) return horner(series_coefficients::C_SINC3, x * x);
    return (x - std::sin(x)) / (x * x * x);
}

// (x cos x - sin x)/x**3; Dantam 2014 eqs. (37), (57), (85).  Cutoff 2.0.
inline double dsinc(double x) {
    x = std::fabs(x);
    if (x < 2.0) return horner(series_coefficients::C_DSINC, x * x);
    return (x * std::cos(x) - std::sin(x)) / (x * x * x);
}

// (x**2/2 - 1 + cos x)/x**4.  Cutoff 3.5.
inline double cosc4(double x) {
    x = std::fabs(x);
    if (x < 3.5) return horner(series_coefficients::C_COSC4, x * x);
    const double x2 = x * x;
    return (0.5 * x2 - 1.0 + std::cos(x)) / (x2 * x2);
}

// (2x - 3 sin x + x cos x)/(2 x**5).  Cutoff 4.0.
inline double se3c(double x) {
    x = std::fabs(x);
    if (x < 4.0) return horner(series_coefficients::C_SE3C, x * x);
    const double x2 = x * x;
    return (2.0 * x - 3.0 * std::sin(x) + x * std::cos(x)) / (2.0 * x2 * x2 * x);
}

// (1 - (x/2) cot(x/2))/x**2, the Φ² coefficient of the inverse SO(3) Jacobian; pole at 2π.  Cutoff 2.5.
inline double jinv(double x) {
    x = std::fabs(x);
    if (x < 2.5) return horner(series_coefficients::C_JINV, x * x);
    const double h = 0.5 * x;
    return (1.0 - h * std::cos(h) / std::sin(h)) / (x * x);
}

// s <= 1e-4 c: (1/c)(1 - y**2/3 + y**4/5 - y**6/7), y = s/c (truncation error below 1e-32).
inline double atan2c_series(double s, double c) {
    const double y = s / c;
    const double y2 = y * y;
    return (1.0 + y2 * (-1.0 / 3.0 + y2 * (0.2 - y2 / 7.0))) / c;
}

// s == 0: +inf on the negative real axis (the caller picks an axis), NaN at s == c == 0.
inline double atan2c_at_zero(double c) { return c < 0.0 ? kInf : kNaN; }

// atan2(s, c)/s for s >= 0: the log / rotation-vector scale phi/|q_v|, Dantam 2014 eqs. (26)-(28).
inline double atan2c(double s, double c) {
    if (s <= 1e-4 * c && c > 0.0) return atan2c_series(s, c);  // false for almost all data (predictable)
    if (s == 0.0) return atan2c_at_zero(c);
    return std::atan2(s, c) / s;
}

// atan2c when phi = atan2(s, c) is already known (ignored on the series branch; same values at s == 0).
inline double atan2c_given(double s, double c, double phi) {
    if (s <= 1e-4 * c && c > 0.0) return atan2c_series(s, c);
    if (s == 0.0) return atan2c_at_zero(c);
    return phi / s;
}

// cos x / sin**2 x - x / sin**3 x = -4 sinc3(2x)/sinc(x)**3; Dantam 2014 eqs. (91)-(92).  Pole at π.
inline double dqalpha(double x) {
    const double sx = sinc(x);
    return -4.0 * sinc3(2.0 * x) / (sx * sx * sx);
}

// (x cos x - sin x)/sin**3 x = dsinc(x)/sinc(x)**3; Dantam 2014 eqs. (39)-(40).  Pole at π.
inline double dlogc(double x) {
    const double sx = sinc(x);
    return dsinc(x) / (sx * sx * sx);
}

}  // namespace dualpose
