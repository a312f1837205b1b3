// The NumPy C API, imported once by module.cpp (the only file that does not define NO_IMPORT_*).
#pragma once

#define PY_SSIZE_T_CLEAN
#include <Python.h>

#define NPY_NO_DEPRECATED_API NPY_1_25_API_VERSION
#define PY_ARRAY_UNIQUE_SYMBOL dualpose_native_ARRAY_API
#define PY_UFUNC_UNIQUE_SYMBOL dualpose_native_UFUNC_API
#ifndef DUALPOSE_IMPORT_NUMPY
#define NO_IMPORT_ARRAY
#define NO_IMPORT_UFUNC
#endif
#include <numpy/arrayobject.h>
#include <numpy/ufuncobject.h>
