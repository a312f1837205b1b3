"""dualpose's AHRS on the real BROAD trials against BROAD's published Madgwick results (Laidig et al. 2021).

Madgwick's total RMSE at β = 0.12 is the published reference (BROAD ``example_code/out/results_madgwick``);
dualpose runs with its defaults (the same settings for every trial; strictly causal, with the online
magnetometer–gyroscope time offset estimated from the IMU data alone), 9D, scored exactly as BROAD scores (no
alignment).  Trial
06 (fast rotation) is the one trial where dualpose's 9D estimate does not beat Madgwick's published value (nor does
VQF's).  Diagnosed in docs/broad.md ("Trial 06: diagnosis", benchmarks/diag_broad_field.py): the field in the volume
~30 cm above the table where the IMU rests points 2.5-3.5 deg west of where it points at the table (a spatial
gradient, also seen in the translation trials 10 and 15), so following the magnetometer there costs ~4 deg of heading;
none of the principled rules tried (rate-dependent magnetometer noise, smaller/larger gyroscope rate noise, a
persistent-disturbance correlation time, gyroscope scale-factor states, heading-noise adaptation, a longer window)
passes both 06 and 01, which shares the table and the volume but whose gyroscope-only heading drifts 13 deg.  It is
kept as a strict expected failure so that the gap stays visible and an improvement is noticed.
"""

from __future__ import annotations

import numpy as np
import pytest

from dualpose.calibration.magnetometer import estimate_mag_calibration
from dualpose.calibration.sensor_time_offset import estimate_sensor_time_offset
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.evaluation.orientation_errors import orientation_rmse
from dualpose.io import load_broad
from realdata import data_dir

BROAD = data_dir("broad", full=True)
MADGWICK_012 = {
    "01_undisturbed_slow_rotation_A": 2.310,
    "06_undisturbed_fast_rotation_A": 2.307,
    "10_undisturbed_slow_translation_A": 3.569,
    "15_undisturbed_fast_translation_A": 12.304,
    "21_undisturbed_fast_combined": 7.158,
    "24_disturbed_tapping_A": 1.768,
    "28_disturbed_stationary_magnet_A": 8.329,
}
KNOWN_MISS = {"06_undisturbed_fast_rotation_A"}


def _trial(name: str):
    path = BROAD / f"{name}.mat"
    if not BROAD.is_dir():
        pytest.skip("BROAD data directory missing")
    return load_broad(path)


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.xfail(strict=True, reason="field heading in the motion volume ~3 deg off"))
        if n in KNOWN_MISS
        else n
        for n in MADGWICK_012
    ],
)
def test_9d_beats_published_madgwick(name):
    t = _trial(name)
    res = estimate_orientation(t.gyr, t.acc, t.mag, t.rate, use_mag=True, n_rest=t.static_start)
    score = orientation_rmse(res.quat, t.quat, t.movement)
    assert score.total_rmse_deg < MADGWICK_012[name]


@pytest.mark.parametrize("name", ["15_undisturbed_fast_translation_A", "28_disturbed_stationary_magnet_A"])
def test_6d_inclination_matches_9d(name):
    # the magnetometer only acts on heading: dropping it must leave the inclination (almost) unchanged
    t = _trial(name)
    r9 = estimate_orientation(t.gyr, t.acc, t.mag, t.rate, use_mag=True, n_rest=t.static_start)
    r6 = estimate_orientation(t.gyr, t.acc, None, t.rate, use_mag=False, n_rest=t.static_start)
    s9 = orientation_rmse(r9.quat, t.quat, t.movement)
    s6 = orientation_rmse(r6.quat, t.quat, t.movement, fit_heading_offset=True)
    assert s6.inclination_rmse_deg < 2.5
    assert abs(s6.inclination_rmse_deg - s9.inclination_rmse_deg) < 0.2


def test_mag_time_offset_is_a_sensor_property():
    # estimated per recording from gyro + mag only (no reference): if the lag is a property of the sensor, the seven
    # independent estimates agree (measured 10.8-11.6 ms); the accelerometer, whose "static field" assumption is
    # broken by linear acceleration, gives no clear minimum (cost ratio close to 1, docs/broad.md)
    estimates = []
    for name in MADGWICK_012:
        t = _trial(name)
        bias = np.median(t.gyr[: t.static_start], axis=0)
        est = estimate_sensor_time_offset(t.gyr, t.mag, t.rate, gyroscope_bias=bias)
        assert est.valid and est.cost_ratio < 0.95
        estimates.append(est.offset_ms)
        # the real-time filter's online (causal) estimate after the last sample agrees (measured: within 0.51 ms)
        online = estimate_orientation(t.gyr, t.acc, t.mag, t.rate, n_rest=t.static_start)
        assert abs(online.mag_time_offset_ms - est.offset_ms) < 1.0
    assert np.ptp(estimates) < 1.5
    assert 3.5 < np.median(estimates) < 30.0  # a lag of more than one sample (3.5 ms), inside the search range


@pytest.mark.parametrize("name", ["10_undisturbed_slow_translation_A", "15_undisturbed_fast_translation_A"])
def test_mag_calibration_refused_without_orientation_coverage(name):
    # translation trials hardly rotate: a hard/soft-iron fit is ill-conditioned there (an unconditional fit took
    # trial 10 from 0.73° to 11.6°), so the decision rule must refuse it on coverage alone
    t = _trial(name)
    cal = estimate_mag_calibration(t.mag)
    assert not cal.applied and "coverage" in cal.reason and cal.coverage[0] < 0.02
