"""Simulated calibration recordings (for tests, benchmarks and ``dualpose calibrate``): static poses in front of
the two-plane scene of :mod:`dualpose.sim`.

The scene's floor plane (z = 0) plays the calibration pattern lying level; with ``gravity_misalignment_deg = 0``
its "up" is the world z axis.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

import dualpose as dp
from dualpose.sim import camera_imu, motion
from dualpose.sim.camera_imu import two_plane_landmarks
from dualpose.types import ImuNoise
from dualpose.types.camera import PinholeCamera
from dualpose.types.imu import STANDARD_GRAVITY

__all__ = [
    "static_motion",
    "calibration_camera_poses",
    "simulate_static_poses",
    "random_extrinsic",
    "StaticPoseSet",
    "simulate_static_pose_set",
]


def static_motion(q_wb: ArrayLike, p_wb: ArrayLike, duration: float) -> motion.SmoothMotion:
    """A :class:`~dualpose.sim.motion.SmoothMotion` at rest at body pose ``(q_wb (4,) xyzw, p_wb (3,) m)``."""
    z = np.zeros((1, 3))
    return motion.SmoothMotion(
        p0=np.asarray(p_wb, float), q0=np.asarray(q_wb, float), pos_amp=z, pos_harm=np.ones(1), pos_phase=z,
        rot_amp=z, rot_harm=np.ones(1), rot_phase=z, phase_kind="linear", omega0=0.0, duration=float(duration),
    )  # fmt: skip


def calibration_camera_poses(
    n_poses: int, seed: int, max_roll_deg: float = 40.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``n_poses`` camera poses ``(q_wc (n, 4), c_w (n, 3))`` looking at the scene from different heights and
    sides, rolled about the optical axis by up to ``max_roll_deg`` (so the gravity direction differs between poses
    about two axes), seeded."""
    rng = np.random.default_rng(seed)
    # per pose: eye offset (3), target offset (3), roll (1) -- the draws in the order a per-pose loop makes them
    u = rng.random((n_poses, 7))
    lo = np.array([-0.5, -0.35, -0.45, -0.2, -0.05, -0.15, -max_roll_deg])
    hi = np.array([0.5, 0.15, 0.45, 0.2, 0.2, 0.15, max_roll_deg])
    d = lo + (hi - lo) * u
    eye = motion.CAMERA_HOME + d[:, 0:3]
    target = motion.SCENE_TARGET + d[:, 3:6]
    roll = np.zeros((n_poses, 3))
    roll[:, 2] = np.radians(d[:, 6])
    q = dp.quat_mul(motion.look_at_quat(eye, target), dp.quat_from_rotvec(roll))
    return q, eye


def random_extrinsic(seed: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
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
    **simulate_kwargs: Any,
) -> list[camera_imu.SimulatedRun]:
    """One :class:`~dualpose.sim.camera_imu.SimulatedRun` at rest per pose of :func:`calibration_camera_poses`.

    Each lasts ``duration`` s.  Poses are seeded by ``pose_seed`` (default ``seed``), sensor noise by
    ``seed * 1000 + k``: a fixed ``pose_seed`` and varying ``seed`` is a Monte-Carlo run over one geometry.
    ``simulate_kwargs`` go to :func:`dualpose.sim.camera_imu.simulate` (e.g. ``imu_noise``, ``pixel_sigma``,
    ``gravity_misalignment_deg``).  The IMU's turn-on biases are drawn once (seeded by ``seed``, with the
    ``imu_noise`` turn-on sigmas) and shared by all poses, as in one calibration session; the bias random walk and
    white noise are independent per pose.
    """
    q_bc, p_bc = motion.extrinsic_arrays(extrinsic)
    q_wb, p_wb = motion.body_from_camera(
        *calibration_camera_poses(n_poses, seed if pose_seed is None else pose_seed, max_roll_deg), q_bc, p_bc
    )
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


@dataclass
class StaticPoseSet:
    """``K`` static poses simulated at once (:func:`simulate_static_pose_set`): arrays over the pose axis.

    Attributes
    ----------
    accel : ndarray (K, N, 3)
        Accelerometer samples at rest, body frame, m/s² (turn-on bias shared by all poses, white noise and bias
        random walk per pose).
    pixels : ndarray (K, M, 2), points : ndarray (K, M, 3), valid : ndarray of bool (K, M)
        The correspondences of all frames of each pose (pixels with N(0, ``pixel_sigma``²) noise, world points in
        metres); rows with ``valid`` False are padding.
    q_wb, p_wb : ndarray (K, 4), (K, 3)
        True body poses.  ``camera``, ``imu_noise``, ``pixel_sigma``, ``gravity`` (3,): the set-up.
    n_frames : int
        Frames per pose.
    """

    accel: np.ndarray
    pixels: np.ndarray
    points: np.ndarray
    valid: np.ndarray
    q_wb: np.ndarray
    p_wb: np.ndarray
    camera: PinholeCamera
    imu_noise: ImuNoise
    pixel_sigma: float
    gravity: np.ndarray
    n_frames: int


