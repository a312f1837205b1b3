"""The offline output of target tracking (dualpose.pipelines.track_target.smooth_segments, ``run_track(...,
output=...)``): the RTS smoother over each filter segment, never across a re-lock; on the simulated target recording
scored against the simulator's truth (which the pipeline never sees), and on EuRoC's imu_april (skipped without the
data)."""

from __future__ import annotations

import numpy as np
import pytest

from dualpose.estimation.smoother import rts_smooth
from dualpose.evaluation.target_reference import errors_against
from dualpose.pipelines.fuse import FILTERS
from dualpose.pipelines.track_target import (
    EUROC_T_BS,
    extrinsic_from_matrix,
    prepare_track,
    run_relocking,
    run_track,
    smooth_segments,
)
from dualpose.types import Trajectory
from dualpose.types.calibration import CameraImuCalibration


def test_the_smoothed_output_beats_the_causal_filter_against_the_truth(simulated, simulated_setup):
    """Default output of the ESKF: the smoothed run, better than the filter on position and rotation against the
    simulator's truth; the causal filter comes along (``filtered``, ``metrics["causal_filter"]``) exactly as
    ``output="filter"`` gives it."""
    _, _, truth, ext = simulated
    sm = run_track(simulated_setup, "eskf", reference_extrinsics=ext)
    fi = run_track(simulated_setup, "eskf", reference_extrinsics=ext, output="filter")
    assert sm.metrics["output"] == "smoothed" and fi.metrics["output"] == "filter" and fi.filtered is None
    assert sm.metrics["smoother"]["segments"] == 1 and sm.metrics["smoother"]["segment_start_samples"] == [0]
    np.testing.assert_array_equal(sm.filtered.positions, fi.estimate.positions)
    np.testing.assert_array_equal(sm.filtered.quats, fi.estimate.quats)
    for key in ("position_rmse_m", "rotation_rmse_deg", "nees_position"):
        assert sm.metrics["causal_filter"][key] == fi.metrics[key], key
    es, ef = errors_against(truth, sm.estimate), errors_against(truth, fi.estimate)
    assert es.position_rmse_m < 0.8 * ef.position_rmse_m
    assert es.rotation_rmse_deg < 0.8 * ef.rotation_rmse_deg
    # the smoothed covariance is smaller than the filter's
    assert np.median(sm.position_sigma) < np.median(fi.position_sigma)
    assert np.median(sm.orientation_sigma_deg) < np.median(fi.orientation_sigma_deg)
    # the smoother's time is counted in the real-time factor (a relation between the recorded times, not a timing)
    m = sm.metrics
    assert m["smoother"]["wall_time_s"] > 0
    assert m["realtime_factor"] == pytest.approx(
        m["duration_s"] / (m["filter_wall_time_s"] + m["smoother"]["wall_time_s"]), rel=1e-12)


def test_a_forced_relock_splits_the_smoother_and_nothing_is_smoothed_across_it(simulated, simulated_setup):
    """A filter started 30 cm off loses the target and re-locks: two segments, the second starting at the re-lock
    sample.  Each segment ends on the filter's own state (the backward pass restarts there), the segment after the
    re-lock is what smoothing a filter started from the re-lock's state alone gives (bit for bit), and the smoothed
    run after the re-lock beats the filter against the truth."""
    _, _, truth, _ = simulated
    rec = simulated_setup.recording
    x = simulated_setup.start.x.copy()
    x[:3] += 0.3
    tr = run_relocking(rec, x, simulated_setup.start.P, "eskf")
    assert len(tr.relocks) >= 1
    sm = smooth_segments(rec, tr)
    starts = sm.segments.tolist()
    assert starts[0] == 0 and len(starts) == len(tr.relocks) + 1
    np.testing.assert_array_equal(rec.t[starts[1:]], tr.relocks)
    for k1 in starts[1:] + [len(rec.t)]:  # the last sample of each segment: smoother = filter
        np.testing.assert_allclose(sm.position[k1 - 1], tr.position[k1 - 1], rtol=0, atol=1e-12)
        np.testing.assert_allclose(sm.quat[k1 - 1], tr.quat[k1 - 1], rtol=0, atol=1e-12)
    # the last segment alone: a filter from the re-lock's start over the rest of the run, smoothed
    k0, x0, P0 = tr.segments[-1]
    f = rec.frames
    j0 = int(np.searchsorted(f.t + rec.time_offset, rec.t[k0], side="right"))
    o = f.offsets
    alone = rts_smooth(FILTERS["eskf"](rec, x0, P0).run(rec.t[k0:], rec.gyro[k0:], rec.accel[k0:], f.t[j0:],
                                                         o[j0:] - o[j0], f.pixels[o[j0] :], f.points[o[j0] :],
                                                         record_nodes=True))  # fmt: skip
    np.testing.assert_array_equal(sm.position[k0:], alone.position)
    np.testing.assert_array_equal(sm.quat[k0:], alone.quat)
    late = rec.t > rec.t[k0] + 0.5
    e_s = errors_against(truth, Trajectory(rec.t[late], sm.position[late], sm.quat[late]))
    e_f = errors_against(truth, Trajectory(rec.t[late], tr.position[late], tr.quat[late]))
    assert e_s.position_rmse_m < e_f.position_rmse_m and e_s.rotation_rmse_deg < e_f.rotation_rmse_deg


def test_outputs_the_filters_cannot_give_are_refused(simulated_setup):
    assert run_track(simulated_setup, "hol22").metrics["output"] == "filter"  # no smoother for Hol22: its default
    with pytest.raises(ValueError, match="needs filter 'eskf'"):
        run_track(simulated_setup, "hol22", output="smoothed")
    with pytest.raises(ValueError, match="output must be"):
        run_track(simulated_setup, "eskf", output="rts")
    tr = run_relocking(simulated_setup.recording, simulated_setup.start.x, simulated_setup.start.P, "hol22")
    with pytest.raises(ValueError, match="needs an ESKF run"):
        smooth_segments(simulated_setup.recording, tr)


# ------------------------------------------------------------------------------------------- EuRoC imu_april


def test_april_smoothed_output_with_outages(euroc_april):
    """imu_april with three 1 s outages, EuRoC's published cam0 extrinsic as the calibration (a fixture, no biases,
    no time shift): the smoothed output has more than one segment (the re-lock after the target loss near 56 s),
    beats the causal filter on both RMSEs and bridges every outage within 5 cm.  The numbers with the calibration
    ``calibrate camera-imu`` estimates are in docs/fusion.md."""
    q, p = extrinsic_from_matrix(EUROC_T_BS["cam0"])
    cal = CameraImuCalibration("cam0", q, p, 0.0, 0.35)
    outages = ((20.0, 21.0), (40.0, 41.0), (47.0, 48.0))
    r = run_track(prepare_track(euroc_april, cal, "cam0", outages), "eskf", outages=outages)
    m = r.metrics
    assert m["output"] == "smoothed" and m["smoother"]["segments"] == m["relocks"] + 1 >= 2
    assert m["position_rmse_m"] < m["causal_filter"]["position_rmse_m"]
    assert m["rotation_rmse_deg"] < m["causal_filter"]["rotation_rmse_deg"]
    for w in m["outages"]:
        assert w["frames"] >= 10 and w["position_max_m"] < 0.05, w
