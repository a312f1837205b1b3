"""The direct native entry in front of the public algebra functions (:class:`dualpose._native.FastPath`).

``@fast_path(kernel)`` replaces a function ``f`` whose work is the gufunc ``kernel`` by a native callable that, for
a call with exactly the kernel's inputs as positional arguments that need no conversion or striding (float64
ndarrays, C-contiguous, of the core shapes and one common batch shape, where a single element -- and, for a scalar
input, a Python float -- goes with every row), computes the kernel's outputs directly into fresh arrays -- the same
rows the gufunc computes, bit for bit, without NumPy's ufunc dispatch or the Python argument checks.  Every other
call (array-likes, other dtypes, other broadcasting, strided views, other keywords) runs ``f`` itself, which stays
the specification: errors and their messages are ``f``'s.  The decorated object reads as ``f`` (name, docstring,
``inspect.signature`` through ``__wrapped__``, pickling by reference).

Options:

* ``nan_declines=True`` for functions whose checks look at NaN outputs (a zero quaternion where a nonzero one is
  needed): a NaN in an output hands the call to ``f``, which raises or returns the same NaN;
* ``max_rows``: the direct entry applies up to this many rows (``f`` takes a different path above it);
* ``fixed``: constant trailing kernel inputs (the default frame flag of a function with a ``frame`` argument);
* ``takes_out=True`` for functions with the parameter ``out`` (a preallocated result, as for NumPy ufuncs): a
  C-contiguous float64 ``out`` of exactly the result's shape that shares no memory with an input is written
  directly (others, e.g. in place over an input, take ``f``).

Put it only in front of an ``f`` that, for such inputs, returns exactly the kernel's outputs.

Lazy arrays: a call with a dask array among the arguments returns lazy dask arrays (one per kernel output):
``dask.array.blockwise`` over the leading axes (``dask.array.apply_gufunc`` with the kernel's core signature, less
the ``fixed`` inputs, for kernels with several outputs), the output dtypes and core sizes given explicitly, the core
axes rechunked to one chunk, the leading axes chunked (and broadcast) as given.  Each block is computed by ``f``
itself on NumPy blocks, so the values are ``f``'s bit for bit (up to ``max_rows``, which depends on the rows per
block), and nothing is computed before ``.compute()``.  Core shapes are checked when the call is made.  dask is never
imported here: ``FastPath`` recognises a dask array by the module of its type, only while ``dask.array`` is imported
(docs/scaling.md, "Lazy and out-of-core").
"""

from __future__ import annotations

import re
import sys
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numpy as np

from dualpose import _native

__all__ = ["fast_path"]

_F = TypeVar("_F", bound=Callable[..., Any])


def fast_path(kernel: np.ufunc, *, nan_declines: bool = False, max_rows: int = -1,
              fixed: tuple[float, ...] = (), takes_out: bool = False) -> Callable[[_F], _F]:
    """Decorator: put the direct entry of the gufunc ``kernel`` in front of the function (see the module text)."""

    def wrap(func: _F) -> _F:
        lazy = _lazy_route(kernel, func, kernel.nin - len(fixed))
        # the FastPath object stands in for func: called as func, read as func (name, docstring, signature)
        return cast(_F, _native.FastPath(kernel, func, nan_declines, max_rows, fixed, takes_out, lazy))

    return wrap


def _is_dask(x: object) -> bool:
    return type(x).__module__.startswith("dask.")


def _lazy_route(kernel: np.ufunc, func: Callable[..., Any], n_in: int) -> Callable[..., Any]:
    """The call ``FastPath`` makes instead of ``func`` when an argument is a dask array (see the module text)."""
    if kernel.signature is None:
        raise TypeError(f"fast_path needs a generalized ufunc; {kernel.__name__} is elementwise")
    cores = re.findall(r"\(([^)]*)\)", kernel.signature.split("->")[0])[:n_in]
    signature = ",".join(f"({c})" for c in cores) + "->" + kernel.signature.split("->")[1]
    out_types = [np.dtype(c) for c in kernel.types[0].split("->")[1]]
    names = _parameters(func)[:n_in]

    def lazy(*args: Any, **kwargs: Any) -> Any:
        return _lazy_call(func, signature, cores, names, out_types, args, kwargs)

    return lazy


def _parameters(func: Callable[..., Any]) -> list[str]:
    code = func.__code__
    return list(code.co_varnames[: code.co_argcount])


def _lazy_call(func: Callable[..., Any], signature: str, cores: list[str], names: list[str],
               out_types: list[np.dtype], args: tuple[Any, ...], kwargs: dict[str, Any]) -> Any:
    """Build the lazy result of ``func(*args, **kwargs)`` (dask is imported: a dask array is among the arguments)."""
    da = sys.modules["dask.array"]
    arrays = list(args[: len(names)])
    for name in names[len(arrays):]:
        if name not in kwargs:
            raise TypeError(f"{func.__name__}() missing required argument '{name}'")
        arrays.append(kwargs.pop(name))
    if kwargs.get("out") is not None:
        raise TypeError(f"{func.__name__}: out= is not supported with dask arrays (the result is a new lazy array)")
    kwargs.pop("out", None)
    extra = args[len(names):]
    wants = [tuple(int(d) for d in core.split(",") if d.strip()) for core in cores]
    for name, want, a in zip(names, wants, arrays, strict=True):
        shape = tuple(a.shape) if _is_dask(a) else np.shape(a)
        if len(shape) < len(want) or (want and shape[len(shape) - len(want):] != want):
            expected = "(..., " + ", ".join(map(str, want)) + ")" if want else "(...)"
            raise ValueError(f"{func.__name__}: {name} must have shape {expected}, got {shape}")
    # the core axes in one chunk, the leading axes as given
    arrays = [da.asarray(a) for a in arrays]
    arrays = [a.rechunk({a.ndim - 1 - i: -1 for i in range(len(w))}) for a, w in zip(arrays, wants, strict=True)]

    def block(*blocks: np.ndarray) -> Any:
        return func(*blocks, *extra, **kwargs)

    def single_blocks(*nested: Any) -> Any:
        # blockwise hands the (one-chunk) core axes missing from the output as nested lists of one block each;
        # unwrapping them avoids the copy that concatenate=True makes
        blocks = []
        for b in nested:
            while isinstance(b, list):
                b = b[0]
            blocks.append(b)
        return func(*blocks, *extra, **kwargs)

    if len(out_types) > 1:
        sizes = {d: int(d) for d in re.findall(r"\d+", signature)}  # the kernels' core sizes are all fixed numbers
        return da.apply_gufunc(block, signature, *arrays, output_dtypes=out_types, output_sizes=sizes)
    # one output: blockwise over the leading axes (apply_gufunc's extra transposes cost a copy per block)
    n_lead = max(a.ndim - len(w) for a, w in zip(arrays, wants, strict=True))
    lead = tuple(f"l{i}" for i in range(n_lead))
    pairs: list[Any] = []
    for k, (a, w) in enumerate(zip(arrays, wants, strict=True)):
        pairs += [a, lead[n_lead - (a.ndim - len(w)):] + tuple(f"c{k}_{j}" for j in range(len(w)))]
    out_core = [int(d) for d in re.findall(r"\d+", signature.split("->")[1])]
    new_axes = {f"o{j}": n for j, n in enumerate(out_core)}
    return da.blockwise(single_blocks, lead + tuple(new_axes), *pairs, new_axes=new_axes, concatenate=False,
                        dtype=out_types[0], meta=np.empty((0,) * (n_lead + len(out_core)), out_types[0]))
