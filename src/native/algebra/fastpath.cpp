// dualpose._native.FastPath: a public function with a direct native entry in front of it.
//
// FastPath(kernel, func, nan_declines=False, max_rows=-1, fixed=(), takes_out=False, lazy=None) is called like
// ``func``.  (``lazy``, if given, takes the calls with a dask array among the arguments; see has_dask_argument.)  A
// call with exactly the kernel's inputs as positional arguments (``fixed`` appended: constant trailing inputs such as
// a frame flag) and no keywords -- or, with ``takes_out``, also an ``out`` array (positional after the inputs or the
// keyword out) -- first goes to the gufunc's direct entry (common/gufunc.hpp, Gufunc::direct).  It computes into
// fresh arrays (or into ``out``) when the operands need no conversion and no broadcasting but of single elements,
// ``out`` shares no memory with an input, and there are at most ``max_rows`` rows (no limit when negative).  With
// ``nan_declines`` a NaN in an output (or the row loop's zero-or-extreme-norm flag) also declines: the function's own
// checks then run on the same output values, so an ``out`` written before a decline ends as ``func`` leaves it.
// Every declined call, and every other call, goes to ``func`` unchanged.  So ``func`` is the specification:
// FastPath may be put in front of it only when, for such inputs, ``func`` returns exactly the kernel's outputs
// (unless an output is NaN, with ``nan_declines``).
//
// The object reads as ``func``: __name__, __qualname__, __module__, __doc__ and any other attribute come from it,
// __wrapped__ is it (inspect.signature follows it), it binds as a method like a function (so inspect.isroutine and
// pydoc take it for one), and pickling stores a reference by name.
#include "../common/direct.hpp"
#include "../common/numpy_api.hpp"

#include <structmember.h>

#include <utility>
#include <vector>

