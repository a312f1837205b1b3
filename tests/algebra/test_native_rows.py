"""The native gufuncs' contiguous row loops against their per-element path.

A C-contiguous batch runs the vectorised loop (blocks of eight rows on a CPU with AVX-512, then blocks of four, then
a scalar tail); a strided view of the same data runs the element kernel.  Both must agree bit for bit for every
batch length (every tail), with zero, subnormal, extreme-norm, infinite and NaN rows inside a block, and in place
(the products, rotation, transform and the two inverses);
and the Hamilton and dual-quaternion products must round as their formulas written out in Python floats (IEEE
double, no fused multiply-add), whatever instruction set the loop was dispatched to.
"""

from __future__ import annotations

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


def qmul_floats(p: list[float], q: list[float]) -> list[float]:
    """The Hamilton product p (x) q of xyzw quaternions, written out in Python floats (IEEE double, no FMA)."""
    ax, ay, az, aw = p
    bx, by, bz, bw = q
    return [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]


def test_quat_mul_rounds_as_its_formula() -> None:
    rng = np.random.default_rng(2)
    p, q = rng.normal(size=(203, 4)), rng.normal(size=(203, 4))
    got = _native.quat_mul(p, q)
    for k in range(len(p)):
        assert got[k].tolist() == qmul_floats(p[k].tolist(), q[k].tolist()), k


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
        e, f = qmul_floats(ar, bd), qmul_floats(ad, br)
        assert got[k].tolist() == qmul_floats(ar, br) + [e[j] + f[j] for j in range(4)], k


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
