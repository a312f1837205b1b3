"""The direct native entry in front of the public algebra functions (``algebra/_fastpath.py``, ``FastPath``).

The Python function behind each entry (``f.__wrapped__``) is the specification: for every input -- exact float64
arrays of one batch shape (taken directly), broadcasting, strided views, other dtypes, lists, zero rows, overflow,
NaN -- the decorated function must give the same outcome bit for bit (values, shapes, scalar vs array, the error
and its message, the floating-point warnings).
"""

from __future__ import annotations

import copy
import inspect
import pickle
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
from dualpose import _native
from dualpose.algebra import derivatives, dualquat, implicit, lie, quat

FAST = sorted(
    (getattr(m, n) for m in (quat, dualquat, implicit, lie, derivatives) for n in m.__all__
     if isinstance(getattr(m, n), _native.FastPath)),
    key=lambda f: f.__name__,
)


def test_every_gufunc_backed_function_has_the_direct_entry() -> None:
    names = {f.__name__ for f in FAST}
    assert len(FAST) == 66
    for n in ("quat_mul", "quat_conj", "dualquat_mul", "dualquat_conj", "dualquat_transform", "quat_rotate", "quat_log",
              "qt_mul_derivative", "so3_left_jacobian", "quat_derivative", "rotvec_rate_from_omega"):
        assert n in names


def core_shapes(f) -> list[tuple[int, ...]]:
    """Core shapes of the user's positional inputs (the kernel's first ones; the rest are fixed constants)."""
    ins = f.kernel.signature.split("->")[0]
    shapes = [tuple(int(d) for d in c.split(",") if d) for c in ins[1:-1].split("),(")]
    required = [p for p in inspect.signature(f.__wrapped__).parameters.values() if p.default is p.empty]
    return shapes[: len(required)]


def make_input(rng: np.random.Generator, core: tuple[int, ...], batch: tuple[int, ...]) -> np.ndarray:
    if core == (3, 3):  # rotation matrices (quat_from_matrix refuses anything else)
        return dp.so3_exp(rng.normal(size=(*batch, 3)))
    return rng.normal(size=(*batch, *core))


def outcome(f, args: list) -> tuple:
    """(kind, value) of a call plus the warning messages: the result or the exception's type and message."""
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        try:
            r = f(*args)
        except (ValueError, TypeError) as exc:
            r = (type(exc), str(exc))
    return r, sorted(str(x.message) for x in w)


def assert_same(a, b) -> None:
    if isinstance(a, tuple) and isinstance(a[0], type):  # an exception
        assert a == b
        return
    if isinstance(a, tuple):
        assert isinstance(b, tuple) and len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert_same(x, y)
        return
    assert type(a) is type(b)
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and a.dtype == b.dtype == np.float64
    assert a.tobytes() == b.tobytes()  # bit for bit, NaN payloads and signed zeros included


LAYOUTS = ["c", "c", "single", "strided", "broadcast", "float32", "int", "list", "scalar_float", "bigendian"]
SPECIAL = ["none", "none", "zero", "huge", "nan"]


@settings(max_examples=400, deadline=None)
@given(k=st.integers(0, len(FAST) - 1), batch=st.sampled_from([(), (1,), (2,), (3,), (2, 3), (0,), (70,)]),
       layout=st.sampled_from(LAYOUTS), special=st.sampled_from(SPECIAL), which=st.integers(0, 7),
       seed=st.integers(0, 2**32 - 1))
def test_same_outcome_as_the_python_path(k, batch, layout, special, which, seed) -> None:
    f = FAST[k]
    rng = np.random.default_rng(seed)
    cores = core_shapes(f)
    args: list = [make_input(rng, c, batch) for c in cores]
    j = which % len(args)
    n = int(np.prod(batch))
    if special != "none" and n:
        flat = args[j].reshape(n, -1)
        flat[0] = {"zero": 0.0, "huge": 1e200, "nan": np.nan}[special]
    x = args[j]
    if layout == "strided":
        args[j] = np.repeat(x, 2, axis=-1)[..., ::2] if x.ndim else x
    elif layout == "single" and n:  # one element with every row of the others
        args[j] = x.reshape(n, *cores[j])[-1].copy()
    elif layout == "broadcast" and n:
        args[j] = x.reshape(-1, *x.shape[len(batch):])[:1].reshape((1,) * len(batch) + x.shape[len(batch):])
    elif layout == "float32" and special != "huge":
        args[j] = x.astype(np.float32)
    elif layout == "int" and special == "none":
        args[j] = np.round(3 * x).astype(np.int64)
    elif layout == "list":
        args[j] = x.tolist()
    elif layout == "scalar_float" and cores[j] == ():  # one Python float for every row
        args[j] = float(x.flat[0]) if x.size else 0.5
    elif layout == "bigendian":
        args[j] = x.astype(">f8")
    got, warned = outcome(f, args)
    want, expect_warned = outcome(f.__wrapped__, args)
    assert_same(got, want)
    assert warned == expect_warned


