"""Tracking against a calibration target (dualpose.pipelines.track_target): on a simulated recording with lens
distortion (scored against the simulator's truth, which the pipeline never sees), and on EuRoC's imu_april (scored
against cam1's per-frame PnP; skipped without the data)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from _target_sim import CAMERA, stream_lines

import dualpose as dp
from dualpose.estimation.initialization import align_with_camera_poses
from dualpose.evaluation.target_reference import errors_against
from dualpose.io.target.recording import read_target_recording
from dualpose.pipelines.track_target import (
    EUROC_T_BS,
    TrackStream,
    extrinsic_from_matrix,
    ideal_pixel_sigma,
    imu_only,
    prepare_track,
    run_relocking,
    run_track,
    stream_track_lines,
    track_imu_noise,
)
from dualpose.types import ImuNoise, RadTanCamera, Trajectory
from dualpose.types.calibration import CameraImuCalibration


def _angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    return math.degrees(math.atan2(float(np.linalg.norm(np.cross(a, b))), float(a @ b)))


def test_startup_estimates_gravity_and_biases_of_the_simulation(simulated, simulated_setup):
    """The simulated world has gravity along −z; the start-up (camera poses + IMU, no truth) finds it to 3σ, and the
    gyro bias of the simulated IMU to 2 mrad/s."""
    src, cal, truth, _ = simulated
    st = simulated_setup.start
    g = st.alignment.gravity
    assert np.linalg.norm(g) == pytest.approx(src.rig.gravity_magnitude, rel=1e-12)
    assert _angle_deg(g, np.array([0.0, 0.0, -1.0])) < 3 * st.alignment.gravity_sigma_deg
    assert st.gyro_bias_from == "start-up" and st.accel_bias_from == "start-up"
    summary = st.summary(cal)
    assert summary["gravity_angle_to_calibration_deg"] is None  # the calibration states no gravity


def test_fused_track_on_the_simulation_beats_per_frame_pnp(simulated, simulated_setup):
    """ESKF and Hol22: against the simulator's truth under 3 mm / 0.15°; against the reference camera (cam1's PnP),
    better than cam0's own per-frame PnP on both position and rotation."""
    _, _, truth, ext = simulated
    for name in ("eskf", "hol22"):
        r = run_track(simulated_setup, name, reference_extrinsics=ext)
        m = r.metrics
        e = errors_against(truth, r.estimate)
        assert e.position_rmse_m < 3e-3 and e.rotation_rmse_deg < 0.15, name
        assert m["position_rmse_m"] < m["camera_pnp"]["position_rmse_m"], name
        assert m["rotation_rmse_deg"] < m["camera_pnp"]["rotation_rmse_deg"], name
        assert m["relocks"] == 0 and m["nis_fraction_inside"] > 0.9, name


def test_outage_is_bridged_and_the_filter_relocks_after_a_long_one(simulated):
    """A 1 s camera outage is bridged by the IMU (error inside < 2 cm); the rejection-driven re-lock brings a filter
    that has lost the target back onto it."""
    src, cal, truth, ext = simulated
    setup = prepare_track(src, cal, "cam0", outages=[(3.0, 4.0)])
    r = run_track(setup, "eskf", outages=[(3.0, 4.0)], reference_extrinsics=ext)
    w = r.metrics["outages"][0]
    assert w["frames"] > 10 and w["position_max_m"] < 0.02
    # a filter started 30 cm off rejects the frames and re-locks on one of them
    x = setup.start.x.copy()
    x[:3] += 0.3
    tr = run_relocking(setup.recording, x, setup.start.P, "eskf")
    assert len(tr.relocks) >= 1 and tr.relocks[0] - setup.recording.t[0] < 0.2
    late = tr.t > tr.relocks[0] + 0.5
    est = Trajectory(tr.t[late], tr.position[late], tr.quat[late])
    err = errors_against(truth, est)
    assert err.position_rmse_m < 5e-3


def test_batch_and_stream_give_the_same_poses_bit_for_bit_on_the_simulation(simulated, simulated_setup):
    src, cal, _, _ = simulated
    for name in ("eskf", "hol22"):
        tr = run_relocking(simulated_setup.recording, simulated_setup.start.x, simulated_setup.start.P, name)
        lines = stream_lines(src, cal)
        out = list(stream_track_lines(lines, TrackStream(src.rig, "cam0", cal, name)))
        got = np.array([[float(v) for v in line.split(",")] for line in out])
        np.testing.assert_array_equal(got, np.column_stack([tr.t, tr.position, tr.quat]))


#: an IMU axis model of the size EuRoC's calibration finds (docs/euroc.md): a few per mille
AXES = {"gyro_axes_matrix": np.eye(3) + 1e-3 * np.array([[2.8, -0.3, 2.3], [-0.3, 2.4, 0.8], [2.3, 0.8, -2.0]]),
        "accel_axes_matrix": np.eye(3) + 1e-3 * np.array([[0.4, -1.9, -0.3], [3.4, 0.6, 1.2], [0.5, -0.9, -1.3]])}


