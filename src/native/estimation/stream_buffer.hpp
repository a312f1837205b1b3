// Python-side helpers of the streaming filters (eskf_stream_*, hol22_stream_*, ahrs_stream_*): the filter state lives
// in one 1-d numpy.uint8 array [header (magic, version, size, ...) | constants | state (| rings: the AHRS)], so that
// a byte copy saves it and restores it; the fast reading of one (3,) sample; and the arguments the camera–IMU
// streams (ESKF, Hol22) share.
#pragma once

#include "../common/numpy_api.hpp"
#include "eskf_args.hpp"

#include <cstddef>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace dualpose::stream {

// What identifies one kind of stream buffer: the header's magic and layout version, and the names its errors use.
struct Kind {
    std::uint64_t magic, version;
    const char* name;          // e.g. "ESKF stream"
    const char* what;          // e.g. "an ESKF stream state"
    const char* check_format;  // PyArg_ParseTuple format of <kind>_stream_check, e.g. "O|s:eskf_stream_check"
};

// A new zeroed buffer of `size` bytes (at least sizeof(S): a stream may keep rings after the struct) whose header
// is (magic, version, size); nullptr with an exception set.
template <class S>
PyObject* new_buffer(const Kind& k, std::size_t size = sizeof(S)) {
    const npy_intp n = static_cast<npy_intp>(size);
    PyObject* out = PyArray_ZEROS(1, &n, NPY_UINT8, 0);
    if (out == nullptr) return nullptr;
    auto* s = static_cast<S*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(out)));
    s->h.magic = k.magic;
    s->h.version = k.version;
    s->h.size = static_cast<std::uint64_t>(size);
    return out;
}

// The stream held by `o` (a 1-d C-contiguous, aligned numpy.uint8 array written by new_buffer<S>), or nullptr with
// TypeError / ValueError naming `name` and k.what: wrong type, not a stream of this kind, another layout version,
// wrong size.  The size is sizeof(S), or, for a stream with rings after the struct, bytes(s) computed from the
// constants the buffer holds (0 when they are inconsistent); bytes is called only once the buffer holds a whole S.
template <class S>
S* stream_of(PyObject* o, const char* name, bool write, const Kind& k, std::uint64_t (*bytes)(const S&) = nullptr) {
    if (!PyArray_Check(o)) {
        PyErr_Format(PyExc_TypeError, "%s must be a numpy.uint8 array (%s); got %s", name, k.what,
                     Py_TYPE(o)->tp_name);
        return nullptr;
    }
    auto* a = reinterpret_cast<PyArrayObject*>(o);
    const int need = NPY_ARRAY_C_CONTIGUOUS | (write ? NPY_ARRAY_WRITEABLE : 0);
    if (PyArray_TYPE(a) != NPY_UINT8 || PyArray_NDIM(a) != 1 || (PyArray_FLAGS(a) & need) != need ||
        reinterpret_cast<std::uintptr_t>(PyArray_DATA(a)) % alignof(S) != 0) {
        PyErr_Format(PyExc_ValueError, "%s must be a 1-d C-contiguous, aligned%s numpy.uint8 array (%s)", name,
                     write ? ", writeable" : "", k.what);
        return nullptr;
    }
    const auto size = static_cast<std::uint64_t>(PyArray_DIM(a, 0));
    auto* s = static_cast<S*>(PyArray_DATA(a));
    if (size < sizeof(s->h) || s->h.magic != k.magic) {
        PyErr_Format(PyExc_ValueError, "%s is not %s (%llu bytes, no such header)", name, k.what,
                     static_cast<unsigned long long>(size));
        return nullptr;
    }
    if (s->h.version != k.version) {
        PyErr_Format(PyExc_ValueError, "%s has %s layout version %llu; this build reads %s version %llu", name, k.name,
                     static_cast<unsigned long long>(s->h.version), k.what,
                     static_cast<unsigned long long>(k.version));
        return nullptr;
    }
    const std::uint64_t expected = size < sizeof(S) || bytes == nullptr ? sizeof(S) : bytes(*s);
    if (expected == 0) {
        PyErr_Format(PyExc_ValueError, "%s holds inconsistent constants (%s)", name, k.what);
        return nullptr;
    }
    if (size != expected || s->h.size != expected) {
        PyErr_Format(PyExc_ValueError, "%s has %llu bytes (header: %llu); %s has %llu", name,
                     static_cast<unsigned long long>(size), static_cast<unsigned long long>(s->h.size), k.what,
                     static_cast<unsigned long long>(expected));
        return nullptr;
    }
    return s;
}

