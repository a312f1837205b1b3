// dualpose._native's Hol22 part: hol22_run (Algorithm 1 over a recording, for dualpose.estimation.hol22.Hol22EKF.run),
// the streaming filter hol22_stream_* (one sample / frame at a time on a state held in a NumPy byte buffer, for
// dualpose.estimation.hol22.Hol22Stream) and the state offsets HOL22_* (hol22_layout.hpp).
#include "eskf_args.hpp"
#include "hol22_layout.hpp"
#include "hol22_run.hpp"
#include "stream_buffer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace dualpose {

namespace {

using namespace hol22;
constexpr int N = DIM;
using V1 = Array<double, 1>;
using V1w = Array<double, 1, true>;
using M2 = Array<double, 2>;
using M2w = Array<double, 2, true>;
using T3w = Array<double, 3, true>;
using I1w = Array<std::int64_t, 1, true>;
constexpr auto cv1 = convert<double, 1>;
constexpr auto cv1w = convert<double, 1, true>;
constexpr auto cm2 = convert<double, 2>;
constexpr auto cm2w = convert<double, 2, true>;
constexpr auto ct3w = convert<double, 3, true>;
constexpr auto ci1 = convert<std::int64_t, 1>;
constexpr auto ci1w = convert<std::int64_t, 1, true>;

// The constants qdiag (22,), gravity (3,), R_imu (6, 6), scale2 (2,), intr (4,), p_bc (3,), Rcb (3, 3).
struct ConfigArrays {
    V1 qdiag, gravity, scale2, intr, p_bc;
    M2 R_imu, Rcb;
    bool ok() const {
        return shape_is("qdiag", qdiag, {N}) && shape_is("gravity", gravity, {3}) &&
               shape_is("R_imu", R_imu, {6, 6}) && shape_is("scale2", scale2, {2}) && shape_is("intr", intr, {4}) &&
               shape_is("p_bc", p_bc, {3}) &&
               shape_is("Rcb", Rcb, {3, 3});
    }
    Config config(double sigma_px, double gate) const {
        Config c{};
        std::copy(qdiag.data, qdiag.data + N, c.qdiag);
        std::copy(gravity.data, gravity.data + 3, c.gravity);
        std::copy(R_imu.data, R_imu.data + 36, c.R_imu);
        std::copy(scale2.data, scale2.data + 2, c.scale2);
        std::copy(intr.data, intr.data + 4, c.intr);
        std::copy(p_bc.data, p_bc.data + 3, c.p_bc);
        std::copy(Rcb.data, Rcb.data + 9, c.Rcb);
        c.sigma_px = sigma_px;
        c.gate = gate;
        return c;
    }
};

PyObject* hol22_run(PyObject*, PyObject* args) {
    BlockArrays ba;
    ConfigArrays ca;
    V1w x, nis;
    M2w P, X;
    T3w Ps;
    I1w acc;
    double sigma_px, gate;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&O&O&O&O&O&O&O&O&O&ddO&O&O&O&:hol22_run", cv1, &ba.t, cm2, &ba.gyro, cm2,
                          &ba.accel, cv1, &ba.cam_t, ci1, &ba.offsets, cm2, &ba.pixels, cm2, &ba.points, cv1w, &x,
                          cm2w, &P, cv1, &ca.qdiag, cv1, &ca.gravity, cm2, &ca.R_imu, cv1, &ca.scale2, cv1, &ca.intr,
                          cv1, &ca.p_bc,
                          cm2, &ca.Rcb, &sigma_px, &gate, cm2w, &X, ct3w, &Ps, cv1w, &nis, ci1w, &acc))
        return nullptr;
    const npy_intp n = ba.t.shape[0], m = ba.pixels.shape[0];
    if (n < 1) return PyErr_SetString(PyExc_ValueError, "hol22_run: no IMU samples"), nullptr;
    SensorBlock b;
    if (!block_of(ba, b) || !shape_is("x", x, {N}) || !shape_is("P", P, {N, N}) || !ca.ok() ||
        !shape_is("X", X, {n, N}) || !shape_is("Ps", Ps, {n, N, N}) || !shape_is("nis_out", nis, {m}) ||
        !shape_is("acc_out", acc, {m}))
        return nullptr;
    const Config c = ca.config(sigma_px, gate);
    Py_BEGIN_ALLOW_THREADS;
    hol22::run(b, c, x.data, P.data, X.data, Ps.data, nis.data, acc.data);
    Py_END_ALLOW_THREADS;
    Py_RETURN_NONE;
}

// ---- the streaming filter: the state in one numpy.uint8 buffer

constexpr stream::Kind stream_kind{STREAM_MAGIC, STREAM_VERSION, "Hol22 stream", "a Hol22 stream state",
                                    "O|s:hol22_stream_check"};

Stream* stream_arg(PyObject* o, bool write) { return stream::stream_of<Stream>(o, "state", write, stream_kind); }

PyObject* stream_new(PyObject*, PyObject* args) {
    V1 x;
    M2 P;
    ConfigArrays ca;
    double sigma_px, gate;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&O&O&dd:hol22_stream_new", cv1, &x, cm2, &P, cv1, &ca.qdiag, cv1,
                          &ca.gravity, cm2, &ca.R_imu, cv1, &ca.scale2, cv1, &ca.intr, cv1, &ca.p_bc, cm2, &ca.Rcb, &sigma_px, &gate))
        return nullptr;
    if (!shape_is("x", x, {N}) || !shape_is("P", P, {N, N}) || !ca.ok()) return nullptr;
    PyObject* out = stream::new_buffer<Stream>(stream_kind);
    if (out == nullptr) return nullptr;
    auto* s = static_cast<Stream*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(out)));
    s->c = ca.config(sigma_px, gate);
    init_filter(s->f, x.data, P.data);
    return out;
}

