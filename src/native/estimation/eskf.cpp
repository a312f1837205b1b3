// Python entry points of the error-state filter (add_eskf): dualpose._native.eskf_*, used by
// dualpose.estimation.eskf and .models.  Arrays are checked here (dtype, C-contiguity, shapes); the kernels are in
// eskf_kernels.hpp, updates.hpp and eskf_run.cpp.
#include "eskf_args.hpp"
#include "eskf_kernels.hpp"
#include "eskf_run.hpp"
#include "stream_buffer.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace dualpose {
namespace {

using namespace eskf;
using V1 = Array<double, 1>;
using V1w = Array<double, 1, true>;
using M2 = Array<double, 2>;
using M2w = Array<double, 2, true>;
using T3 = Array<double, 3>;
using T3w = Array<double, 3, true>;
using I1 = Array<std::int64_t, 1>;
using I1w = Array<std::int64_t, 1, true>;
constexpr auto cv1 = convert<double, 1>;
constexpr auto cv1w = convert<double, 1, true>;
constexpr auto cm2 = convert<double, 2>;
constexpr auto cm2w = convert<double, 2, true>;
constexpr auto ct3w = convert<double, 3, true>;
constexpr auto ci1 = convert<std::int64_t, 1>;
constexpr auto ci1w = convert<std::int64_t, 1, true>;

bool state_ok(const V1w& x, const M2w& P) { return shape_is("x", x, {NX}) && shape_is("P", P, {NE, NE}); }

bool config_ok(const V1& gravity, const V1& noise, const V1& intr, const V1& q_bc, const V1& p_bc) {
    return shape_is("gravity", gravity, {3}) && shape_is("noise", noise, {6}) && shape_is("intr", intr, {4}) &&
           shape_is("q_bc", q_bc, {4}) && shape_is("p_bc", p_bc, {3});
}

Config make_config(const V1& gravity, const V1& noise, const V1& intr, const V1& q_bc, const V1& p_bc,
                   double sigma_px, double gate) {
    Config c{};
    std::copy(gravity.data, gravity.data + 3, c.gravity);
    std::copy(noise.data, noise.data + 6, c.noise);
    std::copy(intr.data, intr.data + 4, c.intr);
    std::copy(q_bc.data, q_bc.data + 4, c.q_bc);
    std::copy(p_bc.data, p_bc.data + 3, c.p_bc);
    c.sigma_px = sigma_px;
    c.gate = gate;
    return c;
}

bool camera_ok(const V1& intr, const V1& q_bc, const V1& p_bc, const M2& pixels, const M2& points) {
    return shape_is("intr", intr, {4}) && shape_is("q_bc", q_bc, {4}) && shape_is("p_bc", p_bc, {3}) &&
           shape_is("pixels", pixels, {-1, 2}) && shape_is("points", points, {pixels.shape[0], 3});
}

// eskf_predict(x, P, gyro, accel, dt, gravity, noise) and eskf_predict_transition(..., F): the same step, the
// transition written to F (15, 15) only by the latter.
template <bool TRANSITION>
PyObject* py_predict(PyObject*, PyObject* args) {
    V1w x;
    M2w P, F;
    V1 gyro, accel, gravity, noise;
    double dt;
    const bool parsed =
        TRANSITION ? PyArg_ParseTuple(args, "O&O&O&O&dO&O&O&:eskf_predict_transition", cv1w, &x, cm2w, &P, cv1, &gyro,
                                      cv1, &accel, &dt, cv1, &gravity, cv1, &noise, cm2w, &F)
                   : PyArg_ParseTuple(args, "O&O&O&O&dO&O&:eskf_predict", cv1w, &x, cm2w, &P, cv1, &gyro, cv1, &accel,
                                      &dt, cv1, &gravity, cv1, &noise);
    if (!parsed || !state_ok(x, P) || !shape_is("gyro", gyro, {3}) || !shape_is("accel", accel, {3}) ||
        !shape_is("gravity", gravity, {3}) || !shape_is("noise", noise, {6}) ||
        (TRANSITION && !shape_is("F", F, {NE, NE})))
        return nullptr;
    double scratch[NE * NE];
    predict_transition(x.data, P.data, gyro.data, accel.data, dt, gravity.data, noise.data,
                       TRANSITION ? F.data : scratch);
    Py_RETURN_NONE;
}

PyObject* py_camera_batch(PyObject*, PyObject* args) {
    V1 x, intr, q_bc, p_bc;
    M2 pixels, points;
    M2w r;
    T3w H;
    V1w depth;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&O&O&:eskf_camera_batch", cv1, &x, cv1, &intr, cv1, &q_bc, cv1, &p_bc,
                          cm2, &pixels, cm2, &points, cm2w, &r, ct3w, &H, cv1w, &depth))
        return nullptr;
    const npy_intp m = pixels.shape[0];
    if (!shape_is("x", x, {NX}) || !camera_ok(intr, q_bc, p_bc, pixels, points) || !shape_is("r", r, {m, 2}) ||
        !shape_is("H", H, {m, 2, NE}) || !shape_is("depth", depth, {m}))
        return nullptr;
    camera_batch(x.data, intr.data, q_bc.data, p_bc.data, pixels.data, points.data, m, r.data, H.data, depth.data);
    Py_RETURN_NONE;
}

