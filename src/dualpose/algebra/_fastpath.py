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
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from dualpose import _native

__all__ = ["fast_path"]

_F = TypeVar("_F", bound=Callable[..., Any])


def fast_path(kernel: np.ufunc, *, nan_declines: bool = False, max_rows: int = -1,
              fixed: tuple[float, ...] = (), takes_out: bool = False) -> Callable[[_F], _F]:
    """Decorator: put the direct entry of the gufunc ``kernel`` in front of the function (see the module text)."""

    def wrap(func: _F) -> _F:
        return _native.FastPath(kernel, func, nan_declines, max_rows, fixed, takes_out)  # type: ignore[return-value]

    return wrap
