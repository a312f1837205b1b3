// Python entry points of the RTS smoother (add_smoother): dualpose._native.smoother_*, used by
// dualpose.estimation.smoother.  Kernels in smoother_kernels.hpp and smoother_rts.cpp.
#include "eskf_args.hpp"
#include "smoother_kernels.hpp"

namespace dualpose {
namespace {

using namespace smoother;
constexpr auto cv1 = convert<double, 1>;
constexpr auto cv1w = convert<double, 1, true>;
constexpr auto cm2 = convert<double, 2>;
constexpr auto cm2w = convert<double, 2, true>;
constexpr auto ct3 = convert<double, 3>;
constexpr auto ct3w = convert<double, 3, true>;

PyObject* py_boxminus(PyObject*, PyObject* args) {
    Array<double, 1> x, y;
    Array<double, 1, true> out;
    if (!PyArg_ParseTuple(args, "O&O&O&:smoother_boxminus", cv1, &x, cv1, &y, cv1w, &out)) return nullptr;
    if (!shape_is("x", x, {NX}) || !shape_is("y", y, {NX}) || !shape_is("out", out, {NE})) return nullptr;
    boxminus(x.data, y.data, out.data);
    Py_RETURN_NONE;
}

PyObject* py_boxplus(PyObject*, PyObject* args) {
    Array<double, 1> x, dx;
    Array<double, 1, true> out;
    if (!PyArg_ParseTuple(args, "O&O&O&:smoother_boxplus", cv1, &x, cv1, &dx, cv1w, &out)) return nullptr;
    if (!shape_is("x", x, {NX}) || !shape_is("dx", dx, {NE}) || !shape_is("out", out, {NX})) return nullptr;
    boxplus(x.data, dx.data, out.data);
    Py_RETURN_NONE;
}

PyObject* py_right_jacobian(PyObject*, PyObject* args) {
    Array<double, 1> phi;
    double inverse;
    Array<double, 2, true> out;
    if (!PyArg_ParseTuple(args, "O&dO&:smoother_right_jacobian", cv1, &phi, &inverse, cm2w, &out)) return nullptr;
    if (!shape_is("phi", phi, {3}) || !shape_is("out", out, {3, 3})) return nullptr;
    right_jacobian(phi.data, inverse, out.data);
    Py_RETURN_NONE;
}

// Parse (x_post, P_post, x_prior, P_prior, F, x_smooth, P_smooth), run the pass with the GIL released.
template <Status (*PASS)(const Stacks&), bool ERROR_STATE>
PyObject* py_rts(PyObject*, PyObject* args) {
    Array<double, 2> xb, xa;
    Array<double, 3> Pb, Pa, F;
    Array<double, 2, true> xs;
    Array<double, 3, true> Ps;
    if (!PyArg_ParseTuple(args, ERROR_STATE ? "O&O&O&O&O&O&O&:smoother_rts_error_state" : "O&O&O&O&O&O&O&:smoother_rts_linear",
                          cm2, &xb, ct3, &Pb, cm2, &xa, ct3, &Pa, ct3, &F, cm2w, &xs, ct3w, &Ps))
        return nullptr;
    const npy_intp K = xb.shape[0], nx = xb.shape[1];
    const npy_intp n = ERROR_STATE ? NE : nx;
    if (ERROR_STATE && !shape_is("x_post", xb, {-1, NX})) return nullptr;
    if (!shape_is("P_post", Pb, {K, n, n}) || !shape_is("x_prior", xa, {K, nx}) ||
        !shape_is("P_prior", Pa, {K, n, n}) || !shape_is("F", F, {K, n, n}) || !shape_is("x_smooth", xs, {K, nx}) ||
        !shape_is("P_smooth", Ps, {K, n, n}))
        return nullptr;
    if (K == 0) {
        PyErr_SetString(PyExc_ValueError, "the stacks must hold at least one step");
        return nullptr;
    }
    const Stacks s{K, static_cast<int>(nx), static_cast<int>(n), xb.data, Pb.data, xa.data, Pa.data, F.data,
                   xs.data, Ps.data};
    Status st;
    Py_BEGIN_ALLOW_THREADS
    st = PASS(s);
    Py_END_ALLOW_THREADS
    if (st == Status::not_finite) return raise_linalg_error(not_finite_message);
    if (st == Status::singular) return raise_linalg_error(singular_message);
    Py_RETURN_NONE;
}

PyMethodDef methods[] = {
    {"smoother_boxminus", py_boxminus, METH_VARARGS,
     "smoother_boxminus(x, y, out): out (15,) = x [-] y, the error state taking nominal y (16,) to x (16,), "
     "with dtheta = Log(q_y* (x) q_x)."},
    {"smoother_boxplus", py_boxplus, METH_VARARGS,
     "smoother_boxplus(x, dx, out): out (16,) = x [+] dx with q <- q (x) Exp(dtheta)."},
    {"smoother_right_jacobian", py_right_jacobian, METH_VARARGS,
     "smoother_right_jacobian(phi, inverse, out): out (3, 3) = J_r(phi) (inverse = 0) or its inverse (inverse = 1) "
     "(Sola 2017 eq. 183, 186)."},
    {"smoother_rts_linear", py_rts<rts_linear, false>, METH_VARARGS,
     "smoother_rts_linear(x_post, P_post, x_prior, P_prior, F, x_smooth, P_smooth): linear RTS over K steps "
     "(Sarkka 2013 Thm 8.2); raises numpy.linalg.LinAlgError on a singular predicted covariance."},
    {"smoother_rts_error_state", py_rts<rts_error_state, true>, METH_VARARGS,
     "smoother_rts_error_state(x_post, P_post, x_prior, P_prior, F, x_smooth, P_smooth): error-state RTS over the "
     "nodes of the error-state filter (docs/fusion.md, Offline smoothing); raises numpy.linalg.LinAlgError on a "
     "singular predicted covariance."},
    {nullptr, nullptr, 0, nullptr},
};

}  // namespace

bool add_smoother(PyObject* m) { return PyModule_AddFunctions(m, methods) == 0; }

}  // namespace dualpose
