// Real NumPy generalized ufuncs from scalar kernels with fixed core shapes.
//
// A kernel is a plain function  void f(const double* in0, ..., double* out0, ...)  on contiguous core buffers
// (row-major for matrices).  Gufunc<F, Ops...> builds the NumPy inner loop for it: each operand's core elements are
// gathered from NumPy's strides into small local buffers, the kernel runs, and the outputs are scattered back, so
// broadcasting, out=, non-contiguous inputs and in-place calls behave as for any ufunc (NumPy handles overlapping
// operands before the loop).  Shapes: S (a scalar, core "()"), V<n> (core "(n)"), M<r, c> (core "(r,c)").
//
// An optional ROWS function  void rows(const double* in0, ..., double* out0, ..., npy_intp n)  replaces the
// per-element loop when every operand is a C-contiguous stack of cores (the usual large batch) and, when it returns
// int, also runs on blocks of rows gathered into contiguous buffers otherwise: a plain, non-template function that
// the compiler vectorises across rows and that can be cloned per instruction set (target_clones); it must compute
// exactly what F computes, row by row, and read a row before writing it.
//
// Every gufunc also gets a direct entry (Gufunc::direct, registered with register_direct): for inputs that need no
// gufunc machinery -- exact float64 ndarrays, C-contiguous, aligned, native byte order, the core shapes, one common
// leading shape (single elements and, for scalar cores, Python floats go with every row) -- it allocates the outputs
// (or takes a preallocated one) and runs ROWS (or F row by row, as the gufunc's strided loop) on them, so it returns
// what the gufunc returns bit for bit; other inputs are declined and take the gufunc.
// dualpose._native.FastPath (algebra/fastpath.cpp) puts it in front of a public function.
#pragma once

#include "direct.hpp"
#include "numpy_api.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

namespace dualpose {

template <int R, int C = -1>
struct Shape {
    static constexpr int ndim = C >= 0 ? 2 : (R > 0 ? 1 : 0);
    static constexpr int size = C >= 0 ? R * C : (R > 0 ? R : 1);
    static constexpr int rows = R;
    static constexpr int cols = C;
    static std::string core() {
        if constexpr (ndim == 0) return "()";
        else if constexpr (ndim == 1) return "(" + std::to_string(R) + ")";
        else return "(" + std::to_string(R) + "," + std::to_string(C) + ")";
    }
};
using S = Shape<0>;
template <int N>
using V = Shape<N>;
template <int R, int C>
using M = Shape<R, C>;

template <class Op>
inline void gather(const char* p, const npy_intp* cs, double* buf) {
    if constexpr (Op::ndim == 0) {
        buf[0] = *reinterpret_cast<const double*>(p);
    } else if constexpr (Op::ndim == 1) {
        for (int k = 0; k < Op::rows; ++k) buf[k] = *reinterpret_cast<const double*>(p + k * cs[0]);
    } else {
        for (int r = 0; r < Op::rows; ++r)
            for (int c = 0; c < Op::cols; ++c)
                buf[r * Op::cols + c] = *reinterpret_cast<const double*>(p + r * cs[0] + c * cs[1]);
    }
}

template <class Op>
inline void scatter(char* p, const npy_intp* cs, const double* buf) {
    if constexpr (Op::ndim == 0) {
        *reinterpret_cast<double*>(p) = buf[0];
    } else if constexpr (Op::ndim == 1) {
        for (int k = 0; k < Op::rows; ++k) *reinterpret_cast<double*>(p + k * cs[0]) = buf[k];
    } else {
        for (int r = 0; r < Op::rows; ++r)
            for (int c = 0; c < Op::cols; ++c)
                *reinterpret_cast<double*>(p + r * cs[0] + c * cs[1]) = buf[r * Op::cols + c];
    }
}

// Whether p[0..n) holds a NaN (a loop the compiler vectorises: quiet comparisons, no early exit).
inline bool has_nan(const double* p, npy_intp n) {
    int any = 0;
    for (npy_intp k = 0; k < n; ++k) any |= p[k] != p[k];
    return any != 0;
}

template <class... Ops>
struct In {
    static constexpr int n = sizeof...(Ops);
};
template <class... Ops>
struct Out {
    static constexpr int n = sizeof...(Ops);
};

template <auto F, class Ins, class Outs, auto ROWS = nullptr>
struct Gufunc;

template <auto F, class... I, class... O, auto ROWS>
struct Gufunc<F, In<I...>, Out<O...>, ROWS> {
    static constexpr int nin = sizeof...(I);
    static constexpr int nout = sizeof...(O);
    static constexpr int nargs = nin + nout;
    // whether the strided loop runs ROWS on gathered blocks (an int ROWS: see run)
    template <class>
    using InPtr = const double*;
    template <class>
    using OutPtr = double*;
    static constexpr bool blocked() {
        if constexpr (std::is_same_v<decltype(ROWS), std::nullptr_t>) return false;
        else return std::is_same_v<
                 decltype(ROWS(std::declval<InPtr<I>>()..., std::declval<OutPtr<O>>()..., npy_intp{})), int>;
    }
    static constexpr bool kBlocked = blocked();

