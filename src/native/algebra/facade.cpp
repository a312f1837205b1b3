// dualpose._native.Facade: the native base of the algebra's object facade (dualpose.algebra.classes).
//
// A Facade holds one float64 array, ``_a``.  A single element made by a product is held inline (its components in
// the object itself) until ``_a`` is first read, which then creates the (n,) array once and keeps it; so composing
// single elements in a loop allocates no array, and reading ``_a`` (``.array``, every method) always gives the same
// stored array.
//
// ``cls._set_product(kernel, func)`` makes ``a * b`` for instances of ``cls`` (both) the product ``kernel`` (a
// two-input gufunc of dualpose._native whose inputs and output have the same core size): two single elements
// (held inline, or as C-contiguous float64 (n,) arrays) are multiplied by the kernel's row function into an inline
// result -- the gufunc's row, bit for bit -- and anything else (batches, views) is ``cls._wrap(func(a._a, b._a))``.
// A product whose row raises a floating-point exception flag also takes ``func`` (which reports it, as NumPy does).
// Other operands give NotImplemented, so ``ndarray * obj`` and ``obj * 2`` raise TypeError.
#include "../common/direct.hpp"
#include "../common/numpy_api.hpp"

#include <cstring>
#include <vector>

namespace dualpose {

namespace {

constexpr int kInline = 8;

struct Facade {
    PyObject_HEAD
    PyObject* a;          // the stored array, or nullptr while the element is held inline
    double v[kInline];    // the inline element
    int n;                // components held inline (0 when `a` holds the element)
};

struct Product {
    PyTypeObject* type;
    RowFn row;
    PyObject* func;
    int size;
};

std::vector<Product>& products() {
    static std::vector<Product> p;
    return p;
}

PyTypeObject FacadeType = {PyVarObject_HEAD_INIT(nullptr, 0) "dualpose._native.Facade"};

// New reference to the stored array, creating it from the inline element on first use.
PyObject* stored(Facade* f) {
    if (f->a == nullptr) {
        if (f->n == 0) {
            PyErr_SetString(PyExc_AttributeError, "_a");
            return nullptr;
        }
        npy_intp dim = f->n;
        PyObject* arr = PyArray_SimpleNew(1, &dim, NPY_DOUBLE);
        if (arr == nullptr) return nullptr;
        std::memcpy(PyArray_DATA(reinterpret_cast<PyArrayObject*>(arr)), f->v, sizeof(double) * f->n);
        f->a = arr;
        f->n = 0;
    }
    Py_INCREF(f->a);
    return f->a;
}

PyObject* get_a(PyObject* self, void*) { return stored(reinterpret_cast<Facade*>(self)); }

int set_a(PyObject* self, PyObject* value, void*) {
    auto* f = reinterpret_cast<Facade*>(self);
    Py_XINCREF(value);
    Py_XSETREF(f->a, value);
    f->n = 0;
    return 0;
}

// The components of a single element of `size` doubles, or nullptr when `o` holds anything else.
const double* single(PyObject* o, int size) {
    auto* f = reinterpret_cast<Facade*>(o);
    if (f->n == size) return f->v;
    if (f->a == nullptr || !PyArray_CheckExact(f->a)) return nullptr;
    auto* a = reinterpret_cast<PyArrayObject*>(f->a);
    if (PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != size || !PyArray_ISCARRAY_RO(a) ||
        !PyArray_ISNOTSWAPPED(a))
        return nullptr;
    return static_cast<const double*>(PyArray_DATA(a));
}

// cls._wrap(a): an instance of cls holding the array a (no copy, no checks).
PyObject* wrap(PyObject* cls, PyObject* a) {
    auto* type = reinterpret_cast<PyTypeObject*>(cls);
    auto* f = reinterpret_cast<Facade*>(type->tp_alloc(type, 0));
    if (f == nullptr) return nullptr;
    Py_INCREF(a);
    f->a = a;
    return reinterpret_cast<PyObject*>(f);
}

PyObject* multiply(PyObject* x, PyObject* y) {
    const Product* p = nullptr;
    for (const Product& q : products())
        if (PyObject_TypeCheck(x, q.type)) {
            p = &q;
            break;
        }
    if (p == nullptr || !PyObject_TypeCheck(y, p->type)) Py_RETURN_NOTIMPLEMENTED;
    const double* in[2] = {single(x, p->size), single(y, p->size)};
    if (in[0] != nullptr && in[1] != nullptr) {
        auto* r = reinterpret_cast<Facade*>(p->type->tp_alloc(p->type, 0));
        if (r == nullptr) return nullptr;
        fp_flags_clear();
        double* out[1] = {r->v};
        p->row(in, out);
        if (!fp_flags_raised()) {
            r->n = p->size;
            return reinterpret_cast<PyObject*>(r);
        }
        Py_DECREF(r);
    }
    PyObject* args[2] = {stored(reinterpret_cast<Facade*>(x)), nullptr};
    if (args[0] == nullptr) return nullptr;
    args[1] = stored(reinterpret_cast<Facade*>(y));
    if (args[1] == nullptr) return Py_DECREF(args[0]), nullptr;
    PyObject* res = PyObject_Vectorcall(p->func, args, 2, nullptr);
    Py_DECREF(args[0]);
    Py_DECREF(args[1]);
    if (res == nullptr) return nullptr;
    PyObject* r = wrap(reinterpret_cast<PyObject*>(p->type), res);
    Py_DECREF(res);
    return r;
}

PyObject* set_product(PyObject* cls, PyObject* args) {
    PyObject *kernel, *func;
    if (!PyArg_ParseTuple(args, "OO:_set_product", &kernel, &func)) return nullptr;
    const DirectEntry* e = find_direct(kernel);
    if (e == nullptr || e->nin != 2 || e->nout != 1 || e->in_size[0] != e->out_size[0] ||
        e->in_size[1] != e->out_size[0] || e->out_size[0] > kInline) {
        PyErr_SetString(PyExc_TypeError, "_set_product: kernel must be a product gufunc of dualpose._native");
        return nullptr;
    }
    auto* type = reinterpret_cast<PyTypeObject*>(cls);
    Py_INCREF(func);
    Py_INCREF(cls);
    for (Product& q : products())
        if (q.type == type) {
            Py_DECREF(q.func);
            Py_DECREF(cls);
            q = {type, e->row, func, e->out_size[0]};
            Py_RETURN_NONE;
        }
    products().push_back({type, e->row, func, e->out_size[0]});
    Py_RETURN_NONE;
}

// pickle and copy: cls._wrap(array)
PyObject* reduce(PyObject* self, PyObject*) {
    PyObject* a = stored(reinterpret_cast<Facade*>(self));
    if (a == nullptr) return nullptr;
    PyObject* w = PyObject_GetAttrString(reinterpret_cast<PyObject*>(Py_TYPE(self)), "_wrap");
    PyObject* r = w ? Py_BuildValue("(N(N))", w, a) : (Py_DECREF(a), nullptr);
    return r;
}

int traverse(PyObject* self, visitproc visit, void* arg) {
    Py_VISIT(reinterpret_cast<Facade*>(self)->a);
    return 0;
}

int clear(PyObject* self) {
    Py_CLEAR(reinterpret_cast<Facade*>(self)->a);
    return 0;
}

void dealloc(PyObject* self) {
    PyObject_GC_UnTrack(self);
    clear(self);
    Py_TYPE(self)->tp_free(self);
}

PyGetSetDef facade_getset[] = {
    {"_a", get_a, set_a, "The stored float64 array (created from an inline element on first use).", nullptr},
    {nullptr, nullptr, nullptr, nullptr, nullptr}};

PyMethodDef facade_methods[] = {
    {"_wrap", wrap, METH_O | METH_CLASS, "cls._wrap(a): an instance holding the array a itself (no copy, no checks)."},
    {"_set_product", set_product, METH_VARARGS | METH_CLASS,
     "cls._set_product(kernel, func): a * b of two instances of cls (see algebra/facade.cpp)."},
    {"__reduce__", reduce, METH_NOARGS, nullptr},
    {nullptr, nullptr, 0, nullptr}};

PyNumberMethods facade_number = {};

}  // namespace

bool add_facade(PyObject* m) {
    facade_number.nb_multiply = multiply;
    FacadeType.tp_basicsize = sizeof(Facade);
    FacadeType.tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_BASETYPE | Py_TPFLAGS_HAVE_GC;
    FacadeType.tp_doc = "Native base of the algebra's object facade: one float64 array _a (see algebra/facade.cpp).";
    FacadeType.tp_new = PyType_GenericNew;
    FacadeType.tp_dealloc = dealloc;
    FacadeType.tp_traverse = traverse;
    FacadeType.tp_clear = clear;
    FacadeType.tp_getset = facade_getset;
    FacadeType.tp_methods = facade_methods;
    FacadeType.tp_as_number = &facade_number;
    return add_type(m, &FacadeType, "Facade");
}

}  // namespace dualpose
