"""``run_fuse(..., smooth=True)``: smoother metrics next to the filter's, consistent with the smoothed arrays and
with :func:`dualpose.estimation.smoother.rts_smooth` called directly; ``smooth`` needs the error-state filter."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.estimation import eskf, initialization, smoother
from dualpose.pipelines.fuse import run_fuse

KEYS = ("ate_rmse_m", "orientation_rmse_deg", "rpe_rmse_m", "rpe_rotation_rmse_deg", "position_rmse_unaligned_m",
        "orientation_rmse_unaligned_deg", "smoother_wall_time_s")  # fmt: skip


@pytest.fixture(scope="module")
def smoothed_job():
    return run_fuse("sim", "eskf", seed=1, smooth=True)


def test_smoothed_metrics_beat_the_filter(smoothed_job):
    m = smoothed_job.metrics
    s = m["smoothed"]
    assert set(KEYS) <= set(s)
    for key in ("ate_rmse_m", "orientation_rmse_deg", "position_rmse_unaligned_m", "orientation_rmse_unaligned_deg"):
        assert s[key] < 0.8 * m[key], key
    assert s["smoother_wall_time_s"] > 0


def test_smoothed_arrays_match_the_metrics_and_the_library(smoothed_job):
    res = smoothed_job
    np.testing.assert_array_equal(res.smoothed.stamps, res.truth.stamps)
    np.testing.assert_allclose(res.smoothed_position_error, res.smoothed.positions - res.truth.positions, atol=1e-15)
    rmse = np.sqrt(np.mean(np.sum(res.smoothed_position_error**2, axis=1)))
    assert res.metrics["smoothed"]["position_rmse_unaligned_m"] == pytest.approx(rmse, rel=1e-12)
    assert res.metrics["smoothed"]["ate_rmse_m"] <= rmse + 1e-12
    ang = np.degrees(dp.quat_angle(res.smoothed.quats, res.truth.quats))
    np.testing.assert_allclose(res.smoothed_orientation_error_deg, ang, atol=1e-12)
    # the same start and filter, smoothed through the library directly
    run = sim.simulate_eight(1)
    x, P0 = initialization.initial_state_from_run(run)
    f = eskf.ErrorStateEKF.from_state(run, x, P0)
    sm = smoother.rts_smooth(f.run_recording(run, record_nodes=True))
    np.testing.assert_array_equal(sm.position, res.smoothed.positions)
    # the filter's own metrics do not change with smooth=True
    plain = run_fuse("sim", "eskf", seed=1)
    for key in ("ate_rmse_m", "orientation_rmse_deg", "rpe_rmse_m", "nis_fraction_inside"):
        assert plain.metrics[key] == res.metrics[key]
    assert plain.smoothed is None and "smoothed" not in plain.metrics


def test_smooth_needs_the_error_state_filter():
    with pytest.raises(ValueError, match="smooth=True .* needs filter 'eskf'.*'hol22'"):
        run_fuse(filter="hol22", smooth=True)
