// The guarded series (common/series.hpp) as NumPy ufuncs of float64, for dualpose.algebra.series.series_ufunc.
#include "../common/gufunc.hpp"
#include "../common/series.hpp"

namespace dualpose {

namespace {

template <double (*F)(double)>
void unary(const double* x, double* o) {
    o[0] = F(x[0]);
}

void atan2c_kernel(const double* s, const double* c, double* o) { o[0] = atan2c(s[0], c[0]); }

template <double (*F)(double)>
bool add_series(PyObject* m, const char* name, const char* doc) {
    return add_gufunc<Gufunc<unary<F>, In<S>, Out<S>>>(m, name, doc);
}

}  // namespace

bool add_series_gufuncs(PyObject* m) {
    return add_series<sinc>(m, "sinc", "sin(x)/x, guarded series below 0.5.") &&
           add_series<cosc2>(m, "cosc2", "(1 - cos x)/x**2, guarded series below 1.0.") &&
           add_series<sinc3>(m, "sinc3", "(x - sin x)/x**3, guarded series below 3.0.") &&
           add_series<dsinc>(m, "dsinc", "(x cos x - sin x)/x**3, guarded series below 2.0.") &&
           add_series<cosc4>(m, "cosc4", "(x**2/2 - 1 + cos x)/x**4, guarded series below 3.5.") &&
           add_series<se3c>(m, "se3c", "(2x - 3 sin x + x cos x)/(2 x**5), guarded series below 4.0.") &&
           add_series<jinv>(m, "jinv", "(1 - (x/2) cot(x/2))/x**2, guarded series below 2.5.") &&
           add_series<dqalpha>(m, "dqalpha", "cos x / sin**2 x - x / sin**3 x = -4 sinc3(2x)/sinc(x)**3.") &&
           add_series<dlogc>(m, "dlogc", "(x cos x - sin x)/sin**3 x = dsinc(x)/sinc(x)**3.") &&
           add_gufunc<Gufunc<atan2c_kernel, In<S, S>, Out<S>>>(m, "atan2c", "atan2(s, c)/s, series for s <= 1e-4 c.");
}

}  // namespace dualpose
