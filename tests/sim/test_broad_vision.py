"""Pseudo-vision on a real BROAD trial (docs/broad-pose.md): frames through the optical reference, the reference
on the IMU clock, noise from the static start, and the recording the fusion pipeline takes."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose import sim
from dualpose.sim import broad_vision as bv
from dualpose.types import PinholeCamera
from realdata import data_dir

BROAD = data_dir("broad")
TRIAL = BROAD / "06_undisturbed_fast_rotation_A.mat"


def test_pseudo_vision_frames(trial):
    landmarks = bv.landmark_shell(np.random.default_rng(1), np.nanmean(trial.pos, axis=0), n=800)
    r = np.linalg.norm(landmarks - np.nanmean(trial.pos, axis=0), axis=1)
    assert r.min() >= 2.0 and r.max() <= 5.0
    frames = bv.pseudo_vision(trial, landmarks, np.random.default_rng(2), pixel_sigma=0.0, dropouts=((60.0, 62.0),))
    t = trial.time
    # no frame where the reference is NaN at a neighbouring sample, none inside the dropout
    ok = np.isfinite(trial.quat).all(axis=1) & np.isfinite(trial.pos).all(axis=1)
    k = np.searchsorted(t, frames.t, side="right")
    assert ok[k - 1].all() and ok[k].all()
    assert not np.any((frames.t >= 60.0) & (frames.t < 62.0))
    assert len(frames) > 0.95 * t[-1] * bv.CAMERA_RATE - 2.0 * bv.CAMERA_RATE  # only the NaN gaps and the dropout
    assert np.all(frames.counts == bv.PER_FRAME)  # the shell is seen in every direction
    # without noise the pixels are the projections through the interpolated reference pose
    cam = PinholeCamera()
    q_bc, p_bc = sim.default_extrinsic()
    for j in (0, len(frames) // 2, len(frames) - 1):
        i = k[j]
        w = (frames.t[j] - t[i - 1]) / (t[i] - t[i - 1])
        p = (1 - w) * trial.pos[i - 1] + w * trial.pos[i]
        q = dp.quat_slerp(trial.quat[i - 1], trial.quat[i], w)
        pix, pts = frames.frame(j)
        np.testing.assert_allclose(pix, cam.project(sim.camera_points(q, p, q_bc, p_bc, pts)), atol=1e-9)


def test_reference_on_the_imu_clock(trial):
    exact = bv.reference_on_imu_clock(trial, 0.0)
    at = np.searchsorted(trial.time, exact.stamps)
    np.testing.assert_allclose(exact.positions, trial.pos[at], atol=1e-12)
    np.testing.assert_allclose(dp.quat_angle(exact.quats, trial.quat[at]), 0.0, atol=1e-7)
    shifted = bv.reference_on_imu_clock(trial, 4.1e-3)
    ok = np.isfinite(trial.pos).all(axis=1)
    for axis in range(3):
        ref = np.interp(shifted.stamps - 4.1e-3, trial.time[ok], trial.pos[ok, axis])
        np.testing.assert_allclose(shifted.positions[:, axis], ref, atol=1e-12)


def test_noise_from_rest_and_dropout_windows():
    rng = np.random.default_rng(7)
    rate = 250.0
    gyr = rng.normal(0.0, 0.004, (20000, 3)) + np.linspace(0, 0.01, 20000)[:, None]  # slow drift is ignored
    acc = rng.normal(0.0, 0.05, (20000, 3)) + [0.0, 0.0, 9.81]
    n = bv.imu_noise_from_rest(gyr, acc, rate, inflation=1.0)
    assert n.gyroscope_noise_density == pytest.approx(0.004 / np.sqrt(rate), rel=0.02)
    assert n.accelerometer_noise_density == pytest.approx(0.05 / np.sqrt(rate), rel=0.02)
    assert n.update_rate == rate and n.gyroscope_random_walk == bv.GYROSCOPE_RANDOM_WALK
    assert bv.imu_noise_from_rest(gyr, acc, rate).gyroscope_noise_density == pytest.approx(
        bv.NOISE_INFLATION * n.gyroscope_noise_density
    )
    assert bv.dropout_windows(10.0, 45.0) == ((14.0, 16.0), (24.0, 26.0), (34.0, 36.0))
    with pytest.raises(ValueError, match="length < period"):
        bv.dropout_windows(0.0, 10.0, 3.0, 2.0)


def test_recording_starts_with_the_first_frame(trial):
    rec = bv.recording_from_broad(trial)
    i0 = rec.info["first_sample"]
    assert rec.t[0] == trial.time[i0] <= rec.frames.t[0] + rec.time_offset < trial.time[i0 + 1]
    assert rec.rest_seconds == pytest.approx((trial.static_start - i0) / trial.rate)
    np.testing.assert_array_equal(rec.gravity, [0.0, 0.0, -bv.BERLIN_GRAVITY])
    assert rec.ground_truth.stamps[0] >= rec.t[0]
    with pytest.raises(TypeError, match="BroadTrial"):
        bv.recording_from_broad("not a trial")
