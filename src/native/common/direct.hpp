// The direct entries of the gufuncs (common/gufunc.hpp, Gufunc::direct), looked up by ufunc object.
#pragma once

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <cstddef>

namespace dualpose {

// args: the kernel's nin inputs; max_rows < 0 for no limit.  Returns 1 with *result set, 0 to decline (the caller
// takes the general path), -1 with a Python error set.
using DirectFn = int (*)(PyObject* const* args, std::ptrdiff_t max_rows, bool nan_declines, PyObject** result);

// Record the direct entry of a gufunc (keeps a reference to it); false with a Python error set.
bool register_direct(PyObject* ufunc, DirectFn fn);

}  // namespace dualpose
