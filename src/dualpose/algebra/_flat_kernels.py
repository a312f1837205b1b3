"""Row-loop kernels over flat, C-contiguous float64 buffers (not public API).

The gufuncs in :mod:`~dualpose.algebra._quat_kernels` and :mod:`~dualpose.algebra._dualquat_kernels` broadcast and
accept any strides, but NumPy calls their inner function once per element with fresh array views, which keeps LLVM
from vectorising across elements.  For the common case -- equal leading shapes, C-contiguous float64 inputs -- the
Python wrappers pass flat 1-D views to these loops instead.  LLVM vectorises them (AVX2/AVX-512 across elements)
and they compute bit for bit the same values as the gufuncs (no fast-math, no contraction).

``dualquat_transform`` and ``dualquat_mul`` are the exceptions: a plain stride-8 row loop makes LLVM emit AVX-512
gathers (slower than the gufunc on AMD Zen), so their loops hand blocks of eight rows to explicit-SIMD
intrinsics (:mod:`~dualpose.algebra._simd`: whole-row vector loads, in-register transposes) and do only the last
``N mod 8`` rows in scalar code.  They use the gufuncs' own formulas (:func:`~dualpose.algebra._kutil.dq_mul`,
:func:`~dualpose.algebra._kutil.transform_point`), also bit for bit.  Their speed against the fused-loop floor
is in docs/benchmarks.md.

Kernels that need ``2/|q|**2`` only handle ordinary norms in ``[1e-280, 1e280]``: they return a nonzero flag when
any element is outside that range (or zero), and the wrapper then recomputes with the gufunc, which rescales
extreme quaternions and reports zeros.  NaN input propagates to the output as in the gufuncs.
"""

from __future__ import annotations

import numba as nb

from dualpose.algebra._kutil import _HUGE, _TINY, dq_mul, norm3, quat_log_parts, rotate, transform_point
from dualpose.algebra._simd import LANES, dualquat_mul_block, dualquat_transform_block
from dualpose.algebra.series import atan2c_given

_V = "float64[::1]"


def _flat(sig: str):
    return nb.njit(sig, cache=True, error_model="numpy", boundscheck=False, nogil=True)


@_flat(f"int64({_V}, {_V}, {_V})")
def quat_rotate(q, v, o):
    """``o[i] = R(q[i]) v[i]`` over flat (N*4,), (N*3,), (N*3,) buffers; returns 0 when every |q|² was ordinary."""
    bad = 0
    for i in range(v.shape[0] // 3):
        x, y, z, w = q[4 * i], q[4 * i + 1], q[4 * i + 2], q[4 * i + 3]
        n2 = x * x + y * y + z * z + w * w
        bad |= (n2 < _TINY) | (n2 > _HUGE)
        o[3 * i], o[3 * i + 1], o[3 * i + 2] = rotate(x, y, z, w, v[3 * i], v[3 * i + 1], v[3 * i + 2], 2.0 / n2)
    return bad


@_flat(f"void({_V}, {_V}, {_V})")
def quat_log_prepare(q, s, w):
    """First pass of the flat quaternion log: ``s[i] = |q_v[i]|`` (guarded norm) and ``w[i] = q_w[i]``."""
    for i in range(s.shape[0]):
        s[i] = norm3(q[4 * i], q[4 * i + 1], q[4 * i + 2])
        w[i] = q[4 * i + 3]


@_flat(f"int64({_V}, {_V}, {_V}, {_V})")
def quat_log_finish(q, s, phi, o):
    """Last pass: ``o[i] = ln q[i]`` from ``s`` and ``phi = atan2(s, w)``; returns 1 if some q[i] is zero."""
    zero = 0
    for i in range(s.shape[0]):
        x, y, z, w, si = q[4 * i], q[4 * i + 1], q[4 * i + 2], q[4 * i + 3], s[i]
        zero |= (si == 0.0) & (w == 0.0)
        o[4 * i], o[4 * i + 1], o[4 * i + 2], o[4 * i + 3] = quat_log_parts(x, y, z, w, atan2c_given(si, w, phi[i]))
    return zero


@_flat(f"int64({_V}, {_V}, {_V})")
def dualquat_transform(s, p, o):
    """``o[i] = R p[i] + t`` of the dual quaternion ``s[i]`` over flat (N*8,), (N*3,), (N*3,) buffers, eight rows at
    a time; returns 0 when every |r|² was ordinary.  ``o`` may be ``p``."""
    n = p.shape[0] // 3
    m = n - n % LANES
    bad = 0
    for i in range(0, m, LANES):
        bad |= dualquat_transform_block(s, p, o, i)
    for i in range(m, n):
        x, y, z, w = s[8 * i], s[8 * i + 1], s[8 * i + 2], s[8 * i + 3]
        n2 = x * x + y * y + z * z + w * w
        bad |= (n2 < _TINY) | (n2 > _HUGE)
        o[3 * i], o[3 * i + 1], o[3 * i + 2] = transform_point(
            x, y, z, w, s[8 * i + 4], s[8 * i + 5], s[8 * i + 6], s[8 * i + 7], p[3 * i], p[3 * i + 1], p[3 * i + 2],
            2.0 / n2,
        )
    return bad


@_flat(f"int64({_V}, {_V}, {_V})")
def dualquat_mul(a, b, o):
    """``o[i] = a[i] (x) b[i]`` over flat (N*8,) buffers, eight rows at a time; returns 0 (the product needs no norm
    check).  ``o`` may be ``a`` or ``b``."""
    n = o.shape[0] // 8
    m = n - n % LANES
    for i in range(0, m, LANES):
        dualquat_mul_block(a, b, o, i)
    for i in range(m, n):
        k = 8 * i
        o[k], o[k + 1], o[k + 2], o[k + 3], o[k + 4], o[k + 5], o[k + 6], o[k + 7] = dq_mul(
            a[k], a[k + 1], a[k + 2], a[k + 3], a[k + 4], a[k + 5], a[k + 6], a[k + 7],
            b[k], b[k + 1], b[k + 2], b[k + 3], b[k + 4], b[k + 5], b[k + 6], b[k + 7],
        )  # fmt: skip
    return 0
