"""The AHRS's rest detector and gyroscope-bias update (docs/broad.md, "Rest detector and bias update") on the seeded
slow-rotation recording with breaks of :mod:`dualpose.sim.rest_breaks`: the bias error at the end of a break against
the Kalman–Bucy posterior the quiet samples allow, no detection in slow rotation, detection within one window of a
break's start, and the stream equal to the batch estimator bit for bit across a save and restore inside a break."""

from __future__ import annotations

import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation
from dualpose.estimation.ahrs.smoother import smooth_orientation
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.evaluation.orientation_errors import orientation_rmse
from dualpose.io import load_broad
from dualpose.sim.rest_breaks import rest_break_recording

BROAD = Path(__file__).resolve().parents[3] / ".." / "shared" / "data" / "broad"
WINDOW_S = AhrsConfig().rest_window


@pytest.fixture(scope="module")
def rec():
    return rest_break_recording(4)


def _run(rec, use_mag, n=None, **cfg):
    n = len(rec.gyr) if n is None else n
    return estimate_orientation(rec.gyr[:n], rec.acc[:n], rec.mag[:n] if use_mag else None, rec.rate,
                                use_mag=use_mag, n_rest=rec.n_rest, config=AhrsConfig(**cfg))  # fmt: skip


@pytest.mark.parametrize("use_mag", [True, False])
def test_bias_after_each_break_reaches_the_noise_level_and_the_orientation_improves(rec, use_mag):
    # without the rest offset (rest_bias_sigma=0) a still break measures the bias to the white-noise level
    white, off = _run(rec, use_mag, rest_bias_sigma=0.0), _run(rec, use_mag, rest_window=0.0)
    on = _run(rec, use_mag)
    ends = rec.breaks[:, 1] - 1
    # Kalman–Bucy posterior of a random walk (density σ_w) seen through white noise (density σ_d) for T seconds
    sd, sw = rec.gyr_sigma / math.sqrt(rec.rate), 1.0e-4
    seconds = (rec.breaks[0, 1] - rec.breaks[0, 0]) / rec.rate
    sigma = math.sqrt(sw * sd / math.tanh(seconds * sw / sd))
    err_white = white.gyroscope_bias[ends] - rec.bias[ends]
    err_off = off.gyroscope_bias[ends] - rec.bias[ends]
    err_on = on.gyroscope_bias[ends] - rec.bias[ends]
    assert np.sqrt(np.mean(err_white**2)) < 1.5 * sigma
    assert np.sqrt(np.mean(err_off**2)) > 2.0 * sigma  # without the update the drift is not followed
    # the default (a break measures the bias to at best √(σ_KB² + rest_bias_sigma²)) still follows the drift
    assert np.sqrt(np.mean(err_on**2)) < 0.8 * np.sqrt(np.mean(err_off**2))
    s_on, s_white, s_off = (orientation_rmse(r.quat, rec.quat, rec.scored, fit_heading_offset=not use_mag)
                            for r in (on, white, off))  # fmt: skip
    assert s_white.total_rmse_deg < 0.7 * s_off.total_rmse_deg
    assert s_on.total_rmse_deg < 0.9 * s_off.total_rmse_deg
    assert on.rest_samples > 0 and off.rest_samples == 0 and on.rest_updates > 0


@pytest.mark.parametrize("use_mag", [True, False])
def test_breaks_that_creep_are_measured_with_the_rest_offset(use_mag):
    # breaks in which the object still turns at 0.05 °/s (2.5 rest_bias_sigma): a spell's mean rate is off by the
    # creep however long the break; with the spell-common offset in the bias measurement the bias after each break
    # is closer to the truth than when the break's mean rate is taken for the bias to its white-noise level
    creep = rest_break_recording(4, creep=math.radians(0.05), drift=0.0)
    on, white = _run(creep, use_mag), _run(creep, use_mag, rest_bias_sigma=0.0)
    ends = creep.breaks[:, 1] - 1
    e_on, e_white = (np.sqrt(np.mean((r.gyroscope_bias[ends] - creep.bias[ends]) ** 2)) for r in (on, white))
    assert e_on < 0.95 * e_white
    if not use_mag:  # 6D: the heading follows the bias alone
        s_on, s_white = (orientation_rmse(r.quat, creep.quat, creep.scored, fit_heading_offset=True).total_rmse_deg
                         for r in (on, white))  # fmt: skip
        assert s_on < 0.95 * s_white