PyObject* py_inject_reset(PyObject*, PyObject* args) {
    V1w x;
    M2w P;
    V1 dx;
    if (!PyArg_ParseTuple(args, "O&O&O&:eskf_inject_reset", cv1w, &x, cm2w, &P, cv1, &dx)) return nullptr;
    if (!state_ok(x, P) || !shape_is("dx", dx, {NE})) return nullptr;
    inject_reset(x.data, P.data, dx.data);
    Py_RETURN_NONE;
}

PyObject* py_joseph(PyObject*, PyObject* args) {
    M2w P;
    M2 K, H, R;
    if (!PyArg_ParseTuple(args, "O&O&O&O&:eskf_joseph", cm2w, &P, cm2, &K, cm2, &H, cm2, &R)) return nullptr;
    const npy_intp m = H.shape[0];
    if (!shape_is("P", P, {NE, NE}) || !shape_is("H", H, {-1, NE}) || !shape_is("K", K, {NE, m}) ||
        !shape_is("R", R, {m, m}))
        return nullptr;
    joseph<NE>(P.data, K.data, H.data, R.data, static_cast<int>(m));
    Py_RETURN_NONE;
}

PyObject* py_joseph_2d(PyObject*, PyObject* args) {
    M2w P;
    M2 K, H;
    double s2;
    if (!PyArg_ParseTuple(args, "O&O&O&d:eskf_joseph_2d", cm2w, &P, cm2, &K, cm2, &H, &s2)) return nullptr;
    if (!shape_is("P", P, {NE, NE}) || !shape_is("K", K, {NE, 2}) || !shape_is("H", H, {2, NE})) return nullptr;
    joseph_2d<NE>(P.data, K.data, H.data, s2);
    Py_RETURN_NONE;
}

PyObject* py_update_points(PyObject*, PyObject* args) {
    V1w x, nis;
    M2w P;
    V1 intr, q_bc, p_bc;
    M2 pixels, points;
    double sigma_px, gate;
    I1w acc;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&ddO&O&:eskf_update_points", cv1w, &x, cm2w, &P, cv1, &intr, cv1, &q_bc,
                          cv1, &p_bc, cm2, &pixels, cm2, &points, &sigma_px, &gate, cv1w, &nis, ci1w, &acc))
        return nullptr;
    const npy_intp m = pixels.shape[0];
    if (!state_ok(x, P) || !camera_ok(intr, q_bc, p_bc, pixels, points) || !shape_is("nis_out", nis, {m}) ||
        !shape_is("accepted_out", acc, {m}))
        return nullptr;
    std::int64_t n_acc;
    Py_BEGIN_ALLOW_THREADS
    n_acc = update_points(x.data, P.data, intr.data, q_bc.data, p_bc.data, pixels.data, points.data, m, sigma_px,
                          gate, nis.data, acc.data);
    Py_END_ALLOW_THREADS
    return PyLong_FromLongLong(n_acc);
}

