// Argument checks shared by the error-state filter's and the smoother's Python entry points: exact shapes (the
// kernels index raw memory, so a wrong shape must be an error, not a read out of bounds) and numpy's LinAlgError.
#pragma once

#include "../common/args.hpp"

#include <initializer_list>
#include <string>

namespace dualpose {

// True if a.shape == dims (-1: any extent); otherwise false with ValueError "<name> must have shape (3,); got (4,)"
// (numpy's notation, * for any extent).
template <class A>
inline bool shape_is(const char* name, const A& a, std::initializer_list<npy_intp> dims) {
    bool ok = static_cast<int>(dims.size()) == PyArray_NDIM(a.obj);
    int k = 0;
    for (npy_intp d : dims) {
        ok = ok && (d < 0 || d == a.shape[k]);
        ++k;
    }
    if (ok) return true;
    auto show = [](auto first, auto last) {
        std::string s = "(";
        for (auto it = first; it != last; ++it)
            s += (it == first ? "" : ", ") + (*it < 0 ? std::string("*") : std::to_string(*it));
        return s + (last - first == 1 ? ",)" : ")");
    };
    const npy_intp* got = PyArray_DIMS(a.obj);
    PyErr_Format(PyExc_ValueError, "%s must have shape %s; got %s", name, show(dims.begin(), dims.end()).c_str(),
                 show(got, got + PyArray_NDIM(a.obj)).c_str());
    return false;
}

// Raise numpy.linalg.LinAlgError(msg) (the error numpy's solve / inv raise); returns nullptr.
inline PyObject* raise_linalg_error(const char* msg) {
    PyObject* mod = PyImport_ImportModule("numpy.linalg");
    if (mod == nullptr) return nullptr;
    PyObject* exc = PyObject_GetAttrString(mod, "LinAlgError");
    Py_DECREF(mod);
    if (exc == nullptr) return nullptr;
    PyErr_SetString(exc, msg);
    Py_DECREF(exc);
    return nullptr;
}

constexpr const char* singular_message = "Matrix is singular to machine precision.";
constexpr const char* not_finite_message = "Array must not contain infs or NaNs.";

}  // namespace dualpose
