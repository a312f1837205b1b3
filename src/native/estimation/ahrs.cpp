// dualpose._native's AHRS part: ahrs_run (the whole recording), ahrs_predict and ahrs_inject_and_reset (one step,
// for dualpose.estimation.ahrs_filter.AhrsFilter), and the layout constants AHRS_* (ahrs_layout.hpp).
#include "eskf_args.hpp"
#include "ahrs_filter.hpp"
#include "ahrs_run.hpp"

namespace dualpose {

namespace {

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
    if (!shape_is("gyr", gyr, {n, 3}) || !shape_is("acc", acc, {n, 3}) || !shape_is("mag", mag, {n, 3}) ||
        !shape_is("q", q, {4}) || !shape_is("b", b, {3}) || !shape_is("P", P, {ahrs::NE, ahrs::NE}) ||
        !shape_is("params", params, {ahrs::N_PARAMS}) || !shape_is("Ha", Ha, {2, ahrs::NE}) ||
        !shape_is("Hm", Hm, {1, ahrs::NE}) || !shape_is("out_q", out_q, {n, 4}) ||
        !shape_is("out_b", out_b, {n, 3}) || !shape_is("stats", stats, {ahrs::N_STATS}))
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
    if (!shape_is("q", q, {4}) || !shape_is("b", b, {3}) || !shape_is("P", P, {ahrs::NE, ahrs::NE}))
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
    if (!shape_is("q", q, {4}) || !shape_is("b", b, {3}) || !shape_is("P", P, {ahrs::NE, ahrs::NE}) ||
        !shape_is("dx", dx, {ahrs::NE}))
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
