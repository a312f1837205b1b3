// Argument checks shared by the error-state filter's and the smoother's Python entry points: exact shapes (the
// kernels index raw memory, so a wrong shape must be an error, not a read out of bounds) and numpy's LinAlgError.
#pragma once

#include "../common/args.hpp"
#include "sensor_block.hpp"

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

// The arrays of a SensorBlock as parsed by PyArg_ParseTuple ("O&" with convert<...>, in the order t, gyro, accel,
// cam_t, offsets, pixels, points).
struct BlockArrays {
    Array<double, 1> t;
    Array<double, 2> gyro, accel;
    Array<double, 1> cam_t;
    Array<std::int64_t, 1> offsets;
    Array<double, 2> pixels, points;
};

// Check the shapes of a block (N IMU samples, F frames, M correspondences; offsets nondecreasing within [0, M]) and
// fill b; false with ValueError otherwise.
inline bool block_of(const BlockArrays& a, SensorBlock& b) {
    const npy_intp n = a.t.shape[0], nf = a.cam_t.shape[0];
    if (!shape_is("gyro", a.gyro, {n, 3}) || !shape_is("accel", a.accel, {n, 3}) ||
        !shape_is("offsets", a.offsets, {nf + 1}) || !shape_is("pixels", a.pixels, {-1, 2}) ||
        !shape_is("points", a.points, {a.pixels.shape[0], 3}))
        return false;
    const npy_intp m = a.pixels.shape[0];
    for (npy_intp j = 0; j <= nf; ++j)
        if (a.offsets[j] < 0 || (j < nf && a.offsets[j] > a.offsets[j + 1]) || a.offsets[j] > m) {
            PyErr_SetString(PyExc_ValueError, "offsets must be nondecreasing within [0, len(pixels)]");
            return false;
        }
    b = SensorBlock{n, nf, a.t.data, a.gyro.data, a.accel.data, a.cam_t.data, a.offsets.data, a.pixels.data,
                    a.points.data};
    return true;
}

constexpr const char* singular_message = "Matrix is singular to machine precision.";
constexpr const char* not_finite_message = "Array must not contain infs or NaNs.";

}  // namespace dualpose
