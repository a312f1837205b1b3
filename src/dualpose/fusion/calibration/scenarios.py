"""Simulated calibration recordings (for tests, benchmarks and ``dualpose calibrate``): static poses in front of
the two-plane scene of :mod:`dualpose.fusion.sim`.

The scene's floor plane (z = 0) plays the calibration pattern lying level; with ``gravity_misalignment_deg = 0``
its "up" is the world z axis.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

import dualpose as dp
from dualpose.fusion import sim

__all__ = [
    "static_trajectory",
    "calibration_camera_poses",
    "simulate_static_poses",
    "random_extrinsic",
    "calibrate_run_time_offset",
]


def static_trajectory(q_wb: np.ndarray, p_wb: np.ndarray, duration: float) -> sim.Trajectory:
    """A :class:`~dualpose.fusion.sim.Trajectory` at rest at body pose ``(q_wb (4,) xyzw, p_wb (3,) m)``."""
    z = np.zeros((1, 3))
    return sim.Trajectory(
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
        eye = sim.CAMERA_HOME + rng.uniform([-0.5, -0.35, -0.45], [0.5, 0.15, 0.45])
        target = sim.SCENE_TARGET + rng.uniform([-0.2, -0.05, -0.15], [0.2, 0.2, 0.15])
        roll = math.radians(rng.uniform(-max_roll_deg, max_roll_deg))
        q[k] = dp.quat_mul(sim.look_at_quat(eye, target), dp.quat_from_rotvec([0.0, 0.0, roll]))
        c[k] = eye
    return q, c


def random_extrinsic(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A random camera→body rotation near a forward-looking mount (±25° about each axis) and lever arm (±5 cm)."""
    rng = np.random.default_rng(seed)
    q_nominal, _ = sim.default_extrinsic()
    q = dp.quat_mul(q_nominal, dp.quat_from_rotvec(rng.uniform(-0.45, 0.45, 3)))
    return q, rng.uniform(-0.05, 0.05, 3)


def simulate_static_poses(
    n_poses: int,
    seed: int,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
    duration: float = 1.0,
    max_roll_deg: float = 40.0,
    pose_seed: int | None = None,
    **simulate_kwargs,  # noqa: ANN003
) -> list[sim.SimulatedRun]:
    """One :class:`~dualpose.fusion.sim.SimulatedRun` at rest per pose of :func:`calibration_camera_poses`.

    Each lasts ``duration`` s.  Poses are seeded by ``pose_seed`` (default ``seed``), sensor noise by
    ``seed * 1000 + k``: a fixed ``pose_seed`` and varying ``seed`` is a Monte-Carlo run over one geometry.
    ``simulate_kwargs`` go to :func:`dualpose.fusion.sim.simulate` (e.g. ``imu_noise``, ``pixel_sigma``,
    ``gravity_misalignment_deg``).  The IMU's turn-on biases are drawn once (seeded by ``seed``, with the
    ``imu_noise`` turn-on sigmas) and shared by all poses, as in one calibration session; the bias random walk and
    white noise are independent per pose.
    """
    q_bc, p_bc = sim.default_extrinsic() if extrinsic is None else extrinsic
    q_bc = np.asarray(q_bc, float)
    p_bc = np.asarray(p_bc, float)
    q_wc, c_w = calibration_camera_poses(n_poses, seed if pose_seed is None else pose_seed, max_roll_deg)
    q_wb = dp.quat_mul(q_wc, dp.quat_conj(q_bc))
    p_wb = c_w - dp.quat_rotate(q_wb, p_bc)
    noise = simulate_kwargs.pop("imu_noise", None) or sim.ImuNoise()
    rng = np.random.default_rng([seed, 2])
    bg = rng.normal(0.0, noise.gyroscope_initial_bias_sigma, 3)
    ba = rng.normal(0.0, noise.accelerometer_initial_bias_sigma, 3)
    per_pose = dataclasses.replace(noise, gyroscope_initial_bias_sigma=0.0, accelerometer_initial_bias_sigma=0.0)
    runs = []
    for k in range(n_poses):
        run = sim.simulate(
            static_trajectory(q_wb[k], p_wb[k], duration),
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


def calibrate_run_time_offset(
    run: sim.SimulatedRun,
    q_bc: np.ndarray | None = None,
    refine: bool = True,
    weighted: bool = False,
    **filter_kwargs,  # noqa: ANN003
):  # noqa: ANN201
    """Both time-offset stages on a simulated run that starts at rest (e.g. ``sim.simulate_eight``).

    Per-frame robust PnP → :func:`~.time_offset.estimate_time_offset` (with ``q_bc``; ``None`` estimates the rotation
    too; the PnP attitude covariances and the gyro noise density give its σ, ``weighted`` also weights with them)
    → if ``refine``,
    :func:`~.time_offset.refine_time_offset_in_filter` over ``±max(4σ, 5 ms)`` with the
    error-state filter started from the rest period + first-frame PnP
    (:func:`dualpose.fusion.initialization.initial_state_from_run`; ``filter_kwargs`` go to
    ``ErrorStateEKF.for_run``, e.g. the estimated ``gravity`` — the filter's NIS only locates the offset well when
    the rest of its model is right).  Returns ``(TimeOffsetEstimate,
    FilterTimeOffsetEstimate or None)``.
    """
    from dualpose.fusion.calibration.time_offset import estimate_time_offset, frame_poses, refine_time_offset_in_filter
    from dualpose.fusion.eskf import ErrorStateEKF
    from dualpose.fusion.initialization import initial_state_from_run

    f = run.frames
    q_wc, cov = frame_poses(f.t, f.offsets, f.pixels, f.points, run.camera.matrix, max(run.pixel_sigma, 1e-3))
    first = estimate_time_offset(
        run.t, run.gyro, f.t, q_wc, q_bc, attitude_covariance=cov,
        gyroscope_noise_density=run.imu_noise.gyroscope_noise_density, weighted=weighted,
    )  # fmt: skip
    if not refine:
        return first, None
    x, P = initial_state_from_run(run)

    def make_filter() -> ErrorStateEKF:  # the run's true offset is NOT passed on: the search sets the attribute
        return ErrorStateEKF.for_run(run, x[0:3], x[3:6], x[6:10], P, gyro_bias=x[10:13], accel_bias=x[13:16],
                                     camera_time_offset=0.0, **filter_kwargs)  # fmt: skip

    second = refine_time_offset_in_filter(
        make_filter, run.t, run.gyro, run.accel, f.t, f.offsets, f.pixels, f.points, first.offset,
        half_width=max(4 * first.sigma, 0.005),
    )  # fmt: skip
    return first, second