    static std::string signature() {
        std::string s;
        ((s += (s.empty() ? "" : ",") + I::core()), ...);
        s += "->";
        bool first = true;
        ((s += (first ? "" : ",") + O::core(), first = false), ...);
        return s;
    }

    template <std::size_t... Ii, std::size_t... Oi>
    static void run(char** args, npy_intp n, const npy_intp* steps, std::index_sequence<Ii...>,
                    std::index_sequence<Oi...>) {
        constexpr std::array<int, nargs> core_ndim = {I::ndim..., O::ndim...};
        std::array<const npy_intp*, nargs> cs{};
        const npy_intp* c = steps + nargs;
        for (int j = 0; j < nargs; ++j) {
            cs[j] = c;
            c += core_ndim[j];
        }
        std::tuple<std::array<double, O::size>...> ob;
        constexpr std::array<int, nargs> sizes = {I::size..., O::size...};
        constexpr std::array<int, nargs> cols = {I::cols..., O::cols...};
        constexpr npy_intp d = sizeof(double);
        bool contiguous = true;  // every operand a C-contiguous stack of cores (scalars, vectors, row-major matrices)
        for (int j = 0; j < nargs; ++j) {
            contiguous &= steps[j] == d * sizes[j];
            if (core_ndim[j] == 1) contiguous &= cs[j][0] == d;
            if (core_ndim[j] == 2) contiguous &= cs[j][0] == d * cols[j] && cs[j][1] == d;
        }
        if constexpr (!std::is_same_v<decltype(ROWS), std::nullptr_t>) {
            if (contiguous) {
                ROWS(reinterpret_cast<const double*>(args[Ii])..., reinterpret_cast<double*>(args[nin + Oi])..., n);
                return;
            }
        }
        if (contiguous) {
            // C-contiguous rows: the kernel reads the inputs in place; outputs go through a local buffer so that
            // an output that is also an input (out=) is only written after the kernel has read it
            for (npy_intp i = 0; i < n; ++i) {
                F((reinterpret_cast<const double*>(args[Ii]) + i * I::size)..., std::get<Oi>(ob).data()...);
                ((std::copy(std::get<Oi>(ob).begin(), std::get<Oi>(ob).end(),
                            reinterpret_cast<double*>(args[nin + Oi]) + i * O::size)),
                 ...);
            }
            return;
        }
        char* p[nargs];
        for (int j = 0; j < nargs; ++j) p[j] = args[j];
        if constexpr (kBlocked) {
            // strided or broadcast operands of a kernel with an int row loop (the heavy kernels of algebra/rows.hpp):
            // blocks of rows gathered into contiguous buffers, ROWS on them (the same values as F row by row), the
            // outputs scattered back; each block's inputs are read before its outputs are written, as NumPy's
            // in-place calls need
            constexpr npy_intp kBlock = 32;
            constexpr int kIn = (I::size + ...), kOut = (O::size + ...);
            double scratch[kBlock * (kIn + kOut)];  // not initialised: every element used is written first
            constexpr std::array<int, nargs> sizes = {I::size..., O::size...};
            double* buf[nargs];
            for (int j = 0, off = 0; j < nargs; off += kBlock * sizes[j], ++j) buf[j] = scratch + off;
            for (npy_intp i0 = 0; i0 < n; i0 += kBlock) {
                const npy_intp m = std::min(kBlock, n - i0);
                for (npy_intp r = 0; r < m; ++r) {
                    (gather<I>(p[Ii], cs[Ii], buf[Ii] + r * I::size), ...);
                    for (int j = 0; j < nin; ++j) p[j] += steps[j];
                }
                ROWS(static_cast<const double*>(buf[Ii])..., buf[nin + Oi]..., m);
                for (npy_intp r = 0; r < m; ++r) {
                    (scatter<O>(p[nin + Oi], cs[nin + Oi], buf[nin + Oi] + r * O::size), ...);
                    for (int j = nin; j < nargs; ++j) p[j] += steps[j];
                }
            }
            return;
        }
        std::tuple<std::array<double, I::size>...> ib;
        for (npy_intp i = 0; i < n; ++i) {
            (gather<I>(p[Ii], cs[Ii], std::get<Ii>(ib).data()), ...);
            F(std::get<Ii>(ib).data()..., std::get<Oi>(ob).data()...);
            (scatter<O>(p[nin + Oi], cs[nin + Oi], std::get<Oi>(ob).data()), ...);
            for (int j = 0; j < nargs; ++j) p[j] += steps[j];
        }
    }

