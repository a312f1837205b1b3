// dualpose._native: the ahead-of-time compiled kernels (one extension, built at install).
//
// Each part registers its gufuncs and functions through one add_* function (defined next to its kernels, e.g.
// algebra/quat.cpp), listed in parts.def.
#define DUALPOSE_IMPORT_NUMPY
#include "common/numpy_api.hpp"

namespace dualpose {
#define DUALPOSE_PART(name) bool name(PyObject* module);
#include "parts.def"
#undef DUALPOSE_PART
}  // namespace dualpose

static PyModuleDef native_module = {PyModuleDef_HEAD_INIT,
                                    "_native",
                                    "Ahead-of-time compiled kernels of dualpose (gufuncs and whole-recording loops).",
                                    -1,
                                    nullptr,
                                    nullptr,
                                    nullptr,
                                    nullptr,
                                    nullptr};

PyMODINIT_FUNC PyInit__native(void) {
    import_array();
    import_umath();
    PyObject* m = PyModule_Create(&native_module);
    if (m == nullptr) return nullptr;
#define DUALPOSE_PART(name)  \
    if (!dualpose::name(m)) { \
        Py_DECREF(m);        \
        return nullptr;      \
    }
#include "parts.def"
#undef DUALPOSE_PART
    return m;
}