// Batch update with residual r (m,), Jacobian H (m, 15), noise R (m, m); returns the NIS rᵀ S⁻¹ r.
PyObject* py_update_dense(PyObject*, PyObject* args) {
    V1w x;
    M2w P;
    V1 r;
    M2 H, R;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&:eskf_update_dense", cv1w, &x, cm2w, &P, cv1, &r, cm2, &H, cm2, &R))
        return nullptr;
    const npy_intp m = r.shape[0];
    if (!state_ok(x, P) || !shape_is("H", H, {m, NE}) || !shape_is("R", R, {m, m})) return nullptr;
    const double* Pm = P.data;
    std::vector<double> HP(m * NE), S(m * m), Si(m * m, 0.0), PHt(NE * m), K(NE * m);
    std::vector<int> piv(m);
    for (npy_intp i = 0; i < m; ++i)  // S = (H P) Hᵀ + R
        for (int j = 0; j < NE; ++j) {
            double s = 0.0;
            for (int k = 0; k < NE; ++k) s += H.data[i * NE + k] * Pm[k * NE + j];
            HP[i * NE + j] = s;
        }
    for (npy_intp i = 0; i < m; ++i)
        for (npy_intp l = 0; l < m; ++l) {
            double s = 0.0;
            for (int j = 0; j < NE; ++j) s += HP[i * NE + j] * H.data[l * NE + j];
            S[i * m + l] = s + R.data[i * m + l];
        }
    if (!all_finite(S.data(), m * m)) return raise_linalg_error(not_finite_message);
    for (npy_intp i = 0; i < m; ++i) Si[i * m + i] = 1.0;
    if (!lu_factor(S.data(), static_cast<int>(m), piv.data())) return raise_linalg_error(singular_message);
    lu_solve(S.data(), piv.data(), static_cast<int>(m), Si.data(), static_cast<int>(m));  // S⁻¹
    double nis = 0.0;
    for (npy_intp i = 0; i < m; ++i) {
        double s = 0.0;
        for (npy_intp j = 0; j < m; ++j) s += Si[i * m + j] * r.data[j];
        nis += r.data[i] * s;
    }
    for (int i = 0; i < NE; ++i)  // K = (P Hᵀ) S⁻¹
        for (npy_intp l = 0; l < m; ++l) {
            double s = 0.0;
            for (int k = 0; k < NE; ++k) s += Pm[i * NE + k] * H.data[l * NE + k];
            PHt[i * m + l] = s;
        }
    for (int i = 0; i < NE; ++i)
        for (npy_intp c = 0; c < m; ++c) {
            double s = 0.0;
            for (npy_intp l = 0; l < m; ++l) s += PHt[i * m + l] * Si[l * m + c];
            K[i * m + c] = s;
        }
    double dx[NE];
    for (int i = 0; i < NE; ++i) {
        double s = 0.0;
        for (npy_intp l = 0; l < m; ++l) s += K[i * m + l] * r.data[l];
        dx[i] = s;
    }
    joseph<NE>(P.data, K.data(), H.data, R.data, static_cast<int>(m));
    inject_reset(x.data, P.data, dx);
    return PyFloat_FromDouble(nis);
}

