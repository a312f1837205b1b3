// Quaternion gufuncs (xyzw, Hamilton): the kernels behind dualpose.algebra.quat.
#include "../common/gufunc.hpp"
#include "../common/quat.hpp"

namespace dualpose {

static void quat_mul(const double* p, const double* q, double* o) { qmul(p, q, o); }

bool add_quat_gufuncs(PyObject* m) {
    return add_gufunc<Gufunc<quat_mul, In<V<4>, V<4>>, Out<V<4>>>>(m, "quat_mul", "Hamilton product p (x) q, xyzw.");
}

}  // namespace dualpose
