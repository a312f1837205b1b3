"""Lazy dask arrays through the public algebra functions (``algebra/_fastpath.py``) and the raw gufuncs.

Reference: each function's own NumPy result on the whole array (bit for bit); laziness: no dask task runs before
``.compute()`` (a ``dask.callbacks.Callback`` counts them).
"""

from __future__ import annotations

import inspect
import subprocess
import sys

import numpy as np
import pytest

import dualpose as dp
from dualpose import _native

da = pytest.importorskip("dask.array")

FAST = sorted((getattr(dp, n) for n in dp.__all__ if isinstance(getattr(dp, n), _native.FastPath)),
              key=lambda f: f.__name__)
BATCH, CHUNKS = (2, 130), (1, 65)  # two leading axes, several blocks each; > 63 rows a block (quat_log's max_rows)



def kernel_cores(kernel: np.ufunc) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]]]:
    ins, outs = kernel.signature.split("->")
    parse = lambda side: [tuple(int(d) for d in c.split(",") if d) for c in side[1:-1].split("),(")]  # noqa: E731
    return parse(ins), parse(outs)


def user_inputs(f, rng: np.random.Generator) -> list[np.ndarray]:
    """Valid NumPy inputs for the user's array arguments of ``f`` (the kernel's first inputs)."""
    n_user = sum(p.default is p.empty for p in inspect.signature(f).parameters.values())
    out = []
    for core in kernel_cores(f.kernel)[0][:n_user]:
        if core == (3, 3):  # rotation matrices
            out.append(dp.so3_exp(rng.normal(size=(*BATCH, 3))))
        else:
            out.append(rng.normal(size=(*BATCH, *core)))
    return out


def test_registry_covers_the_gufunc_backed_functions() -> None:
    assert len(FAST) == 66


@pytest.mark.parametrize("f", FAST, ids=lambda f: f.__name__)
def test_dask_input_gives_a_lazy_array_equal_to_numpy(f, dask_task_counter) -> None:
    rng = np.random.default_rng(7)
    args = user_inputs(f, rng)
    expected = f(*args)
    lazy_args = [da.from_array(a, chunks=CHUNKS + (-1,) * (a.ndim - len(BATCH))) for a in args]
    counter = dask_task_counter
    with counter:
        lazy = f(*lazy_args)
        assert counter.tasks == 0  # building the graph computes nothing
    lazy_t = lazy if isinstance(lazy, tuple) else (lazy,)
    expected_t = expected if isinstance(expected, tuple) else (expected,)
    assert len(lazy_t) == len(expected_t)
    for lz, ex in zip(lazy_t, expected_t, strict=True):
        assert isinstance(lz, da.Array)
        assert lz.chunks[: len(BATCH)] == ((1, 1), (65, 65))  # leading axes as given
        assert all(len(c) == 1 for c in lz.chunks[len(BATCH):])  # core axes in one chunk
        got = lz.compute()
        assert got.dtype == ex.dtype and got.shape == ex.shape
        np.testing.assert_array_equal(got, ex)  # bit for bit (NaN in the same places)


def test_mixed_numpy_and_dask_inputs_broadcast_and_core_axis_is_rechunked() -> None:
    rng = np.random.default_rng(1)
    p = rng.normal(size=(300, 4))
    q = rng.normal(size=4)
    lazy = dp.quat_mul(da.from_array(p, chunks=(100, 2)), q)  # core axis split in two: rechunked to one chunk
    assert lazy.chunks == ((100, 100, 100), (4,))
    np.testing.assert_array_equal(lazy.compute(), dp.quat_mul(p, q))
    np.testing.assert_array_equal(dp.quat_mul(p=da.from_array(p, chunks=100), q=q).compute(), dp.quat_mul(p, q))
    a, b = rng.normal(size=(1, 100, 4)), rng.normal(size=(3, 1, 4))  # size-1 leading axes broadcast
    lazy = dp.quat_mul(da.from_array(a, chunks=(1, 30, 4)), da.from_array(b, chunks=(2, 1, 4)))
    assert lazy.chunks == ((2, 1), (30, 30, 30, 10), (4,))
    np.testing.assert_array_equal(lazy.compute(), dp.quat_mul(a, b))