// Parse the 22 arguments of eskf_run (and the 8 node arrays of eskf_run_recorded when rec is given).
bool parse_run(PyObject* args, const char* fmt, RunArgs& a, NodeRecord* rec) {
    BlockArrays ba;
    V1 gravity, noise, intr, q_bc, p_bc;
    V1w x, nis;
    M2w P, X, XF;
    T3w Ps, PF;
    I1w acc;
    M2w XA, XB;
    T3w PA, PB, FS;
    V1w TN;
    I1w imu_node, frame_node;
    double sigma_px, gate;
    bool ok = rec ? PyArg_ParseTuple(args, fmt, cv1, &ba.t, cm2, &ba.gyro, cm2, &ba.accel, cv1, &ba.cam_t, ci1,
                                     &ba.offsets, cm2, &ba.pixels, cm2, &ba.points, cv1w, &x, cm2w, &P, cv1, &gravity,
                                     cv1, &noise, cv1, &intr, cv1, &q_bc, cv1, &p_bc, &sigma_px, &gate, cm2w, &X,
                                     ct3w, &Ps, cm2w, &XF, ct3w, &PF, cv1w, &nis, ci1w, &acc, cm2w, &XA, ct3w, &PA,
                                     cm2w, &XB, ct3w, &PB, ct3w, &FS, cv1w, &TN, ci1w, &imu_node, ci1w, &frame_node)
                  : PyArg_ParseTuple(args, fmt, cv1, &ba.t, cm2, &ba.gyro, cm2, &ba.accel, cv1, &ba.cam_t, ci1,
                                     &ba.offsets, cm2, &ba.pixels, cm2, &ba.points, cv1w, &x, cm2w, &P, cv1, &gravity,
                                     cv1, &noise, cv1, &intr, cv1, &q_bc, cv1, &p_bc, &sigma_px, &gate, cm2w, &X,
                                     ct3w, &Ps, cm2w, &XF, ct3w, &PF, cv1w, &nis, ci1w, &acc);
    if (!ok) return false;
    const npy_intp n = ba.t.shape[0], nf = ba.cam_t.shape[0], m = ba.pixels.shape[0];
    if (n < 1) {
        PyErr_SetString(PyExc_ValueError, "t must hold at least one IMU sample");
        return false;
    }
    if (!block_of(ba, a.b) || !state_ok(x, P) || !config_ok(gravity, noise, intr, q_bc, p_bc) ||
        !shape_is("X", X, {n, NX}) || !shape_is("Ps", Ps, {n, NE, NE}) || !shape_is("XF", XF, {nf, NX}) ||
        !shape_is("PF", PF, {nf, NE, NE}) || !shape_is("nis_out", nis, {m}) || !shape_is("accepted_out", acc, {m}))
        return false;
    if (rec) {
        const npy_intp k = XA.shape[0];
        if (k < n + nf) {
            PyErr_Format(PyExc_ValueError, "the node arrays must hold at least N + F = %zd nodes; got %zd",
                         static_cast<Py_ssize_t>(n + nf), static_cast<Py_ssize_t>(k));
            return false;
        }
        if (!shape_is("XA", XA, {k, NX}) || !shape_is("PA", PA, {k, NE, NE}) || !shape_is("XB", XB, {k, NX}) ||
            !shape_is("PB", PB, {k, NE, NE}) || !shape_is("FS", FS, {k, NE, NE}) || !shape_is("TN", TN, {k}) ||
            !shape_is("imu_node", imu_node, {n}) || !shape_is("frame_node", frame_node, {nf}))
            return false;
        *rec = {XA.data, PA.data, XB.data, PB.data, FS.data, TN.data, imu_node.data, frame_node.data};
    }
    a.x = x.data;
    a.P = P.data;
    a.c = make_config(gravity, noise, intr, q_bc, p_bc, sigma_px, gate);
    a.o = Outputs{X.data, Ps.data, XF.data, PF.data, nis.data, acc.data};
    return true;
}

PyObject* py_run(PyObject*, PyObject* args) {
    RunArgs a;
    if (!parse_run(args, "O&O&O&O&O&O&O&O&O&O&O&O&O&O&ddO&O&O&O&O&O&:eskf_run", a, nullptr)) return nullptr;
    Py_BEGIN_ALLOW_THREADS
    eskf::run(a, nullptr);
    Py_END_ALLOW_THREADS
    Py_RETURN_NONE;
}

