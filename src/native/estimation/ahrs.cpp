// dualpose._native's AHRS part: ahrs_run (the whole recording), the streaming filter ahrs_stream_* (one sample at a
// time on a state held in a NumPy byte buffer, for dualpose.estimation.ahrs.stream.AhrsStream), ahrs_predict and
// ahrs_inject_and_reset (one step, for dualpose.estimation.ahrs.estimator.AhrsFilter), and the layout constants AHRS_*
// (ahrs_layout.hpp).
#include "eskf_args.hpp"
#include "ahrs_filter.hpp"
#include "ahrs_run.hpp"
#include "stream_buffer.hpp"

#include <cstdint>

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
    if (!ahrs::lag_params_valid(ahrs::make_params(params.data, Ha.data, Hm.data, dt).lag)) {
        PyErr_SetString(PyExc_ValueError, "params: the time-offset search range is too long for this rate");
        return nullptr;
    }
    Py_BEGIN_ALLOW_THREADS;
    ahrs::run(n, gyr.data, acc.data, mag.data, dt, q.data, b.data, P.data, params.data, Ha.data, Hm.data, out_q.data,
              out_b.data, stats.data);
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

constexpr stream::Kind stream_kind{ahrs::STREAM_MAGIC, ahrs::STREAM_VERSION, "AHRS stream", "an AHRS stream state",
                                    "O|s:ahrs_stream_check"};

// The bytes of an AHRS stream with the constants held by s: the struct and the rings after it (the constants come
// from the buffer: the ring lengths are bounded before the size is computed from them); 0 when they are inconsistent.
std::uint64_t stream_bytes_of(const ahrs::Stream& st) {
    const ahrs::Params& p = st.p;
    const bool sane = st.h.n_win >= 1 && st.h.n_win <= (1ULL << 40) &&
                      p.n_win == static_cast<std::int64_t>(st.h.n_win) && ahrs::lag_params_valid(p.lag) &&
                      ahrs::rest_params_valid(p.rest) &&
                      st.h.n_ring == static_cast<std::uint64_t>(ahrs::ring_doubles(p));
    return sane ? ahrs::stream_bytes(ahrs::ring_doubles(p)) : 0;
}

ahrs::Stream* stream_arg(PyObject* o, bool write) {
    return stream::stream_of<ahrs::Stream>(o, "state", write, stream_kind, stream_bytes_of);
}

PyObject* ahrs_stream_new(PyObject*, PyObject* args) {
    Array<double, 1> params, q, b;
    Array<double, 2> Ha, Hm, P;
    double dt;
    if (!PyArg_ParseTuple(args, "O&O&O&dO&O&O&:ahrs_stream_new", convert<double, 1>, &params, convert<double, 2>,
                          &Ha, convert<double, 2>, &Hm, &dt, convert<double, 1>, &q, convert<double, 1>, &b,
                          convert<double, 2>, &P))
        return nullptr;
    if (!shape_is("params", params, {ahrs::N_PARAMS}) || !shape_is("Ha", Ha, {2, ahrs::NE}) ||
        !shape_is("Hm", Hm, {1, ahrs::NE}) || !shape_is("q", q, {4}) || !shape_is("b", b, {3}) ||
        !shape_is("P", P, {ahrs::NE, ahrs::NE}))
        return nullptr;
    const ahrs::Params p = ahrs::make_params(params.data, Ha.data, Hm.data, dt);
    if (p.n_win > (std::int64_t{1} << 40)) {
        PyErr_SetString(PyExc_ValueError, "params: the window is too long");
        return nullptr;
    }
    if (!ahrs::lag_params_valid(p.lag)) {
        PyErr_SetString(PyExc_ValueError, "params: the time-offset search range is too long for this rate");
        return nullptr;
    }
    if (!ahrs::rest_params_valid(p.rest)) {
        PyErr_SetString(PyExc_ValueError, "params: the rest window is too long");
        return nullptr;
    }
    PyObject* out = stream::new_buffer<ahrs::Stream>(stream_kind, ahrs::stream_bytes(ahrs::ring_doubles(p)));
    if (out == nullptr) return nullptr;
    auto* st = static_cast<ahrs::Stream*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(out)));
    st->h.n_win = static_cast<std::uint64_t>(p.n_win);
    st->h.n_ring = static_cast<std::uint64_t>(ahrs::ring_doubles(p));
    st->p = p;
    ahrs::init_state(st->s, st->ring(), p, q.data, b.data, P.data);
    return out;
}

PyObject* ahrs_stream_step(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "ahrs_stream_step(state, gyr, acc, mag) takes 4 arguments");
        return nullptr;
    }
    ahrs::Stream* st = stream_arg(args[0], true);
    if (st == nullptr) return nullptr;
    double g[3], a[3], m[3];
    if (!stream::read3(args[1], "gyro", g) || !stream::read3(args[2], "accel", a) ||
        !stream::read3(args[3], "mag", m, true))
        return nullptr;
    ahrs::step(st->s, st->ring(), st->p, g, a, m);
    return stream::new_vector(st->s.q, 4);
}