def simulate_static_pose_set(
    n_poses: int,
    seed: int,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
    duration: float = 0.5,
    max_roll_deg: float = 40.0,
    imu_noise: ImuNoise | None = None,
    pixel_sigma: float = 1.0,
    camera_rate: float = 12.5,
    camera_phase: float = 0.0137,
    landmarks_per_frame: int = 20,
    n_landmarks: int = 300,
    gravity_misalignment_deg: float = 0.0,
    first_pose: int = 0,
) -> StaticPoseSet:
    """The static poses of :func:`simulate_static_poses` (same pose geometry, same sensor models) simulated for all
    poses at once, without Python loops over poses or samples -- for sessions of many thousands of poses.

    Poses ``first_pose .. first_pose + n_poses - 1`` of the sequence :func:`calibration_camera_poses` seeded by
    ``seed`` draws, so a long session can be simulated in chunks.  Noise is seeded by ``(seed, first_pose)``:
    statistically as :func:`simulate_static_poses`, not the same draws.  One landmark set (the calibration scene,
    seeded by ``seed``) serves all poses.  The accelerometer turn-on bias is drawn once from ``seed``.
    """
    noise = ImuNoise() if imu_noise is None else imu_noise
    q_bc, p_bc = motion.extrinsic_arrays(extrinsic)
    q_wc, c_w = calibration_camera_poses(first_pose + n_poses, seed, max_roll_deg)
    q_wc, c_w = q_wc[first_pose:], c_w[first_pose:]
    q_wb, p_wb = motion.body_from_camera(q_wc, c_w, q_bc, p_bc)
    ang = math.radians(gravity_misalignment_deg)
    gravity = STANDARD_GRAVITY * np.array([0.0, math.sin(ang), -math.cos(ang)])
    ba = np.random.default_rng([seed, 2]).normal(0.0, noise.accelerometer_initial_bias_sigma, 3)
    rng = np.random.default_rng([seed, 3, first_pose])
    dt = 1.0 / noise.update_rate
    n = int(math.floor(duration * noise.update_rate + 1e-9)) + 1
    f_b = dp.quat_rotate(dp.quat_conj(q_wb), -gravity)  # (K, 3): at rest the specific force is -g in the body
    walk = np.cumsum(rng.normal(0.0, noise.accelerometer_random_walk * math.sqrt(dt), (n_poses, n, 3)), axis=1)
    walk -= walk[:, :1]
    accel = f_b[:, None, :] + ba + walk + rng.normal(0.0, noise.accelerometer_noise_density / math.sqrt(dt),
                                                     (n_poses, n, 3))  # fmt: skip

    camera = PinholeCamera()
    landmarks = two_plane_landmarks(np.random.default_rng([seed, 1]), n_landmarks)
    n_frames = len(np.arange(camera_phase, duration + 1e-12, 1.0 / camera_rate))
    R_cw = dp.matrix_from_quat(dp.quat_conj(q_wc))  # (K, 3, 3)
    pc = (landmarks[None, :, :] - c_w[:, None, :]) @ np.swapaxes(R_cw, 1, 2)  # (K, L, 3) camera frame
    z = np.where(pc[..., 2] > 0.05, pc[..., 2], 1.0)
    uv = np.stack([camera.fx * pc[..., 0] / z + camera.cx, camera.fy * pc[..., 1] / z + camera.cy], axis=-1)
    vis = (pc[..., 2] > 0.05) & (uv[..., 0] >= 0) & (uv[..., 0] < camera.width) & (uv[..., 1] >= 0)
    vis &= uv[..., 1] < camera.height
    # per frame a random subset of at most ``landmarks_per_frame`` visible landmarks: the smallest random keys
    keys = np.where(vis[:, None, :], rng.random((n_poses, n_frames, len(landmarks))), np.inf)
    m = min(landmarks_per_frame, len(landmarks))
    ids = np.argpartition(keys, m - 1, axis=2)[:, :, :m] if m < len(landmarks) else np.argsort(keys, axis=2)
    valid = np.isfinite(np.take_along_axis(keys, ids, axis=2)).reshape(n_poses, -1)
    ids = ids.reshape(n_poses, -1)
    pixels = np.take_along_axis(uv, ids[..., None], axis=1) + rng.normal(0.0, pixel_sigma, (n_poses, ids.shape[1], 2))
    return StaticPoseSet(
        accel=accel, pixels=pixels, points=landmarks[ids], valid=valid, q_wb=q_wb, p_wb=p_wb, camera=camera,
        imu_noise=noise, pixel_sigma=pixel_sigma, gravity=gravity, n_frames=n_frames,
    )  # fmt: skip
