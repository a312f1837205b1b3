"""The native gufuncs' contiguous row loops (4-row vector blocks plus a scalar tail) against their per-element path.

A C-contiguous batch runs the vectorised loop; a strided view of the same data runs the element kernel.  Both must
agree bit for bit for every batch length (every tail), with zero, extreme-norm and NaN rows inside a block, and
in place; and the Hamilton product must round as its formula written out in Python floats (IEEE double, no fused
multiply-add), whatever instruction set the loop was dispatched to.
"""

from __future__ import annotations

import numpy as np
import pytest

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
@pytest.mark.parametrize("n", [0, 1, 3, 4, 5, 8, 13, 64, 203])
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


def test_quat_mul_rounds_as_its_formula() -> None:
    rng = np.random.default_rng(2)
    p, q = rng.normal(size=(203, 4)), rng.normal(size=(203, 4))
    got = _native.quat_mul(p, q)
    for k in range(len(p)):
        ax, ay, az, aw = (float(v) for v in p[k])
        bx, by, bz, bw = (float(v) for v in q[k])
        want = [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
        assert got[k].tolist() == want, k


@pytest.mark.parametrize("name", ["quat_mul", "quat_rotate", "dualquat_mul", "dualquat_transform", "quat_log"])
def test_kernels_are_numpy_gufuncs(name: str) -> None:
    f = getattr(_native, name)
    assert isinstance(f, np.ufunc) and f.signature is not None