def test_axis_models_and_scale_sigmas_keep_batch_and_stream_bit_identical(simulated):
    """A calibration with IMU axis matrices (applied to every sample before the filter) and the ESKF's scale-factor
    noise: the stream still gives the batch's poses bit for bit, and the samples the filter sees are M⁻¹ times the
    recorded ones."""
    src, cal, _, _ = simulated
    cal_ax = dataclasses.replace(cal, **AXES)
    setup = prepare_track(src, cal_ax, "cam0", scale_sigmas="mems")
    k0 = setup.start.imu_index
    np.testing.assert_allclose(setup.recording.gyro @ AXES["gyro_axes_matrix"].T, src.imu.gyro[k0:], atol=1e-12)
    np.testing.assert_allclose(setup.recording.accel @ AXES["accel_axes_matrix"].T, src.imu.accel[k0:], atol=1e-12)
    assert setup.recording.imu_noise.gyroscope_scale_sigma == 0.005
    for name in ("eskf", "hol22"):
        tr = run_relocking(setup.recording, setup.start.x, setup.start.P, name)
        out = list(stream_track_lines(stream_lines(src, cal_ax), TrackStream(src.rig, "cam0", cal_ax, name, "mems")))
        got = np.array([[float(v) for v in line.split(",")] for line in out])
        np.testing.assert_array_equal(got, np.column_stack([tr.t, tr.position, tr.quat]))


def test_ideal_pixel_sigma_is_one_for_a_pinhole_and_grows_with_barrel_distortion():
    pin = RadTanCamera(fx=300.0, fy=300.0, cx=160.0, cy=120.0, k1=0.0, k2=0.0, p1=0.0, p2=0.0, width=320, height=240)
    assert ideal_pixel_sigma(pin, 0.5) == pytest.approx(0.5, rel=1e-12)
    assert 1.05 * 0.5 < ideal_pixel_sigma(CAMERA, 0.5) < 2 * 0.5


def test_alignment_recovers_gravity_velocity_and_biases_from_exact_poses():
    """Noise-free IMU and exact poses of the simulated eight in a tilted scene: gravity direction to 1e-3 deg,
    velocities to 1 mm/s, gyro and accelerometer biases to 1e-4."""
    from dualpose import sim

    run = sim.simulate_eight(3, imu_noise=ImuNoise().scaled(0.0))
    bg, ba = np.array([0.01, -0.02, 0.005]), np.array([0.05, -0.03, 0.08])
    tf = np.arange(0.2, 6.0, 0.05)
    kin = run.motion.kinematics(tf)
    tilt = dp.quat_from_rotvec([0.3, -0.2, 1.0])  # scene frame = world rotated: gravity no longer along an axis
    q = dp.quat_mul(dp.quat_conj(tilt), kin["quat"])
    p = dp.quat_rotate(dp.quat_conj(tilt), kin["position"])
    al = align_with_camera_poses(run.t, run.gyro + bg, run.accel + ba, tf, p, q, 9.81, 1e-4, 1e-5, 1e-4)
    g_true = dp.quat_rotate(dp.quat_conj(tilt), run.gravity)
    assert _angle_deg(al.gravity, g_true) < 1e-2
    np.testing.assert_allclose(al.gyro_bias, bg, atol=1e-4)
    np.testing.assert_allclose(al.accel_bias, ba, atol=2e-3)
    v_true = dp.quat_rotate(dp.quat_conj(tilt), kin["velocity"])
    np.testing.assert_allclose(al.velocity, v_true, atol=5e-3)


# ------------------------------------------------------------------------------------------- EuRoC imu_april


@pytest.fixture(scope="module")
def april(euroc_april):
    return read_target_recording(euroc_april)


@pytest.fixture(scope="module")
def published_calibration():
    """Test fixture: EuRoC's published Kalibr extrinsic of cam0 (Burri et al. 2016), no biases, no time shift,
    reprojection RMS 0.35 px -- built here, not an estimate of this code."""
    q, p = extrinsic_from_matrix(EUROC_T_BS["cam0"])
    return CameraImuCalibration("cam0", q, p, 0.0, 0.35)


OUTAGES = ((20.0, 21.0), (40.0, 41.0), (47.0, 48.0))


@pytest.fixture(scope="module")
def april_run(april, published_calibration):
    setup = prepare_track(april, published_calibration, "cam0", OUTAGES)
    return setup, run_track(setup, "eskf", outages=OUTAGES)