namespace dualpose {

namespace {

std::vector<std::pair<PyObject*, DirectEntry>>& registry() {
    static std::vector<std::pair<PyObject*, DirectEntry>> r;
    return r;
}

constexpr int kMaxInputs = 12;

struct FastPath {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject* func;
    PyObject* kernel;
    PyObject* fixed;  // tuple of constant trailing inputs
    PyObject* lazy;   // called instead of func when an argument is a dask array (nullptr: never)
    DirectFn direct;
    Py_ssize_t nin;
    Py_ssize_t max_rows;
    bool nan_declines;
    bool takes_out;  // func has the parameter out (the kernel's one output, preallocated) after the inputs
};

// The preallocated output of a call with one argument beyond the inputs (positional, or the keyword out), else
// nullptr; *ok is false when the call has any other form.
PyObject* out_argument(const FastPath* self, PyObject* const* args, Py_ssize_t n, PyObject* kwnames, Py_ssize_t nuser,
                       bool* ok) {
    *ok = false;
    if (!self->takes_out) return nullptr;
    if (kwnames == nullptr) {
        if (n != nuser + 1) return nullptr;
    } else {
        if (n != nuser || PyTuple_GET_SIZE(kwnames) != 1) return nullptr;
        const int eq = PyUnicode_CompareWithASCIIString(PyTuple_GET_ITEM(kwnames, 0), "out");
        if (eq != 0) return nullptr;
    }
    *ok = true;
    PyObject* out = args[nuser];
    return out == Py_None ? nullptr : out;
}

// Whether an argument (positional or keyword value) is an instance of a type defined in a module of dask.  While
// dask.array is not imported there can be none, and the check is one dictionary lookup.
bool has_dask_argument(PyObject* const* args, Py_ssize_t n, PyObject* kwnames) {
    static PyObject* const key = PyUnicode_InternFromString("dask.array");
    static PyObject* const module_attr = PyUnicode_InternFromString("__module__");
    static PyObject* const prefix = PyUnicode_InternFromString("dask.");
    if (key == nullptr || module_attr == nullptr || prefix == nullptr) return PyErr_Clear(), false;
    if (PyDict_GetItem(PyImport_GetModuleDict(), key) == nullptr) return false;
    const Py_ssize_t total = n + (kwnames ? PyTuple_GET_SIZE(kwnames) : 0);
    for (Py_ssize_t j = 0; j < total; ++j) {
        PyObject* m = PyObject_GetAttr(reinterpret_cast<PyObject*>(Py_TYPE(args[j])), module_attr);
        if (m == nullptr) {
            PyErr_Clear();
            continue;
        }
        const bool dask = PyUnicode_Check(m) && PyUnicode_Tailmatch(m, prefix, 0, PY_SSIZE_T_MAX, -1) == 1;
        Py_DECREF(m);
        if (dask) return true;
    }
    return false;
}

PyObject* fast_call(PyObject* self_, PyObject* const* args, size_t nargsf, PyObject* kwnames) {
    auto* self = reinterpret_cast<FastPath*>(self_);
    const Py_ssize_t n = PyVectorcall_NARGS(nargsf);
    const Py_ssize_t nfixed = PyTuple_GET_SIZE(self->fixed);
    const Py_ssize_t nuser = self->nin - nfixed;
    PyObject* out = nullptr;
    bool ok = kwnames == nullptr && n == nuser;
    if (!ok) out = out_argument(self, args, n, kwnames, nuser, &ok);
    if (ok) {
        PyObject* const* all = args;
        PyObject* buf[kMaxInputs];
        if (nfixed) {
            for (Py_ssize_t j = 0; j < nuser; ++j) buf[j] = args[j];
            for (Py_ssize_t j = 0; j < nfixed; ++j) buf[nuser + j] = PyTuple_GET_ITEM(self->fixed, j);
            all = buf;
        }
        PyObject* result = nullptr;
        const int s = self->direct(all, out, self->max_rows, self->nan_declines, &result);
        if (s > 0) return result;
        if (s < 0) return nullptr;
    }
    if (self->lazy != nullptr && has_dask_argument(args, n, kwnames))
        return PyObject_Vectorcall(self->lazy, args, nargsf, kwnames);
    return PyObject_Vectorcall(self->func, args, nargsf, kwnames);
}

PyObject* fast_new(PyTypeObject* type, PyObject* args, PyObject* kwds) {
    static const char* names[] = {"kernel", "func", "nan_declines", "max_rows", "fixed", "takes_out", "lazy", nullptr};
    PyObject *kernel, *func, *fixed = nullptr, *lazy = Py_None;
    int nan_declines = 0, takes_out = 0;
    Py_ssize_t max_rows = -1;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OO|pnO!pO:FastPath", const_cast<char**>(names), &kernel, &func,
                                     &nan_declines, &max_rows, &PyTuple_Type, &fixed, &takes_out, &lazy))
        return nullptr;
    const DirectEntry* e = find_direct(kernel);
    if (e == nullptr) {
        PyErr_SetString(PyExc_TypeError, "FastPath: kernel must be a gufunc of dualpose._native");
        return nullptr;
    }
    if (!PyCallable_Check(func) || (lazy != Py_None && !PyCallable_Check(lazy))) {
        PyErr_SetString(PyExc_TypeError, "FastPath: func and lazy must be callable");
        return nullptr;
    }
    const int nin = reinterpret_cast<PyUFuncObject*>(kernel)->nin;
    const Py_ssize_t nfixed = fixed ? PyTuple_GET_SIZE(fixed) : 0;
    if (nin > kMaxInputs || nfixed >= nin) {
        PyErr_SetString(PyExc_ValueError, "FastPath: fixed must leave at least one of the kernel's inputs");
        return nullptr;
    }
    auto* self = reinterpret_cast<FastPath*>(type->tp_alloc(type, 0));
    if (self == nullptr) return nullptr;
    self->vectorcall = fast_call;
    Py_INCREF(func);
    self->func = func;
    self->lazy = lazy == Py_None ? nullptr : (Py_INCREF(lazy), lazy);
    Py_INCREF(kernel);
    self->kernel = kernel;
    self->fixed = fixed ? (Py_INCREF(fixed), fixed) : PyTuple_New(0);
    self->direct = e->direct;
    self->nin = nin;
    self->max_rows = max_rows;
    self->nan_declines = nan_declines != 0;
    self->takes_out = takes_out != 0 && e->nout == 1 && nfixed == 0;
    if (self->fixed == nullptr) return Py_DECREF(self), nullptr;
    return reinterpret_cast<PyObject*>(self);
}

int fast_traverse(PyObject* self_, visitproc visit, void* arg) {
    auto* self = reinterpret_cast<FastPath*>(self_);
    Py_VISIT(self->func);
    Py_VISIT(self->kernel);
    Py_VISIT(self->fixed);
    Py_VISIT(self->lazy);
    return 0;
}

int fast_clear(PyObject* self_) {
    auto* self = reinterpret_cast<FastPath*>(self_);
    Py_CLEAR(self->func);
    Py_CLEAR(self->kernel);
    Py_CLEAR(self->fixed);
    Py_CLEAR(self->lazy);
    return 0;
}

