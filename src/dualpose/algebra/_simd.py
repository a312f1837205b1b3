"""Explicit SIMD for the flat kernels: numba intrinsics that emit LLVM vector IR (not public API).

Some row layouts defeat LLVM's loop vectoriser.  A dual quaternion row is 8 doubles, and with AVX-512 the
vectoriser loads stride-8 columns with gathers (3-11x slower than the gufunc on AMD Zen); without gathers its
factor-8 interleaved loads were still slower than the gufunc.  The intrinsics here do the vectorisation by hand,
in portable LLVM IR: load eight rows as whole vectors, transpose them in registers with ``shufflevector`` into one
``<8 x double>`` per component, evaluate the *same* scalar formula on those vectors, and transpose back.
:func:`row_block` builds such an intrinsic for two inputs and one output of 8- or 3-double rows
(``dualquat_transform``: 8, 3 -> 3; ``dualquat_mul``: 8, 8 -> 8).

The formula is not re-written: the inline helper's Python function (:func:`lane_formula`, its ``py_func`` with
nested helpers resolved the same way) is called with :class:`_Lanes` arguments, whose ``+ - * /`` emit
``fadd/fsub/fmul/fdiv`` without fast-math flags.  Python keeps the expression tree, IEEE arithmetic is lane-wise,
and LLVM contracts or reassociates nothing without those flags, so every lane rounds exactly as the scalar gufunc
does (the tests check bit equality).  LLVM lowers the generic vectors to whatever the CPU has (one zmm with
AVX-512, two ymm with AVX2, four xmm with SSE2 or NEON).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from types import FunctionType

from llvmlite import ir
from numba import types
from numba.core.dispatcher import Dispatcher
from numba.extending import intrinsic

from dualpose.algebra._kutil import _HUGE, _TINY, dq_mul, transform_point

#: rows per vector block
LANES = 8
_F64 = ir.DoubleType()
_VEC = ir.VectorType(_F64, LANES)
_MASK = ir.VectorType(ir.IntType(32), LANES)
_I64 = ir.IntType(64)


class _Lanes:
    """An ``<8 x double>`` value with Python arithmetic (numbers are splatted), for running scalar formulas."""

    __slots__ = ("b", "v")

    def __init__(self, builder: ir.IRBuilder, value: ir.Value) -> None:
        self.b, self.v = builder, value

    @staticmethod
    def _val(x: _Lanes | float) -> ir.Value:
        return x.v if isinstance(x, _Lanes) else ir.Constant(_VEC, [float(x)] * LANES)

    def _op(self, name: str, a: _Lanes | float, c: _Lanes | float) -> _Lanes:
        return _Lanes(self.b, getattr(self.b, name)(self._val(a), self._val(c)))

    def __add__(self, o: _Lanes | float) -> _Lanes:
        return self._op("fadd", self, o)

    def __radd__(self, o: float) -> _Lanes:
        return self._op("fadd", o, self)

    def __sub__(self, o: _Lanes | float) -> _Lanes:
        return self._op("fsub", self, o)

    def __rsub__(self, o: float) -> _Lanes:
        return self._op("fsub", o, self)

    def __mul__(self, o: _Lanes | float) -> _Lanes:
        return self._op("fmul", self, o)

    def __rmul__(self, o: float) -> _Lanes:
        return self._op("fmul", o, self)

    def __truediv__(self, o: _Lanes | float) -> _Lanes:
        return self._op("fdiv", self, o)

    def __rtruediv__(self, o: float) -> _Lanes:
        return self._op("fdiv", o, self)

    def _branch(self, *_: object) -> bool:
        raise TypeError("a vectorised formula must be branch-free: no comparisons or truth tests on its values")

    __bool__ = __eq__ = __ne__ = __lt__ = __le__ = __gt__ = __ge__ = _branch
    __hash__ = None  # type: ignore[assignment]


def _shuffle(b: ir.IRBuilder, u: ir.Value, v: ir.Value, mask: Sequence[int]) -> ir.Value:
    """Lane k of the result is lane ``mask[k]`` of the concatenation ``[u, v]``."""
    return b.shuffle_vector(u, v, ir.Constant(_MASK, list(mask)))


def transpose8(b: ir.IRBuilder, rows: Sequence[ir.Value]) -> list[ir.Value]:
    """8x8 transpose in three butterfly stages (24 two-input shuffles): ``cols[k][r] == rows[r][k]``."""
    out = list(rows)
    for half in (1, 2, 4):  # swap blocks of `half` lanes between vectors `half` apart
        nxt = [None] * LANES
        for r in range(LANES):
            if r & half:
                continue
            lo = [k if not k & half else k - half + LANES for k in range(LANES)]
            hi = [k + half if not k & half else k + LANES for k in range(LANES)]
            nxt[r] = _shuffle(b, out[r], out[r + half], lo)
            nxt[r + half] = _shuffle(b, out[r], out[r + half], hi)
        out = nxt
    return out


def _gather_lanes(b: ir.IRBuilder, vecs: Sequence[ir.Value], src: Sequence[tuple[int, int]]) -> ir.Value:
    """The vector whose lane k is lane ``src[k][1]`` of ``vecs[src[k][0]]`` (three input vectors, two shuffles)."""
    first = [8 * v + lane if v < 2 else 0 for v, lane in src]
    tmp = _shuffle(b, vecs[0], vecs[1], first)
    return _shuffle(b, tmp, vecs[2], [k if v < 2 else LANES + lane for k, (v, lane) in enumerate(src)])


def split3(b: ir.IRBuilder, vecs: Sequence[ir.Value]) -> list[ir.Value]:
    """Eight 3-vectors stored row after row in three vectors -> one vector per component."""
    return [_gather_lanes(b, vecs, [divmod(3 * r + c, LANES) for r in range(LANES)]) for c in range(3)]


def join3(b: ir.IRBuilder, cols: Sequence[ir.Value]) -> list[ir.Value]:
    """Inverse of :func:`split3`: three component vectors -> eight 3-vectors stored row after row."""
    return [_gather_lanes(b, cols, [(f % 3, f // 3) for f in range(LANES * k, LANES * (k + 1))]) for k in range(3)]


def _vector_ptr(b: ir.IRBuilder, data: ir.Value, offset: ir.Value, k: int) -> ir.Value:
    return b.bitcast(b.gep(data, [b.add(offset, ir.Constant(_I64, LANES * k))]), _VEC.as_pointer())


#: in-register layout changes for the row widths the flat kernels use: rows -> component vectors, and back
_SPLIT = {3: split3, 8: transpose8}
_JOIN = {3: join3, 8: transpose8}


def load_rows(b: ir.IRBuilder, data: ir.Value, row: ir.Value, width: int) -> list[_Lanes]:
    """Rows ``row .. row+7`` of a C-contiguous ``(N, width)`` buffer as one :class:`_Lanes` per component."""
    at = b.mul(row, ir.Constant(_I64, width))
    vecs = [b.load(_vector_ptr(b, data, at, k), align=8) for k in range(width)]
    return [_Lanes(b, c) for c in _SPLIT[width](b, vecs)]


def store_rows(b: ir.IRBuilder, data: ir.Value, row: ir.Value, cols: Sequence[_Lanes]) -> None:
    """Inverse of :func:`load_rows`: write one vector per component as rows ``row .. row+7``."""
    at = b.mul(row, ir.Constant(_I64, len(cols)))
    for k, vec in enumerate(_JOIN[len(cols)](b, [c.v for c in cols])):
        b.store(vec, _vector_ptr(b, data, at, k), align=8)


def lane_formula(helper: Dispatcher) -> FunctionType:
    """The Python function of a numba inline helper, with the helpers it calls replaced the same way (recursively).

    Called with :class:`_Lanes`, it builds the helper's own expression tree on vectors; only ``+ - * /`` may touch
    the arguments (a comparison, truth test or ``math`` call on them raises TypeError when the kernel compiles).
    """
    fn = helper.py_func
    env = dict(fn.__globals__)
    for name in fn.__code__.co_names:
        if isinstance(env.get(name), Dispatcher):
            env[name] = lane_formula(env[name])
    return FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)


def prefetch_rows(b: ir.IRBuilder, data: ir.Value, row: ir.Value, width: int) -> None:
    """Hint rows ``row .. row+7`` of an ``(N, width)`` buffer into the caches for reading (``llvm.prefetch``: no
    effect on results, and an address past the end of the buffer does not fault)."""
    try:
        ptr = ir.PointerType()  # opaque pointers (llvmlite >= 0.44)
    except TypeError:
        ptr = ir.IntType(8).as_pointer()
    i32 = ir.IntType(32)
    fn = b.module.declare_intrinsic("llvm.prefetch", [ptr], ir.FunctionType(ir.VoidType(), [ptr, i32, i32, i32]))
    at = b.mul(row, ir.Constant(_I64, width))
    for k in range(width):  # 8 rows of `width` doubles = `width` cache lines of 64 bytes
        addr = b.bitcast(b.gep(data, [b.add(at, ir.Constant(_I64, LANES * k))]), ptr)
        b.call(fn, [addr, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])  # read, keep, data


def row_block(name: str, widths: tuple[int, int, int], body: Callable[..., tuple[Sequence[_Lanes], ir.Value | None]],
              prefetch: int = 0):
    """An intrinsic ``f(a, b, o, i) -> int64`` over rows ``i .. i+7`` of C-contiguous buffers of row widths
    ``widths = (a, b, o)``: load both inputs (whole-row vectors, transposed in registers), ``body(builder, a_cols,
    b_cols) -> (o_cols, flags)`` with ``flags`` an ``<8 x i1>`` (or None), store ``o``, return ``flags`` as a bit
    mask of rows.  All loads precede the stores, so ``o`` may be ``a`` or ``b``.  ``prefetch > 0`` also hints the
    input rows that many rows ahead into the caches (see :func:`prefetch_rows`).
    """

    def typer(typingctx, a, b, o, i):
        def codegen(context, builder, signature, args):
            data = [context.make_array(t)(context, builder, v).data for t, v in zip(signature.args[:3], args[:3],
                                                                                    strict=True)]
            row = args[3]
            if prefetch:
                ahead = builder.add(row, ir.Constant(_I64, prefetch))
                for d, w in zip(data[:2], widths[:2], strict=True):
                    prefetch_rows(builder, d, ahead, w)
            ins = [load_rows(builder, d, row, w) for d, w in zip(data[:2], widths[:2], strict=True)]
            cols, flags = body(builder, *ins)
            assert len(cols) == widths[2], (name, len(cols))
            store_rows(builder, data[2], row, cols)
            if flags is None:
                return ir.Constant(_I64, 0)
            return builder.zext(builder.bitcast(flags, ir.IntType(LANES)), _I64)

        return types.int64(a, b, o, types.int64), codegen

    typer.__name__ = typer.__qualname__ = name
    return intrinsic(typer)


def _transform_body(b: ir.IRBuilder, s: Sequence[_Lanes], p: Sequence[_Lanes]) -> tuple[tuple[_Lanes, ...], ir.Value]:
    x, y, z, w = s[:4]
    n2 = x * x + y * y + z * z + w * w  # as unit_scale, which returns s2 = 2/n2 for these norms
    tiny = b.fcmp_ordered("<", n2.v, ir.Constant(_VEC, [_TINY] * LANES))
    huge = b.fcmp_ordered(">", n2.v, ir.Constant(_VEC, [_HUGE] * LANES))
    return lane_formula(transform_point)(*s, *p, 2.0 / n2), b.or_(tiny, huge)


#: Rows ``i .. i+7`` of the flat transform: ``o[3r:3r+3] = R p + t`` from ``s[8r:8r+8]``, ``p[3r:3r+3]``.  Returns a
#: bit mask of the rows whose ``|r|**2`` is outside ``[1e-280, 1e280]`` (the caller then leaves the whole batch to
#: the rescaling gufunc); NaN rows are not flagged and give NaN.  ``o`` may be ``p``.
dualquat_transform_block = row_block("dualquat_transform_block", (8, 3, 3), _transform_body)

#: Rows ``i .. i+7`` of the flat product ``o[8r:8r+8] = a[8r:8r+8] (x) b[8r:8r+8]`` (:func:`dq_mul`); returns 0.
#: ``o`` may be ``a`` or ``b``.  Prefetching the inputs 32 rows (2 KiB) ahead took N = 1e6 from 1.16-1.28x to
#: 1.06-1.10x the fused-loop floor on AMD Zen 4 (64-128 rows: similar; prefetching ``o`` for writing: slower).
dualquat_mul_block = row_block("dualquat_mul_block", (8, 8, 8), lambda b, x, y: (lane_formula(dq_mul)(*x, *y), None),
                               prefetch=32)