PyObject* py_run_recorded(PyObject*, PyObject* args) {
    RunArgs a;
    NodeRecord rec;
    if (!parse_run(args, "O&O&O&O&O&O&O&O&O&O&O&O&O&O&ddO&O&O&O&O&O&O&O&O&O&O&O&O&O&:eskf_run_recorded", a, &rec))
        return nullptr;
    std::int64_t k;
    Py_BEGIN_ALLOW_THREADS
    k = eskf::run(a, &rec);
    Py_END_ALLOW_THREADS
    return PyLong_FromLongLong(k);
}

// ---- the streaming filter (dualpose.estimation.eskf.EskfStream): the state in one numpy.uint8 buffer

constexpr stream::Kind stream_kind{STREAM_MAGIC, STREAM_VERSION, "ESKF stream", "an ESKF stream state",
                                    "O|s:eskf_stream_check"};

Stream* stream_arg(PyObject* o, bool write) { return stream::stream_of<Stream>(o, "state", write, stream_kind); }

PyObject* py_stream_new(PyObject*, PyObject* args) {
    V1 x, gravity, noise, intr, q_bc, p_bc;
    M2 P;
    double sigma_px, gate;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&O&dd:eskf_stream_new", cv1, &x, cm2, &P, cv1, &gravity, cv1, &noise,
                          cv1, &intr, cv1, &q_bc, cv1, &p_bc, &sigma_px, &gate))
        return nullptr;
    if (!shape_is("x", x, {NX}) || !shape_is("P", P, {NE, NE}) || !config_ok(gravity, noise, intr, q_bc, p_bc))
        return nullptr;
    PyObject* out = stream::new_buffer<Stream>(stream_kind);
    if (out == nullptr) return nullptr;
    auto* s = static_cast<Stream*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(out)));
    s->c = make_config(gravity, noise, intr, q_bc, p_bc, sigma_px, gate);
    init_filter(s->f, x.data, P.data);
    return out;
}

// eskf_stream_imu(state, t, gyro, accel) -> x (16,): the IMU sample at t (after the frames up to t were given).
PyObject* py_stream_imu(PyObject*, PyObject* const* args, Py_ssize_t nargs) {
    double t, g[3], a[3];
    Stream* s = stream::imu_args<Stream>(args, nargs, "eskf_stream_imu(state, t, gyro, accel)", stream_kind, t, g, a);
    if (s == nullptr) return nullptr;
    if (!std::isfinite(t) || (s->f.samples > 0 && !(t > s->f.t0))) return stream::time_error(t, s->f.t0);
    double F[NE * NE];
    if (s->f.samples == 0)
        start(s->f, t, g, a);
    else
        finish_interval(s->f, s->c, t, g, a, F);
    return stream::new_vector(s->f.x, NX);
}

using stream::FrameArgs;

// eskf_stream_frame(state, tj, t1, g1, a1, pixels, points, nis, accepted) -> int: predict to the frame time tj
// with the input interpolated towards the next IMU sample (t1, g1, a1), then the camera update.
PyObject* py_stream_frame(PyObject*, PyObject* args) {
    PyObject *state, *go, *ao;
    double tj, t1;
    FrameArgs fa;
    if (!PyArg_ParseTuple(args, "OddOOO&O&O&O&:eskf_stream_frame", &state, &tj, &t1, &go, &ao, cm2, &fa.pixels, cm2,
                          &fa.points, cv1w, &fa.nis, ci1w, &fa.acc))
        return nullptr;
    Stream* s = stream_arg(state, true);
    double g[3], a[3];
    if (s == nullptr || !stream::read3(go, "gyro", g) || !stream::read3(ao, "accel", a) || !fa.ok()) return nullptr;
    if (s->f.samples == 0 || !(s->f.tc <= tj && tj <= t1 && t1 > s->f.t0)) {
        PyErr_SetString(PyExc_ValueError, "eskf_stream_frame: the frame time must lie in the interval from the "
                                          "time reached to the next IMU sample");
        return nullptr;
    }
    double F[NE * NE];
    predict_to_frame(s->f, s->c, tj, t1, g, a, F);
    return PyLong_FromLongLong(
        update_frame(s->f, s->c, fa.pixels.data, fa.points.data, fa.pixels.shape[0], fa.nis.data, fa.acc.data));
}

