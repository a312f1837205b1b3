"""Recording's value checks (IMU ranges, noise parameters, gravity) and its gap / gravity-convention checks."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dualpose.sim import recording_from_simulation, simulate_eight
from dualpose.types import ImuNoise, Recording
from dualpose.types.recording import RecordingWarning


@pytest.fixture(scope="module")
def rec() -> Recording:
    return recording_from_simulation(simulate_eight(0))


def _with(rec: Recording, **changes) -> Recording:
    return dataclasses.replace(rec, **changes)


def test_corrupt_imu_sample_is_refused(rec):
    accel = rec.accel.copy()
    accel[7, 1] = 1e300
    with pytest.raises(ValueError, match=r"accel: sample 7 .* 1e\+300"):
        _with(rec, accel=accel)


def test_huge_noise_density_is_refused(rec):
    with pytest.raises(ValueError, match="imu_noise.accelerometer_noise_density"):
        _with(rec, imu_noise=ImuNoise(accelerometer_noise_density=1e300))


def test_gravity_magnitude_is_checked(rec):
    with pytest.raises(ValueError, match="gravity: magnitude"):
        _with(rec, gravity=[0.0, 0.0, 0.0])


def test_gap_warning_names_the_times(rec):
    keep = (rec.t < 2.0) | (rec.t > 3.0)
    gappy = _with(rec, t=rec.t[keep], gyro=rec.gyro[keep], accel=rec.accel[keep], ground_truth=None)
    with pytest.warns(RecordingWarning, match=r"1 IMU gap\(s\).*1\.990-3\.010 s"):
        gaps = gappy.check_imu_gaps()
    assert len(gaps) == 1
    assert rec.imu_gaps() == []


def test_gravity_convention(rec):
    q_wb = rec.ground_truth.quats[0]
    assert rec.check_gravity(q_wb) < 1.0
    with pytest.raises(ValueError, match="points up"):
        _with(rec, gravity=np.array([0.0, 0.0, 9.81])).check_gravity(q_wb)
    with pytest.warns(RecordingWarning, match="deg from -gravity"):
        _with(rec, gravity=9.81 * np.array([0.0, np.sin(0.5), -np.cos(0.5)])).check_gravity(q_wb)
