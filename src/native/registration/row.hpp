// Layout of the result row the registration kernels write (ROW_SIZE doubles per problem): the one C++ copy of
// src/dualpose/registration/_row.py (its docstring describes each field).  Exported as module constants
// (REGISTRATION_ROW_SIZE, REGISTRATION_QUAT_AT, ...) and compared with _row.py by
// tests/registration/test_native_layout.py.
#pragma once

namespace dualpose::row {

constexpr int ROW_SIZE = 25;
constexpr int QUAT_AT = 0;          // rotation quaternion xyzw (w >= 0), 4
constexpr int TRANSLATION_AT = 4;   // translation, 3
constexpr int SCALE = 7;            // scale (1 unless want_scale)
constexpr int COST = 8;             // cost E
constexpr int EIGENVALUES_AT = 9;   // eigenvalues (descending) of the deciding 4x4 matrix, 4
constexpr int EIGEN_GAP = 13;       // the gap that decided uniqueness
constexpr int SINGULAR_AT = 14;     // singular values of H (svd only), 3
constexpr int REFLECTION = 17;      // Umeyama's d (svd only)
constexpr int UNIQUE = 18;          // 1 if the optimal rotation is unique
constexpr int CLOSED_FORM = 19;     // 1 if the closed-form eigen-solve was accepted
constexpr int POINT_EXPONENT = 20;  // e: the centred points were solved as 2**e (p - c) (0 for ordinary spreads)
constexpr int GAP_TOLERANCE = 22;   // the gap tolerance used
constexpr int POINT_COST = 23;      // the point part of the cost
constexpr int BAD_INPUT = 24;       // 0, or 1 + index into BAD_INPUT_NAMES, or N_BAD_INPUT_NAMES + 1 (overflow)
// model_points, measured_points, model_directions, measured_directions (_row.BAD_INPUT_NAMES)
constexpr int N_BAD_INPUT_NAMES = 4;

}  // namespace dualpose::row