@pytest.mark.parametrize("f", FAST, ids=lambda f: f.__name__)
def test_contiguous_batches(f) -> None:
    """The inputs the direct entry takes, at every size class (one element, small, above the flat-path thresholds),
    with and without a zero row."""
    rng = np.random.default_rng(4)
    for batch in [(), (1,), (2,), (63,), (64,), (70,), (2, 40), (5000,)]:
        args = [make_input(rng, c, batch) for c in core_shapes(f)]
        got, want = outcome(f, args), outcome(f.__wrapped__, args)
        assert_same(got[0], want[0])
        assert got[1] == want[1]
        if batch:
            args[0].reshape(-1, args[0].shape[-1] if args[0].ndim > len(batch) else 1)[-1] = 0.0
            assert_same(outcome(f, args)[0], outcome(f.__wrapped__, args)[0])


def test_single_elements_and_small_batches_equal_the_gufunc() -> None:
    """The direct rows against the raw gufunc on contiguous input (its row loop), for every function."""
    rng = np.random.default_rng(5)
    for f in FAST:
        cores = core_shapes(f)
        for batch in [(), (1,), (5,), (4, 3)]:
            args = [make_input(rng, c, batch) for c in cores]
            fixed = f.kernel.nin - len(cores)
            consts = {0: (), 1: (0.0,), 2: (1.0, 0.0)}[fixed] if f.__name__ != "rotvec_rate_from_omega" else (1.0, 1.0)
            if f.__name__ in ("so3_right_jacobian", "se3_right_jacobian"):
                consts = (-1.0, 0.0)
            elif f.__name__.endswith("_jacobian_inv"):
                consts = (-1.0 if "right" in f.__name__ else 1.0, 1.0)
            assert_same(outcome(f, args)[0], outcome(f.kernel, [*args, *consts])[0])


def test_routing() -> None:
    """Eligible calls never reach the Python function; every other call reaches it once, with its arguments."""
    calls: list[tuple] = []

    def spy(*args, **kwargs):
        calls.append((args, kwargs))
        return dp.quat_mul.__wrapped__(*args, **kwargs)

    f = _native.FastPath(_native.quat_mul, spy)
    p, q = np.random.default_rng(1).normal(size=(2, 6, 4))
    for a, b in [(p[0], q[0]), (p, q), (p.reshape(2, 3, 4), q.reshape(2, 3, 4)), (p[:0], q[:0]), (p[0], q),
                 (p.reshape(2, 3, 4), q[0])]:  # a single element goes with every row
        f(a, b)
    assert calls == []
    out = np.empty((6, 4))
    ineligible = [
        ((p[:1], q), {}),  # broadcasting over a length-1 axis
        ((p.reshape(2, 3, 4)[:, :1], q.reshape(2, 3, 4)), {}),
        ((p[::2], q[:3]), {}),  # strided
        ((p.astype(np.float32), q), {}),
        ((p.tolist(), q), {}),
        ((p, q, out), {}),
        ((p, q), {"out": out}),
        ((p,), {}),
    ]
    for args, kwargs in ineligible:
        try:
            f(*args, **kwargs)
        except TypeError:
            pass
    assert len(calls) == len(ineligible)
    limited = _native.FastPath(_native.quat_mul, spy, max_rows=5)
    limited(p[:5], q[:5])
    assert len(calls) == len(ineligible)
    limited(p, q)
    assert len(calls) == len(ineligible) + 1


