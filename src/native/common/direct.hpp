// The direct entries of the gufuncs (common/gufunc.hpp, Gufunc::direct and Gufunc::row), looked up by ufunc object.
#pragma once

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <cstddef>

namespace dualpose {

// args: the kernel's nin inputs; out: a preallocated output or nullptr (allocate); max_rows < 0 for no limit.
// Returns 1 with *result set, 0 to decline (the caller takes the general path), -1 with a Python error set.
using DirectFn = int (*)(PyObject* const* args, PyObject* out, std::ptrdiff_t max_rows, bool nan_declines,
                         PyObject** result);
// One row of the kernel on contiguous core buffers: in[j] the j-th input, out[j] the j-th output (not aliasing them).
using RowFn = void (*)(const double* const* in, double* const* out);

struct DirectEntry {
    DirectFn direct;
    RowFn row;
    int nin, nout;
    int in_size[8], out_size[8];  // doubles per core (the first 8 operands)
};

// Record the direct entry of a gufunc (keeps a reference to it); false with a Python error set.
bool register_direct(PyObject* ufunc, const DirectEntry& entry);
// The entry of a gufunc of dualpose._native, or nullptr (valid while no gufunc is registered: copy what you keep).
const DirectEntry* find_direct(PyObject* ufunc);

// Ready a static type and add it to the module as `name`; false with a Python error set.
inline bool add_type(PyObject* module, PyTypeObject* type, const char* name) {
    if (PyType_Ready(type) < 0) return false;
    Py_INCREF(type);
    return PyModule_AddObject(module, name, reinterpret_cast<PyObject*>(type)) == 0 || (Py_DECREF(type), false);
}

}  // namespace dualpose

// Floating-point exception flags around a direct computation (NumPy reports those a ufunc loop raises; a direct
// call that raises one is declined, so the gufunc recomputes it and reports them).  On x86-64 the double arithmetic
// and libm run on SSE, whose flags live in MXCSR: reading it is cheap, and it is written only when a flag is
// already set, where <cfenv>'s feclearexcept also rewrites the x87 environment (about 40 ns).
#if defined(__x86_64__) && defined(__SSE2__)
#include <xmmintrin.h>
namespace dualpose {
constexpr unsigned kFpFlags = 0x1D;  // MXCSR invalid, divide-by-zero, overflow, underflow
inline void fp_flags_clear() {
    const unsigned c = _mm_getcsr();
    if (c & kFpFlags) _mm_setcsr(c & ~kFpFlags);
}
inline bool fp_flags_raised() { return (_mm_getcsr() & kFpFlags) != 0; }
}  // namespace dualpose
#else
#include <cfenv>
namespace dualpose {
constexpr int kFpFlags = FE_DIVBYZERO | FE_OVERFLOW | FE_INVALID | FE_UNDERFLOW;
inline void fp_flags_clear() { std::feclearexcept(kFpFlags); }
inline bool fp_flags_raised() { return std::fetestexcept(kFpFlags) != 0; }
}  // namespace dualpose
#endif
