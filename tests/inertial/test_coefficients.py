"""Coefficient tables re-derived from first principles with exact rational arithmetic."""

import math
from fractions import Fraction as F

import numpy as np
import pytest

from dualpose.inertial import coning_coefficients


def _solve(a, b):
    n = len(a)
    m = [row[:] + [bb] for row, bb in zip(a, b, strict=True)]
    for i in range(n):
        p = next(r for r in range(i, n) if m[r][i] != 0)
        m[i], m[p] = m[p], m[i]
        for r in range(n):
            if r != i and m[r][i] != 0:
                f = m[r][i] / m[i][i]
                m[r] = [x - f * y for x, y in zip(m[r], m[i], strict=True)]
    return [m[i][n] / m[i][i] for i in range(n)]


def polynomial_fit_coefficients(n):
    """ω(t) = Σ c_m t^m (degree n−1) through the n increments (h = 1); ½∫α×ω dt as Σ k_ij θ_i × θ_j."""
    a = [[F(i ** (p + 1) - (i - 1) ** (p + 1), p + 1) for p in range(n)] for i in range(1, n + 1)]
    inv_cols = [_solve(a, [F(int(i == j)) for i in range(n)]) for j in range(n)]
    ainv = [[inv_cols[j][i] for j in range(n)] for i in range(n)]  # c = ainv θ
    T = F(n)
    # ½ ∫ α × ω = ½ Σ_pq c_p × c_q T^(p+q+2) / ((p+1)(p+q+2)); keep the antisymmetric part
    b = [
        [F(1, 4) * (F(1, (p + 1) * (p + q + 2)) - F(1, (q + 1) * (p + q + 2))) * T ** (p + q + 2) for q in range(n)]
        for p in range(n)
    ]
    mm = [
        [sum(ainv[p][i] * b[p][q] * ainv[q][j] for p in range(n) for q in range(n)) for j in range(n)] for i in range(n)
    ]
    return {(i, j): mm[i][j] - mm[j][i] for i in range(n) for j in range(i + 1, n)}


def _taylor(f_coeff, order):
    return [f_coeff(k) for k in range(order + 1)]


def _sin(c, order):
    return _taylor(lambda k: F((-1) ** ((k - 1) // 2)) * F(c) ** k / math.factorial(k) if k % 2 else F(0), order)


def _one_minus_cos_times2(order):
    return _taylor(lambda k: F(0) if k == 0 or k % 2 else -2 * F((-1) ** (k // 2), math.factorial(k)), order)


def coning_residual(n, lag_sums, order):
    """Per-update coning error / a² as a Taylor series in x = Ωh (small a):
    exact ½(nx − sin nx) minus Σ_l K_l 2(1 − cos x) sin(lx)."""
    ex = [F(0)] * (order + 1)
    ex[1] += F(n, 2)
    ex = [e - F(1, 2) * s for e, s in zip(ex, _sin(n, order), strict=True)]
    c2 = _one_minus_cos_times2(order)
    for lag, k in enumerate(lag_sums, start=1):
        sl = _sin(lag, order)
        prod = [sum(c2[i] * sl[p - i] for i in range(p + 1)) for p in range(order + 1)]
        ex = [e - k * q for e, q in zip(ex, prod, strict=True)]
    return ex


def lag_sums(kmat):
    n = kmat.shape[0]
    return [sum((kmat[i, i + lag] for i in range(n - lag)), F(0)) for lag in range(1, n)]


@pytest.mark.parametrize("n", [2, 3, 4])
def test_polynomial_family_is_the_polynomial_fit(n):
    k = coning_coefficients(n, "polynomial", exact=True)
    derived = polynomial_fit_coefficients(n)
    for (i, j), v in derived.items():
        assert k[i, j] == v, (i, j)


def test_restored_formulas_n2_n3():
    assert coning_coefficients(2, "coning-optimal", exact=True)[0, 1] == F(2, 3)
    poly = coning_coefficients(3, "polynomial", exact=True)
    assert (poly[0, 2], poly[0, 1], poly[1, 2]) == (F(33, 80), F(57, 80), F(57, 80))
    opt = coning_coefficients(3, "coning-optimal", exact=True)
    assert (opt[0, 2], opt[0, 1], opt[1, 2]) == (F(9, 20), F(27, 40), F(27, 40))


@pytest.mark.parametrize("n, rho", [(1, F(1, 12)), (2, F(1, 960)), (3, F(1, 204120)), (4, F(1, 82575360))])
def test_coning_optimal_cancels_to_order_2n_minus_1_and_gives_rho(n, rho):
    res = coning_residual(n, lag_sums(coning_coefficients(n, "coning-optimal", exact=True)), 2 * n + 1)
    assert all(c == 0 for c in res[: 2 * n + 1])
    # per-update error c x^(2N+1), x = ΩT/N; drift = error / T  =>  ρ_N = c / N^(2N+1)
    assert res[2 * n + 1] / F(n) ** (2 * n + 1) == rho


def test_families_differ_under_coning_for_n3_n4():
    for n in (3, 4):
        a = lag_sums(coning_coefficients(n, "polynomial", exact=True))
        b = lag_sums(coning_coefficients(n, "coning-optimal", exact=True))
        assert a != b
        np.testing.assert_array_equal(
            coning_coefficients(n, "polynomial"), coning_coefficients(n, "polynomial", True).astype(float)
        )


def test_bad_arguments():
    with pytest.raises(ValueError, match="samples"):
        coning_coefficients(5)
    with pytest.raises(TypeError, match="samples"):
        coning_coefficients(2.0)
    with pytest.raises(ValueError, match="coefficients"):
        coning_coefficients(2, "taylor")
    with pytest.raises(ValueError, match="one-plus-previous"):
        coning_coefficients(2, "one-plus-previous")


def test_residual_of_polynomial_n3_and_one_plus_previous():
    """Leading drift coefficients used by test_integrate: polynomial N=3 a²Ω(ΩT)⁴/6480 (order x⁵ not cancelled),
    one-plus-previous a²Ω(ΩT)⁴/60 (its lag-1 cross term spans the update boundary: Σ = 1/12 at lag 1, N = 1)."""
    res = coning_residual(3, lag_sums(coning_coefficients(3, "polynomial", exact=True)), 7)
    assert res[3] == 0 and res[5] / F(3) ** 5 == F(-1, 6480)
    res1 = coning_residual(1, [], 5)  # one-plus-previous: as N = 2 with the lag-1 pair weighted 1/12 per update
    c2 = _one_minus_cos_times2(5)
    s1 = _sin(1, 5)
    corr = [F(1, 12) * sum(c2[i] * s1[p - i] for i in range(p + 1)) for p in range(6)]
    diff = [a - b for a, b in zip(res1, corr, strict=True)]
    assert diff[3] == 0 and diff[5] == F(1, 60)
