// Row loops over flat, C-contiguous float64 buffers, called by the Python wrappers for large C-contiguous
// batches without broadcasting (dualpose._validation.try_flat_kernel).  They run the gufuncs' own contiguous row
// loops (rows.hpp), so flat and gufunc results are equal bit for bit; what the flat call adds is the loop's flag
// (nonzero when a row's norm was zero or extreme), so the wrapper looks for zeros only when there may be one,
// instead of scanning the whole output as after a gufunc call.
#include "../common/args.hpp"
#include "../common/lie.hpp"
#include "../common/series.hpp"
#include "rows.hpp"

namespace dualpose {

namespace {

using In1 = Array<double, 1>;
using Out1 = Array<double, 1, true>;

template <int WA, int WB, int WO>
bool rows_of(const In1& a, const In1& b, const Out1& o, npy_intp& n) {
    n = o.shape[0] / WO;
    if (a.shape[0] != WA * n || b.shape[0] != WB * n || o.shape[0] != WO * n) {
        PyErr_Format(PyExc_ValueError, "flat buffers of %d, %d and %d doubles per row do not hold the same rows", WA,
                     WB, WO);
        return false;
    }
    return true;
}

// f(a, b, o) -> int over rows of WA, WB -> WO doubles.
template <int WA, int WB, int WO, int (*ROWS)(const double*, const double*, double*, npy_intp)>
PyObject* flat_call(PyObject*, PyObject* args) {
    In1 a, b;
    Out1 o;
    if (!PyArg_ParseTuple(args, "O&O&O&", convert<double, 1>, &a, convert<double, 1>, &b, convert<double, 1, true>, &o))
        return nullptr;
    npy_intp n;
    if (!rows_of<WA, WB, WO>(a, b, o, n)) return nullptr;
    int flag;
    Py_BEGIN_ALLOW_THREADS flag = ROWS(a.data, b.data, o.data, n);
    Py_END_ALLOW_THREADS return PyLong_FromLong(flag);
}

// First pass of the flat quaternion log: s[i] = |q_v[i]| (guarded norm), w[i] = q_w[i].
PyObject* quat_log_prepare(PyObject*, PyObject* args) {
    In1 q;
    Out1 s, w;
    if (!PyArg_ParseTuple(args, "O&O&O&", convert<double, 1>, &q, convert<double, 1, true>, &s,
                          convert<double, 1, true>, &w))
        return nullptr;
    const npy_intp n = s.shape[0];
    if (q.shape[0] != 4 * n || w.shape[0] != n) {
        PyErr_SetString(PyExc_ValueError, "quat_log_prepare: q must hold 4 doubles per row of s and w");
        return nullptr;
    }
    Py_BEGIN_ALLOW_THREADS for (npy_intp i = 0; i < n; ++i) {
        const double* r = q.data + 4 * i;
        s[i] = norm3(r[0], r[1], r[2]);
        w[i] = r[3];
    }
    Py_END_ALLOW_THREADS Py_RETURN_NONE;
}

// Last pass: o[i] = ln q[i] from s and phi = atan2(s, w) (Dantam 2014 eqs. (25)-(28) with the guarded atan2c);
// returns 1 if some q[i] is zero.
PyObject* quat_log_finish(PyObject*, PyObject* args) {
    In1 q, s, phi;
    Out1 o;
    if (!PyArg_ParseTuple(args, "O&O&O&O&", convert<double, 1>, &q, convert<double, 1>, &s, convert<double, 1>, &phi,
                          convert<double, 1, true>, &o))
        return nullptr;
    const npy_intp n = s.shape[0];
    if (q.shape[0] != 4 * n || phi.shape[0] != n || o.shape[0] != 4 * n) {
        PyErr_SetString(PyExc_ValueError, "quat_log_finish: q and o must hold 4 doubles per row of s and phi");
        return nullptr;
    }
    int zero = 0;
    Py_BEGIN_ALLOW_THREADS for (npy_intp i = 0; i < n; ++i) {
        const Quat v = load4(q.data + 4 * i);
        zero |= (s[i] == 0.0) & (v.w == 0.0);
        if (extreme_exponent(v) != 0)  // as the gufunc: exactly rescaled (rare; ordinary rows are unchanged)
            store(o.data + 4 * i, quat_log_any(v));
        else
            store(o.data + 4 * i, quat_log_parts(v, atan2c_given(s[i], v.w, phi[i])));
    }
    Py_END_ALLOW_THREADS return PyLong_FromLong(zero);
}

PyMethodDef flat_methods[] = {
    {"flat_quat_rotate", flat_call<4, 3, 3, quat_rotate_rows>, METH_VARARGS,
     "flat_quat_rotate(q, v, o) -> flag: o[i] = R(q[i]) v[i] over flat (N*4,), (N*3,), (N*3,) buffers."},
    {"flat_dualquat_mul", flat_call<8, 8, 8, dualquat_mul_rows>, METH_VARARGS,
     "flat_dualquat_mul(a, b, o) -> 0: o[i] = a[i] (x) b[i] over flat (N*8,) buffers."},
    {"flat_dualquat_transform", flat_call<8, 3, 3, dualquat_transform_rows>, METH_VARARGS,
     "flat_dualquat_transform(s, p, o) -> flag: o[i] = R p[i] + t of s[i] over flat (N*8,), (N*3,), (N*3,)."},
    {"quat_log_prepare", quat_log_prepare, METH_VARARGS, "quat_log_prepare(q, s, w): |q_v| and q_w, flat."},
    {"quat_log_finish", quat_log_finish, METH_VARARGS,
     "quat_log_finish(q, s, phi, o) -> flag: ln q from |q_v| and atan2(|q_v|, q_w), flat; 1 if some q is zero."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_flat_kernels(PyObject* m) { return PyModule_AddFunctions(m, flat_methods) == 0; }

}  // namespace dualpose
