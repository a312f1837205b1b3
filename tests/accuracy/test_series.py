"""Every guarded series of dualpose.algebra.series against mpmath, on both sides of every cutoff.

The reference is the closed form evaluated in mpmath at the float64 argument with enough extra digits to absorb
its cancellation (6 per decade below 1), or the exact limit at 0.  The error is relative; near a root of the
function it is absolute, scaled by the function's magnitude |f(0)|.  The Horner coefficients must be the exact
Taylor rationals (checked against independent closed forms of the coefficients) rounded once to float64.
"""

from __future__ import annotations

import math
from fractions import Fraction

import mpmath
import numpy as np
import pytest
from mpmath import mp, mpf

from dualpose.algebra import series

EPS = 2.0**-52
BAR = 4.0  # units of EPS

CLOSED = {
    "sinc": lambda x: mp.sin(x) / x,
    "cosc2": lambda x: (1 - mp.cos(x)) / x**2,
    "sinc3": lambda x: (x - mp.sin(x)) / x**3,
    "dsinc": lambda x: (x * mp.cos(x) - mp.sin(x)) / x**3,
    "cosc4": lambda x: (x**2 / 2 - 1 + mp.cos(x)) / x**4,
    "se3c": lambda x: (2 * x - 3 * mp.sin(x) + x * mp.cos(x)) / (2 * x**5),
    "jinv": lambda x: (1 - (x / 2) * mp.cot(x / 2)) / x**2,
    "dqalpha": lambda x: mp.cos(x) / mp.sin(x) ** 2 - x / mp.sin(x) ** 3,
    "dlogc": lambda x: (x * mp.cos(x) - mp.sin(x)) / mp.sin(x) ** 3,
}
# exact limits at 0 (from the Taylor expansions of the closed forms)
LIMITS = {
    "sinc": Fraction(1),
    "cosc2": Fraction(1, 2),
    "sinc3": Fraction(1, 6),
    "dsinc": Fraction(-1, 3),
    "cosc4": Fraction(1, 24),
    "se3c": Fraction(1, 120),
    "jinv": Fraction(1, 12),
    "dqalpha": Fraction(-2, 3),  # Dantam 2014 eq. (92)
    "dlogc": Fraction(-1, 3),
}
ROOTS = {"sinc": (math.pi,)}  # roots in the tested range [0, 4]


def _points() -> list[tuple[str, float]]:
    pts: list[tuple[str, float]] = [("0", 0.0), ("1e-300", 1e-300), ("1e-20", 1e-20), ("1e-8", 1e-8), ("1e-3", 1e-3)]
    # every cutoff, and half of every cutoff (dqalpha evaluates sinc3 at 2x): 1 ulp below, at, 1 ulp above
    cuts = sorted({v for k, v in series.CUTOFFS.items() if k != "atan2c"} | {v / 2 for v in series.CUTOFFS.values()
                                                                             if v > 1e-3})
    for c in cuts:
        pts += [(f"{c:g}-ulp", float(np.nextafter(c, 0.0))), (f"{c:g}", c), (f"{c:g}+ulp", float(np.nextafter(c, 9.0)))]
    pts += [("0.1", 0.1), ("2.2", 2.2), ("-0.7", -0.7), ("-2.6", -2.6)]
    pts += [("pi-1e-4", math.pi - 1e-4), ("pi-1e-8", math.pi - 1e-8), ("pi", math.pi)]
    return pts


POINTS = _points()


def reference(name: str, x: float) -> mpf:
    """f(x) at the float64 x, exact to > 40 digits (extra precision absorbs the closed form's cancellation)."""
    if x == 0.0:
        lim = LIMITS[name]
        with mp.workdps(50):
            return mpf(lim.numerator) / lim.denominator
    ax = abs(x)
    extra = 6 * max(0, math.ceil(-math.log10(ax))) if ax < 1 else 0
    with mp.workdps(50 + extra):
        return +CLOSED[name](mpf(x))


def error(name: str, x: float, computed: float, truth: mpf) -> float:
    """Relative error in EPS; near a root, absolute error over |f(0)|."""
    with mp.workdps(50):
        diff = abs(mpf(computed) - truth)
        if any(abs(x - r) < 1e-2 for r in ROOTS.get(name, ())):
            return float(diff / abs(mpf(LIMITS[name].numerator) / LIMITS[name].denominator)) / EPS
        return float(diff / abs(truth)) / EPS


@pytest.mark.parametrize("name", list(CLOSED))
@pytest.mark.parametrize("x", [p[1] for p in POINTS], ids=[p[0] for p in POINTS])
def test_series_value(name: str, x: float) -> None:
    computed = float(series.series_ufunc(name)(x))
    assert np.isfinite(computed), (name, x, computed)
    err = error(name, x, computed, reference(name, x))
    assert err <= BAR, f"{name}({x!r}) = {computed!r}: error {err:.3g} ε"


def test_njit_matches_ufunc() -> None:
    """The njit scalar functions the kernels inline give the same bits as the ufuncs tested above."""
    xs = [p[1] for p in POINTS]
    for name in CLOSED:
        fn = getattr(series, name)
        uf = series.series_ufunc(name)
        assert [fn(x) for x in xs] == [float(uf(x)) for x in xs], name