// eskf_stream_update(state, pixels, points, nis, accepted) -> int: the camera update at the current time.
PyObject* py_stream_update(PyObject*, PyObject* args) {
    PyObject* state;
    FrameArgs fa;
    if (!PyArg_ParseTuple(args, "OO&O&O&O&:eskf_stream_update", &state, cm2, &fa.pixels, cm2, &fa.points, cv1w,
                          &fa.nis, ci1w, &fa.acc))
        return nullptr;
    Stream* s = stream_arg(state, true);
    if (s == nullptr || !fa.ok()) return nullptr;
    return PyLong_FromLongLong(
        update_frame(s->f, s->c, fa.pixels.data, fa.points.data, fa.pixels.shape[0], fa.nis.data, fa.acc.data));
}

// eskf_stream_run(state, t, gyro, accel, cam_t, offsets, pixels, points, X, Ps, nis, accepted) -> int: feed a
// block; Ps may be None; returns the frames consumed.
PyObject* py_stream_run(PyObject*, PyObject* args) {
    stream::BlockRun r;
    Stream* s = stream::block_run_args<Stream>(args, "OO&O&O&O&O&O&O&O&OO&O&:eskf_stream_run", stream_kind, NX, NE, r);
    if (s == nullptr) return nullptr;
    const Outputs o{r.X, r.Ps, nullptr, nullptr, r.nis, r.acc};
    std::int64_t used;
    Py_BEGIN_ALLOW_THREADS
    used = feed(s->f, s->c, r.b, o, nullptr, nullptr);
    Py_END_ALLOW_THREADS
    return PyLong_FromLongLong(used);
}

// eskf_stream_get(state) -> (x (16,), P (225,), t0, tc, samples)
PyObject* py_stream_get(PyObject*, PyObject* args) {
    PyObject* state;
    if (!PyArg_ParseTuple(args, "O:eskf_stream_get", &state)) return nullptr;
    const Stream* s = stream_arg(state, false);
    if (s == nullptr) return nullptr;
    return Py_BuildValue("NNddL", stream::new_vector(s->f.x, NX), stream::new_vector(s->f.P, NE * NE), s->f.t0,
                         s->f.tc, static_cast<long long>(s->f.samples));
}

