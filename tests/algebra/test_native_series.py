"""The C++ series (src/native/common/series.hpp) use exactly series.py's Taylor coefficients and cutoffs.

Below each cutoff the native ufunc must equal, bit for bit, a Horner evaluation in Python of the coefficients
that :mod:`dualpose.algebra.series` derives from exact rationals (so the hexadecimal literals in the header are
those numbers, term count included); at and above the cutoff it must have switched to the closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from dualpose.algebra import series

POLY = ["sinc", "cosc2", "sinc3", "dsinc", "cosc4", "se3c", "jinv"]


def horner(coeffs: tuple[float, ...], y: float) -> float:
    acc = 0.0
    for c in reversed(coeffs):
        acc = acc * y + c
    return acc


@pytest.mark.parametrize("name", POLY)
def test_series_branch_uses_the_python_coefficients(name: str) -> None:
    cut = series.CUTOFFS[name]
    coeffs = series._coeff_tuple(name)
    xs = np.concatenate([np.linspace(0.0, cut, 257)[:-1], [1e-300, 1e-8, math.nextafter(cut, 0.0)]])
    xs = np.concatenate([xs, -xs])
    got = series.series_ufunc(name)(xs)
    want = np.array([horner(coeffs, abs(x) * abs(x)) for x in xs])
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("name", POLY)
def test_closed_form_at_and_above_the_cutoff(name: str) -> None:
    cut = series.CUTOFFS[name]
    assert float(series.series_ufunc(name)(cut)) == pytest.approx(series._CLOSED[name](cut), rel=1e-15)
    x = 1.25 * cut
    truth = series._CLOSED[name](x)
    assert float(series.series_ufunc(name)(x)) == pytest.approx(truth, rel=1e-13)


def test_atan2c_series_and_special_values() -> None:
    uf = series.series_ufunc("atan2c")
    c = 2.0
    for s in (0.0, 1e-300, 1e-8, 1e-4 * c):
        y = s / c
        y2 = y * y
        assert float(uf(s, c)) == (1.0 + y2 * (-1.0 / 3.0 + y2 * (0.2 - y2 / 7.0))) / c
    assert float(uf(0.5, 0.25)) == math.atan2(0.5, 0.25) / 0.5
    assert float(uf(0.0, -1.0)) == math.inf
    assert math.isnan(float(uf(0.0, 0.0)))