def _atan2c_points() -> list[tuple[str, float, float]]:
    out = []
    for c in (1.0, 0.3, 7.0):
        cut = 1e-4 * c
        for lab, s in [("0", 0.0), ("1e-310", 1e-310), ("1e-300", 1e-300), ("1e-20", 1e-20), ("1e-8", 1e-8),
                       ("cut-ulp", float(np.nextafter(cut, 0))), ("cut", cut), ("cut+ulp", float(np.nextafter(cut, 1))),
                       ("0.1", 0.1), ("1", 1.0), ("1e3", 1e3)]:
            out.append((f"c={c:g}-s={lab}", s, c))
    for s in (1e-300, 1e-8, 0.5, 1.0):
        out.append((f"c=-1-s={s:g}", s, -1.0))
    out += [("c=1e-300-s=1e-300", 1e-300, 1e-300), ("c=0-s=1", 1.0, 0.0), ("c=-1e-300-s=1e-300", 1e-300, -1e-300)]
    return out


ATAN2C_POINTS = _atan2c_points()


@pytest.mark.parametrize(("s", "c"), [p[1:] for p in ATAN2C_POINTS], ids=[p[0] for p in ATAN2C_POINTS])
def test_atan2c(s: float, c: float) -> None:
    """atan2(s, c)/s (Dantam 2014 eqs. (26)-(28)); the limit 1/c at s = 0."""
    computed = float(series.series_ufunc("atan2c")(s, c))
    with mp.workdps(60):
        truth = 1 / mpf(c) if s == 0.0 else mp.atan2(mpf(s), mpf(c)) / mpf(s)
        err = float(abs(mpf(computed) - truth) / abs(truth)) / EPS
    assert err <= BAR, f"atan2c({s!r}, {c!r}) = {computed!r}: error {err:.3g} ε"


def test_atan2c_special_points() -> None:
    """Documented: +inf on the negative real axis (the caller picks an axis), NaN at s = c = 0."""
    uf = series.series_ufunc("atan2c")
    assert float(uf(0.0, -1.0)) == math.inf
    assert math.isnan(float(uf(0.0, 0.0)))


def _independent_coefficients(name: str, n: int) -> list[Fraction]:
    """a_k of f(x) = sum a_k x**(2k), from closed forms independent of series.taylor_coefficients."""
    f = math.factorial
    out = []
    for k in range(n):
        sg = (-1) ** k
        if name == "sinc":
            a = Fraction(sg, f(2 * k + 1))
        elif name == "cosc2":
            a = Fraction(sg, f(2 * k + 2))
        elif name == "sinc3":
            a = Fraction(sg, f(2 * k + 3))
        elif name == "dsinc":  # x cos x - sin x = sum_n (-1)^n 2n x^(2n+1)/(2n+1)!
            a = Fraction(-sg * (2 * k + 2), f(2 * k + 3))
        elif name == "cosc4":
            a = Fraction(sg, f(2 * k + 4))
        elif name == "se3c":  # 2x - 3 sin x + x cos x = sum_n (-1)^n (2n-2) x^(2n+1)/(2n+1)!
            a = Fraction(sg * (k + 1), f(2 * k + 5))
        elif name == "jinv":  # (x/2)cot(x/2) = sum_n (-1)^n B_2n x^2n/(2n)!
            p, q = mpmath.bernfrac(2 * k + 2)
            a = sg * Fraction(int(p), int(q)) / f(2 * k + 2)
        else:
            raise AssertionError(name)
        out.append(a)
    return out


HORNER = ["sinc", "cosc2", "sinc3", "dsinc", "cosc4", "se3c", "jinv"]


@pytest.mark.parametrize("name", HORNER)
def test_horner_coefficients_are_exact_rationals(name: str) -> None:
    coeffs = getattr(series, f"_C_{name.upper()}")
    n = len(coeffs)
    exact = series.taylor_coefficients(name, n)
    assert exact == _independent_coefficients(name, n)
    # float(Fraction) is correctly rounded: each coefficient is its exact rational rounded once
    assert tuple(coeffs) == tuple(float(a) for a in exact)
    # the number of terms suffices: the first omitted term is below 2**-56 of |f| at the cutoff
    cut = Fraction(series.CUTOFFS[name])
    nxt = series.taylor_coefficients(name, n + 1)[n]
    fcut = abs(Fraction(float(reference(name, float(cut)))))
    assert abs(nxt) * cut ** (2 * n) < Fraction(2.0**-56) * fcut


def test_dantam_series_coefficients() -> None:
    """The printed series of Dantam 2014 eqs. (85) and (92) agree with the guarded functions near 0."""
    x = 1e-2
    eq85 = -1 / 3 + x**2 / 30 - x**4 / 840 + x**6 / 45360
    eq92 = -2 / 3 - x**2 / 5 - 17 * x**4 / 420 - 29 * x**6 / 4200
    assert abs(series.dsinc(x) - eq85) <= 2 * EPS * abs(eq85)
    assert abs(series.dqalpha(x) - eq92) <= 2 * EPS * abs(eq92)
