"""``dualpose calibrate``: camera–IMU calibration on a simulated session, checked against the simulator's truth.

The session: ``--poses`` static poses in front of the level two-plane scene (camera→body rotation, Hol's method),
then Hol's eight-shaped run with the scene's vertical misaligned by ``--gravity-misalignment`` degrees and the
camera clock shifted by ``--time-offset`` ms.  The chain uses its own estimates: the estimated rotation feeds the
gravity alignment (from the eight's first 0.9 s at rest) and the time-offset search (rate matching, then the
error-state filter's NIS, with the estimated gravity).  Prints a table (or one JSON object with ``--json``).
Nothing is written to disk.

``dualpose calibrate hand-eye CAMERA.csv BODY.csv`` (:mod:`dualpose.cli.calibrate_hand_eye`) calibrates a camera
against a motion-capture marker or a robot hand from two recorded pose files.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from dualpose.cli import calibrate_hand_eye


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``dualpose calibrate``."""
    p = subparsers.add_parser(
        "calibrate",
        help="camera-IMU rotation, scene gravity and time offset on a simulated session",
        description=(
            "Calibrate a simulated camera-IMU rig (Hol 2008): camera-IMU rotation from static poses, the scene's "
            "gravity direction from a period at rest, and the camera-IMU time offset; each estimate is reported "
            "with its predicted standard deviation and its error against the simulator's truth."
        ),
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the simulation (0)")
    p.add_argument("--poses", type=int, default=6, help="number of static poses for the rotation (6, >= 2)")
    p.add_argument("--extrinsic", choices=("default", "random"), default="default", help="true camera-IMU mount")
    p.add_argument("--gravity-misalignment", type=float, default=1.0, metavar="DEG", help="scene tilt, deg (1)")
    p.add_argument("--time-offset", type=float, default=15.0, metavar="MS", help="t_imu - t_cam, ms (15)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    sub = p.add_subparsers(dest="calibrate_command", required=False, metavar="{hand-eye}",
                           help="calibrate from recorded files (without it: the simulated session)")  # fmt: skip
    calibrate_hand_eye.add_subparser(sub)
    return p


def run_calibrate(
    seed: int = 0,
    poses: int = 6,
    extrinsic: str = "default",
    gravity_misalignment_deg: float = 1.0,
    time_offset_ms: float = 15.0,
) -> dict:
    """Run the simulated session; returns the metrics dictionary printed by the command."""
    import numpy as np

    import dualpose as dp
    from dualpose.fusion import calibration as cal
    from dualpose.fusion import sim
    from dualpose.fusion.calibration.scenarios import calibrate_run_time_offset, random_extrinsic, simulate_static_poses

    if poses < 2:
        raise ValueError(f"--poses must be >= 2; got {poses}")
    ext = sim.default_extrinsic() if extrinsic == "default" else random_extrinsic(seed)
    static = simulate_static_poses(poses, seed, extrinsic=ext, duration=0.5)
    stacked = cal.stack_static_periods([cal.static_period_from_run(r) for r in static])
    bias_cov = np.eye(3) * sim.ImuNoise().accelerometer_initial_bias_sigma ** 2
    rot = cal.camera_imu_rotation(**stacked, accel_bias_covariance=bias_cov)
    rot_err = math.degrees(dp.quat_angle(rot.q_bc, ext[0]))

    run = sim.simulate(
        sim.eight_trajectory(extrinsic=ext), seed=seed, extrinsic=ext,
        gravity_misalignment_deg=gravity_misalignment_deg, time_offset=time_offset_ms * 1e-3,
    )  # fmt: skip
    rest = cal.static_period_from_run(run, 0.0, 0.9)
    grav = cal.scene_gravity(
        rest.specific_force, rest.q_wc, rot.q_bc, rest.specific_force_covariance, rest.attitude_covariance,
        extrinsic_covariance=rot.covariance, accel_bias_covariance=bias_cov, magnitude=9.81,
    )  # fmt: skip
    true_dir = run.gravity / np.linalg.norm(run.gravity)
    g_err = math.degrees(math.atan2(np.linalg.norm(np.cross(grav.direction, true_dir)), grav.direction @ true_dir))

    run.q_bc = rot.q_bc  # the rest of the chain uses the estimated rotation, not the truth
    first, second = calibrate_run_time_offset(run, rot.q_bc, gravity=grav.gravity)
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


def _table(m: dict) -> str:
    rows = [
        (
            "camera-IMU rotation error [deg]",
            f"{m['extrinsic_error_deg']:.3f}  (predicted σ {m['extrinsic_sigma_deg']:.3f})",
        ),
        ("  gravity spread of the poses [deg]", f"{m['extrinsic_spread_deg']:.1f}"),
        ("scene tilt [deg]", f"{m['gravity_tilt_deg']:.3f}  (true {m['gravity_misalignment_deg']:.3f})"),
        ("gravity direction error [deg]", f"{m['gravity_error_deg']:.3f}  (predicted σ {m['gravity_sigma_deg']:.3f})"),
        (
            "time offset, rate matching [ms]",
            f"{m['time_offset_stage1_ms']:.2f} ± {m['time_offset_stage1_sigma_ms']:.2f}",
        ),
        ("time offset, filter NIS [ms]", f"{m['time_offset_ms']:.2f}  (true {m['time_offset_injected_ms']:.2f})"),
    ]
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{name:<{width}}  {value}" for name, value in rows)


def run(args: argparse.Namespace) -> int:
    if getattr(args, "calibrate_command", None) == "hand-eye":
        return calibrate_hand_eye.run(args)
    try:
        m = run_calibrate(args.seed, args.poses, args.extrinsic, args.gravity_misalignment, args.time_offset)
    except ValueError as exc:
        print(f"dualpose calibrate: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(m) if args.json else _table(m))
    return 0