def test_april_tracks_the_whole_recording_with_reference_scoring(april_run):
    """The 72 s hand-held recording with three 1 s outages (one at 2.5 rad/s) and the 1.2 s target loss near 56 s:
    the ESKF stays on the target (re-locks after the loss), bridges each outage within 5 cm, and is scored against
    cam1's PnP (no alignment).  Measured with the defaults (smoothed output, MEMS scale-factor noise): 6.2 mm /
    0.303 deg, the causal filter 8.4 mm / 0.323 deg, against camera-only PnP's 5.8 mm / 0.300 deg -- the bound here
    is the filter's measurement with margin, not the issue's target (docs/fusion.md for that)."""
    setup, r = april_run
    m = r.metrics
    assert m["reference"]["camera"] == "cam1" and m["reference"]["frames_scored"] > 1300
    assert m["camera_pnp"]["position_rmse_m"] < 6.5e-3 and m["camera_pnp"]["rotation_rmse_deg"] < 0.33
    assert m["position_rmse_m"] < 0.012 and m["rotation_rmse_deg"] < 0.45
    for w in m["outages"]:
        assert w["frames"] >= 10 and w["position_max_m"] < 0.05, w
    assert any(55.0 < t < 60.0 for t in m["relock_times_s"])  # after the 1.2 s loss of the target near 56 s
    assert 0.88 < m["nis_fraction_inside"] < 0.99
    g = np.array(m["startup"]["gravity_target"])
    assert np.linalg.norm(g) == pytest.approx(9.81007, rel=1e-9) and m["startup"]["gravity_sigma_deg"] < 0.3


def test_april_imu_only_drifts_away(april_run):
    setup, r = april_run
    io = imu_only(setup, (1.0, 5.0))
    assert io["5s"]["position_rmse_m"] > 10 * r.metrics["position_rmse_m"]


def test_april_batch_and_stream_agree_bit_for_bit_on_a_cut(april, published_calibration):
    """The first 11 s (10 s start-up window + 1 s) as lines with the measured pixels: the stream's poses are the
    batch run's to the last bit."""
    t_end = float(april.imu.stamps[0]) + 11.0
    imu = april.imu
    keep = imu.stamps < t_end
    cut_imu = type(imu)(imu.stamps_ns[keep], imu.stamps[keep], imu.gyro[keep], imu.accel[keep], imu.name)
    det = april.detections["cam0"]
    cut = dataclasses.replace(april, imu=cut_imu, detections={"cam0": det.select(det.t < t_end)})
    setup = prepare_track(cut, published_calibration, "cam0")
    tr = run_relocking(setup.recording, setup.start.x, setup.start.P, "eskf")
    out = list(stream_track_lines(stream_lines(cut, published_calibration), TrackStream(april.rig, "cam0",
                                                                                   published_calibration)))  # fmt: skip
    got = np.array([[float(v) for v in line.split(",")] for line in out])
    np.testing.assert_array_equal(got, np.column_stack([tr.t, tr.position, tr.quat]))


@pytest.mark.parametrize("kind", ["imu", "cam"])
def test_stream_refuses_lines_out_of_time_order_in_the_startup_window(simulated, kind):
    src, cal, _, _ = simulated
    lines = [line for line in stream_lines(src, cal, t_end=3.0) if line.strip()]
    idx = [i for i, line in enumerate(lines) if line.startswith(kind)]
    a, b = idx[20], idx[21]  # early: still inside the start-up window
    lines[a], lines[b] = lines[b], lines[a]
    with pytest.raises(ValueError, match=rf"stdin line {b + 1}: .*increase strictly"):
        list(stream_track_lines(lines, TrackStream(src.rig, "cam0", cal)))


def test_outage_scores_of_a_window_without_frames_are_none_not_nan(simulated, simulated_setup):
    import json

    src, cal, _, ext = simulated
    late = (1e4, 1e4 + 1.0)  # after the end of the recording: no reference frame inside
    r = run_track(simulated_setup, "eskf", outages=[late], reference_extrinsics=ext)
    w = r.metrics["outages"][0]
    assert w["frames"] == 0 and w["position_rmse_m"] is None and w["rotation_rmse_deg"] is None
    json.dumps(r.metrics, allow_nan=False)


def test_an_outage_window_without_frames_is_refused(simulated):
    src, cal, _, _ = simulated
    with pytest.raises(ValueError, match=r"outage 10000:10001 s holds no frame"):
        prepare_track(src, cal, "cam0", outages=[(3.0, 4.0), (1e4, 1e4 + 1.0)])


@pytest.mark.parametrize("bad", ["ab", "xyz", "MEMS", (0.1, float("nan")), (-0.1, 0.0)])
def test_scale_sigmas_other_than_two_numbers_or_mems_are_refused_by_name(simulated, bad):
    src, _, _, _ = simulated
    with pytest.raises(ValueError, match=r"scale_sigmas must be two finite numbers >= 0 \(or 'mems'\)"):
        track_imu_noise(src.rig, bad)


def test_a_rig_without_imu_noise_is_refused_naming_the_sensor_file(simulated):
    src, _, _, _ = simulated
    with pytest.raises(ValueError, match=r"no IMU noise densities \(imu0\)"):
        track_imu_noise(dataclasses.replace(src.rig, imu_noise=None), "mems")
