// dualpose._native's Hol22 part: hol22_run (Algorithm 1 over a recording, for
// dualpose.estimation.hol22.Hol22EKF.run) and the state offsets HOL22_* (hol22_layout.hpp).
#include "eskf_args.hpp"
#include "hol22_layout.hpp"
#include "hol22_run.hpp"

#include <cstdint>

namespace dualpose {

namespace {

PyObject* hol22_run(PyObject*, PyObject* args) {
    constexpr int N = hol22::DIM;
    Array<double, 1> t, cam_t, qdiag, gravity, intr, p_bc;
    Array<double, 2> gyro, accel, pixels, points, R_imu, Rcb;
    Array<std::int64_t, 1> offsets;
    Array<double, 1, true> x, nis;
    Array<double, 2, true> P, X;
    Array<double, 3, true> Ps;
    Array<std::int64_t, 1, true> acc;
    double sigma_px, gate;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&O&O&O&O&O&O&O&O&ddO&O&O&O&:hol22_run", convert<double, 1>, &t,
                          convert<double, 2>, &gyro, convert<double, 2>, &accel, convert<double, 1>, &cam_t,
                          convert<std::int64_t, 1>, &offsets, convert<double, 2>, &pixels, convert<double, 2>, &points,
                          convert<double, 1, true>, &x, convert<double, 2, true>, &P, convert<double, 1>, &qdiag,
                          convert<double, 1>, &gravity, convert<double, 2>, &R_imu, convert<double, 1>, &intr,
                          convert<double, 1>, &p_bc, convert<double, 2>, &Rcb, &sigma_px, &gate,
                          convert<double, 2, true>, &X, convert<double, 3, true>, &Ps, convert<double, 1, true>, &nis,
                          convert<std::int64_t, 1, true>, &acc))
        return nullptr;
    const npy_intp n = t.shape[0], nf = cam_t.shape[0], m = pixels.shape[0];
    if (n < 1) return PyErr_SetString(PyExc_ValueError, "hol22_run: no IMU samples"), nullptr;
    if (!shape_is("gyro", gyro, {n, 3}) || !shape_is("accel", accel, {n, 3}) ||
        !shape_is("offsets", offsets, {nf + 1}) || !shape_is("pixels", pixels, {m, 2}) ||
        !shape_is("points", points, {m, 3}) || !shape_is("x", x, {N}) || !shape_is("P", P, {N, N}) ||
        !shape_is("qdiag", qdiag, {N}) || !shape_is("gravity", gravity, {3}) || !shape_is("R_imu", R_imu, {6, 6}) ||
        !shape_is("intr", intr, {4}) || !shape_is("p_bc", p_bc, {3}) || !shape_is("Rcb", Rcb, {3, 3}) ||
        !shape_is("X", X, {n, N}) || !shape_is("Ps", Ps, {n, N, N}) || !shape_is("nis_out", nis, {m}) ||
        !shape_is("acc_out", acc, {m}))
        return nullptr;
    for (npy_intp j = 0; j < nf; ++j)
        if (offsets[j] < 0 || offsets[j] > offsets[j + 1] || offsets[j + 1] > m)
            return PyErr_SetString(PyExc_ValueError, "hol22_run: offsets must increase within [0, len(pixels)]"),
                   nullptr;
    const hol22::Hol22Inputs in{n,           nf,          t.data,    gyro.data,    accel.data, cam_t.data,
                                offsets.data, pixels.data, points.data, qdiag.data, gravity.data, R_imu.data,
                                intr.data,   p_bc.data,   Rcb.data,  sigma_px,     gate};
    Py_BEGIN_ALLOW_THREADS;
    hol22::run(in, x.data, P.data, X.data, Ps.data, nis.data, acc.data);
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

PyMethodDef hol22_methods[] = {
    {"hol22_run", hol22_run, METH_VARARGS,
     "hol22_run(t, gyro, accel, cam_t, offsets, pixels, points, x, P, qdiag, gravity, R_imu, intr, p_bc, Rcb, "
     "sigma_px, gate, X, Ps, nis_out, acc_out): Hol's Algorithm 1 over a recording (dualpose.estimation.hol22); x, "
     "P, X, Ps, nis_out, acc_out written in place.  The GIL is released."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_hol22(PyObject* m) {
    if (PyModule_AddFunctions(m, hol22_methods) != 0) return false;
#define DUALPOSE_ADD(name) \
    if (PyModule_AddIntConstant(m, "HOL22_" #name, hol22::name) != 0) return false;
    DUALPOSE_HOL22_CONSTANTS(DUALPOSE_ADD)
#undef DUALPOSE_ADD
    return true;
}

}  // namespace dualpose
