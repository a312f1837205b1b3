"""Scale-invariant algebra at any finite nonzero magnitude (subnormal 1e-320 to 1e300): the kernels rescale extreme
input exactly by a power of two (common/kutil.hpp extreme_exponent), so the result equals the one of the same
quaternion at unit scale, and ``ln|q|`` equals mpmath's; ordinary input is untouched (docs/refusals.md)."""

from __future__ import annotations

import warnings

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import dualpose as dp
from dualpose.algebra.implicit import twist_from_qt

#: components of a quaternion of norm about 1 (the largest at least 0.25, so its norm is >= 0.25)
_unit = st.lists(st.floats(-1.0, 1.0, allow_subnormal=False), min_size=4, max_size=4).filter(
    lambda c: max(abs(v) for v in c) >= 0.25
)
#: binary exponents spanning 1e-320 (subnormal) to 1e300
_exponent = st.integers(-1063, 996)

_SCALE_INVARIANT = {
    "quat_normalize": dp.quat_normalize,
    "rotvec_from_quat": dp.rotvec_from_quat,
    "matrix_from_quat": dp.matrix_from_quat,
    "axis_angle_from_quat": lambda q: np.concatenate([a.ravel() for a in dp.axis_angle_from_quat(q)]),
    "quat_rotate": lambda q: dp.quat_rotate(q, np.array([0.3, -1.2, 2.0])),
    "quat_angle": lambda q: dp.quat_angle(q, dp.quat_normalize([0.1, 0.2, -0.3, 0.9])),
    "quat_slerp": lambda q: dp.quat_slerp(q, np.array([0.1, 0.2, -0.3, 0.9]), 0.3),
    "quat_log vector": lambda q: dp.quat_log(q)[:3],
    "twist_from_qt": lambda q: twist_from_qt(q, np.array([1.0, 2.0, 3.0])),
}


def _scaled(c: list[float], e: int) -> tuple[np.ndarray, np.ndarray]:
    """``q = 2**e c`` (rounded where it is subnormal) and the same ``q`` exactly rescaled back to unit size."""
    q = np.ldexp(np.array(c), e)
    return q, np.ldexp(q, -e)  # exact: q's value, whatever rounding made it


@settings(max_examples=150, deadline=None)
@given(_unit, _exponent)
def test_scale_invariant_functions_equal_their_unit_scale_value(c, e):
    q, unit = _scaled(c, e)
    if not np.any(q):
        return  # the whole quaternion underflowed to zero: refused (test below)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow / invalid RuntimeWarning at any magnitude
        for name, f in _SCALE_INVARIANT.items():
            # quat_angle's accurate difference form (|p|, |q| not exactly 1) is scale-invariant to ~1e-13 only
            tol = 1e-12 if name == "quat_angle" else 1e-13
            np.testing.assert_allclose(f(q), f(unit), rtol=tol, atol=1e-15, err_msg=name)


@settings(max_examples=100, deadline=None)
@given(_unit, _exponent)
def test_log_norm_matches_mpmath_and_dual_quaternions_normalize(c, e):
    q, unit = _scaled(c, e)
    if not np.any(q):
        return
    mpmath.mp.dps = 40
    exact = mpmath.log(mpmath.sqrt(sum(mpmath.mpf(float(v)) ** 2 for v in q)))
    assert dp.quat_log(q)[3] == pytest.approx(float(exact), rel=1e-15, abs=1e-13)
    t = np.array([0.5, -1.0, 2.0])
    s_unit = dp.dualquat_from_qt(unit, t)
    s = np.ldexp(s_unit, e)  # a dual quaternion scaled as a whole (real and dual part)
    if not np.all(np.isfinite(s)) or not np.any(s[:4]) or e < -1000:
        return  # the dual part of a subnormal scale loses its digits: not the same transform any more
    np.testing.assert_allclose(dp.dualquat_normalize(s), dp.dualquat_normalize(s_unit), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(dp.qt_from_dualquat(s)[1], t, rtol=1e-13, atol=1e-14)
    p = [1.0, 2.0, 3.0]
    np.testing.assert_allclose(dp.dualquat_transform(s, p), dp.dualquat_transform(s_unit, p), rtol=1e-13, atol=1e-14)


def test_the_issue_examples_and_zero_and_non_finite_input():
    q = np.array([1e-320, 0.0, 0.0, 1e-320])  # a quarter turn about x at subnormal magnitude
    np.testing.assert_allclose(dp.rotvec_from_quat(q), [np.pi / 2, 0.0, 0.0], rtol=1e-15)
    np.testing.assert_allclose(dp.matrix_from_quat(q), [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-15)
    np.testing.assert_allclose(dp.quat_log(q)[:3], [np.pi / 4, 0.0, 0.0], rtol=1e-15)
    big = np.array([1.7e308, 1.7e308, 0.0, 0.0])  # near the largest double: no overflow either
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(dp.quat_normalize(big), [2**-0.5, 2**-0.5, 0, 0], rtol=1e-15)
        np.testing.assert_allclose(dp.rotvec_from_quat(big), [np.pi / 2**0.5, np.pi / 2**0.5, 0], rtol=1e-15)
        assert np.isnan(dp.quat_normalize([np.nan, 0.0, 0.0, 1.0])).all()  # NaN propagates (documented)
    for f in (dp.quat_normalize, dp.matrix_from_quat, dp.rotvec_from_quat):
        with pytest.raises(ValueError, match="nonzero quaternion"):
            f(np.zeros(4))


def test_batches_of_mixed_magnitudes_match_row_by_row():
    """The four-row lanes of the contiguous loops (ordinary blocks) and the row kernel (extreme blocks) agree."""
    rng = np.random.default_rng(4)
    q = rng.normal(size=(64, 4))
    q[::5] *= 1e-310
    q[1::7] *= 1e250
    v = rng.normal(size=(64, 3))
    whole = dp.quat_rotate(q, v)
    rows = np.array([dp.quat_rotate(q[i], v[i]) for i in range(64)])
    np.testing.assert_array_equal(whole, rows)
    unit = q / np.max(np.abs(q), axis=1, keepdims=True)
    np.testing.assert_allclose(whole, dp.quat_rotate(unit, v), rtol=1e-13, atol=1e-14)
