// The inertial part of dualpose._native: inertial_update_vectors, inertial_fold_quat, inertial_fold_dualquat (one
// pass over the updates per batch element, the state in registers: one exponential, one product and one
// renormalization per update), for dualpose.inertial.integrate.
#include "../common/args.hpp"
#include "../common/dualquat.hpp"
#include "fold.hpp"

#include <cstdint>

namespace dualpose {

namespace {

using inertial::Screw;
using inertial::update_vector;

// Checks shared by the three functions: kmat (n, n), x (B, M, W) with M >= updates * n, out (B, ...).
bool check(const char* name, const Array<double, 3>& x, int n, const Array<double, 2>& kmat, npy_intp updates,
           npy_intp batch, int width) {
    if (n < 1 || kmat.shape[0] != n || kmat.shape[1] != n) {
        PyErr_Format(PyExc_ValueError, "%s: kmat must have shape (n, n) with n = %d >= 1", name, n);
        return false;
    }
    if (x.shape[2] != width || x.shape[0] != batch || x.shape[1] < updates * n) {
        PyErr_Format(PyExc_ValueError, "%s: x must have shape (B, M, %d) with M >= %zd rows for the output", name,
                     width, updates * n);
        return false;
    }
    return true;
}

// out[b, k] = update_vector(x[b], k, ...) (first 3 or 6 components).
PyObject* inertial_update_vectors(PyObject*, PyObject* args) {
    Array<double, 3> x;
    Array<double, 2> kmat;
    Array<double, 3, true> out;
    int n;
    double cprev, sgn;
    if (!PyArg_ParseTuple(args, "O&iO&ddO&", convert<double, 3>, &x, &n, convert<double, 2>, &kmat, &cprev, &sgn,
                          convert<double, 3, true>, &out))
        return nullptr;
    const npy_intp w = out.shape[2];
    if (w != 3 && w != 6) {
        PyErr_SetString(PyExc_ValueError, "inertial_update_vectors: out must have width 3 or 6");
        return nullptr;
    }
    if (!check("inertial_update_vectors", x, n, kmat, out.shape[1], out.shape[0], int(w))) return nullptr;
    PyThreadState* save = PyEval_SaveThread();
    for (npy_intp b = 0; b < x.shape[0]; ++b) {
        const double* xb = x.data + b * x.shape[1] * w;
        for (npy_intp k = 0; k < out.shape[1]; ++k) {
            const Screw v = w == 6 ? update_vector<6>(xb, k, n, kmat.data, cprev, sgn)
                                   : update_vector<3>(xb, k, n, kmat.data, cprev, sgn);
            double* o = &out(b, k, 0);
            store(o, v.s);
            if (w == 6) store(o + 3, v.t);
        }
    }
    PyEval_RestoreThread(save);
    Py_RETURN_NONE;
}

// out[b, 0] = q0[b]/|q0[b]|; out[b, k+1] = normalize(out[b, k] (x) exp(Φ_k/2)), or exp(Φ_k/2) (x) out[b, k] when
// sgn < 0 (inertial frame), with Φ_k = update_vector(x[b], k, ...).
PyObject* inertial_fold_quat(PyObject*, PyObject* args) {
    Array<double, 2> q0, kmat;
    Array<double, 3> x;
    Array<double, 3, true> out;
    int n;
    double cprev, sgn;
    if (!PyArg_ParseTuple(args, "O&O&iO&ddO&", convert<double, 2>, &q0, convert<double, 3>, &x, &n,
                          convert<double, 2>, &kmat, &cprev, &sgn, convert<double, 3, true>, &out))
        return nullptr;
    if (q0.shape[1] != 4 || out.shape[2] != 4 || out.shape[1] < 1 || q0.shape[0] != out.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "inertial_fold_quat: q0 must be (B, 4) and out (B, K + 1, 4)");
        return nullptr;
    }
    if (!check("inertial_fold_quat", x, n, kmat, out.shape[1] - 1, out.shape[0], 3)) return nullptr;
    const bool left = sgn < 0.0;
    PyThreadState* save = PyEval_SaveThread();
    for (npy_intp b = 0; b < x.shape[0]; ++b) {
        const double* xb = x.data + b * x.shape[1] * 3;
        Quat q = load4(&q0(b, 0));
        const double nn = norm4(q);
        q = {q.x / nn, q.y / nn, q.z / nn, q.w / nn};
        store(&out(b, 0, 0), q);
        for (npy_intp k = 0; k < out.shape[1] - 1; ++k) {
            const Quat e = quat_exp_rotvec(update_vector<3>(xb, k, n, kmat.data, cprev, sgn).s);
            q = left ? qmul(e, q) : qmul(q, e);
            const double m = norm4(q);
            q = {q.x / m, q.y / m, q.z / m, q.w / m};
            store(&out(b, k + 1, 0), q);
        }
    }
    PyEval_RestoreThread(save);
    Py_RETURN_NONE;
}

// As inertial_fold_quat for dual quaternions and screw vectors; renormalized (dual-number norm) each update.
PyObject* inertial_fold_dualquat(PyObject*, PyObject* args) {
    Array<double, 2> s0, kmat;
    Array<double, 3> x;
    Array<double, 3, true> out;
    int n;
    double cprev, sgn;
    if (!PyArg_ParseTuple(args, "O&O&iO&ddO&", convert<double, 2>, &s0, convert<double, 3>, &x, &n,
                          convert<double, 2>, &kmat, &cprev, &sgn, convert<double, 3, true>, &out))
        return nullptr;
    if (s0.shape[1] != 8 || out.shape[2] != 8 || out.shape[1] < 1 || s0.shape[0] != out.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "inertial_fold_dualquat: s0 must be (B, 8) and out (B, K + 1, 8)");
        return nullptr;
    }
    if (!check("inertial_fold_dualquat", x, n, kmat, out.shape[1] - 1, out.shape[0], 6)) return nullptr;
    const bool left = sgn < 0.0;
    PyThreadState* save = PyEval_SaveThread();
    for (npy_intp b = 0; b < x.shape[0]; ++b) {
        const double* xb = x.data + b * x.shape[1] * 6;
        DualQuat s = dq_normalize(load8(&s0(b, 0)));
        store(&out(b, 0, 0), s);
        for (npy_intp k = 0; k < out.shape[1] - 1; ++k) {
            const DualQuat e = inertial::screw_half_exp(update_vector<6>(xb, k, n, kmat.data, cprev, sgn));
            s = dq_normalize(left ? dq_mul(e, s) : dq_mul(s, e));
            store(&out(b, k + 1, 0), s);
        }
    }
    PyEval_RestoreThread(save);
    Py_RETURN_NONE;
}

PyMethodDef methods[] = {
    {"inertial_update_vectors", inertial_update_vectors, METH_VARARGS,
     "inertial_update_vectors(x, n, kmat, cprev, sgn, out): rotation (width 3) or screw (width 6) vector of each "
     "N-sample update, x (B, K*N, w), kmat (N, N), out (B, K, w)."},
    {"inertial_fold_quat", inertial_fold_quat, METH_VARARGS,
     "inertial_fold_quat(q0, x, n, kmat, cprev, sgn, out): attitude quaternions q0 (B, 4) folded with the "
     "rotation-vector updates of x (B, K*N, 3) into out (B, K + 1, 4); body frame (sgn > 0) or inertial (sgn < 0)."},
    {"inertial_fold_dualquat", inertial_fold_dualquat, METH_VARARGS,
     "inertial_fold_dualquat(s0, x, n, kmat, cprev, sgn, out): poses s0 (B, 8) folded with the screw-vector updates "
     "of x (B, K*N, 6) into out (B, K + 1, 8)."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_inertial(PyObject* m) { return PyModule_AddFunctions(m, methods) == 0; }

}  // namespace dualpose