def test_routing_of_out() -> None:
    calls: list[int] = []

    def spy(*args, **kwargs):
        calls.append(1)
        return dp.quat_mul.__wrapped__(*args, **kwargs)

    f = _native.FastPath(_native.quat_mul, spy, takes_out=True)
    p, q = np.random.default_rng(2).normal(size=(2, 6, 4))
    out = np.empty((6, 4))
    assert f(p, q, out) is out and f(p, q, out=out) is out and type(f(p, q, out=None)) is np.ndarray
    assert calls == []
    want = dp.quat_mul.__wrapped__(p, q)
    assert out.tobytes() == want.tobytes()
    for o in (p, q[::-1].copy(order="F"), np.empty((6, 4), np.float32), np.empty((1, 6, 4)), np.empty((12, 4))[::2]):
        try:
            f(p, q, out=o)
        except (TypeError, ValueError):
            pass
    assert len(calls) == 5  # in place over an input, Fortran order, float32, wrong shape, strided: the Python path


OUT_KINDS = ["fresh", "input", "fortran", "float32", "shape", "none", "list"]


@settings(max_examples=150, deadline=None)
@given(k=st.sampled_from([f for f in FAST if "out" in inspect.signature(f).parameters]),
       batch=st.sampled_from([(), (1,), (2,), (3, 2), (70,)]), kind=st.sampled_from(OUT_KINDS),
       special=st.sampled_from(SPECIAL), keyword=st.booleans(), seed=st.integers(0, 2**32 - 1))
def test_out_same_outcome_as_the_python_path(k, batch, kind, special, keyword, seed) -> None:
    """``out=``: the same result, the same final contents of ``out`` and of the inputs, the same errors."""
    rng = np.random.default_rng(seed)
    args = [make_input(rng, c, batch) for c in core_shapes(k)]
    n = int(np.prod(batch))
    if special != "none" and n:
        args[0].reshape(n, -1)[0] = {"zero": 0.0, "huge": 1e200, "nan": np.nan}[special]
    width = {"quat_mul": 4, "dualquat_mul": 8}.get(k.__name__, 3)
    shape = (*batch, width)

    def make_out(a):
        if kind == "input":
            same = [x for x in a if x.shape == shape]
            return same[0] if same else np.full(shape, 5.0)
        return {"fresh": lambda: np.full(shape, 5.0), "fortran": lambda: np.asfortranarray(np.full(shape, 5.0)),
                "float32": lambda: np.full(shape, 5.0, np.float32), "shape": lambda: np.full((*batch, width + 1), 5.0),
                "none": lambda: None, "list": lambda: [0.0] * width}[kind]()

    results = []
    for f in (k, k.__wrapped__):
        a = [x.copy() for x in args]
        o = make_out(a)
        r = outcome(lambda *x, f=f, o=o: f(*x, out=o) if keyword else f(*x, o), a)
        results.append((r, a, o))
    (got, a1, o1), (want, a2, o2) = results
    if isinstance(got[0], np.ndarray) and o1 is not None and not isinstance(o1, list):
        assert (got[0] is o1) == (want[0] is o2)
    assert_same(got[0], want[0])
    assert got[1] == want[1]
    for x, y in zip(a1, a2, strict=True):
        assert x.tobytes() == y.tobytes()
    if isinstance(o1, np.ndarray):
        assert o1.tobytes() == o2.tobytes()


def test_nan_outputs_decline_only_where_asked() -> None:
    calls: list[int] = []

    def spy(*args):
        calls.append(1)
        return dp.quat_normalize.__wrapped__(*args)

    q = np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 2.0, 3.0, 4.0]])
    with pytest.raises(ValueError, match=r"q must be a nonzero quaternion; element \(0,\) is zero"):
        _native.FastPath(_native.quat_normalize, spy, nan_declines=True)(q)
    assert calls == [1]
    assert np.isnan(_native.FastPath(_native.quat_normalize, spy)(q)[0]).all()  # no check asked: the raw rows
    assert calls == [1]


def test_reads_as_the_function() -> None:
    f = dp.quat_mul
    assert f.__name__ == "quat_mul" and f.__qualname__ == "quat_mul" and f.__module__ == "dualpose.algebra.quat"
    assert f.__doc__ == f.__wrapped__.__doc__ and f.__doc__.startswith("Hamilton product")
    assert str(inspect.signature(f)) == str(inspect.signature(f.__wrapped__))
    assert f.__annotations__ == f.__wrapped__.__annotations__
    assert pickle.loads(pickle.dumps(f)) is f and copy.deepcopy(f) is f
    assert "quat_mul" in repr(f) and inspect.isroutine(f)
    with pytest.raises(TypeError, match="kernel must be a gufunc"):
        _native.FastPath(np.add, f.__wrapped__)
