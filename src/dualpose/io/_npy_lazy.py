"""A ``.npy`` file as a lazy dask array whose blocks are views of the file's memory map (docs/scaling.md,
"Out-of-core rate").

``dask.array.from_array(np.load(path, mmap_mode="r"))`` is the obvious way to put a ``.npy`` file under dask, but
dask copies any array-like that has a ``copy`` method when the graph is built (``x = x.copy()`` at the start of
``dask.array.from_array``, from release 2024.12.0 on): the whole file is read into anonymous memory before any task
runs.  :func:`read_npy_lazy` hands dask an object without ``copy`` instead, so
each block is read only when a task needs it, as a view of the pages the kernel maps (no copy, no allocation).
"""

from __future__ import annotations

import hashlib
import importlib
import os
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["read_npy_lazy"]


class _NpyBlocks:
    """The array in a ``.npy`` file, sliced on demand through a read-only memory map opened on first use (in each
    process: pickling keeps the path only, never the data)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self._map: np.memmap[Any, np.dtype[Any]] | None = None
        array = self._open()
        self.shape: tuple[int, ...] = tuple(array.shape)
        self.dtype: np.dtype[Any] = array.dtype
        self.ndim = array.ndim

    def _open(self) -> np.memmap[Any, np.dtype[Any]]:
        if self._map is None:
            self._map = np.load(self.path, mmap_mode="r")
        return self._map

    def __getitem__(self, key: Any) -> NDArray[Any]:
        # a plain ndarray view of the mapped pages (np.asarray of a memmap slice does not copy)
        return np.asarray(self._open()[key])

    def __getstate__(self) -> dict[str, Any]:
        return {"path": self.path, "shape": self.shape, "dtype": self.dtype, "ndim": self.ndim, "_map": None}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)


def read_npy_lazy(path: str | os.PathLike[str], chunk_rows: int) -> Any:
    """The array stored in a ``.npy`` file as a lazy ``dask.array.Array``, chunked along its first axis.

    Nothing is read when the array is made; each task maps its block of the file read-only (a NumPy view of the
    file's pages, no copy), so memory stays at a few blocks per worker whatever the file's size.  Use it instead of
    ``dask.array.from_array(np.load(path, mmap_mode="r"))``, which copies the whole file into memory (see the
    module text).  Needs dask (``pip install 'dualpose[dask]'``).

    Parameters
    ----------
    path : str or path-like
        A ``.npy`` file (NumPy format 1.0-3.0) holding a numeric array of any shape with at least one axis, e.g.
        ``(N, 4)`` quaternions xyzw.
    chunk_rows : int
        Rows of the first axis per block (positive); the other axes are one chunk each, as the algebra functions
        want their core axes.

    Returns
    -------
    dask.array.Array
        Shape and dtype of the stored array; chunks ``(chunk_rows, ...)`` along the first axis, the last one shorter.
        Its name is derived from the file's path, size, modification time and ``chunk_rows``.

    Raises
    ------
    ValueError
        When ``chunk_rows`` is not positive, the array has no axes, or the file is not a ``.npy`` file NumPy can map
        (an object array, a damaged header).
    """
    da = importlib.import_module("dask.array")  # an optional dependency, needed only here

    if isinstance(chunk_rows, bool) or not isinstance(chunk_rows, (int, np.integer)) or chunk_rows <= 0:
        raise ValueError(f"chunk_rows must be a positive integer; got {chunk_rows!r}")
    path = os.fspath(path)
    try:
        blocks = _NpyBlocks(path)
    except ValueError as exc:
        raise ValueError(f"{path}: cannot map the array in this .npy file ({exc})") from None
    if blocks.ndim == 0:
        raise ValueError(f"{path}: the stored array has no axes (a scalar); nothing to chunk")
    stat = os.stat(path)
    token = hashlib.blake2b(f"{os.path.abspath(path)}|{stat.st_size}|{stat.st_mtime_ns}|{chunk_rows}".encode(),
                            digest_size=16).hexdigest()
    chunks = (int(chunk_rows),) + tuple(blocks.shape[1:])
    meta = np.empty((0,) * blocks.ndim, dtype=blocks.dtype)
    return da.from_array(blocks, chunks=chunks, name=f"npy-{token}", asarray=False, meta=meta)
