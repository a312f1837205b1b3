"""Row-loop kernels over flat, C-contiguous float64 buffers (not public API).

The gufuncs in :mod:`~dualpose.algebra._quat_kernels` and :mod:`~dualpose.algebra._dualquat_kernels` broadcast and
accept any strides, but NumPy calls their inner function once per element with fresh array views, which keeps LLVM
from vectorising across elements.  For the common case -- equal leading shapes, C-contiguous float64 inputs -- the
Python wrappers pass flat 1-D views to these loops instead.  LLVM vectorises them (AVX2/AVX-512 across elements)
and they compute bit for bit the same values as the gufuncs (no fast-math, no contraction).

(A flat ``dualquat_transform`` was tried and dropped: its stride-8 loads make LLVM emit AVX-512 gathers, 3-6x
slower than the gufunc on AMD Zen.)

Kernels that need ``2/|q|**2`` only handle ordinary norms in ``[1e-280, 1e280]``: they return a nonzero flag when
any element is outside that range (or zero), and the wrapper then recomputes with the gufunc, which rescales
extreme quaternions and reports zeros.  NaN input propagates to the output as in the gufuncs.
"""

from __future__ import annotations

import numba as nb

from dualpose.algebra._kutil import _HUGE, _TINY, norm3, quat_log_parts, rotate
from dualpose.algebra.series import atan2c_given

_V = "float64[::1]"


def _flat(sig: str):  # noqa: ANN202
    return nb.njit(sig, cache=True, error_model="numpy", boundscheck=False, nogil=True)


@_flat(f"int64({_V}, {_V}, {_V})")
def quat_rotate(q, v, o):  # noqa: ANN001, ANN201
    """``o[i] = R(q[i]) v[i]`` over flat (N*4,), (N*3,), (N*3,) buffers; returns 0 when every |q|² was ordinary."""
    bad = 0
    for i in range(v.shape[0] // 3):
        x, y, z, w = q[4 * i], q[4 * i + 1], q[4 * i + 2], q[4 * i + 3]
        n2 = x * x + y * y + z * z + w * w
        bad |= (n2 < _TINY) | (n2 > _HUGE)
        o[3 * i], o[3 * i + 1], o[3 * i + 2] = rotate(x, y, z, w, v[3 * i], v[3 * i + 1], v[3 * i + 2], 2.0 / n2)
    return bad


@_flat(f"void({_V}, {_V}, {_V})")
def quat_log_prepare(q, s, w):  # noqa: ANN001
    """First pass of the flat quaternion log: ``s[i] = |q_v[i]|`` (guarded norm) and ``w[i] = q_w[i]``."""
    for i in range(s.shape[0]):
        s[i] = norm3(q[4 * i], q[4 * i + 1], q[4 * i + 2])
        w[i] = q[4 * i + 3]


@_flat(f"int64({_V}, {_V}, {_V}, {_V})")
def quat_log_finish(q, s, phi, o):  # noqa: ANN001, ANN201
    """Last pass: ``o[i] = ln q[i]`` from ``s`` and ``phi = atan2(s, w)``; returns 1 if some q[i] is zero."""
    zero = 0
    for i in range(s.shape[0]):
        x, y, z, w, si = q[4 * i], q[4 * i + 1], q[4 * i + 2], q[4 * i + 3], s[i]
        zero |= (si == 0.0) & (w == 0.0)
        o[4 * i], o[4 * i + 1], o[4 * i + 2], o[4 * i + 3] = quat_log_parts(x, y, z, w, atan2c_given(si, w, phi[i]))
    return zero
