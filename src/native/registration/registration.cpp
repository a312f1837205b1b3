// The registration part of dualpose._native: registration_solve_one, registration_solve_batch and the result-row
// layout constants (REGISTRATION_*), for dualpose.registration.estimate / batch.
#include "../common/args.hpp"
#include "row.hpp"
#include "solve.hpp"

namespace dualpose {

namespace {

bool same_shape(const npy_intp* a, const npy_intp* b, int n) {
    for (int k = 0; k < n; ++k)
        if (a[k] != b[k]) return false;
    return true;
}

// The checked arguments: (p0, p1, beta, n0, n1, alpha, method, want_scale, out) of B problems (NP = 3) or one
// problem (NP = 2, B = 1).
template <int NP>
PyObject* solve(PyObject* args, const char* name) {
    Array<double, NP> p0, p1, n0, n1;
    Array<double, NP - 1> beta, alpha;
    Array<double, NP - 1, true> out;
    int method, want_scale;
    if (!PyArg_ParseTuple(args, "O&O&O&O&O&O&ipO&", convert<double, NP>, &p0, convert<double, NP>, &p1,
                          convert<double, NP - 1>, &beta, convert<double, NP>, &n0, convert<double, NP>, &n1,
                          convert<double, NP - 1>, &alpha, &method, &want_scale, convert<double, NP - 1, true>, &out))
        return nullptr;
    const bool ok = same_shape(p0.shape, p1.shape, NP) && same_shape(n0.shape, n1.shape, NP) &&
                    p0.shape[NP - 1] == 3 && n0.shape[NP - 1] == 3 && same_shape(beta.shape, p0.shape, NP - 1) &&
                    same_shape(alpha.shape, n0.shape, NP - 1) && out.shape[NP - 2] == row::ROW_SIZE &&
                    (NP == 2 || (n0.shape[0] == p0.shape[0] && out.shape[0] == p0.shape[0]));
    if (!ok) {
        PyErr_Format(PyExc_ValueError,
                     "%s: expected p0, p1 %s, beta %s, n0, n1 %s, alpha %s and out %s with matching sizes", name,
                     NP == 3 ? "(B, n, 3)" : "(n, 3)", NP == 3 ? "(B, n)" : "(n,)", NP == 3 ? "(B, m, 3)" : "(m, 3)",
                     NP == 3 ? "(B, m)" : "(m,)", NP == 3 ? "(B, ROW_SIZE)" : "(ROW_SIZE,)");
        return nullptr;
    }
    if (method < reg::DQ || method > reg::SVD) {
        PyErr_Format(PyExc_ValueError, "%s: method code must be 0 (dq), 1 (horn) or 2 (svd); got %d", name, method);
        return nullptr;
    }
    const reg::Problems pr{p0.data, p1.data, beta.data, n0.data, n1.data, alpha.data,
                           NP == 3 ? p0.shape[0] : 1, p0.shape[NP - 2], n0.shape[NP - 2]};
    std::int64_t first_bad;
    if (NP == 3 && pr.nprob > 64) {
        PyThreadState* save = PyEval_SaveThread();
        first_bad = reg::solve_batch(pr, method, want_scale != 0, out.data);
        PyEval_RestoreThread(save);
    } else {
        first_bad = reg::solve_batch(pr, method, want_scale != 0, out.data);
    }
    return PyLong_FromLongLong(first_bad);
}

PyObject* registration_solve_batch(PyObject*, PyObject* args) { return solve<3>(args, "registration_solve_batch"); }
PyObject* registration_solve_one(PyObject*, PyObject* args) { return solve<2>(args, "registration_solve_one"); }

PyMethodDef methods[] = {
    {"registration_solve_batch", registration_solve_batch, METH_VARARGS,
     "registration_solve_batch(p0, p1, beta, n0, n1, alpha, method, want_scale, out) -> int: solve B "
     "independent problems, p0, p1 (B, n, 3), beta (B, n), n0, n1 (B, m, 3), alpha (B, m), method 0 = dq "
     "(Walker 1991), 1 = horn (Horn 1987), 2 = svd (Arun 1987 / Umeyama 1991); out (B, REGISTRATION_ROW_SIZE) "
     "rows with the layout of dualpose.registration._row.  Returns the index of the first problem whose row holds a "
     "BAD_INPUT code, or -1."},
    {"registration_solve_one", registration_solve_one, METH_VARARGS,
     "registration_solve_one(p0, p1, beta, n0, n1, alpha, method, want_scale, out) -> int: one problem, "
     "p0, p1 (n, 3), beta (n,), n0, n1 (m, 3), alpha (m,); out (REGISTRATION_ROW_SIZE,).  Returns 0 if the row "
     "holds a BAD_INPUT code, else -1."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_registration(PyObject* m) {
    if (PyModule_AddFunctions(m, methods) != 0) return false;
    const struct {
        const char* name;
        int value;
    } constants[] = {
        {"REGISTRATION_ROW_SIZE", row::ROW_SIZE},       {"REGISTRATION_QUAT_AT", row::QUAT_AT},
        {"REGISTRATION_TRANSLATION_AT", row::TRANSLATION_AT}, {"REGISTRATION_SCALE", row::SCALE},
        {"REGISTRATION_COST", row::COST},               {"REGISTRATION_EIGENVALUES_AT", row::EIGENVALUES_AT},
        {"REGISTRATION_EIGEN_GAP", row::EIGEN_GAP},     {"REGISTRATION_SINGULAR_AT", row::SINGULAR_AT},
        {"REGISTRATION_REFLECTION", row::REFLECTION},   {"REGISTRATION_UNIQUE", row::UNIQUE},
        {"REGISTRATION_CLOSED_FORM", row::CLOSED_FORM}, {"REGISTRATION_POINT_EXPONENT", row::POINT_EXPONENT}, {"REGISTRATION_GAP_TOLERANCE", row::GAP_TOLERANCE},
        {"REGISTRATION_POINT_COST", row::POINT_COST},   {"REGISTRATION_BAD_INPUT", row::BAD_INPUT},
        {"REGISTRATION_N_BAD_INPUT_NAMES", row::N_BAD_INPUT_NAMES},
    };
    for (const auto& c : constants)
        if (PyModule_AddIntConstant(m, c.name, c.value) != 0) return false;
    return true;
}

}  // namespace dualpose
