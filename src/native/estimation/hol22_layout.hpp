// Layout of Hol's 22-state filter (Hol 2008 eq. 8): the one C++ definition of the state offsets, equal to
// dualpose.estimation.state.HOL22_* (exported as module constants HOL22_*, checked by tests/estimation/test_hol22.py).
#pragma once

namespace dualpose::hol22 {

constexpr int POSITION = 0;           // b^e (3) m
constexpr int VELOCITY = 3;           // ḃ^e (3) m/s
constexpr int ACCELERATION = 6;       // b̈^e (3) m/s²
constexpr int QUAT_BE = 9;            // q^{be} (4) xyzw
constexpr int ANGULAR_VELOCITY = 13;  // ω^b_{eb} (3) rad/s
constexpr int GYRO_BIAS = 16;         // δ^b_ω (3) rad/s
constexpr int ACCEL_BIAS = 19;        // δ^b_a (3) m/s²
constexpr int DIM = 22;

#define DUALPOSE_HOL22_CONSTANTS(X) \
    X(POSITION) X(VELOCITY) X(ACCELERATION) X(QUAT_BE) X(ANGULAR_VELOCITY) X(GYRO_BIAS) X(ACCEL_BIAS) X(DIM)

}  // namespace dualpose::hol22
