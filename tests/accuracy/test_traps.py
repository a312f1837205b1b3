"""Regression tests for numerical traps found in peer libraries; each asserts dualpose's correct behaviour.

References are mpmath (``accuracy_reference``): the exact value of the function at the float64 input.
"""

from __future__ import annotations

import math
import warnings
import zlib

import accuracy_cases as cases
import accuracy_reference as ref
import numpy as np
import pytest
from mpmath import mp, mpf

from dualpose.algebra import dualquat, quat, series

EPS = ref.EPS


def componentwise_rel(computed: np.ndarray, truth: list) -> float:
    """max_i |c_i − t_i| / |t_i| over the nonzero t_i, in units of EPS (zero truths must be computed exactly)."""
    c = np.asarray(computed, dtype=np.float64).ravel()
    worst = 0.0
    with mp.workdps(ref.DPS):
        for ci, ti in zip(c, truth, strict=True):
            if ti == 0:
                if ci != 0.0:
                    return math.inf
                continue
            worst = max(worst, float(abs(mpf(float(ci)) - ti) / abs(ti)) / EPS)
    return worst


def unit_axes(rng: np.random.Generator, n: int) -> np.ndarray:
    a = rng.normal(size=(n, 3))
    return a / np.linalg.norm(a, axis=1, keepdims=True)


# ---------------------------------------------------------------------------------------------------------------
# (1) flushing tiny angles to zero (several libraries return the identity / zero for θ below ~1e-20)
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("angle", [1e-21, 1e-25, 1e-300])
def test_tiny_rotvec_not_flushed(rng: np.random.Generator, angle: float) -> None:
    for v in unit_axes(rng, 5) * angle:
        q = quat.quat_from_rotvec(v)
        assert q[3] == 1.0
        assert componentwise_rel(q, ref.quat_from_rotvec(v)[0]) <= 4
        back = quat.rotvec_from_quat(q)
        assert componentwise_rel(back, ref.rotvec_from_quat(q)[0]) <= 4
        assert np.all(np.abs(back - v) <= 4 * EPS * np.abs(v))  # round trip keeps every component
        lq = quat.quat_log(q)
        assert componentwise_rel(lq[:3], ref.quat_log(q)[0][:3]) <= 4
        eq = quat.quat_exp(np.append(v / 2, 0.0))
        assert componentwise_rel(eq, ref.quat_exp(np.append(v / 2, 0.0))[0]) <= 4


# ---------------------------------------------------------------------------------------------------------------
# (2) angles from acos: 2 acos|p·q| is 0 or ~2e-8 for a 1e-9 rotation; quat_angle must be relatively accurate
# ---------------------------------------------------------------------------------------------------------------