void fast_dealloc(PyObject* self) {
    PyObject_GC_UnTrack(self);
    fast_clear(self);
    Py_TYPE(self)->tp_free(self);
}

// Attributes not of FastPath itself come from the wrapped function.
PyObject* fast_getattro(PyObject* self, PyObject* name) {
    PyObject* r = PyObject_GenericGetAttr(self, name);
    if (r != nullptr || !PyErr_ExceptionMatches(PyExc_AttributeError)) return r;
    PyErr_Clear();
    return PyObject_GetAttr(reinterpret_cast<FastPath*>(self)->func, name);
}

PyObject* from_func(PyObject* self, void* name) {
    return PyObject_GetAttrString(reinterpret_cast<FastPath*>(self)->func, static_cast<const char*>(name));
}

PyObject* fast_repr(PyObject* self_) {
    auto* self = reinterpret_cast<FastPath*>(self_);
    PyObject* name = PyObject_GetAttrString(self->func, "__qualname__");
    if (name == nullptr) return nullptr;
    PyObject* r = PyUnicode_FromFormat("<function %S with a fast path>", name);
    Py_DECREF(name);
    return r;
}

// As a function: bound when read through an instance (so inspect and pydoc treat it as a routine).
PyObject* fast_descr_get(PyObject* self, PyObject* obj, PyObject*) {
    if (obj == nullptr || obj == Py_None) {
        Py_INCREF(self);
        return self;
    }
    return PyMethod_New(self, obj);
}

// pickle and copy: a reference to the module attribute of the same name (as for a plain function)
PyObject* fast_reduce(PyObject* self, PyObject*) { return from_func(self, const_cast<char*>("__qualname__")); }

PyGetSetDef fast_getset[] = {
    {"__name__", from_func, nullptr, nullptr, const_cast<char*>("__name__")},
    {"__qualname__", from_func, nullptr, nullptr, const_cast<char*>("__qualname__")},
    {"__module__", from_func, nullptr, nullptr, const_cast<char*>("__module__")},
    {"__doc__", from_func, nullptr, nullptr, const_cast<char*>("__doc__")},
    {nullptr, nullptr, nullptr, nullptr, nullptr}};

PyMemberDef fast_members[] = {
    {"__wrapped__", T_OBJECT_EX, offsetof(FastPath, func), READONLY, "The function called for every other input."},
    {"kernel", T_OBJECT_EX, offsetof(FastPath, kernel), READONLY, "The gufunc whose direct entry is tried first."},
    {nullptr, 0, 0, 0, nullptr}};

PyMethodDef fast_methods[] = {{"__reduce__", fast_reduce, METH_NOARGS, nullptr}, {nullptr, nullptr, 0, nullptr}};

PyTypeObject FastPathType = {PyVarObject_HEAD_INIT(nullptr, 0) "dualpose._native.FastPath"};

}  // namespace

bool register_direct(PyObject* ufunc, const DirectEntry& entry) {
    Py_INCREF(ufunc);
    registry().emplace_back(ufunc, entry);
    return true;
}

const DirectEntry* find_direct(PyObject* ufunc) {
    for (const auto& [u, e] : registry())
        if (u == ufunc) return &e;
    return nullptr;
}

bool add_fast_path(PyObject* m) {
    FastPathType.tp_basicsize = sizeof(FastPath);
    FastPathType.tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL;
    FastPathType.tp_doc = "FastPath(kernel, func, nan_declines=False, max_rows=-1, fixed=(), takes_out=False): func "
                          "with the direct native entry of the gufunc kernel in front of it (see algebra/fastpath.cpp).";
    FastPathType.tp_new = fast_new;
    FastPathType.tp_dealloc = fast_dealloc;
    FastPathType.tp_traverse = fast_traverse;
    FastPathType.tp_clear = fast_clear;
    FastPathType.tp_vectorcall_offset = offsetof(FastPath, vectorcall);
    FastPathType.tp_call = PyVectorcall_Call;
    FastPathType.tp_getattro = fast_getattro;
    FastPathType.tp_repr = fast_repr;
    FastPathType.tp_descr_get = fast_descr_get;
    FastPathType.tp_getset = fast_getset;
    FastPathType.tp_members = fast_members;
    FastPathType.tp_methods = fast_methods;
    return add_type(m, &FastPathType, "FastPath");
}

}  // namespace dualpose
