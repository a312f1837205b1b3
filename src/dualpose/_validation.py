"""Argument checking shared by every public function.

The checks are cheap (a type test and a shape test on the fast path) so that a single-element call stays in the
microsecond range.  Errors name the argument and the expected shape.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "identity_array", "as_array", "as_scalar_array", "call_kernel", "call_kernel_pair", "raise_if_zero_norm",
    "check_finite",
]


def _convert(x: Any, name: str) -> NDArray[np.float64]:
    try:
        arr = np.asarray(x)
    except (ValueError, TypeError) as exc:  # ragged lists and the like
        raise TypeError(f"{name} must be a numeric array-like; got {type(x).__name__} ({exc})") from None
    kind = arr.dtype.kind
    if kind == "f" or kind in "iu":
        return arr.astype(np.float64, copy=False)
    if kind == "O":
        try:
            return arr.astype(np.float64)
        except (ValueError, TypeError):
            pass
    raise TypeError(f"{name} must be a real numeric array; got dtype {arr.dtype}")


def as_array(x: Any, name: str, size: int | tuple[int, ...]) -> NDArray[np.float64]:
    """Return ``x`` as a float64 array whose trailing axes are ``size``.

    Raises
    ------
    TypeError
        When ``x`` is not real numeric (strings, complex, booleans, ragged lists).
    ValueError
        When the trailing shape is not ``size``.
    """
    a: NDArray[np.float64] = _convert(x, name) if type(x) is not np.ndarray or x.dtype != np.float64 else x
    if isinstance(size, int):
        if a.shape[-1:] != (size,):
            raise ValueError(f"{name} must have shape (..., {size}); got shape {a.shape}")
    else:
        k = len(size)
        if a.shape[a.ndim - k :] != size or a.ndim < k:
            dims = ", ".join(str(s) for s in size)
            raise ValueError(f"{name} must have shape (..., {dims}); got shape {a.shape}")
    return a


def as_scalar_array(x: Any, name: str) -> NDArray[np.float64] | np.float64:
    """Return ``x`` (a scalar or an array of scalars, shape ``(...)``) as float64 (a Python float as
    :class:`numpy.float64`)."""
    if type(x) is not np.ndarray or x.dtype != np.float64:
        if isinstance(x, float):
            result: NDArray[np.float64] | np.float64 = np.float64(float(x))
            return result
        return _convert(x, name)
    a: NDArray[np.float64] = x
    return a


def _core_ndim(ufunc: np.ufunc, index: int) -> int:
    sig = ufunc.signature
    if sig is None:
        return 0
    ins = sig.split("->")[0]
    parts = ins.replace("),(", ")|(").split("|")
    core = parts[index].strip("()")
    return 0 if core == "" else len(core.split(","))


def shape_error(ufunc: np.ufunc, args: Sequence[np.ndarray], names: Sequence[str]) -> ValueError:
    """Build a ValueError naming the arguments whose leading (batch) shapes do not broadcast."""
    lead = []
    for i, (a, n) in enumerate(zip(args, names, strict=False)):
        k = _core_ndim(ufunc, i)
        shape = np.shape(a)
        lead.append((n, shape[: len(shape) - k] if k else shape))
    desc = ", ".join(f"{n} has batch shape {s}" for n, s in lead)
    return ValueError(f"batch shapes do not broadcast: {desc}")


def call_kernel(ufunc: np.ufunc, args: tuple[Any, ...], names: Sequence[str],
                out: np.ndarray | None = None) -> NDArray[np.float64]:
    """Call a (g)ufunc with one float64 output, translating numpy's broadcasting error into one that names the
    arguments.

    ``out`` (optional) is a preallocated float64 array for the result, as for NumPy ufuncs.
    """
    result: NDArray[np.float64] = _call(ufunc, args, names, out)
    return result


def call_kernel_pair(ufunc: np.ufunc, args: tuple[Any, ...],
                     names: Sequence[str]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`call_kernel` for a (g)ufunc with two float64 outputs."""
    first, second = _call(ufunc, args, names, None)
    return first, second


def _call(ufunc: np.ufunc, args: tuple[Any, ...], names: Sequence[str], out: np.ndarray | None) -> Any:
    if out is None:
        try:
            return ufunc(*args)
        except ValueError:
            raise shape_error(ufunc, args, names) from None
    if type(out) is not np.ndarray or out.dtype != np.float64:
        raise TypeError(f"out must be a float64 numpy array; got {type(out).__name__}")
    try:
        return ufunc(*args, out=out)
    except ValueError:
        err = shape_error(ufunc, args, names)
        raise ValueError(f"{err}; or out has the wrong shape {out.shape}") from None


#: below this many elements the gufunc path (lower call overhead) is used even when the flat loops apply
FLAT_MIN_ELEMENTS = 64


def try_flat_kernel(kernel: Callable[..., int], arrays: tuple[np.ndarray, ...], out: np.ndarray | None,
                    width: int) -> tuple[NDArray[np.float64], int] | None:
    """Run a flat row loop of :mod:`dualpose._native` (``flat_*``) when the inputs allow it.

    Applies when every array is C-contiguous with the same leading shape (no broadcasting), there are at least
    :data:`FLAT_MIN_ELEMENTS` elements, and ``out`` is None or a C-contiguous float64 array of the result's shape
    that is either one of the input arrays itself (in place: the loops read each row before writing it) or shares
    no memory with them (other overlaps are left to the gufunc, which NumPy runs on copies).  The flat loops compute
    every row exactly as the gufunc does.  Returns ``(result, flag)``, where a nonzero flag means some row had a
    zero or extreme norm (the caller then looks for zeros), or None when the loop does not apply.
    """
    lead = arrays[0].shape[:-1]
    if arrays[0].size < FLAT_MIN_ELEMENTS * arrays[0].shape[-1]:
        return None
    for a in arrays:
        if a.shape[:-1] != lead or not a.flags.c_contiguous:
            return None
    shape = (*lead, width)
    if out is None:
        out = np.empty(shape)
    elif type(out) is not np.ndarray or out.dtype != np.float64 or out.shape != shape or not out.flags.c_contiguous:
        return None
    else:
        for a in arrays:
            if a is not out and np.may_share_memory(out, a):
                return None
    return out, kernel(*(a.reshape(-1) for a in arrays), out.reshape(-1))


def raise_if_zero_norm(out: np.ndarray, arg: np.ndarray, name: str, what: str = "a nonzero quaternion") -> None:
    """Kernels write NaN where an input that must be nonzero is zero; turn that into a ValueError.

    NaN inputs are allowed to propagate (documented); only an exactly zero argument raises.
    """
    if np.isnan(out).any():
        zero = np.all(arg[..., :4] == 0.0, axis=-1)
        if np.any(zero):
            idx = tuple(int(i) for i in np.argwhere(np.atleast_1d(zero))[0])
            raise ValueError(f"{name} must be {what}; element {idx} is zero")


def check_finite(x: np.ndarray, name: str) -> None:
    """Conversions and solvers refuse non-finite input rather than guess a branch."""
    if not np.isfinite(x).all():
        raise ValueError(f"{name} contains NaN or infinity; conversions need finite input")


def identity_array(shape: int | tuple[int, ...], size: int) -> NDArray[np.float64]:
    """Identity (dual) quaternions: zeros of shape ``shape + (size,)`` with component 3 (``w``) set to 1."""
    lead = (shape,) if isinstance(shape, int) else tuple(shape)
    out = np.zeros((*lead, size))
    out[..., 3] = 1.0
    return out