def _angle_pairs(seed: int, n: int, angle: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """(p, q) with q a random orientation and p = ±q (x) exp(θ u / 2), built in mpmath, rounded to float64."""
    rng = np.random.default_rng(seed)
    out = []
    with mp.workdps(ref.DPS):
        a = mpf(angle)
        for i in range(n):
            q = cases.random_rotation(rng)
            r = ref.rot_quat(mp.sin(a / 2), mp.cos(a / 2), cases.random_unit(rng))
            p = ref.to_f64(ref.qmul(q, r))
            out.append((-p if i % 2 else p, ref.to_f64(q)))
    return out


@pytest.mark.parametrize("angle", ["1e-9", "1e-15"])
def test_small_angle_between_orientations(angle: str) -> None:
    naive_ok = 0
    for p, q in _angle_pairs(7, 20, angle):
        truth = ref.quat_angle(p, q)[0][0]
        got = float(quat.quat_angle(p, q))
        with mp.workdps(ref.DPS):
            rel = float(abs(mpf(got) - truth) / truth)
        assert rel <= 1e-15, f"quat_angle({p!r}, {q!r}) = {got!r}, truth {float(truth)!r}, rel. error {rel:.3g}"
        naive = 2 * math.acos(min(1.0, abs(float(p @ q))))
        naive_ok += abs(naive - float(truth)) <= 1e-3 * float(truth)
    assert naive_ok == 0  # the trap is real for every pair: acos cannot resolve these angles


def test_small_angle_from_identity() -> None:
    """The same with q = identity (the inputs are exactly unit in float64)."""
    rng = np.random.default_rng(11)
    for u in unit_axes(rng, 10):
        p = quat.quat_from_rotvec(1e-9 * u)
        truth = ref.quat_angle(p, np.array([0.0, 0.0, 0.0, 1.0]))[0][0]
        got = float(quat.quat_angle(p, [0.0, 0.0, 0.0, 1.0]))
        with mp.workdps(ref.DPS):
            assert float(abs(mpf(got) - truth) / truth) <= 1e-15


# ---------------------------------------------------------------------------------------------------------------
# (3) (1 − cos θ)/θ² series multiplied by an extra θ (amino): the value must be ~1/2, exact to a few ulp
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "x", [1e-3, float(np.nextafter(series.CUTOFFS["cosc2"], 0.0)), series.CUTOFFS["cosc2"]], ids=["1e-3", "cut-", "cut"]
)
def test_cosc2_series(x: float) -> None:
    with mp.workdps(80):
        xm = mpf(x)
        truth = 2 * (mp.sin(xm / 2) / xm) ** 2  # (1 − cos x)/x² without cancellation
        for got in (series.cosc2(x), float(series.series_ufunc("cosc2")(x))):
            assert float(abs(mpf(got) - truth) / truth) <= 4 * EPS, (x, got)


# ---------------------------------------------------------------------------------------------------------------
# (4) SE(3) exp using R in place of the left Jacobian for small angles (jaxlie, below θ = 1e-5): t = J_l(ω) v
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("angle", [1e-6, 9.9e-6, 1e-5])
def test_twist_translation_uses_left_jacobian(rng: np.random.Generator, angle: float) -> None:
    for w_dir, v in zip(unit_axes(rng, 5), rng.normal(size=(5, 3)), strict=True):
        xi = np.concatenate([angle * w_dir, v])
        s = dualquat.dualquat_from_twist(xi)
        with mp.workdps(ref.DPS):
            w0, w1, w2, v0, v1, v2 = ref.exact(xi)
            m = mp.matrix([[0, -w2, w1, v0], [w2, 0, -w0, v1], [-w1, w0, 0, v2], [0, 0, 0, 0]])
            jv = [mp.expm(m)[i, 3] for i in range(3)]  # J_l(ω) v, independently of any series
            got = ref.dq_translation(ref.exact(s))  # exact translation of the computed dual quaternion
            err = ref.norm([a - b for a, b in zip(got, jv, strict=True)]) / ref.norm(jv)
            rv = ref.rot_matrix(ref.exact(s[:4]))
            r_times_v = [mp.fsum(rv[i][j] * [v0, v1, v2][j] for j in range(3)) for i in range(3)]
            trap = ref.norm([a - b for a, b in zip(r_times_v, jv, strict=True)]) / ref.norm(jv)
        assert float(err) <= 4 * EPS, f"|ω| = {angle}: translation error {float(err) / EPS:.3g} ε"
        assert float(trap) > 1e4 * EPS  # R v is measurably wrong here: the test discriminates


# ---------------------------------------------------------------------------------------------------------------
# (5) DQ log at real part −1 (amino: NaN): finite, and exp(log S) == S
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("tnorm", [0.0, 1e-6, 1.0, 1e6])
def test_dualquat_log_at_minus_one(rng: np.random.Generator, tnorm: float) -> None:
    for t in unit_axes(rng, 4) * tnorm:
        # r = −1 (a 2π rotation): d = ½ t (x) r = [−t/2, 0]; also a non-unit dual part with d_w != 0
        for s in (np.concatenate([[0.0, 0.0, 0.0, -1.0], -t / 2, [0.0]]),
                  np.concatenate([[0.0, 0.0, 0.0, -2.5], -t, [0.25 * tnorm]])):
            lg = dualquat.dualquat_log(s)
            assert np.all(np.isfinite(lg)), lg
            err = ref.normwise_error(s, ref.dualquat_exp(lg))  # exact exp of the float64 log
            assert err <= 4, f"exp(log S) − S = {err:.3g} ε for S = {s!r}"
            back = dualquat.dualquat_exp(lg)
            assert ref.normwise_error(back, [ref.exact(s)]) <= 4


