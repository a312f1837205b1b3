"""Simulated calibration recordings (for tests, benchmarks and ``dualpose calibrate``): static poses in front of
the two-plane scene of :mod:`dualpose.sim`.

The scene's floor plane (z = 0) plays the calibration pattern lying level; with ``gravity_misalignment_deg = 0``
its "up" is the world z axis.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import dualpose as dp
from dualpose.sim import camera_imu, motion
from dualpose.types import ImuNoise

__all__ = [
    "static_motion",
    "calibration_camera_poses",
    "simulate_static_poses",
    "random_extrinsic",
]


def static_motion(q_wb: np.ndarray, p_wb: np.ndarray, duration: float) -> motion.SmoothMotion:
    """A :class:`~dualpose.motion.SmoothMotion` at rest at body pose ``(q_wb (4,) xyzw, p_wb (3,) m)``."""
    z = np.zeros((1, 3))
    return motion.SmoothMotion(
        p0=np.asarray(p_wb, float), q0=np.asarray(q_wb, float), pos_amp=z, pos_harm=np.ones(1), pos_phase=z,
        rot_amp=z, rot_harm=np.ones(1), rot_phase=z, phase_kind="linear", omega0=0.0, duration=float(duration),
    )  # fmt: skip


def calibration_camera_poses(n_poses: int, seed: int, max_roll_deg: float = 40.0) -> tuple[np.ndarray, np.ndarray]:
    """``n_poses`` camera poses ``(q_wc (n, 4), c_w (n, 3))`` looking at the scene from different heights and
    sides, rolled about the optical axis by up to ``max_roll_deg`` (so the gravity direction differs between poses
    about two axes), seeded."""
    rng = np.random.default_rng(seed)
    q = np.empty((n_poses, 4))
    c = np.empty((n_poses, 3))
    for k in range(n_poses):  # a handful of poses: the per-pose construction is not a hot path
        eye = motion.CAMERA_HOME + rng.uniform([-0.5, -0.35, -0.45], [0.5, 0.15, 0.45])
        target = motion.SCENE_TARGET + rng.uniform([-0.2, -0.05, -0.15], [0.2, 0.2, 0.15])
        roll = math.radians(rng.uniform(-max_roll_deg, max_roll_deg))
        q[k] = dp.quat_mul(motion.look_at_quat(eye, target), dp.quat_from_rotvec([0.0, 0.0, roll]))
        c[k] = eye
    return q, c


def random_extrinsic(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random camera→body rotation near a forward-looking mount (±25° about each axis) and lever arm (±5 cm)."""
    rng = np.random.default_rng(seed)
    q_nominal, _ = motion.default_extrinsic()
    q = dp.quat_mul(q_nominal, dp.quat_from_rotvec(rng.uniform(-0.45, 0.45, 3)))
    return q, rng.uniform(-0.05, 0.05, 3)


def simulate_static_poses(
    n_poses: int,
    seed: int,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
    duration: float = 1.0,
    max_roll_deg: float = 40.0,
    pose_seed: int | None = None,
    **simulate_kwargs,
) -> list[camera_imu.SimulatedRun]:
    """One :class:`~dualpose.camera_imu.SimulatedRun` at rest per pose of :func:`calibration_camera_poses`.

    Each lasts ``duration`` s.  Poses are seeded by ``pose_seed`` (default ``seed``), sensor noise by
    ``seed * 1000 + k``: a fixed ``pose_seed`` and varying ``seed`` is a Monte-Carlo run over one geometry.
    ``simulate_kwargs`` go to :func:`dualpose.camera_imu.simulate` (e.g. ``imu_noise``, ``pixel_sigma``,
    ``gravity_misalignment_deg``).  The IMU's turn-on biases are drawn once (seeded by ``seed``, with the
    ``imu_noise`` turn-on sigmas) and shared by all poses, as in one calibration session; the bias random walk and
    white noise are independent per pose.
    """
    q_bc, p_bc = motion.default_extrinsic() if extrinsic is None else extrinsic
    q_bc = np.asarray(q_bc, float)
    p_bc = np.asarray(p_bc, float)
    q_wc, c_w = calibration_camera_poses(n_poses, seed if pose_seed is None else pose_seed, max_roll_deg)
    q_wb = dp.quat_mul(q_wc, dp.quat_conj(q_bc))
    p_wb = c_w - dp.quat_rotate(q_wb, p_bc)
    noise = simulate_kwargs.pop("imu_noise", None) or ImuNoise()
    rng = np.random.default_rng([seed, 2])
    bg = rng.normal(0.0, noise.gyroscope_initial_bias_sigma, 3)
    ba = rng.normal(0.0, noise.accelerometer_initial_bias_sigma, 3)
    per_pose = dataclasses.replace(noise, gyroscope_initial_bias_sigma=0.0, accelerometer_initial_bias_sigma=0.0)
    runs = []
    for k in range(n_poses):
        run = camera_imu.simulate(
            static_motion(q_wb[k], p_wb[k], duration),
            seed=seed * 1000 + k,
            extrinsic=(q_bc, p_bc),
            imu_noise=per_pose,
            **simulate_kwargs,
        )
        run.gyro += bg
        run.accel += ba
        run.truth["gyro_bias"] += bg
        run.truth["accel_bias"] += ba
        run.imu_noise = noise
        runs.append(run)
    return runs
