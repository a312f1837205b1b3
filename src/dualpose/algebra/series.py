"""Guarded series for every removable singularity in dualpose, collected in one place.

Each function below is evaluated by a Horner polynomial (exact rational Taylor coefficients rounded once to
float64) below its own cutoff, and by a closed form that is accurate above it.  The cutoff of each function is
chosen where the closed form's cancellation error has fallen to about one ulp; the number of Taylor terms is
chosen so that the first omitted term is below 2**-56 of the function value at the cutoff.  All are even
functions of ``x`` and are evaluated on ``|x|``.  The kernels use the C++ copies in ``src/native/common/series.hpp``
(coefficients written out as hexadecimal literals of :func:`taylor_coefficients`, checked against this module by
``tests/algebra/test_native_series.py``); each name below is that kernel as a NumPy ufunc of ``dualpose._native``
(:func:`series_ufunc` looks one up by name).

=============  ====================================  ===========  ===========================================
name           function                              cutoff       used by (Dantam 2014 eq.)
=============  ====================================  ===========  ===========================================
``sinc``       sin x / x                             0.5          exp, rotvec -> quat (23), slerp, pow
``cosc2``      (1 - cos x) / x**2                    1.0          SO(3) left Jacobian
``sinc3``      (x - sin x) / x**3                    3.0          SO(3)/SE(3) Jacobians, DQ log alpha (92)
``dsinc``      (x cos x - sin x) / x**3              2.0          (37), (57), DQ exp (85)
``cosc4``      (x**2/2 - 1 + cos x) / x**4           3.5          SE(3) left Jacobian (Barfoot's Q)
``se3c``       (2x - 3 sin x + x cos x) / (2 x**5)   4.0          SE(3) left Jacobian (Barfoot's Q)
``jinv``       (1 - (x/2) cot(x/2)) / x**2           2.5          inverse SO(3)/SE(3) Jacobians
``atan2c``     atan2(s, c) / s                       s <= 1e-4 c  quat / DQ log (26)-(28), rotvec
``dqalpha``    (cos x / sin**2 x - x / sin**3 x)     (composed)   DQ log (88), (91)-(92)
``dlogc``      (x cos x - sin x) / sin**3 x          (composed)   unit-log derivative (39)-(40)
=============  ====================================  ===========  ===========================================

The two composed functions are exact rewrites in terms of guarded primitives, so they inherit their cutoffs:
``dqalpha(x) = -4 sinc3(2x) / sinc(x)**3`` and ``dlogc(x) = dsinc(x) / sinc(x)**3``.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

from dualpose import _native

__all__ = [
    "CUTOFFS",
    "sinc",
    "cosc2",
    "sinc3",
    "dsinc",
    "cosc4",
    "se3c",
    "jinv",
    "atan2c",
    "dqalpha",
    "dlogc",
    "series_ufunc",
    "taylor_coefficients",
]

_EPS_TARGET = 2.0**-56


def _sin_cos_terms(n: int) -> tuple[list[Fraction], list[Fraction]]:
    """Exact Taylor coefficients of sin and cos up to x**n."""
    s = [Fraction(0)] * (n + 1)
    c = [Fraction(0)] * (n + 1)
    for k in range(n + 1):
        val = Fraction((-1) ** (k // 2), math.factorial(k))
        if k % 2:
            s[k] = val
        else:
            c[k] = val
    return s, c


def _bernoulli(n: int) -> list[Fraction]:
    b = [Fraction(0)] * (n + 1)
    b[0] = Fraction(1)
    for m in range(1, n + 1):
        b[m] = -sum((math.comb(m + 1, k) * b[k] for k in range(m)), Fraction(0)) / (m + 1)
    return b


def taylor_coefficients(name: str, n_terms: int) -> list[Fraction]:
    """Exact coefficients ``a_k`` with ``f(x) = sum_k a_k x**(2k)`` for the named series."""
    deg = 2 * n_terms + 8
    s, c = _sin_cos_terms(deg)
    x = [Fraction(0)] * (deg + 1)
    x[1] = Fraction(1)
    x2 = [Fraction(0)] * (deg + 1)
    x2[2] = Fraction(1)

    def combo(*terms: tuple[Fraction, list[Fraction]]) -> list[Fraction]:
        out = [Fraction(0)] * (deg + 1)
        for w, poly in terms:
            for i, v in enumerate(poly):
                out[i] += w * v
        return out

    def xtimes(p: list[Fraction]) -> list[Fraction]:
        return [Fraction(0)] + p[:-1]

    one = [Fraction(1)] + [Fraction(0)] * deg
    if name == "sinc":
        num, shift = s, 1
    elif name == "cosc2":
        num, shift = combo((Fraction(1), one), (Fraction(-1), c)), 2
    elif name == "sinc3":
        num, shift = combo((Fraction(1), x), (Fraction(-1), s)), 3
    elif name == "dsinc":
        num, shift = combo((Fraction(1), xtimes(c)), (Fraction(-1), s)), 3
    elif name == "cosc4":
        num, shift = combo((Fraction(1, 2), x2), (Fraction(-1), one), (Fraction(1), c)), 4
    elif name == "se3c":
        num = combo((Fraction(1), x), (Fraction(-3, 2), s), (Fraction(1, 2), xtimes(c)))
        shift = 5
    elif name == "jinv":
        b = _bernoulli(2 * n_terms + 2)
        # (x/2) cot(x/2) = sum_n (-1)^n B_2n x^2n / (2n)!  ;  jinv = (1 - that) / x^2
        return [
            -Fraction((-1) ** m) * b[2 * m] / math.factorial(2 * m) for m in range(1, n_terms + 1)
        ]
    else:
        raise ValueError(f"unknown series {name!r}")
    coeffs = num[shift:]
    even = coeffs[0::2]
    assert all(v == 0 for v in coeffs[1::2]), name
    return even[:n_terms]


_CLOSED = {
    "sinc": lambda x: math.sin(x) / x,
    "cosc2": lambda x: (1 - math.cos(x)) / x**2,
    "sinc3": lambda x: (x - math.sin(x)) / x**3,
    "dsinc": lambda x: (x * math.cos(x) - math.sin(x)) / x**3,
    "cosc4": lambda x: (x * x / 2 - 1 + math.cos(x)) / x**4,
    "se3c": lambda x: (2 * x - 3 * math.sin(x) + x * math.cos(x)) / (2 * x**5),
    "jinv": lambda x: (1 - (x / 2) / math.tan(x / 2)) / x**2,
}

CUTOFFS = {
    "sinc": 0.5,
    "cosc2": 1.0,
    "sinc3": 3.0,
    "dsinc": 2.0,
    "cosc4": 3.5,
    "se3c": 4.0,
    "jinv": 2.5,
    "atan2c": 1e-4,
}


def _coeff_tuple(name: str) -> tuple[float, ...]:
    """Enough terms that the first omitted one is below 2**-56 of |f| at the cutoff."""
    cut = Fraction(CUTOFFS[name])
    fcut = abs(Fraction(_CLOSED[name](float(cut))))
    n = 2
    while True:
        co = taylor_coefficients(name, n + 1)
        if abs(co[n]) * cut ** (2 * n) < Fraction(_EPS_TARGET) * fcut:
            return tuple(float(v) for v in co[:n])
        n += 1


# the Horner coefficients, rounded once from the exact rationals (the C++ literals are checked against them)
_C_SINC = _coeff_tuple("sinc")
_C_COSC2 = _coeff_tuple("cosc2")
_C_SINC3 = _coeff_tuple("sinc3")
_C_DSINC = _coeff_tuple("dsinc")
_C_COSC4 = _coeff_tuple("cosc4")
_C_SE3C = _coeff_tuple("se3c")
_C_JINV = _coeff_tuple("jinv")

#: the series as NumPy ufuncs of float64 (scalars in, scalars out), evaluated by the C++ kernels of
#: ``src/native/common/series.hpp`` with the coefficients above
sinc = _native.sinc
cosc2 = _native.cosc2
sinc3 = _native.sinc3
dsinc = _native.dsinc
cosc4 = _native.cosc4
se3c = _native.se3c
jinv = _native.jinv
atan2c = _native.atan2c
dqalpha = _native.dqalpha
dlogc = _native.dlogc


def series_ufunc(name: str) -> np.ufunc:
    """The named series as a NumPy ufunc of float64 (``atan2c`` takes two arguments)."""
    try:
        return _SERIES_UFUNCS[name]
    except KeyError:
        raise KeyError(f"unknown series {name!r}; one of {sorted(_SERIES_UFUNCS)}") from None


_SERIES_UFUNCS: dict[str, np.ufunc] = {
    "sinc": sinc,
    "cosc2": cosc2,
    "sinc3": sinc3,
    "dsinc": dsinc,
    "cosc4": cosc4,
    "se3c": se3c,
    "jinv": jinv,
    "atan2c": atan2c,
    "dqalpha": dqalpha,
    "dlogc": dlogc,
}
