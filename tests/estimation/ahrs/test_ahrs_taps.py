"""The accelerometer's impulse clipping (docs/broad.md, "Twelve trials", (b)): taps on a slowly rotating
IMU (seeded, :mod:`dualpose.sim.rest_breaks` with impulses added to the accelerometer) are cut before the low-pass,
so the inclination stays near that of the same recording without taps; without impulses nothing is clipped."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation
from dualpose.evaluation.orientation_errors import orientation_rmse
from dualpose.sim.rest_breaks import rest_break_recording


@pytest.fixture(scope="module")
def rec():
    return rest_break_recording(3, n_breaks=0, segment=60.0, drift=0.0)


def _tapped(rec, seed=0, every=2.0, peak=80.0, samples=2):
    """The accelerometer with a tap every ``every`` s: ``samples`` samples of ``peak`` m/s² in a random body
    direction (a finger's impact: milliseconds, several g)."""
    rng = np.random.default_rng(seed)
    acc = rec.acc.copy()
    for k in range(rec.n_rest + int(rec.rate), len(acc) - samples, int(every * rec.rate)):
        d = rng.normal(size=3)
        acc[k : k + samples] += peak * d / np.linalg.norm(d)
    return acc


def _inclination(rec, acc, **cfg):
    r = estimate_orientation(rec.gyr, acc, None, rec.rate, use_mag=False, n_rest=rec.n_rest, config=AhrsConfig(**cfg))
    return r, orientation_rmse(r.quat, rec.quat, rec.scored, fit_heading_offset=True).inclination_rmse_deg


def test_taps_are_clipped_and_the_inclination_stays_near_the_tap_free_one(rec):
    acc = _tapped(rec)
    _, clean = _inclination(rec, rec.acc)
    _, clipped = _inclination(rec, acc)
    _, raw = _inclination(rec, acc, acc_clip=0.0)
    assert raw > 2.0 * clean  # the taps through the low-pass tilt the estimate
    assert clipped < 0.5 * raw and clipped < 1.3 * clean


def test_without_impulses_nothing_is_clipped(rec):
    # smooth hand-like acceleration and white noise: the outputs are those without the clipping, bit for bit
    on, _ = _inclination(rec, rec.acc)
    off, _ = _inclination(rec, rec.acc, acc_clip=0.0)
    assert np.array_equal(on.quat, off.quat)


def test_a_sustained_acceleration_step_passes(rec):
    # a step of 5 m/s² (k = 5 times the RMS of the change would cut it at first) held for 10 s: after the running
    # RMS has grown (tens of ms) it passes, so the estimate sees the same mean specific force as without clipping
    acc = rec.acc.copy()
    k0 = rec.n_rest + int(20 * rec.rate)
    acc[k0 : k0 + int(10 * rec.rate), 0] += 5.0
    on, _ = _inclination(rec, acc)
    off, _ = _inclination(rec, acc, acc_clip=0.0)
    rel = dp.quat_mul(dp.quat_conj(off.quat), on.quat)
    angle = np.degrees(2.0 * np.arctan2(np.linalg.norm(rel[:, :3], axis=1), np.abs(rel[:, 3])))
    assert angle[-1] < 0.05 and angle[k0 + int(2 * rec.rate) :].max() < 0.2
