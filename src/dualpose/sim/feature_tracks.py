"""Feature-track mode of the simulator: an unknown scene seen as tracks (what :mod:`dualpose.estimation.msckf`
consumes), with the exact truth kept aside.

A simulated run (:func:`dualpose.sim.simulate`) supplies the motion, the IMU stream and the frame times; here every
landmark visible in a frame (more than ``min_depth`` in front of the camera, inside the image) is observed as the
normalised image coordinates ``(X/Z, Y/Z)`` plus zero-mean Gaussian noise of standard deviation ``feature_sigma``,
and keeps one track id while it stays visible (a landmark that leaves the image and comes back starts a new track).
The landmark positions are not handed to the estimator.
"""

from __future__ import annotations

import numpy as np

from dualpose.sim.camera_imu import SimulatedRun, camera_points, simulate
from dualpose.sim.motion import SmoothMotion
from dualpose.types.features import FeatureTracks, TrackRecording
from dualpose.types.imu import ImuNoise

__all__ = ["track_recording", "simulate_tracks"]


def track_recording(run: SimulatedRun, feature_sigma: float = 1e-3, seed: int = 0,
                    min_depth: float = 0.05) -> TrackRecording:  # fmt: skip
    """The :class:`~dualpose.types.TrackRecording` of ``run``: its IMU stream and every visible landmark of every
    frame as a feature track (module docstring); seeded noise.  ``TrackRecording.meta["landmark_ids"]`` (M,) keeps the
    landmark of each observation (truth, for tests).  ``feature_sigma = 0`` gives exact tracks (the recording then
    states σ = 1e-6 for a filter)."""
    rng = np.random.default_rng(seed)
    f = run.frames
    kin = run.motion.kinematics(f.t_true)
    cam = run.camera
    L = len(run.landmarks)
    visible_before = np.zeros(L, bool)
    track_of = np.zeros(L, dtype=np.int64)
    next_id = 0
    ids_all, uv_all, lm_all, offsets = [], [], [], [0]
    for k in range(len(f.t)):
        pc = camera_points(kin["quat"][k], kin["position"][k], run.q_bc, run.p_bc, run.landmarks)
        front = pc[:, 2] > min_depth
        px = np.full((L, 2), -1.0)
        px[front] = cam.project(pc[front])
        vis = front & (px[:, 0] >= 0) & (px[:, 0] < cam.width) & (px[:, 1] >= 0) & (px[:, 1] < cam.height)
        appear = np.flatnonzero(vis & ~visible_before)  # a new track (first sight, or back after leaving)
        track_of[appear] = next_id + np.arange(len(appear))
        next_id += len(appear)
        visible_before = vis
        idx = np.flatnonzero(vis)
        uv = pc[idx, :2] / pc[idx, 2:3] + rng.normal(0.0, feature_sigma, (len(idx), 2))
        ids_all.append(track_of[idx].copy())
        uv_all.append(uv)
        lm_all.append(idx)
        offsets.append(offsets[-1] + len(idx))
    tracks = FeatureTracks(f.t, np.asarray(offsets, np.int64), np.concatenate(ids_all), np.concatenate(uv_all))
    return TrackRecording(
        t=run.t, gyro=run.gyro, accel=run.accel, tracks=tracks, q_bc=run.q_bc, p_bc=run.p_bc,
        imu_noise=run.imu_noise, feature_sigma=max(feature_sigma, 1e-6), time_offset=run.time_offset,
        focal_length=float(cam.fx), meta={"landmark_ids": np.concatenate(lm_all)}, name="sim",
    )  # fmt: skip


def simulate_tracks(motion: SmoothMotion, seed: int = 0, imu_noise: ImuNoise | None = None,
                    feature_sigma: float = 1e-3, camera_rate: float = 20.0,
                    n_landmarks: int = 200) -> tuple[SimulatedRun, TrackRecording]:  # fmt: skip
    """Simulate ``motion`` (:func:`dualpose.sim.simulate` with ``n_landmarks`` unknown landmarks on two planes,
    frames at ``camera_rate``) and return the run (truth) with its feature-track recording."""
    run = simulate(motion, seed=seed, imu_noise=imu_noise, camera_rate=camera_rate, n_landmarks=n_landmarks)
    return run, track_recording(run, feature_sigma, seed)