# ---------------------------------------------------------------------------------------------------------------
# (6) fractional powers computed in float32 (scipy RigidTransform.__pow__): S**0.5 must be float64-accurate
# ---------------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("tnorm", ["1e-6", "1", "1e6"])
@pytest.mark.parametrize("angle", ["1e-6", "0.5", "2", "pi-1e-6"])
def test_dualquat_sqrt_float64_accurate(angle: str, tnorm: str) -> None:
    rng = np.random.default_rng(zlib.crc32(f"{angle}/{tnorm}".encode()))
    with mp.workdps(ref.DPS):
        a = mp.pi - mpf(angle[3:]) if angle.startswith("pi-") else mpf(angle)
        for _ in range(4):
            q = ref.rot_quat(mp.sin(a / 2), mp.cos(a / 2), cases.random_unit(rng))
            t = [mpf(tnorm) * c for c in cases.random_unit(rng)]
            s = ref.to_f64(ref.dq_from_qt(q, t))
            got = dualquat.dualquat_pow(s, 0.5)
            truth = ref.dualquat_pow(s, 0.5)
            err = ref.normwise_error(got, truth)
            err_r = ref.normwise_error(got, truth, slice(0, 4))
            assert err <= 4 and err_r <= 4, f"S**0.5 error {err:.3g} ε (real part {err_r:.3g} ε) for {s!r}"
            # and it is a square root: (S**0.5)**2 == S to float64 accuracy
            assert ref.normwise_error(dualquat.dualquat_mul(got, got), [ref.exact(s)]) <= 8


# ---------------------------------------------------------------------------------------------------------------
# (7) canonicalisation that flips only the real part (spatialmath): the translation must be kept
# ---------------------------------------------------------------------------------------------------------------


def test_canonical_keeps_translation(rng: np.random.Generator) -> None:
    q = rng.normal(size=(200, 2, 4))
    t = rng.normal(size=(200, 2, 3)) * np.array([1e-6, 1.0, 1e6])[rng.integers(0, 3, size=(200, 2, 1))]
    s = dualquat.dualquat_from_qt(q, t)
    prod = dualquat.dualquat_mul(s[:, 0], s[:, 1])
    flipped = prod[:, 3] < 0
    assert 50 < flipped.sum() < 150  # both branches are exercised
    can = dualquat.dualquat_canonical(prod)
    assert np.all(can[:, 3] >= 0)
    assert np.array_equal(can[flipped], -prod[flipped]) and np.array_equal(can[~flipped], prod[~flipped])
    _, t_prod = dualquat.qt_from_dualquat(prod)
    _, t_can = dualquat.qt_from_dualquat(can)
    assert np.array_equal(t_can, t_prod)
    for k in np.flatnonzero(flipped)[:10]:  # and that translation is the composed one (mpmath)
        with mp.workdps(ref.DPS):
            truth = ref.dq_translation(ref.dq_mul(ref.exact(s[k, 0]), ref.exact(s[k, 1])))
        assert ref.normwise_error(t_can[k], [truth]) <= 8


def test_dualquat_log_at_minus_one_is_quiet() -> None:
    """The special point is a documented value, not an exception: no floating-point warning is raised either."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for s in ([0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, -2.5, 0.0, 0.0, 0.0, 0.0]):
            assert np.all(np.isfinite(dualquat.dualquat_log(s)))
            assert np.all(np.isfinite(dualquat.dualquat_pow(s, 0.5)))
