"""Camera–IMU calibration on a simulated session (the job behind ``dualpose calibrate``), checked against truth.

The session: ``poses`` static poses in front of the level two-plane scene (camera→body rotation, Hol 2008 §5),
then Hol's eight-shaped run with the scene's vertical misaligned by ``gravity_misalignment_deg`` degrees and the
camera clock shifted by ``time_offset_ms``.  The chain uses its own estimates: the estimated rotation feeds the
gravity alignment (from the eight's first 0.9 s at rest) and the time-offset search (rate matching, then the
error-state filter's NIS, with the estimated gravity).  Method and results: docs/fusion.md, "Calibration".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

import dualpose as dp
from dualpose import calibration as cal
from dualpose import sim
from dualpose.calibration.time_offset import (
    FilterTimeOffsetEstimate,
    TimeOffsetEstimate,
    estimate_time_offset,
    frame_poses,
    refine_time_offset_in_filter,
)
from dualpose.estimation.eskf import ErrorStateEKF
from dualpose.estimation.initialization import initial_state_from_run
from dualpose.sim.calibration_scenarios import random_extrinsic, simulate_static_pose_set
from dualpose.types import ImuNoise
from dualpose.types.imu import STANDARD_GRAVITY

__all__ = ["calibrate_run_time_offset", "calibrate_simulated_session", "static_session"]

#: static poses simulated and solved together (bounds the memory: ~60 MB of arrays per chunk)
_CHUNK = 2000


def calibrate_run_time_offset(
    run: sim.SimulatedRun,
    q_bc: np.ndarray | None = None,
    refine: bool = True,
    weighted: bool = False,
    **filter_kwargs: Any,
) -> tuple[TimeOffsetEstimate, FilterTimeOffsetEstimate | None]:
    """Both time-offset stages on a simulated run that starts at rest (e.g. ``sim.simulate_eight``).

    Per-frame robust PnP → :func:`~dualpose.calibration.time_offset.estimate_time_offset` (with ``q_bc``; ``None``
    estimates the rotation too; the PnP attitude covariances and the gyro noise density give its σ, ``weighted``
    also weights with them) → if ``refine``,
    :func:`~dualpose.calibration.time_offset.refine_time_offset_in_filter` over ``±max(4σ, 5 ms)`` with the
    error-state filter started from the rest period + first-frame PnP
    (:func:`dualpose.estimation.initialization.initial_state_from_run`; ``filter_kwargs`` go to
    ``ErrorStateEKF.for_run``, e.g. the estimated ``gravity`` — the filter's NIS only locates the offset well when
    the rest of its model is right).  Returns ``(TimeOffsetEstimate,
    FilterTimeOffsetEstimate or None)``.
    """
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
        return ErrorStateEKF.from_state(run, x, P, camera_time_offset=0.0, **filter_kwargs)

    second = refine_time_offset_in_filter(
        make_filter, run.t, run.gyro, run.accel, f.t, f.offsets, f.pixels, f.points, first.offset,
        half_width=max(4 * first.sigma, 0.005),
    )  # fmt: skip
    return first, second


def session_steps(poses: int) -> int:
    """Total of the ``n`` that :func:`calibrate_simulated_session` reports to ``progress``."""
    return poses + 2


def static_session(
    poses: int,
    seed: int,
    extrinsic: tuple[np.ndarray, np.ndarray],
    duration: float = 0.5,
    progress: Callable[[int], None] | None = None,
) -> cal.StaticArrays:
    """``poses`` simulated static poses (:func:`dualpose.sim.calibration_scenarios.simulate_static_pose_set`) summarised
    by :func:`dualpose.calibration.static_periods`, in chunks of ``_CHUNK`` poses; ``progress(n)`` is called
    with the number of poses done after each chunk.  Returns the stacked arrays of
    :func:`dualpose.calibration.stack_static_periods`."""
    parts = []
    for first in range(0, poses, _CHUNK):
        s = simulate_static_pose_set(min(_CHUNK, poses - first), seed, extrinsic=extrinsic, duration=duration,
                                     first_pose=first)  # fmt: skip
        parts.append(cal.static_periods(s.accel, s.pixels, s.points, s.valid, s.camera.matrix,
                                        s.imu_noise.accelerometer_noise_density, s.imu_noise.update_rate,
                                        pixel_sigma=s.pixel_sigma))  # fmt: skip
        if progress is not None:
            progress(len(s.accel))
    return cal.StaticArrays(
        specific_force=np.concatenate([p["specific_force"] for p in parts]),
        q_wc=np.concatenate([p["q_wc"] for p in parts]),
        specific_force_covariance=np.concatenate([p["specific_force_covariance"] for p in parts]),
        attitude_covariance=np.concatenate([p["attitude_covariance"] for p in parts]),
    )


def calibrate_simulated_session(
    seed: int = 0,
    poses: int = 6,
    extrinsic: str = "default",
    gravity_misalignment_deg: float = 1.0,
    time_offset_ms: float = 15.0,
    progress: Callable[[int, str], None] | None = None,
) -> dict[str, Any]:
    """The session of ``dualpose calibrate`` (module docstring); returns the metrics dictionary the command prints.

    ``progress(n, stage)``, if given, is called as work is done: ``n`` static poses solved (stage "static poses"),
    then one step each for "gravity" and "time offset" (``session_steps`` counts them).

    Raises
    ------
    ValueError
        ``poses < 2``.
    """
    if poses < 2:
        raise ValueError(f"--poses must be >= 2; got {poses}")

    def report(n: int, stage: str) -> None:
        if progress is not None:
            progress(n, stage)

    ext = sim.default_extrinsic() if extrinsic == "default" else random_extrinsic(seed)
    stacked = static_session(poses, seed, ext, duration=0.5, progress=lambda n: report(n, "static poses"))
    bias_cov = np.eye(3) * ImuNoise().accelerometer_initial_bias_sigma ** 2
    rot = cal.camera_imu_rotation(**stacked, accel_bias_covariance=bias_cov)
    rot_err = math.degrees(dp.quat_angle(rot.q_bc, ext[0]))

    run = sim.simulate(
        sim.eight_motion(extrinsic=ext), seed=seed, extrinsic=ext,
        gravity_misalignment_deg=gravity_misalignment_deg, time_offset=time_offset_ms * 1e-3,
    )  # fmt: skip
    rest = cal.static_period_from_run(run, 0.0, 0.9)
    grav = cal.scene_gravity(
        rest.specific_force, rest.q_wc, rot.q_bc, rest.specific_force_covariance, rest.attitude_covariance,
        extrinsic_covariance=rot.covariance, accel_bias_covariance=bias_cov, magnitude=STANDARD_GRAVITY,
    )  # fmt: skip
    report(1, "gravity")
    true_dir = run.gravity / np.linalg.norm(run.gravity)
    g_err = math.degrees(math.atan2(np.linalg.norm(np.cross(grav.direction, true_dir)), grav.direction @ true_dir))

    run.q_bc = rot.q_bc  # the rest of the chain uses the estimated rotation, not the truth
    first, second = calibrate_run_time_offset(run, rot.q_bc, gravity=grav.gravity)
    assert second is not None  # refine=True
    report(1, "time offset")
    return {
        "seed": seed,
        "poses": poses,
        "extrinsic_error_deg": rot_err,
        "extrinsic_sigma_deg": math.degrees(math.sqrt(np.trace(rot.covariance))),
        "extrinsic_spread_deg": rot.spread_deg,
        "q_bc": rot.q_bc.tolist(),
        "gravity_direction": grav.direction.tolist(),
        "gravity_tilt_deg": grav.tilt_deg,
        "gravity_misalignment_deg": gravity_misalignment_deg,
        "gravity_error_deg": g_err,
        "gravity_sigma_deg": grav.sigma_deg,
        "time_offset_injected_ms": time_offset_ms,
        "time_offset_stage1_ms": 1e3 * first.offset,
        "time_offset_stage1_sigma_ms": 1e3 * first.sigma,
        "time_offset_ms": 1e3 * second.offset,
        "time_offset_error_ms": 1e3 * second.offset - time_offset_ms,
    }