// hol22_stream_imu(state, t, gyro, accel) -> x (22,)
PyObject* stream_imu(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
    double t, g[3], a[3];
    Stream* s = stream::imu_args<Stream>(args, nargs, "hol22_stream_imu(state, t, gyro, accel)", stream_kind, t, g, a);
    if (s == nullptr) return nullptr;
    if (!std::isfinite(t) || (s->f.samples > 0 && !(t > s->f.t_imu))) return stream::time_error(t, s->f.t_imu);
    if (s->f.started && t < s->f.tc) return stream::time_error(t, s->f.tc);
    imu_step(s->f, s->c, t, g, a);
    return stream::new_vector(s->f.x, N);
}

// hol22_stream_frame(state, tj, pixels, points, nis, accepted) -> int (the number accepted)
PyObject* stream_frame(PyObject*, PyObject* args) {
    PyObject* state;
    double tj;
    stream::FrameArgs fa;
    if (!PyArg_ParseTuple(args, "OdO&O&O&O&:hol22_stream_frame", &state, &tj, cm2, &fa.pixels, cm2, &fa.points, cv1w,
                          &fa.nis, ci1w, &fa.acc))
        return nullptr;
    Stream* s = stream_arg(state, true);
    if (s == nullptr || !fa.ok()) return nullptr;
    if (!std::isfinite(tj) || (s->f.started && tj < s->f.tc)) return stream::time_error(tj, s->f.tc);
    const npy_intp m = fa.pixels.shape[0];
    frame_step(s->f, s->c, tj, fa.pixels.data, fa.points.data, m, fa.nis.data, fa.acc.data);
    std::int64_t n_acc = 0;
    for (npy_intp k = 0; k < m; ++k) n_acc += fa.acc.data[k];
    return PyLong_FromLongLong(n_acc);
}

// hol22_stream_run(state, t, gyro, accel, cam_t, offsets, pixels, points, X, Ps, nis, accepted) -> int: feed a block
// (Ps may be None); returns the frames consumed.
PyObject* stream_run(PyObject*, PyObject* args) {
    stream::BlockRun r;
    Stream* s = stream::block_run_args<Stream>(args, "OO&O&O&O&O&O&O&O&OO&O&:hol22_stream_run", stream_kind, N, N, r);
    if (s == nullptr) return nullptr;
    std::int64_t used;
    Py_BEGIN_ALLOW_THREADS;
    used = feed(s->f, s->c, r.b, r.X, r.Ps, r.nis, r.acc);
    Py_END_ALLOW_THREADS;
    return PyLong_FromLongLong(used);
}

// hol22_stream_get(state) -> (x (22,), P (484,), t_imu, tc, samples)
PyObject* stream_get(PyObject*, PyObject* args) {
    PyObject* state;
    if (!PyArg_ParseTuple(args, "O:hol22_stream_get", &state)) return nullptr;
    const Stream* s = stream_arg(state, false);
    if (s == nullptr) return nullptr;
    return Py_BuildValue("NNddL", stream::new_vector(s->f.x, N), stream::new_vector(s->f.P, N * N), s->f.t_imu,
                         s->f.tc, static_cast<long long>(s->f.samples));
}

PyMethodDef hol22_methods[] = {
    {"hol22_run", hol22_run, METH_VARARGS,
     "hol22_run(t, gyro, accel, cam_t, offsets, pixels, points, x, P, qdiag, gravity, R_imu, scale2, intr, p_bc, Rcb, "
     "sigma_px, gate, X, Ps, nis_out, acc_out): Hol's Algorithm 1 over a recording (dualpose.estimation.hol22); x, "
     "P, X, Ps, nis_out, acc_out written in place.  The GIL is released."},
    {"hol22_stream_new", stream_new, METH_VARARGS,
     "hol22_stream_new(x, P, qdiag, gravity, R_imu, scale2, intr, p_bc, Rcb, sigma_px, gate) -> state: a new Hol22 "
     "stream "
     "(numpy.uint8 array: layout header, constants, filter state) before its first sample."},
    {"hol22_stream_imu", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(stream_imu)), METH_FASTCALL,
     "hol22_stream_imu(state, t, gyro, accel) -> x (22,): one IMU sample (time update, IMU update)."},
    {"hol22_stream_frame", stream_frame, METH_VARARGS,
     "hol22_stream_frame(state, tj, pixels, points, nis, accepted) -> int: one camera frame at tj (time update, "
     "camera update); returns the number accepted."},
    {"hol22_stream_run", stream_run, METH_VARARGS,
     "hol22_stream_run(state, t, gyro, accel, cam_t, offsets, pixels, points, X, Ps, nis, accepted) -> int: the "
     "steps over a block (Ps may be None); returns the number of frames consumed.  The GIL is released."},
    {"hol22_stream_get", stream_get, METH_VARARGS,
     "hol22_stream_get(state) -> (x (22,), P (484,), t_imu, tc, samples): copies of the stream's state (t_imu: "
     "the last IMU sample's time)."},
    {"hol22_stream_check", stream::check<Stream, stream_kind>, METH_VARARGS,
     "hol22_stream_check(state, name='state'): ValueError naming `name` unless state is a Hol22 stream of this "
     "layout version and size."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_hol22(PyObject* m) {
    if (PyModule_AddFunctions(m, hol22_methods) != 0) return false;
#define DUALPOSE_ADD(name) \
    if (PyModule_AddIntConstant(m, "HOL22_" #name, hol22::name) != 0) return false;
    DUALPOSE_HOL22_CONSTANTS(DUALPOSE_ADD)
    DUALPOSE_ADD(STREAM_VERSION)
#undef DUALPOSE_ADD
    return true;
}

}  // namespace dualpose
