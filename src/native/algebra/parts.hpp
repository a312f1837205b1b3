// Registration functions of the algebra's gufunc groups that add_lie_gufuncs (lie.cpp) calls in turn.
#pragma once

#include "../common/numpy_api.hpp"

namespace dualpose {
bool add_implicit_gufuncs(PyObject* module);    // implicit.cpp
bool add_derivative_gufuncs(PyObject* module);  // derivatives.cpp
}  // namespace dualpose
