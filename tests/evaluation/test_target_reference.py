"""The three-cornered hat of dualpose.evaluation.target_reference against errors of known variance."""

from __future__ import annotations

import numpy as np
import pytest

from dualpose.evaluation.target_reference import three_cornered_hat


def _readings(rng: np.random.Generator, sigmas: tuple[float, float, float], k: int = 400_000) -> list[np.ndarray]:
    truth = rng.normal(size=(k, 3)) * 5.0
    return [truth + s * rng.normal(size=(k, 3)) for s in sigmas]


def test_independent_errors_give_each_instruments_variance() -> None:
    a, b, c = _readings(np.random.default_rng(0), (0.1, 0.3, 0.05))
    va, vb, vc = three_cornered_hat(a - b, a - c, b - c)
    # the analytic values are σ²; the sampling error of a mean square of K normal draws is ~ sqrt(2/K) relative
    np.testing.assert_allclose(np.sqrt(va), 0.1, rtol=0.02)
    np.testing.assert_allclose(np.sqrt(vb), 0.3, rtol=0.01)
    np.testing.assert_allclose(np.sqrt(vc), 0.05, rtol=0.1)


def test_a_bias_counts_as_the_instruments_error() -> None:
    a, b, c = _readings(np.random.default_rng(1), (0.0, 0.0, 0.0), k=1000)
    a = a + np.array([0.2, 0.0, 0.0])
    va, vb, vc = three_cornered_hat(a - b, a - c, b - c)
    np.testing.assert_allclose(va, [0.04, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(vb, 0.0, atol=1e-12)
    np.testing.assert_allclose(vc, 0.0, atol=1e-12)


def test_an_error_shared_by_two_instruments_is_given_to_the_third() -> None:
    rng = np.random.default_rng(2)
    k = 200_000
    truth = rng.normal(size=k)
    common = 0.2 * rng.normal(size=k)
    a = truth + common + 0.05 * rng.normal(size=k)
    b = truth + common + 0.05 * rng.normal(size=k)
    c = truth
    va, vb, vc = three_cornered_hat(a - b, a - c, b - c)
    assert float(va) == pytest.approx(0.05**2, rel=0.05)
    assert float(vb) == pytest.approx(0.05**2, rel=0.05)
    assert float(vc) == pytest.approx(0.2**2, rel=0.02)


def test_negative_variance_is_returned_not_clipped() -> None:
    rng = np.random.default_rng(3)
    truth = rng.normal(size=10_000)
    e = 0.3 * rng.normal(size=10_000)
    a, b, c = truth + e, truth - e, truth  # a and b anti-correlated
    va, vb, vc = three_cornered_hat(a - b, a - c, b - c)
    assert float(vc) < 0.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((np.zeros((5, 3)), np.zeros((5, 3)), np.zeros((4, 3))), "same shape"),
        ((np.zeros(1), np.zeros(1), np.zeros(1)), "K >= 2"),
        ((np.zeros((5, 3, 1)), np.zeros((5, 3)), np.zeros((5, 3))), "d_ab must have shape"),
        ((np.zeros(5), np.full(5, np.nan), np.zeros(5)), "d_ac must be finite"),
    ],
)
def test_bad_input_is_refused_with_the_argument_named(args: tuple[np.ndarray, ...], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        three_cornered_hat(*args)
