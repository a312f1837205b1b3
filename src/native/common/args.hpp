// Arguments of the whole-recording loop functions: NumPy arrays checked once, then used through raw pointers.
//
//   static PyObject* eskf_run(PyObject*, PyObject* args) {
//       Array<double, 2> gyro; Array<double, 1, true> x; double dt;
//       if (!PyArg_ParseTuple(args, "O&O&d", convert<double, 2>, &gyro, convert<double, 1, true>, &x, &dt))
//           return nullptr;
//       ... gyro(i, j), x[k] ...
//   }
//
// convert<T, NDIM, WRITE> accepts only arrays of exactly that dtype (float64 or int64) and dimension that are
// C-contiguous and aligned (and writeable when WRITE): the Python wrappers own conversions and copies, a kernel never
// silently works on a copy it then throws away.  The array is borrowed: the caller's tuple keeps it alive.
#pragma once

#include "numpy_api.hpp"

#include <cstdint>
#include <type_traits>

namespace dualpose {

template <class T, int NDIM, bool WRITE = false>
struct Array {
    PyArrayObject* obj = nullptr;
    T* data = nullptr;
    npy_intp shape[NDIM > 0 ? NDIM : 1] = {};

    npy_intp size() const { return obj ? PyArray_SIZE(obj) : 0; }
    T& operator[](npy_intp i) const { return data[i]; }
    T& operator()(npy_intp i, npy_intp j) const { return data[i * shape[1] + j]; }
    T& operator()(npy_intp i, npy_intp j, npy_intp k) const { return data[(i * shape[1] + j) * shape[2] + k]; }
    T* row(npy_intp i) const { return data + i * (size() / (shape[0] ? shape[0] : 1)); }
};

template <class T>
constexpr int npy_type() {
    if constexpr (std::is_same_v<T, double>) return NPY_DOUBLE;
    else if constexpr (std::is_same_v<T, std::int64_t>) return NPY_INT64;
    else static_assert(sizeof(T) == 0, "float64 or int64 only");
}

// PyArg_ParseTuple "O&" converter for Array<T, NDIM, WRITE>.
template <class T, int NDIM, bool WRITE = false>
int convert(PyObject* o, void* address) {
    auto* out = static_cast<Array<T, NDIM, WRITE>*>(address);
    if (!PyArray_Check(o)) {
        PyErr_Format(PyExc_TypeError, "expected a numpy array, got %s", Py_TYPE(o)->tp_name);
        return 0;
    }
    auto* a = reinterpret_cast<PyArrayObject*>(o);
    if (PyArray_TYPE(a) != npy_type<T>() || PyArray_NDIM(a) != NDIM) {
        PyErr_Format(PyExc_TypeError, "expected a %d-d %s array, got a %d-d array of type %d", NDIM,
                     npy_type<T>() == NPY_DOUBLE ? "float64" : "int64", PyArray_NDIM(a), PyArray_TYPE(a));
        return 0;
    }
    int need = NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED | (WRITE ? NPY_ARRAY_WRITEABLE : 0);
    if ((PyArray_FLAGS(a) & need) != need) {
        PyErr_SetString(PyExc_ValueError,
                        WRITE ? "expected a C-contiguous, aligned, writeable array" : "expected a C-contiguous array");
        return 0;
    }
    out->obj = a;
    out->data = static_cast<T*>(PyArray_DATA(a));
    for (int k = 0; k < NDIM; ++k) out->shape[k] = PyArray_DIM(a, k);
    return 1;
}

}  // namespace dualpose