// <kind>_stream_check(state, name='state'): ValueError naming `name` unless state is a stream of kind K (the
// binding shared by every streaming filter).
template <class S, const Kind& K, std::uint64_t (*BYTES)(const S&) = nullptr>
PyObject* check(PyObject*, PyObject* args) {
    PyObject* state;
    const char* name = "state";
    if (!PyArg_ParseTuple(args, K.check_format, &state, &name)) return nullptr;
    if (stream_of<S>(state, name, false, K, BYTES) == nullptr) return nullptr;
    Py_RETURN_NONE;
}

// Three doubles from a 1-d float64 array of 3 elements (fast path, any stride: e.g. a row of a Fortran-ordered
// (n, 3) array) or any sequence of 3 numbers; with none_ok, None gives zeros (an absent magnetometer in 6D);
// ValueError naming `name` otherwise.
inline bool read3_any(PyObject* o, const char* name, double* v, bool none_ok) {
    if (PyArray_Check(o)) {
        auto* a = reinterpret_cast<PyArrayObject*>(o);
        if (PyArray_TYPE(a) == NPY_DOUBLE && PyArray_NDIM(a) == 1 && PyArray_DIM(a, 0) == 3 && PyArray_ISALIGNED(a) &&
            PyArray_ISNOTSWAPPED(a)) {
            const char* d = static_cast<const char*>(PyArray_DATA(a));
            const npy_intp st = PyArray_STRIDE(a, 0);
            for (int i = 0; i < 3; ++i) v[i] = *reinterpret_cast<const double*>(d + i * st);
            return true;
        }
    }
    if (none_ok && o == Py_None) {
        v[0] = v[1] = v[2] = 0.0;
        return true;
    }
    PyObject* seq = PySequence_Fast(o, "");
    if (seq == nullptr || PySequence_Fast_GET_SIZE(seq) != 3) {
        Py_XDECREF(seq);
        PyErr_Clear();
        PyErr_Format(PyExc_ValueError, "%s must be 3 numbers (shape (3,))", name);
        return false;
    }
    for (int i = 0; i < 3; ++i) {
        v[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(seq, i));
        if (v[i] == -1.0 && PyErr_Occurred()) {
            Py_DECREF(seq);
            return false;
        }
    }
    Py_DECREF(seq);
    return true;
}

// read3_any, and ValueError naming `name` when a value is NaN or infinite (a filter fed one would carry NaN from
// then on without a word).
inline bool read3(PyObject* o, const char* name, double* v, bool none_ok = false) {
    if (!read3_any(o, name, v, none_ok)) return false;
    if (!(std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]))) {
        PyErr_Format(PyExc_ValueError, "%s must be finite (no NaN or infinity)", name);
        return false;
    }
    return true;
}

// ValueError "t must be finite and increase strictly: got <t> after <last>"; returns nullptr.
inline PyObject* time_error(double t, double last) {
    PyObject* a = PyFloat_FromDouble(t);
    PyObject* b = PyFloat_FromDouble(last);
    if (a != nullptr && b != nullptr)
        PyErr_Format(PyExc_ValueError, "t must be finite and increase strictly: got %R after %R", a, b);
    Py_XDECREF(a);
    Py_XDECREF(b);
    return nullptr;
}

// A new float64 vector (n,) holding a copy of v.
inline PyObject* new_vector(const double* v, npy_intp n) {
    PyObject* out = PyArray_SimpleNew(1, &n, NPY_DOUBLE);
    if (out != nullptr) std::memcpy(PyArray_DATA(reinterpret_cast<PyArrayObject*>(out)), v, n * sizeof(double));
    return out;
}