PyObject* ahrs_stream_run(PyObject*, PyObject* args) {
    PyObject* state;
    Array<double, 2> gyr, acc, mag;
    Array<double, 2, true> out_q, out_b;
    if (!PyArg_ParseTuple(args, "OO&O&O&O&O&:ahrs_stream_run", &state, convert<double, 2>, &gyr, convert<double, 2>,
                          &acc, convert<double, 2>, &mag, convert<double, 2, true>, &out_q, convert<double, 2, true>,
                          &out_b))
        return nullptr;
    ahrs::Stream* st = stream_arg(state, true);
    if (st == nullptr) return nullptr;
    const npy_intp n = gyr.shape[0];
    if (!shape_is("gyr", gyr, {n, 3}) || !shape_is("acc", acc, {n, 3}) || !shape_is("mag", mag, {n, 3}) ||
        !shape_is("out_q", out_q, {n, 4}) || !shape_is("out_b", out_b, {n, 3}))
        return nullptr;
    Py_BEGIN_ALLOW_THREADS;
    for (npy_intp k = 0; k < n; ++k) {
        ahrs::step(st->s, st->ring(), st->p, gyr.data + 3 * k, acc.data + 3 * k, mag.data + 3 * k);
        for (int i = 0; i < 4; ++i) out_q.data[4 * k + i] = st->s.q[i];
        for (int i = 0; i < 3; ++i) out_b.data[3 * k + i] = st->s.b[i];
    }
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

PyObject* ahrs_rest_run(PyObject*, PyObject* args) {
    Array<double, 2> gyr, acc, mag;
    int use_mag;
    Array<double, 1, true> sums;
    Array<double, 2, true> out_q, out_b;
    if (!PyArg_ParseTuple(args, "O&O&O&pO&O&O&:ahrs_rest_run", convert<double, 2>, &gyr, convert<double, 2>, &acc,
                          convert<double, 2>, &mag, &use_mag, convert<double, 1, true>, &sums,
                          convert<double, 2, true>, &out_q, convert<double, 2, true>, &out_b))
        return nullptr;
    const npy_intp n = gyr.shape[0];
    if (!shape_is("gyr", gyr, {n, 3}) || !shape_is("acc", acc, {n, 3}) || !shape_is("mag", mag, {n, 3}) ||
        !shape_is("sums", sums, {10}) || !shape_is("out_q", out_q, {n, 4}) || !shape_is("out_b", out_b, {n, 3}))
        return nullptr;
    ahrs::rest_run(n, gyr.data, acc.data, mag.data, use_mag != 0, sums.data, out_q.data, out_b.data);
    Py_RETURN_NONE;
}

PyObject* ahrs_stream_get(PyObject*, PyObject* args) {
    PyObject* state;
    if (!PyArg_ParseTuple(args, "O:ahrs_stream_get", &state)) return nullptr;
    const ahrs::Stream* st = stream_arg(state, false);
    if (st == nullptr) return nullptr;
    return Py_BuildValue("NNNN", stream::new_vector(st->s.q, 4), stream::new_vector(st->s.b, 3),
                         stream::new_vector(st->s.P, ahrs::NE * ahrs::NE),
                         stream::new_vector(st->s.stats, ahrs::N_STATS));
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
    {"ahrs_stream_new", ahrs_stream_new, METH_VARARGS,
     "ahrs_stream_new(params, Ha, Hm, dt, q, b, P) -> state: a new AHRS stream (numpy.uint8 array holding the layout "
     "version, the constants, the state and the sliding window) before its first sample."},
    {"ahrs_stream_step", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(ahrs_stream_step)), METH_FASTCALL,
     "ahrs_stream_step(state, gyr, acc, mag) -> q (4,): one sample (the step of ahrs_run); mag may be None (6D)."},
    {"ahrs_stream_run", ahrs_stream_run, METH_VARARGS,
     "ahrs_stream_run(state, gyr, acc, mag, out_q, out_b): ahrs_stream_step over n samples; out_q (n, 4), out_b (n, 3) "
     "written.  The GIL is released."},
    {"ahrs_rest_run", ahrs_rest_run, METH_VARARGS,
     "ahrs_rest_run(gyr, acc, mag, use_mag, sums, out_q, out_b): the causal outputs inside the rest period (running "
     "means; sums (10,) updated in place, out_q (n, 4), out_b (n, 3) written)."},
    {"ahrs_stream_get", ahrs_stream_get, METH_VARARGS,
     "ahrs_stream_get(state) -> (q (4,), b (3,), P (36,), stats (N_STATS,)): copies of the stream's state."},
    {"ahrs_stream_check", stream::check<ahrs::Stream, stream_kind, stream_bytes_of>, METH_VARARGS,
     "ahrs_stream_check(state, name='state'): ValueError naming `name` unless state is an AHRS stream of this "
     "layout version and size."},
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
    DUALPOSE_ADD(STREAM_VERSION)
#undef DUALPOSE_ADD
    return true;
}

}  // namespace dualpose