def test_keyword_and_frame_arguments_reach_every_block() -> None:
    rng = np.random.default_rng(2)
    q, w = rng.normal(size=(200, 4)), rng.normal(size=(200, 3))
    lazy = dp.quat_derivative(da.from_array(q, chunks=50), da.from_array(w, chunks=50), frame="body")
    np.testing.assert_array_equal(lazy.compute(), dp.quat_derivative(q, w, frame="body"))
    lazy = dp.quat_integrate(da.from_array(q, chunks=50), w, 0.01, "body")
    np.testing.assert_array_equal(lazy.compute(), dp.quat_integrate(q, w, 0.01, "body"))


def test_bad_core_shape_and_out_are_refused_when_the_call_is_made() -> None:
    x = da.zeros((10, 3), chunks=5)
    with pytest.raises(ValueError, match=r"quat_mul: p must have shape \(\.\.\., 4\), got \(10, 3\)"):
        dp.quat_mul(x, x)
    with pytest.raises(TypeError, match="out= is not supported with dask"):
        dp.quat_mul(da.zeros((10, 4), chunks=5), np.zeros(4), out=np.zeros((10, 4)))


KERNELS = sorted({f.kernel for f in FAST}, key=lambda k: k.__name__)


@pytest.mark.parametrize("kernel", KERNELS, ids=lambda k: k.__name__)
def test_raw_gufunc_through_apply_gufunc_with_output_dtypes(kernel: np.ufunc) -> None:
    rng = np.random.default_rng(3)
    ins, outs = kernel_cores(kernel)
    # scalar core inputs are 0 (the default frame / order flags; t = 0, dt = 0)
    args = [dp.so3_exp(rng.normal(size=(90, 3))) if c == (3, 3) else np.zeros(90) if c == ()
            else rng.normal(size=(90, *c)) for c in ins]
    sizes = {str(d): d for c in ins + outs for d in c}
    lazy = da.apply_gufunc(kernel, kernel.signature, *(da.from_array(a, chunks=30) for a in args),
                           output_dtypes=[float] * kernel.nout if kernel.nout > 1 else float, output_sizes=sizes)
    with np.errstate(all="ignore"):
        expected = kernel(*args)
        got = tuple(x.compute() for x in lazy) if kernel.nout > 1 else (lazy.compute(),)
    for g, e in zip(got, expected if kernel.nout > 1 else (expected,), strict=True):
        np.testing.assert_array_equal(g, e)


def test_raw_gufunc_through_xarray_apply_ufunc() -> None:
    xr = pytest.importorskip("xarray")
    rng = np.random.default_rng(4)
    p, q = rng.normal(size=(120, 4)), rng.normal(size=(120, 4))
    xp = xr.DataArray(p, dims=("time", "component")).chunk({"time": 40})
    xq = xr.DataArray(q, dims=("time", "component")).chunk({"time": 40})
    r = xr.apply_ufunc(_native.quat_mul, xp, xq, input_core_dims=[["component"], ["component"]],
                       output_core_dims=[["component"]], dask="parallelized", output_dtypes=[float])
    assert isinstance(r.data, da.Array)
    np.testing.assert_array_equal(r.compute().values, dp.quat_mul(p, q))


def test_dualpose_does_not_import_dask() -> None:
    code = ("import sys, numpy as np, dualpose as dp\n"
            "from dualpose.inertial import integrate_attitude\n"
            "dp.quat_mul([0.0, 0, 0, 1], np.ones((3, 4))); integrate_attitude([0.0, 0, 0, 1], np.zeros((2, 3)))\n"
            "assert 'dask' not in sys.modules, 'dask imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True)