PyMethodDef methods[] = {
    {"eskf_predict", py_predict<false>, METH_VARARGS,
     "eskf_predict(x, P, gyro, accel, dt, gravity, noise): propagate nominal state x (16,) and error covariance "
     "P (15, 15) in place over dt with constant IMU input (Solà 2017 eq. 260, 269-270)."},
    {"eskf_predict_transition", py_predict<true>, METH_VARARGS,
     "eskf_predict_transition(x, P, gyro, accel, dt, gravity, noise, F): eskf_predict that also writes the "
     "error-state transition of the step (Solà eq. 269) to F (15, 15)."},
    {"eskf_camera_batch", py_camera_batch, METH_VARARGS,
     "eskf_camera_batch(x, intr, q_bc, p_bc, pixels, points, r, H, depth): reprojection residuals r (M, 2), "
     "Jacobians H (M, 2, 15) and camera depths (M,) of M point correspondences."},
    {"eskf_inject_reset", py_inject_reset, METH_VARARGS,
     "eskf_inject_reset(x, P, dx): inject dx (15,) into x and apply the reset Jacobian (Solà eq. 285-287)."},
    {"eskf_joseph", py_joseph, METH_VARARGS,
     "eskf_joseph(P, K, H, R): Joseph-form update P <- (I - K H) P (I - K H)^T + K R K^T in place, symmetrised."},
    {"eskf_joseph_2d", py_joseph_2d, METH_VARARGS,
     "eskf_joseph_2d(P, K, H, s2): the Joseph update of a 2-row measurement with noise s2 I2."},
    {"eskf_update_points", py_update_points, METH_VARARGS,
     "eskf_update_points(x, P, intr, q_bc, p_bc, pixels, points, sigma_px, gate, nis_out, accepted_out) -> int: "
     "sequential chi2-gated update with the point correspondences of one frame; returns the number accepted."},
    {"eskf_update_dense", py_update_dense, METH_VARARGS,
     "eskf_update_dense(x, P, r, H, R) -> float: batch update with residual r (m,), Jacobian H (m, 15), noise "
     "R (m, m); returns the NIS."},
    {"eskf_stream_new", py_stream_new, METH_VARARGS,
     "eskf_stream_new(x, P, gravity, noise, intr, q_bc, p_bc, sigma_px, gate) -> state: a new ESKF stream "
     "(numpy.uint8 array: layout header, constants, filter state) before its first sample."},
    {"eskf_stream_imu", reinterpret_cast<PyCFunction>(reinterpret_cast<void (*)()>(py_stream_imu)), METH_FASTCALL,
     "eskf_stream_imu(state, t, gyro, accel) -> x (16,): one IMU sample (the step of eskf_run)."},
    {"eskf_stream_frame", py_stream_frame, METH_VARARGS,
     "eskf_stream_frame(state, tj, t1, g1, a1, pixels, points, nis, accepted) -> int: predict to the frame time tj "
     "(input interpolated towards the next IMU sample t1, g1, a1) and update with the frame."},
    {"eskf_stream_update", py_stream_update, METH_VARARGS,
     "eskf_stream_update(state, pixels, points, nis, accepted) -> int: camera update at the current time."},
    {"eskf_stream_run", py_stream_run, METH_VARARGS,
     "eskf_stream_run(state, t, gyro, accel, cam_t, offsets, pixels, points, X, Ps, nis, accepted) -> int: the "
     "steps over a block (Ps may be None); returns the number of frames consumed.  The GIL is released."},
    {"eskf_stream_get", py_stream_get, METH_VARARGS,
     "eskf_stream_get(state) -> (x (16,), P (225,), t0, tc, samples): copies of the stream's state."},
    {"eskf_stream_check", stream::check<Stream, stream_kind>, METH_VARARGS,
     "eskf_stream_check(state, name='state'): ValueError naming `name` unless state is an ESKF stream of this "
     "layout version and size."},
    {"eskf_run", py_run, METH_VARARGS,
     "eskf_run(t, gyro, accel, cam_t, offsets, pixels, points, x, P, gravity, noise, intr, q_bc, p_bc, sigma_px, "
     "gate, X, Ps, XF, PF, nis_out, accepted_out): filter a whole stream (see ErrorStateEKF.run)."},
    {"eskf_run_recorded", py_run_recorded, METH_VARARGS,
     "eskf_run_recorded(<the arguments of eskf_run>, XA, PA, XB, PB, FS, TN, imu_node, frame_node) -> int: "
     "eskf_run that also stores every filter node for the RTS smoother; returns the number of nodes."},
    {nullptr, nullptr, 0, nullptr},
};

}  // namespace

bool add_eskf(PyObject* m) {
    for (const auto& c : eskf::layout_constants)
        if (PyModule_AddIntConstant(m, c.name, c.value) != 0) return false;
    if (PyModule_AddIntConstant(m, "ESKF_STREAM_VERSION", eskf::STREAM_VERSION) != 0) return false;
    return PyModule_AddFunctions(m, methods) == 0;
}

}  // namespace dualpose