    static void loop(char** args, const npy_intp* dims, const npy_intp* steps, void*) {
        run(args, dims[0], steps, std::index_sequence_for<I...>{}, std::index_sequence_for<O...>{});
    }

    // The direct entry (see the top of this file): 1 with *result the output (a tuple for several), 0 when the
    // inputs need the gufunc, when the computation raised a floating-point exception flag or, with nan_declines,
    // when an output holds a NaN; -1 with a Python error set.
    static int direct(PyObject* const* args, PyObject* out, std::ptrdiff_t max_rows, bool nan_declines,
                      PyObject** result) {
        return direct_impl(args, out, max_rows, nan_declines, result, std::index_sequence_for<I...>{},
                           std::index_sequence_for<O...>{});
    }

    template <std::size_t... Ii, std::size_t... Oi>
    static int direct_impl(PyObject* const* args, PyObject* out, npy_intp max_rows, bool nan_declines,
                           PyObject** result, std::index_sequence<Ii...>, std::index_sequence<Oi...>) {
        constexpr int core_ndim[nin] = {I::ndim...};
        constexpr int core_rows[nin] = {I::rows...};
        constexpr int core_cols[nin] = {I::cols...};
        constexpr npy_intp core_size[nin] = {I::size...};
        const double* in[nin];
        npy_intp step[nin];  // doubles per row: the core size; 0 for a single element or a Python float (every row)
        double value[nin];
        int lead_ndim = -1;
        const npy_intp* lead = nullptr;
        for (int j = 0; j < nin; ++j) {
            PyObject* o = args[j];
            if (core_ndim[j] == 0 && PyFloat_Check(o)) {
                value[j] = PyFloat_AS_DOUBLE(o);
                in[j] = &value[j];
                step[j] = 0;
                continue;
            }
            if (!PyArray_CheckExact(o)) return 0;
            auto* a = reinterpret_cast<PyArrayObject*>(o);
            if (PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISCARRAY_RO(a) || !PyArray_ISNOTSWAPPED(a)) return 0;
            const int nd = PyArray_NDIM(a) - core_ndim[j];
            const npy_intp* d = PyArray_DIMS(a);
            if (nd < 0) return 0;
            if (core_ndim[j] >= 1 && d[nd] != core_rows[j]) return 0;
            if (core_ndim[j] == 2 && d[nd + 1] != core_cols[j]) return 0;
            in[j] = static_cast<const double*>(PyArray_DATA(a));
            step[j] = nd == 0 ? 0 : core_size[j];  // a single element goes with every row (as the gufunc broadcasts)
            if (nd == 0) continue;
            if (lead_ndim < 0) {
                lead_ndim = nd;
                lead = d;
            } else if (nd != lead_ndim || !std::equal(d, d + nd, lead)) {
                return 0;  // other broadcasting: the gufunc's job
            }
        }
        if (lead_ndim < 0) lead_ndim = 0;  // single elements only
        npy_intp n = 1;
        for (int k = 0; k < lead_ndim; ++k) n *= lead[k];
        if (max_rows >= 0 && n > max_rows) return 0;
        constexpr int out_ndim[nout] = {O::ndim...};
        constexpr int out_rows[nout] = {O::rows...};
        constexpr int out_cols[nout] = {O::cols...};
        constexpr npy_intp out_size[nout] = {O::size...};
        PyObject* outs[nout] = {};
        double* od[nout];
        npy_intp dims[NPY_MAXDIMS];
        if (lead_ndim + 2 > NPY_MAXDIMS) return 0;
        std::copy(lead, lead + lead_ndim, dims);
        if (out != nullptr) {
            // a preallocated output: exactly the result's shape, C-contiguous, writeable, sharing no memory with an
            // input (NumPy would work on copies of overlapping operands)
            if (nout != 1 || !PyArray_CheckExact(out)) return 0;
            auto* o = reinterpret_cast<PyArrayObject*>(out);
            dims[lead_ndim] = out_rows[0];
            dims[lead_ndim + 1] = out_cols[0];
            if (PyArray_TYPE(o) != NPY_DOUBLE || !PyArray_ISCARRAY(o) || !PyArray_ISNOTSWAPPED(o) ||
                PyArray_NDIM(o) != lead_ndim + out_ndim[0] ||
                !std::equal(dims, dims + lead_ndim + out_ndim[0], PyArray_DIMS(o)))
                return 0;
            const char* lo = static_cast<const char*>(PyArray_DATA(o));
            const char* hi = lo + PyArray_NBYTES(o);
            for (int j = 0; j < nin; ++j) {
                const char* a = reinterpret_cast<const char*>(in[j]);
                const char* b = a + sizeof(double) * (step[j] ? n * step[j] : core_size[j]);
                if (a < hi && lo < b) return 0;
            }
            Py_INCREF(out);
            outs[0] = out;
            od[0] = reinterpret_cast<double*>(PyArray_DATA(o));
        }
        for (int j = out != nullptr ? nout : 0; j < nout; ++j) {
            dims[lead_ndim] = out_rows[j];
            dims[lead_ndim + 1] = out_cols[j];
            outs[j] = PyArray_SimpleNew(lead_ndim + out_ndim[j], dims, NPY_DOUBLE);
            if (outs[j] == nullptr) {
                for (int k = 0; k < j; ++k) Py_DECREF(outs[k]);
                return -1;
            }
            od[j] = static_cast<double*>(PyArray_DATA(reinterpret_cast<PyArrayObject*>(outs[j])));
        }
        // every input a stack of n cores (or one row in all): the gufunc's contiguous loop (ROWS when there is one);
        // else F row by row, as the gufunc's strided loop
        bool full = true;
        for (int j = 0; j < nin; ++j) full &= step[j] != 0;
        full |= n == 1;
        fp_flags_clear();  // a computation that raises a flag is declined (direct.hpp)
        bool decline = false;
        constexpr npy_intp kChunk = 1024;  // rows per NaN scan, while they are in cache
        {
            const bool nogil = n >= 4 * kChunk;
            PyThreadState* ts = nogil ? PyEval_SaveThread() : nullptr;
            bool flagged = false;  // an int ROWS flags every row whose norm is zero or extreme (algebra/rows.hpp):
                                   // with nan_declines its flag stands for the NaN scan
            if constexpr (!std::is_same_v<decltype(ROWS), std::nullptr_t>) {
                if constexpr (std::is_same_v<decltype(ROWS(in[Ii]..., od[Oi]..., n)), int>) {
                    if (full && nan_declines) {
                        decline = ROWS(in[Ii]..., od[Oi]..., n) != 0;
                        flagged = true;
                    }
                }
            }
            for (npy_intp i0 = 0, m = 0; i0 < n && !decline && !flagged; i0 += m) {
                m = nan_declines ? std::min(kChunk, n - i0) : n - i0;
                bool done = false;
                if constexpr (!std::is_same_v<decltype(ROWS), std::nullptr_t>) {
                    if (full) {
                        ROWS((in[Ii] + i0 * step[Ii])..., (od[Oi] + i0 * out_size[Oi])..., m);
                        done = true;
                    }
                }
                if (!done)
                    for (npy_intp i = i0; i < i0 + m; ++i) F((in[Ii] + i * step[Ii])..., (od[Oi] + i * out_size[Oi])...);
                if (nan_declines)
                    for (int j = 0; j < nout; ++j) decline |= has_nan(od[j] + i0 * out_size[j], m * out_size[j]);
            }
            decline |= fp_flags_raised();
            if (nogil) PyEval_RestoreThread(ts);
        }
        if (decline) {
            for (int j = 0; j < nout; ++j) Py_DECREF(outs[j]);
            return 0;
        }
        if constexpr (nout == 1) {
            *result = out != nullptr ? outs[0] : PyArray_Return(reinterpret_cast<PyArrayObject*>(outs[0]));
        } else {
            PyObject* t = PyTuple_New(nout);
            if (t == nullptr) {
                for (int j = 0; j < nout; ++j) Py_DECREF(outs[j]);
                return -1;
            }
            for (int j = 0; j < nout; ++j) PyTuple_SET_ITEM(t, j, PyArray_Return(reinterpret_cast<PyArrayObject*>(outs[j])));
            *result = t;
        }
        return *result == nullptr ? -1 : 1;
    }