def test_the_creep_is_a_rotation_of_the_truth_inside_the_breaks_only():
    still, creep = rest_break_recording(2), rest_break_recording(2, creep=math.radians(0.05))
    b0, b1 = creep.breaks[0]
    # the gyroscope (bias and noise removed) reads the creep's rate inside a break, nothing before the first one
    rate = np.degrees(np.linalg.norm(np.mean(creep.gyr[b0 + 10 : b1 - 10] - creep.bias[b0 + 10 : b1 - 10], axis=0)))
    assert abs(rate - 0.05) < 0.01
    assert np.array_equal(still.gyr[:b0], creep.gyr[:b0]) and np.array_equal(still.quat[:b0], creep.quat[:b0])


def test_slow_rotation_without_rest_never_triggers_the_detector():
    # one 120 s segment of slow rotation (up to ~17 °/s) that starts abruptly after the rest period
    slow = rest_break_recording(7, n_breaks=0, segment=120.0, ramp=1e-3)
    for use_mag in (True, False):
        assert _run(slow, use_mag).rest_samples == 0


def test_broad_movement_never_triggers_the_detector():
    if not BROAD.is_dir():
        pytest.skip("BROAD data directory missing")
    tr = load_broad(BROAD / "01_undisturbed_slow_rotation_A.mat")
    end = int(np.flatnonzero(tr.movement)[-1]) + 1
    r = estimate_orientation(tr.gyr[:end], tr.acc[:end], None, tr.rate, use_mag=False, n_rest=tr.static_start)
    assert r.rest_samples == 0


def test_a_break_is_detected_within_one_window(rec):
    n_win = int(round(WINDOW_S * rec.rate))
    ramp = 2.0 * rec.rate  # the rotation slows down over the 2 s before a break

    def flagged(n):
        return _run(rec, False, n).rest_samples

    for start, end in rec.breaks:
        before = flagged(start - int(ramp))
        lo, hi = start - int(ramp), start + n_win  # first sample flagged: by one window into the break at the latest
        assert flagged(hi) > before
        while hi - lo > 1:  # bisection on the causal count
            mid = (lo + hi) // 2
            lo, hi = (lo, mid) if flagged(mid) > before else (mid, hi)
        assert start - ramp < hi <= start + n_win
        assert flagged(end) - before >= end - start - n_win  # and it stays flagged to the break's end


def test_stream_equals_batch_across_a_save_inside_a_break(rec):
    t = np.arange(len(rec.gyr)) / rec.rate
    ref = _run(rec, True)
    k = int(rec.breaks[1, 0]) + 500
    s = AhrsStream(rec.rate, n_rest=rec.n_rest)
    q1, b1 = s.update_batch(t[:k], rec.gyr[:k], rec.acc[:k], rec.mag[:k])
    r = AhrsStream.from_state(pickle.loads(pickle.dumps(s.state_dict())))
    q2 = np.array([r.update_imu(t[j], rec.gyr[j], rec.acc[j], rec.mag[j]) for j in range(k, len(t))])
    assert np.array_equal(np.vstack([q1, q2]), ref.quat) and np.array_equal(b1, ref.gyroscope_bias[:k])
    assert r.rest_samples == ref.rest_samples


def test_smoother_with_the_rest_update_keeps_its_forward_pass_and_improves_on_it(rec):
    sm = smooth_orientation(rec.gyr, rec.acc, rec.mag, rec.rate, n_rest=rec.n_rest, mag_time_offset="online",
                            rest_update=True)  # fmt: skip
    fw = _run(rec, True)
    k = rec.n_rest - 1  # the batch estimator's own outputs inside the rest period are running means
    assert np.array_equal(sm.forward.quat[k:], fw.quat[k:]) and sm.forward.rest_samples == fw.rest_samples > 0
    s_sm = orientation_rmse(sm.quat, rec.quat, rec.scored).total_rmse_deg
    assert s_sm < orientation_rmse(fw.quat, rec.quat, rec.scored).total_rmse_deg
    off = smooth_orientation(rec.gyr, rec.acc, rec.mag, rec.rate, n_rest=rec.n_rest, mag_time_offset="online")
    assert off.forward.rest_samples == 0  # offline default: no rest update


def test_without_a_rest_period_the_class_noise_values_still_detect_the_breaks(rec):
    # n_rest=0: thresholds from the AhrsNoise class defaults (1.2e-4 rad/s/√Hz: 2.5 times below this gyroscope's
    # noise, inside the margin of 3); the initial 5 s of rest are seen by the detector too
    n_win = int(round(WINDOW_S * rec.rate))
    r = estimate_orientation(rec.gyr, rec.acc, None, rec.rate, use_mag=False, n_rest=0)
    quiet = int(np.sum(rec.breaks[:, 1] - rec.breaks[:, 0])) + rec.n_rest
    assert quiet - 4 * n_win <= r.rest_samples <= quiet + 4 * 2 * int(rec.rate)  # each stop's 2 s slow-down at most
