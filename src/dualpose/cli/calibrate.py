"""``dualpose calibrate``: camera–IMU calibration on a simulated session, checked against the simulator's truth.

The session: ``--poses`` static poses in front of the level two-plane scene (camera→body rotation, Hol's method),
then Hol's eight-shaped run with the scene's vertical misaligned by ``--gravity-misalignment`` degrees and the
camera clock shifted by ``--time-offset`` ms.  The chain uses its own estimates: the estimated rotation feeds the
gravity alignment (from the eight's first 0.9 s at rest) and the time-offset search (rate matching, then the
error-state filter's NIS, with the estimated gravity).  Prints a table (or one JSON object with ``--json``).
Nothing is written to disk.

``dualpose calibrate hand-eye CAMERA.csv BODY.csv`` (:mod:`dualpose.cli.calibrate_hand_eye`) calibrates a camera
against a motion-capture marker or a robot hand from two recorded pose files; ``dualpose calibrate camera-imu``
(:mod:`dualpose.cli.calibrate_camera_imu`) calibrates a camera against its IMU from a calibration-target recording.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from dualpose.cli import calibrate_camera_imu, calibrate_hand_eye
from dualpose.cli._args import float_in, int_in, seed

#: bounds of the numeric options: the session's poses, the scene tilt (deg) and the injected offset (ms)
MAX_POSES = 1_000_000
MAX_TILT_DEG = 45.0
MAX_OFFSET_MS = 100.0


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
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
    p.add_argument("--seed", type=seed, default=0, help="seed of the simulation (0; >= 0)")
    p.add_argument("--poses", type=int_in(2, MAX_POSES), default=6,
                   help=f"number of static poses for the rotation (6; 2 to {MAX_POSES})")
    p.add_argument("--extrinsic", choices=("default", "random"), default="default", help="true camera-IMU mount")
    p.add_argument("--gravity-misalignment", type=float_in(-MAX_TILT_DEG, MAX_TILT_DEG), default=1.0, metavar="DEG",
                   help=f"scene tilt, deg (1; |DEG| <= {MAX_TILT_DEG:g})")
    p.add_argument("--time-offset", type=float_in(-MAX_OFFSET_MS, MAX_OFFSET_MS), default=15.0, metavar="MS",
                   help=f"t_imu - t_cam, ms (15; |MS| <= {MAX_OFFSET_MS:g}: the rate matching searches +-100 ms)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    sub = p.add_subparsers(dest="calibrate_command", required=False, metavar="{hand-eye,camera-imu}",
                           help="calibrate from recorded files (without it: the simulated session)")  # fmt: skip
    calibrate_hand_eye.add_subparser(sub)
    calibrate_camera_imu.add_subparser(sub)
    return p


def _table(m: dict[str, Any]) -> str:
    from dualpose.cli._output import aligned_rows

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
    return aligned_rows(rows)


def run(args: argparse.Namespace) -> int:
    if getattr(args, "calibrate_command", None) == "hand-eye":
        return calibrate_hand_eye.run(args)
    if getattr(args, "calibrate_command", None) == "camera-imu":
        return calibrate_camera_imu.run(args)
    from dualpose.cli._progress import progress_bar
    from dualpose.pipelines.calibrate import calibrate_simulated_session, session_steps

    try:
        with progress_bar(session_steps(args.poses), "dualpose calibrate") as bar:

            def progress(n: int, stage: str) -> None:
                bar.set_postfix_str(stage)
                bar.update(n)

            m = calibrate_simulated_session(args.seed, args.poses, args.extrinsic, args.gravity_misalignment,
                                            args.time_offset, progress=progress)  # fmt: skip
    except ValueError as exc:
        print(f"dualpose calibrate: error: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(m) if args.json else _table(m))
    return 0
