"""Magnetometer self-calibration: recovery of injected hard/soft iron on synthetic recordings with an analytic
orientation, refusal when the data cannot support a fit (poor orientation coverage, no calibration error, a field
whose magnitude changes in time), and the effect on the AHRS."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.calibration.magnetometer import MagCalibration, estimate_mag_calibration, fit_mag_calibration
from dualpose.estimation.ahrs import estimate_orientation

RATE = 100.0
FIELD_E = np.array([0.0, 20.0, -44.0])  # µT, ENU
HARD = np.array([6.0, -4.0, 9.0])  # µT
# calibration matrix (symmetric, positive definite): calibrated = SOFT (m - HARD)
SOFT = np.array([[1.08, 0.04, -0.03], [0.04, 0.95, 0.05], [-0.03, 0.05, 1.02]])


def _quat(t: np.ndarray, amplitude: float = 1.0) -> np.ndarray:
    # tumbling motion covering many directions (rotation vector components up to ~1.4 rad, several frequencies)
    phi = amplitude * np.stack(
        [
            1.1 * np.sin(2 * np.pi * 0.17 * t + 0.3) + 0.9 * np.sin(2 * np.pi * 0.05 * t),
            0.8 * np.sin(2 * np.pi * 0.23 * t + 1.1) + 0.2 * np.sin(2 * np.pi * 0.41 * t),
            2.4 * np.sin(2 * np.pi * 0.07 * t + 2.0),
        ],
        axis=-1,
    )
    return dp.quat_from_rotvec(phi)


def _mag(q: np.ndarray, rng, hard=HARD, soft=SOFT, noise: float = 0.3) -> np.ndarray:
    body = dp.quat_rotate(dp.quat_conj(q), np.broadcast_to(FIELD_E, (q.shape[0], 3)))
    return body @ np.linalg.inv(soft).T + hard + rng.normal(0.0, noise, body.shape)


def _expected_matrix(soft: np.ndarray) -> np.ndarray:
    # the fit fixes trace A = 3 (the overall scale is irrelevant for directions)
    return 3.0 * soft / np.trace(soft)


def test_recovers_hard_and_soft_iron_with_good_coverage():
    rng = np.random.default_rng(1)
    t = np.arange(int(120 * RATE)) / RATE
    cal = estimate_mag_calibration(_mag(_quat(t), rng), noise_spread=0.3 / 48.0)
    assert cal.coverage[0] > 0.05
    assert cal.applied and cal.model == "symmetric"  # smaller models cannot explain a full soft iron
    np.testing.assert_allclose(cal.offset, HARD, atol=0.3)
    np.testing.assert_allclose(cal.matrix, _expected_matrix(SOFT), atol=0.01)
    assert cal.spread_after < 0.2 * cal.spread_before
    # the calibrated magnitude is constant up to the noise
    calibrated = cal.apply(_mag(_quat(t), np.random.default_rng(2)))
    norm = np.linalg.norm(calibrated, axis=1)
    assert np.std(norm) / np.mean(norm) < 0.015


def test_hard_iron_only_selects_the_smallest_model():
    rng = np.random.default_rng(3)
    t = np.arange(int(120 * RATE)) / RATE
    cal = estimate_mag_calibration(_mag(_quat(t), rng, soft=np.eye(3)), noise_spread=0.3 / 48.0)
    assert cal.applied and cal.model == "hard_iron"
    np.testing.assert_allclose(cal.offset, HARD, atol=0.3)
    np.testing.assert_array_equal(cal.matrix, np.eye(3))
    d = cal.as_dict()
    assert d["mag_calibration_applied"] is True and d["mag_calibration_model"] == "hard_iron"


def test_poor_coverage_is_refused():
    # rotation about the vertical only (the field directions sweep a cone): offset and field are not separable
    rng = np.random.default_rng(4)
    t = np.arange(int(120 * RATE)) / RATE
    q = dp.quat_from_rotvec(np.outer(1.5 * np.sin(2 * np.pi * 0.1 * t), [0.0, 0.0, 1.0]))
    cal = estimate_mag_calibration(_mag(q, rng))
    assert not cal.applied and cal.model == "none"
    assert "coverage" in cal.reason and cal.coverage[0] < 0.02
    m = _mag(q, rng)
    np.testing.assert_array_equal(cal.apply(m), m)
    # an unconditional fit on these data would be badly wrong (this is what the rule protects against)
    b, _, sb, _ = fit_mag_calibration(m, "hard_iron")
    assert np.linalg.norm(b - HARD) > 1.0 or sb > 1.0


def test_no_calibration_error_is_refused():
    rng = np.random.default_rng(5)
    t = np.arange(int(120 * RATE)) / RATE
    cal = estimate_mag_calibration(_mag(_quat(t), rng, hard=np.zeros(3), soft=np.eye(3)), noise_spread=0.3 / 48.0)
    assert not cal.applied and "spread" in cal.reason


def test_time_varying_field_magnitude_is_refused():
    # a calibrated sensor in a field whose magnitude drifts by ±4 % over time: no body-fixed model explains it
    rng = np.random.default_rng(6)
    t = np.arange(int(120 * RATE)) / RATE
    m = _mag(_quat(t), rng, hard=np.zeros(3), soft=np.eye(3))
    m *= (1.0 + 0.04 * np.sin(2 * np.pi * 0.013 * t))[:, None]
    cal = estimate_mag_calibration(m, noise_spread=0.3 / 48.0)
    assert not cal.applied


def test_bad_arguments():
    with pytest.raises(ValueError, match="mag must have shape"):
        estimate_mag_calibration(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="mag must be finite"):
        estimate_mag_calibration(np.full((200, 3), np.nan))
    with pytest.raises(ValueError, match="model"):
        fit_mag_calibration(np.ones((200, 3)), "ellipsoid")
    with pytest.raises(ValueError, match="noise_spread"):
        estimate_mag_calibration(np.ones((200, 3)), noise_spread=-1.0)
    with pytest.raises(ValueError, match="mag_calibration"):
        estimate_orientation(np.zeros((50, 3)), np.tile([0, 0, 9.81], (50, 1)), np.ones((50, 3)), RATE,
                             mag_calibration="on")
    assert not estimate_mag_calibration(np.ones((50, 3))).applied  # too few samples


def test_estimate_orientation_applies_the_calibration():
    # 2 s at rest, then tumbling for 120 s with hard + soft iron: the calibrated heading is far better
    rng = np.random.default_rng(7)
    t = np.arange(int(122 * RATE)) / RATE
    tm = np.maximum(t - 2.0, 0.0)
    moving = t >= 2.0
    q_true = _quat(tm)
    h = 1e-6
    dq = (_quat(tm + h) - _quat(tm - h)) / (2 * h)
    rate_body = 2.0 * dp.quat_mul(dp.quat_conj(q_true), dq)[:, :3]
    gyr = np.where(moving[:, None], rate_body, 0.0) + rng.normal(0.0, 0.005, (t.size, 3))
    acc = dp.quat_rotate(dp.quat_conj(q_true), np.broadcast_to([0.0, 0.0, 9.81], (t.size, 3)))
    acc = acc + rng.normal(0.0, 0.02, acc.shape)
    mag = _mag(q_true, rng)
    errs = {}
    for setting in ("auto", None):
        r = estimate_orientation(gyr, acc, mag, RATE, n_rest=int(2 * RATE), mag_time_offset=0.0,
                                 mag_calibration=setting)
        e = dp.quat_mul(r.quat, dp.quat_conj(q_true))
        errs[setting] = np.degrees(2 * np.arctan2(np.abs(e[moving, 2]), np.abs(e[moving, 3])))
        assert r.mag_calibration_applied is (setting == "auto")
    rmse = {k: float(np.sqrt(np.mean(v**2))) for k, v in errs.items()}
    assert rmse["auto"] < 1.0 and rmse["auto"] < 0.5 * rmse[None]
    r6 = estimate_orientation(gyr, acc, mag, RATE, n_rest=int(2 * RATE), use_mag=False)
    assert r6.mag_calibration is None and not r6.mag_calibration_applied


def test_given_calibration_is_applied_as_is():
    cal = MagCalibration(True, "hard_iron", np.array([1.0, 2.0, 3.0]), np.eye(3), "given", 0, np.zeros(3), 0.0, 0.0,
                         {"hard_iron": {"spread": 0.0}})
    np.testing.assert_allclose(cal.apply(np.array([[1.0, 2.0, 3.0]])), [[0.0, 0.0, 0.0]])
    assert cal.spread_after == 0.0