    template <std::size_t... Ii, std::size_t... Oi>
    static void row_impl(const double* const* in, double* const* out, std::index_sequence<Ii...>,
                         std::index_sequence<Oi...>) {
        F(in[Ii]..., out[Oi]...);
    }
    static void row(const double* const* in, double* const* out) {
        row_impl(in, out, std::index_sequence_for<I...>{}, std::index_sequence_for<O...>{});
    }

    static DirectEntry entry() {
        DirectEntry e{&direct, &row, nin, nout, {}, {}};
        constexpr int is[] = {I::size...};
        constexpr int os[] = {O::size...};
        for (int j = 0; j < nin && j < 8; ++j) e.in_size[j] = is[j];
        for (int j = 0; j < nout && j < 8; ++j) e.out_size[j] = os[j];
        return e;
    }

    // The ufunc object (a new reference), or nullptr with a Python error set.
    static PyObject* create(const char* name, const char* doc) {
        static PyUFuncGenericFunction funcs[1] = {&loop};
        static void* data[1] = {nullptr};
        static char types[nargs];
        for (int j = 0; j < nargs; ++j) types[j] = NPY_DOUBLE;
        static const std::string sig = signature();
        return PyUFunc_FromFuncAndDataAndSignature(funcs, data, types, 1, nin, nout, PyUFunc_None, name, doc, 0,
                                                   sig.c_str());
    }
};

// Add the gufunc of kernel F as attribute ``name`` of ``module``; returns false with a Python error set.
template <class G>
inline bool add_gufunc(PyObject* module, const char* name, const char* doc) {
    PyObject* u = G::create(name, doc);
    if (u == nullptr) return false;
    if (!register_direct(u, G::entry())) return Py_DECREF(u), false;
    return PyModule_AddObject(module, name, u) == 0 || (Py_DECREF(u), false);
}

}  // namespace dualpose
