// Block offsets of the error-state filter's vectors: the C++ copy of dualpose.estimation.state (ESKF_STATE,
// ESKF_ERROR), exported as module constants (add_eskf_layout) and checked against state.py by
// tests/estimation/test_kernels.py, so that the two definitions cannot drift.
//
//   nominal x (16,)  = [p (3), v (3), q_wb (4, xyzw), b_g (3), b_a (3)]        (Solà 2017 §5.1)
//   error  δx (15,)  = [δp, δv, δθ (local: q = q̂ ⊗ Exp(δθ)), δb_g, δb_a]        (Solà 2017 §5.3)
#pragma once

namespace dualpose::eskf {

constexpr int NX = 16;  // ESKF_DIM
constexpr int NE = 15;  // ESKF_ERROR_DIM
// nominal state
constexpr int P = 0;   // ESKF_POSITION
constexpr int V = 3;   // ESKF_VELOCITY
constexpr int Q = 6;   // ESKF_QUAT
constexpr int BG = 10;  // ESKF_GYRO_BIAS
constexpr int BA = 13;  // ESKF_ACCEL_BIAS
// error state
constexpr int DP = 0;    // ESKF_D_POSITION
constexpr int DV = 3;    // ESKF_D_VELOCITY
constexpr int DTH = 6;   // ESKF_D_ATTITUDE
constexpr int DBG = 9;   // ESKF_D_GYRO_BIAS
constexpr int DBA = 12;  // ESKF_D_ACCEL_BIAS

static_assert(BA + 3 == NX && DBA + 3 == NE, "blocks cover the vectors");

// (name in dualpose.estimation.state, value) of every offset above, for the module constants.
struct LayoutConstant {
    const char* name;
    int value;
};
constexpr LayoutConstant layout_constants[] = {
    {"ESKF_DIM", NX},         {"ESKF_ERROR_DIM", NE},      {"ESKF_POSITION", P},        {"ESKF_VELOCITY", V},
    {"ESKF_QUAT", Q},         {"ESKF_GYRO_BIAS", BG},      {"ESKF_ACCEL_BIAS", BA},     {"ESKF_D_POSITION", DP},
    {"ESKF_D_VELOCITY", DV},  {"ESKF_D_ATTITUDE", DTH},    {"ESKF_D_GYRO_BIAS", DBG},   {"ESKF_D_ACCEL_BIAS", DBA},
};

}  // namespace dualpose::eskf
