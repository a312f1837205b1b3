"""Monte-Carlo NEES consistency of the error-state filter, and Hol's 1° gravity-misalignment drift."""

from __future__ import annotations

import math

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.estimation import consistency, eskf
from dualpose.types import ImuNoise

N_RUNS = 25


def _start(run: sim.SimulatedRun, seed: int) -> eskf.ErrorStateEKF:
    """Initial state drawn from the filter's prior around the truth (biases start at 0, within the prior)."""
    return consistency.filter_from_prior(run, np.random.default_rng([seed, 7]))


def test_nees_over_25_runs_inside_95_band() -> None:
    """Average 15-dim NEES over 25 seeded eight-shaped runs lies in the two-sided 95% band [12.9, 17.2]."""
    traj = sim.eight_motion()
    total = 0.0
    for s in range(N_RUNS):
        run = sim.simulate(traj, seed=1000 + s)
        res = _start(run, s).run_recording(run)
        total = total + consistency.nees_against_truth(run.truth, res)
    avg = total / N_RUNS
    lo, hi = consistency.nees_band(15, N_RUNS)
    assert lo == pytest.approx(12.93, abs=0.01) and hi == pytest.approx(17.22, abs=0.01)
    assert lo < avg.mean() < hi
    assert np.mean((avg >= lo) & (avg <= hi)) > 0.85


def test_gravity_misalignment_drift_matches_hol() -> None:
    """1° misalignment: 9.81 sin 1° = 0.171 m/s² of false acceleration, ½ a t² = 8.6 cm after 1 s (Hol: 8.5 cm)."""
    run = sim.simulate(
        sim.eight_motion(), seed=0, imu_noise=ImuNoise().scaled(0.0), gravity_misalignment_deg=1.0
    )
    tr = run.truth
    f = eskf.ErrorStateEKF.for_run(run, tr["position"][0], tr["velocity"][0], tr["quat"][0], np.eye(15) * 1e-12)
    empty = np.zeros(1, np.int64)
    res = f.run(run.t, run.gyro, run.accel, np.zeros(0), empty, np.zeros((0, 2)), np.zeros((0, 3)))
    k = np.searchsorted(run.t, 1.0)
    drift = np.linalg.norm(res.position[k] - tr["position"][k])
    expected = 0.5 * 9.81 * math.sin(math.radians(1.0)) * 1.0**2
    assert drift == pytest.approx(expected, rel=0.01)
    assert expected == pytest.approx(0.0856, abs=5e-4)


def test_filter_with_misaligned_gravity_stays_bounded() -> None:
    """With vision the filter absorbs most of a 1° misalignment (into the accelerometer bias), at a small cost."""
    errs = {}
    for deg in (0.0, 1.0):
        run = sim.simulate_eight(3, gravity_misalignment_deg=deg)
        res = _start(run, 3).run_recording(run)
        m = (run.t >= 1.0) & (run.t <= 6.4)
        errs[deg] = np.sqrt(np.mean(np.sum((res.position - run.truth["position"]) ** 2, axis=1)[m]))
        ori = np.degrees(dp.quat_angle(res.quat, run.truth["quat"]))
    assert errs[1.0] < 0.02
    assert errs[1.0] > errs[0.0]
    assert ori.max() < 2.0