// The arguments of <kind>_stream_imu(state, t, gyro, accel) (METH_FASTCALL): the writeable stream of kind k, t, and
// gyro, accel (3,); nullptr with TypeError naming `usage` (e.g. "eskf_stream_imu(state, t, gyro, accel)") or
// ValueError otherwise.
template <class S>
S* imu_args(PyObject* const* args, Py_ssize_t nargs, const char* usage, const Kind& k, double& t, double* g,
            double* a) {
    if (nargs != 4) {
        PyErr_Format(PyExc_TypeError, "%s takes 4 arguments", usage);
        return nullptr;
    }
    S* s = stream_of<S>(args[0], "state", true, k);
    if (s == nullptr) return nullptr;
    t = PyFloat_AsDouble(args[1]);
    if (t == -1.0 && PyErr_Occurred()) return nullptr;
    if (!read3(args[2], "gyro", g) || !read3(args[3], "accel", a)) return nullptr;
    return s;
}

// The correspondences of one frame, pixels (M, 2) and points (M, 3), and its (M,) outputs nis and accepted.
struct FrameArgs {
    Array<double, 2> pixels, points;
    Array<double, 1, true> nis;
    Array<std::int64_t, 1, true> acc;
    bool ok() const {
        const npy_intp m = pixels.shape[0];
        return shape_is("pixels", pixels, {-1, 2}) && shape_is("points", points, {m, 3}) &&
               shape_is("nis", nis, {m}) && shape_is("accepted", acc, {m});
    }
};

// A block fed to a camera–IMU stream and the outputs of its steps: X (N, nx), Ps (N, ne, ne) or nullptr (None),
// nis and accepted (M,).
struct BlockRun {
    SensorBlock b;
    double *X, *Ps, *nis;
    std::int64_t* acc;
};

// The arguments of <kind>_stream_run(state, t, gyro, accel, cam_t, offsets, pixels, points, X, Ps, nis, accepted)
// for a stream of kind k with nominal state (nx,) and error covariance (ne, ne); fmt the PyArg_ParseTuple format
// ("OO&O&O&O&O&O&O&O&OO&O&:<kind>_stream_run").  The writeable stream, r filled; nullptr with an exception set.
template <class S>
S* block_run_args(PyObject* args, const char* fmt, const Kind& k, npy_intp nx, npy_intp ne, BlockRun& r) {
    PyObject *state, *ps_obj;
    BlockArrays ba;
    Array<double, 2, true> X;
    Array<double, 1, true> nis;
    Array<std::int64_t, 1, true> acc;
    if (!PyArg_ParseTuple(args, fmt, &state, convert<double, 1>, &ba.t, convert<double, 2>, &ba.gyro,
                          convert<double, 2>, &ba.accel, convert<double, 1>, &ba.cam_t, convert<std::int64_t, 1>,
                          &ba.offsets, convert<double, 2>, &ba.pixels, convert<double, 2>, &ba.points,
                          convert<double, 2, true>, &X, &ps_obj, convert<double, 1, true>, &nis,
                          convert<std::int64_t, 1, true>, &acc))
        return nullptr;
    S* s = stream_of<S>(state, "state", true, k);
    if (s == nullptr || !block_of(ba, r.b)) return nullptr;
    const npy_intp n = r.b.n, m = ba.pixels.shape[0];
    Array<double, 3, true> Ps;
    if (ps_obj != Py_None && (!convert<double, 3, true>(ps_obj, &Ps) || !shape_is("Ps", Ps, {n, ne, ne})))
        return nullptr;
    if (!shape_is("X", X, {n, nx}) || !shape_is("nis", nis, {m}) || !shape_is("accepted", acc, {m})) return nullptr;
    r.X = X.data;
    r.Ps = ps_obj == Py_None ? nullptr : Ps.data;
    r.nis = nis.data;
    r.acc = acc.data;
    return s;
}

}  // namespace dualpose::stream
