// dualpose._native's AHRS part: ahrs_run (the whole recording), ahrs_predict and ahrs_inject_and_reset (one step,
// for dualpose.estimation.ahrs_filter.AhrsFilter), and the layout constants AHRS_* (ahrs_layout.hpp).
#include "../common/args.hpp"
#include "ahrs_filter.hpp"
#include "ahrs_run.hpp"

#include <initializer_list>

namespace dualpose {

namespace {

// True when a has exactly the given shape; otherwise false with a ValueError naming the argument.
template <class A>
bool has_shape(const A& a, std::initializer_list<npy_intp> shape, const char* name) {
    int k = 0;
    bool ok = true;
    for (npy_intp s : shape) ok &= a.shape[k++] == s;
    if (!ok) PyErr_Format(PyExc_ValueError, "ahrs: %s has the wrong shape", name);
    return ok;
}

PyObject* ahrs_run(PyObject*, PyObject* args) {
    Array<double, 2> gyr, acc, mag, Ha, Hm;
    Array<double, 1> params;
    Array<double, 1, true> q, b, stats;
    Array<double, 2, true> P, out_q, out_b;
    double dt;
    if (!PyArg_ParseTuple(args, "O&O&O&dO&O&O&O&O&O&O&O&O&:ahrs_run", convert<double, 2>, &gyr, convert<double, 2>,
                          &acc, convert<double, 2>, &mag, &dt, convert<double, 1, true>, &q, convert<double, 1, true>,
                          &b, convert<double, 2, true>, &P, convert<double, 1>, &params, convert<double, 2>, &Ha,
                          convert<double, 2>, &Hm, convert<double, 2, true>, &out_q, convert<double, 2, true>, &out_b,
                          convert<double, 1, true>, &stats))
        return nullptr;
    const npy_intp n = gyr.shape[0];
    if (!has_shape(gyr, {n, 3}, "gyr") || !has_shape(acc, {n, 3}, "acc") || !has_shape(mag, {n, 3}, "mag") ||
        !has_shape(q, {4}, "q") || !has_shape(b, {3}, "b") || !has_shape(P, {ahrs::NE, ahrs::NE}, "P") ||
        !has_shape(params, {ahrs::N_PARAMS}, "params") || !has_shape(Ha, {2, ahrs::NE}, "Ha") ||
        !has_shape(Hm, {1, ahrs::NE}, "Hm") || !has_shape(out_q, {n, 4}, "out_q") ||
        !has_shape(out_b, {n, 3}, "out_b") || !has_shape(stats, {ahrs::N_STATS}, "stats"))
        return nullptr;
    Py_BEGIN_ALLOW_THREADS;
    ahrs::run(n, gyr.data, acc.data, mag.data, dt, q.data, b.data, P.data, params.data, Ha.data, Hm.data, out_q.data,
              out_b.data, stats.data);
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

PyObject* ahrs_predict(PyObject*, PyObject* args) {
    Array<double, 1, true> q, b;
    Array<double, 2, true> P;
    double gx, gy, gz, dt, gyr_var, bias_var, scale_var;
    if (!PyArg_ParseTuple(args, "O&O&O&ddddddd:ahrs_predict", convert<double, 1, true>, &q, convert<double, 1, true>,
                          &b, convert<double, 2, true>, &P, &gx, &gy, &gz, &dt, &gyr_var, &bias_var, &scale_var))
        return nullptr;
    if (!has_shape(q, {4}, "q") || !has_shape(b, {3}, "b") || !has_shape(P, {ahrs::NE, ahrs::NE}, "P"))
        return nullptr;
    double R[9];
    ahrs::predict(q.data, b.data, P.data, gx, gy, gz, dt, gyr_var, bias_var, scale_var, R);
    Py_RETURN_NONE;
}

PyObject* ahrs_inject_and_reset(PyObject*, PyObject* args) {
    Array<double, 1, true> q, b;
    Array<double, 2, true> P;
    Array<double, 1> dx;
    if (!PyArg_ParseTuple(args, "O&O&O&O&:ahrs_inject_and_reset", convert<double, 1, true>, &q,
                          convert<double, 1, true>, &b, convert<double, 2, true>, &P, convert<double, 1>, &dx))
        return nullptr;
    if (!has_shape(q, {4}, "q") || !has_shape(b, {3}, "b") || !has_shape(P, {ahrs::NE, ahrs::NE}, "P") ||
        !has_shape(dx, {ahrs::NE}, "dx"))
        return nullptr;
    ahrs::inject_and_reset(q.data, b.data, P.data, dx.data);
    Py_RETURN_NONE;
}

PyMethodDef ahrs_methods[] = {
    {"ahrs_run", ahrs_run, METH_VARARGS,
     "ahrs_run(gyr, acc, mag, dt, q, b, P, params, Ha, Hm, out_q, out_b, stats): the AHRS over a recording "
     "(dualpose.estimation.ahrs); q, b, P, out_q, out_b, stats written in place.  The GIL is released."},
    {"ahrs_predict", ahrs_predict, METH_VARARGS,
     "ahrs_predict(q, b, P, gx, gy, gz, dt, gyr_var, bias_var, scale_var): one AHRS predict in place."},
    {"ahrs_inject_and_reset", ahrs_inject_and_reset, METH_VARARGS,
     "ahrs_inject_and_reset(q, b, P, dx): inject the error state dx (6,) and apply the reset Jacobian to P."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_ahrs(PyObject* m) {
    if (PyModule_AddFunctions(m, ahrs_methods) != 0) return false;
#define DUALPOSE_ADD(name) \
    if (PyModule_AddIntConstant(m, "AHRS_" #name, ahrs::name) != 0) return false;
    DUALPOSE_AHRS_CONSTANTS(DUALPOSE_ADD)
#undef DUALPOSE_ADD
    return true;
}

}  // namespace dualpose
