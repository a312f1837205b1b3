// The fast path of the numeric text-table reader (dualpose.io._text.read_float_table): one pass over a block of
// whole lines, the numbers written straight into the output rows.
//
// Grammar accepted, per data line: fields of the form [+-] digits [. digits] [(e|E) [+-] digits] (at least one
// digit before the exponent), separated by runs of blanks or by commas with optional blanks around them; "#" starts
// a comment that runs to the end of the line; blank and comment-only lines are skipped.  Numbers are converted by
// std::from_chars, which rounds correctly (the double Python's float() returns).  Anything else -- another
// character, a non-ASCII byte, a wrong number of fields, a value outside the double range -- stops the parse with
// status BAD and the caller re-reads the file with the line-by-line reader, whose error names the file and line.
#include "../common/args.hpp"

#include <charconv>
#include <cstdint>

namespace dualpose {
namespace {

enum Status : int { OK = 0, BAD = 1, OUT_FULL = 2 };

inline bool is_blank(std::uint8_t c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }
inline bool is_digit(std::uint8_t c) { return c >= '0' && c <= '9'; }

// Skip to the end of a comment starting at i; false if it holds a non-ASCII byte.
inline bool skip_comment(const std::uint8_t* buf, npy_intp n, npy_intp& i) {
    while (i < n && buf[i] != '\n') {
        if (buf[i] >= 128) return false;
        ++i;
    }
    return true;
}

constexpr double POW10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                               1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

// One number at buf[i]; on success stores it in *v and leaves i after it.  A mantissa m <= 2^53 with a power of
// ten 10^e, |e| <= 22, is converted as one correctly rounded operation m * 10^e or m / 10^-e (both operands are
// exact doubles: Clinger 1990, "How to read floating point numbers accurately", the fast path); every other
// number goes through std::from_chars, also correctly rounded.
inline bool parse_number(const std::uint8_t* buf, npy_intp n, npy_intp& i, bool comma, double* v) {
    npy_intp start = i;
    bool neg = false;
    if (i < n && buf[i] == '+') start = ++i;  // from_chars takes '-' but not '+'
    else if (i < n && buf[i] == '-') neg = true, ++i;
    std::uint64_t m = 0;
    int digits = 0, exp10 = 0;
    while (i < n && is_digit(buf[i])) {
        if (digits < 19) m = m * 10 + (buf[i] - '0');
        ++i, ++digits;
    }
    if (i < n && buf[i] == '.') {
        ++i;
        while (i < n && is_digit(buf[i])) {
            if (digits < 19) m = m * 10 + (buf[i] - '0');
            ++i, ++digits, --exp10;
        }
    }
    if (digits == 0) return false;
    bool fast = digits <= 19;
    if (i < n && (buf[i] == 'e' || buf[i] == 'E')) {
        ++i;
        bool eneg = false;
        if (i < n && (buf[i] == '+' || buf[i] == '-')) eneg = buf[i] == '-', ++i;
        int ne = 0, ev = 0;
        while (i < n && is_digit(buf[i])) {
            if (ev < 100000) ev = ev * 10 + (buf[i] - '0');
            ++i, ++ne;
        }
        if (ne == 0) return false;
        exp10 += eneg ? -ev : ev;
    }
    if (i < n) {
        const std::uint8_t c = buf[i];
        if (!(is_blank(c) || c == '\n' || c == '#' || (comma && c == ','))) return false;
    }
    if (fast && m <= (std::uint64_t(1) << 53) && exp10 >= -22 && exp10 <= 22) {
        const double x = static_cast<double>(m);
        const double r = exp10 >= 0 ? x * POW10[exp10] : x / POW10[-exp10];
        *v = neg ? -r : r;
        return true;
    }
    const char* first = reinterpret_cast<const char*>(buf + start);
    const char* last = reinterpret_cast<const char*>(buf + i);
    auto [ptr, ec] = std::from_chars(first, last, *v);
    return ec == std::errc() && ptr == last;  // out of range (1e400) is refused: the line reader reports it
}

// Parse the lines of buf[pos:] into out[row:]; returns (status, pos, row).  On OUT_FULL, pos is the start of the
// first line not stored (grow out and call again); on BAD, the start of the offending line.
PyObject* io_parse_block(PyObject*, PyObject* args) {
    Py_buffer view;
    Array<double, 2, true> out;
    Py_ssize_t pos, ncols, row;
    int comma;
    if (!PyArg_ParseTuple(args, "y*nnpO&n", &view, &pos, &ncols, &comma, convert<double, 2, true>, &out, &row))
        return nullptr;
    if (out.shape[1] != ncols || ncols <= 0 || pos < 0 || row < 0) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_ValueError, "out must have shape (rows, ncols) with ncols >= 1; pos, row >= 0");
        return nullptr;
    }
    const std::uint8_t* buf = static_cast<const std::uint8_t*>(view.buf);
    const npy_intp n = view.len;
    const npy_intp cap = out.shape[0];
    int status = OK;
    {
        NPY_BEGIN_ALLOW_THREADS;
        while (pos < n) {
            npy_intp i = pos;
            while (i < n && is_blank(buf[i])) ++i;
            if (i >= n) {
                pos = n;
                break;
            }
            if (buf[i] == '\n') {  // blank line
                pos = i + 1;
                continue;
            }
            if (buf[i] == '#') {  // comment line
                if (!skip_comment(buf, n, i)) {
                    status = BAD;
                    break;
                }
                pos = i + 1;
                continue;
            }
            if (row >= cap) {
                status = OUT_FULL;
                break;
            }
            double* dst = out.data + row * ncols;
            Py_ssize_t col = 0;
            bool ok = true;
            while (true) {
                if (col == ncols || !parse_number(buf, n, i, comma, dst + col)) {
                    ok = false;
                    break;
                }
                ++col;
                while (i < n && is_blank(buf[i])) ++i;
                if (i >= n || buf[i] == '\n') break;
                if (buf[i] == '#') {  // trailing comment
                    ok = skip_comment(buf, n, i);
                    break;
                }
                if (comma) {
                    if (buf[i] != ',') {
                        ok = false;
                        break;
                    }
                    ++i;
                    while (i < n && is_blank(buf[i])) ++i;
                    if (i >= n || buf[i] == '\n' || buf[i] == '#') {  // trailing comma
                        ok = false;
                        break;
                    }
                }
            }
            if (!ok || col != ncols) {
                status = BAD;
                break;
            }
            ++row;
            pos = i + 1;
        }
        NPY_END_ALLOW_THREADS;
    }
    PyBuffer_Release(&view);
    if (status == OK && pos > n) pos = n;
    return Py_BuildValue("inn", status, pos, row);
}

PyMethodDef io_methods[] = {
    {"io_parse_block", io_parse_block, METH_VARARGS,
     "io_parse_block(buf, pos, ncols, comma, out, row) -> (status, pos, row): the numeric lines of the bytes-like "
     "buf[pos:] (whole lines) into out[row:] (float64 (R, ncols)); status 0 done, 1 not a plain table "
     "(use the line reader), 2 out is full."},
    {nullptr, nullptr, 0, nullptr}};

}  // namespace

bool add_io(PyObject* module) { return PyModule_AddFunctions(module, io_methods) == 0; }

}  // namespace dualpose
