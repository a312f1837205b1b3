"""Explicit SIMD for the flat kernels: numba intrinsics that emit LLVM vector IR (not public API).

Some row layouts defeat LLVM's loop vectoriser.  A dual quaternion row is 8 doubles, and with AVX-512 the
vectoriser loads stride-8 columns with gathers (3-11x slower than the gufunc on AMD Zen); without gathers its
factor-8 interleaved loads were still slower than the gufunc.  The intrinsics here do the vectorisation by hand,
in portable LLVM IR: load eight rows as whole vectors, transpose them in registers with ``shufflevector`` into one
``<8 x double>`` per component, evaluate the *same* scalar formula on those vectors, and transpose back.

The formula is not re-written: the inline helper's Python function (``helper.py_func``) is called with
:class:`_Lanes` arguments, whose ``+ - * /`` emit ``fadd/fsub/fmul/fdiv`` without fast-math flags.  Python keeps
the expression tree, IEEE arithmetic is lane-wise, and LLVM contracts or reassociates nothing without those flags,
so every lane rounds exactly as the scalar gufunc does (the tests check bit equality).  LLVM lowers the generic
vectors to whatever the CPU has (one zmm with AVX-512, two ymm with AVX2, four xmm with SSE2 or NEON).
"""

from __future__ import annotations

from collections.abc import Sequence

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

from dualpose.algebra._kutil import _HUGE, _TINY, transform_point

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


@intrinsic
def dualquat_transform_block(typingctx, s, p, o, i):  # noqa: ANN001, ANN201, ARG001
    """Rows ``i .. i+7`` of the flat transform: ``o[3r:3r+3] = R p + t`` from ``s[8r:8r+8]``, ``p[3r:3r+3]``.

    Returns a bit mask of the rows whose ``|r|**2`` is outside ``[1e-280, 1e280]`` (the caller then leaves the
    whole batch to the rescaling gufunc); NaN rows are not flagged and give NaN.  All loads precede the stores,
    so ``o`` may be ``p``.
    """
    sig = types.int64(s, p, o, types.int64)

    def codegen(context, builder, signature, args):  # noqa: ANN001, ANN202
        sa, pa, oa = (context.make_array(t)(context, builder, a) for t, a in zip(signature.args[:3], args[:3],
                                                                                   strict=True))
        row = args[3]
        at8 = builder.mul(row, ir.Constant(_I64, 8))
        at3 = builder.mul(row, ir.Constant(_I64, 3))
        rows = [builder.load(_vector_ptr(builder, sa.data, at8, k), align=8) for k in range(8)]
        pts = [builder.load(_vector_ptr(builder, pa.data, at3, k), align=8) for k in range(3)]
        x, y, z, w, dx, dy, dz, dw = (_Lanes(builder, c) for c in transpose8(builder, rows))
        px, py, pz = (_Lanes(builder, c) for c in split3(builder, pts))
        n2 = x * x + y * y + z * z + w * w  # as unit_scale, which returns s2 = 2/n2 for these norms
        res = transform_point.py_func(x, y, z, w, dx, dy, dz, dw, px, py, pz, 2.0 / n2)
        for k, vec in enumerate(join3(builder, [c.v for c in res])):
            builder.store(vec, _vector_ptr(builder, oa.data, at3, k), align=8)
        tiny = builder.fcmp_ordered("<", n2.v, ir.Constant(_VEC, [_TINY] * LANES))
        huge = builder.fcmp_ordered(">", n2.v, ir.Constant(_VEC, [_HUGE] * LANES))
        flags = builder.bitcast(builder.or_(tiny, huge), ir.IntType(LANES))
        return builder.zext(flags, _I64)

    return sig, codegen
