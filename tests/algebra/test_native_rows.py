"""The native gufuncs' contiguous row loops against their per-element path.

A C-contiguous batch runs the vectorised loop (blocks of eight rows on a CPU with AVX-512, then blocks of four, then
a scalar tail); a strided view of the same data runs the element kernel.  Both must agree bit for bit for every
batch length (every tail), with zero, subnormal, extreme-norm, infinite and NaN rows inside a block, and in place
(the products, rotation, transform and the two inverses);
and the Hamilton and dual-quaternion products must round as their formulas written out in Python floats (IEEE
double; with fused multiply-adds exactly where the build uses them, _native.FUSED_MULTIPLY_ADD), whatever
instruction set the loop was dispatched to.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import warnings
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from dualpose import _native


def strided(a: np.ndarray) -> np.ndarray:
    buf = np.zeros((*a.shape[:-1], 2 * a.shape[-1]))
    buf[..., ::2] = a
    return buf[..., ::2]


def rows(rng: np.random.Generator, n: int, width: int) -> np.ndarray:
    a = rng.normal(size=(n, width)) * 10.0 ** rng.uniform(-3, 3, size=(n, 1))
    specials = [0.0, 1e-200, 1e200, np.nan]  # every 7th row: a zero, tiny, huge or NaN (real) part
    for k in range(0, n, 7):
        a[k, :4] *= specials[(k // 7) % 4]
    return a


KERNELS = [
    ("quat_mul", (4, 4)),
    ("quat_rotate", (4, 3)),
    ("dualquat_mul", (8, 8)),
    ("dualquat_transform", (8, 3)),
]


@pytest.mark.parametrize("name,widths", KERNELS)
@pytest.mark.parametrize("n", [0, 1, 3, 4, 5, 7, 8, 9, 13, 15, 16, 17, 23, 64, 203])
def test_contiguous_loop_equals_element_kernel(name: str, widths: tuple[int, int], n: int) -> None:
    rng = np.random.default_rng(n)
    a, b = rows(rng, n, widths[0]), rng.normal(size=(n, widths[1]))
    f = getattr(_native, name)
    with np.errstate(all="ignore"):
        np.testing.assert_array_equal(f(a, b), f(strided(a), b))
        np.testing.assert_array_equal(f(a, b), f(a, strided(b)))


@pytest.mark.parametrize("name,widths", KERNELS)
def test_contiguous_loop_in_place(name: str, widths: tuple[int, int]) -> None:
    rng = np.random.default_rng(1)
    a, b = rows(rng, 37, widths[0]), rng.normal(size=(37, widths[1]))
    f = getattr(_native, name)
    with np.errstate(all="ignore"):
        expect = f(strided(a), b)
        if widths[1] == expect.shape[-1]:
            f(a, b, out=b)
            np.testing.assert_array_equal(b, expect)


def fma(a: float, b: float, c: float) -> float:
    """a b + c rounded once (exact rational arithmetic; int / int is correctly rounded)."""
    x = Fraction(a) * Fraction(b) + Fraction(c)
    return x.numerator / x.denominator


def qmul_floats(p: list[float], q: list[float], fused: bool) -> list[float]:
    """The Hamilton product p (x) q of xyzw quaternions, written out in Python floats (IEEE double): term after
    term, each added product rounded once with ``fused`` (a fused multiply-add), else rounded before the sum."""
    ax, ay, az, aw = p
    bx, by, bz, bw = q

    def acc(first: float, *terms: tuple[float, float, float]) -> float:  # first + sign a b + ...
        t = first
        for sign, a, b in terms:
            t = fma(sign * a, b, t) if fused else t + sign * (a * b)
        return t

    return [
        acc(aw * bx, (1, ax, bw), (1, ay, bz), (-1, az, by)),
        acc(aw * by, (-1, ax, bz), (1, ay, bw), (1, az, bx)),
        acc(aw * bz, (1, ax, by), (-1, ay, bx), (1, az, bw)),
        acc(aw * bw, (-1, ax, bx), (-1, ay, by), (-1, az, bz)),
    ]


def test_quat_mul_rounds_as_its_formula() -> None:
    # the build's own choice (fused multiply-adds on a CPU with FMA and AVX2), the same on every path
    rng = np.random.default_rng(2)
    p, q = rng.normal(size=(203, 4)), rng.normal(size=(203, 4))
    got = _native.quat_mul(p, q)
    fused = _native.FUSED_MULTIPLY_ADD
    for k in range(len(p)):
        assert got[k].tolist() == qmul_floats(p[k].tolist(), q[k].tolist(), fused), k
    # the two roundings differ on these rows, so the check tells them apart
    assert any(qmul_floats(a, b, True) != qmul_floats(a, b, False) for a, b in zip(p.tolist(), q.tolist(), strict=True))


#: any double: zero, subnormal, tiny, ordinary, huge, infinite or NaN, each sign
ANY = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True),
    st.sampled_from([0.0, -0.0, 5e-324, -2.2e-308, 1e-160, 1e160, -1.7e308, np.inf, np.nan]),
    st.floats(-10.0, 10.0),
)


@pytest.mark.parametrize("name,widths", KERNELS)
@given(data=st.data(), n=st.integers(0, 41))
def test_contiguous_loop_equals_element_kernel_for_any_values(name: str, widths: tuple[int, int], data: st.DataObject,
                                                              n: int) -> None:
    # ordinary rows with up to three values of any kind put anywhere: a block with such a row takes the fallback,
    # the other blocks the vector path
    a = data.draw(arrays(np.float64, (n, widths[0]), elements=st.floats(-10.0, 10.0)))
    b = data.draw(arrays(np.float64, (n, widths[1]), elements=st.floats(-10.0, 10.0)))
    if n:
        for x in (a, b):
            for _ in range(data.draw(st.integers(0, 3))):
                x[data.draw(st.integers(0, n - 1)), data.draw(st.integers(0, x.shape[1] - 1))] = data.draw(ANY)
    f = getattr(_native, name)
    with np.errstate(all="ignore"):
        got = f(a, b)
        np.testing.assert_array_equal(got, f(strided(a), strided(b)))
        if name in ("quat_mul", "dualquat_mul"):  # in place: the output over the first input
            f(a, b, out=a)
            np.testing.assert_array_equal(a, got)


def test_dualquat_mul_rounds_as_its_formula() -> None:
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(203, 8)), rng.normal(size=(203, 8))
    got = _native.dualquat_mul(a, b)
    for k in range(len(a)):
        ar, ad, br, bd = a[k, :4].tolist(), a[k, 4:].tolist(), b[k, :4].tolist(), b[k, 4:].tolist()
        fused = _native.FUSED_MULTIPLY_ADD
        e, f = qmul_floats(ar, bd, fused), qmul_floats(ad, br, fused)
        assert got[k].tolist() == qmul_floats(ar, br, fused) + [e[j] + f[j] for j in range(4)], k


#: the one-input kernels with a contiguous row loop and the same ordinary-block split (the inverses)
INVERSES = [("quat_inv", 4), ("dualquat_inv", 8)]


@pytest.mark.parametrize("name,width", INVERSES)
@pytest.mark.parametrize("n", [0, 1, 3, 4, 5, 7, 8, 9, 13, 15, 16, 17, 23, 64, 203])
def test_inverse_loop_equals_element_kernel(name: str, width: int, n: int) -> None:
    a = rows(np.random.default_rng(n), n, width)
    f = getattr(_native, name)
    with np.errstate(all="ignore"):
        got = f(a)
        np.testing.assert_array_equal(got, f(strided(a)))
        np.testing.assert_array_equal(got, np.array([f(r) for r in a]).reshape(got.shape))  # one row at a time
        f(a, out=a)  # in place
        np.testing.assert_array_equal(a, got)


@pytest.mark.parametrize("name,width", INVERSES)
@given(data=st.data(), n=st.integers(0, 41))
def test_inverse_loop_equals_element_kernel_for_any_values(name: str, width: int, data: st.DataObject,
                                                           n: int) -> None:
    a = data.draw(arrays(np.float64, (n, width), elements=st.floats(-10.0, 10.0)))
    if n:
        for _ in range(data.draw(st.integers(0, 3))):
            a[data.draw(st.integers(0, n - 1)), data.draw(st.integers(0, width - 1))] = data.draw(ANY)
    f = getattr(_native, name)
    with np.errstate(all="ignore"):
        got = f(a)
        np.testing.assert_array_equal(got, f(strided(a)))
        f(a, out=a)
        np.testing.assert_array_equal(a, got)


@pytest.mark.parametrize("name", ["quat_mul", "quat_rotate", "dualquat_mul", "dualquat_transform", "quat_log"])
def test_kernels_are_numpy_gufuncs(name: str) -> None:
    f = getattr(_native, name)
    assert isinstance(f, np.ufunc) and f.signature is not None


@pytest.mark.parametrize("name,width", [("quat_conj", 4), ("dualquat_conj", 8)])
@given(data=st.data(), n=st.integers(0, 19))
def test_conjugates_multiply_as_numpy(name: str, width: int, data: st.DataObject, n: int) -> None:
    # the kernels multiply by the sign pattern as NumPy does: the same bytes, NaN signs and payloads included
    q = data.draw(arrays(np.float64, (n, width), elements=ANY))
    signs = np.tile([-1.0, -1.0, -1.0, 1.0], width // 4)
    f = getattr(_native, name)
    with np.errstate(all="ignore"):
        want = (q * signs).tobytes()
        assert f(q).tobytes() == want
        assert f(strided(q)).tobytes() == want


def test_unfused_arithmetic_on_request() -> None:
    # DUALPOSE_NO_FMA=1 at load: the arithmetic of a CPU without FMA, on every path alike (the checks above, run in a
    # fresh process)
    code = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r})
        import test_native_rows as t
        from dualpose import _native
        assert not _native.FUSED_MULTIPLY_ADD
        t.test_quat_mul_rounds_as_its_formula()
        t.test_dualquat_mul_rounds_as_its_formula()
        for n in (5, 13, 203):
            for name, widths in t.KERNELS:
                t.test_contiguous_loop_equals_element_kernel(name, widths, n)
            for name, width in t.INVERSES:
                t.test_inverse_loop_equals_element_kernel(name, width, n)
    """)
    subprocess.run([sys.executable, "-c", code], env={**os.environ, "DUALPOSE_NO_FMA": "1"}, check=True)


@pytest.mark.parametrize("name,widths", KERNELS + [(name, (width, 0)) for name, width in INVERSES])
@pytest.mark.parametrize("n", [5, 23])  # a four-row tail; eight- and four-row blocks
def test_nan_rows_raise_no_flag_on_any_path(name: str, widths: tuple[int, int], n: int) -> None:
    # a NaN in a row's quaternion gives NaN in that row only, quietly (no RuntimeWarning) on the contiguous, strided
    # and broadcast paths, as the row kernel's own magnitude test (a quiet self-comparison first)
    rng = np.random.default_rng(n)
    a = rng.normal(size=(n, widths[0]))
    a[2, 1] = np.nan
    b = (rng.normal(size=(n, widths[1])),) if widths[1] else ()
    f = getattr(_native, name)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = f(a, *b)
        for other in (f(strided(a), *b), f(a, *(x[0] for x in b)) if b else f(a[2])):
            assert np.isnan(other).any()
        np.testing.assert_array_equal(got, f(strided(a), *b))
    assert np.isnan(got[2]).any() and np.isfinite(np.delete(got, 2, axis=0)).all()
