"""``dualpose calibrate camera-imu IMU.csv DETECTIONS.csv --sensors SENSORS.yaml --camera cam0``.

Calibrates one camera of a rig against its IMU from a recording of a fixed calibration target: the camera pose in
the IMU frame, the time offset ``τ`` (camera stamp ``t`` ↔ IMU time ``t + τ``), the IMU biases and the direction of
gravity in the target frame, each with its first-order standard deviation.  Prints a table, or one JSON object with
``--json`` (the file ``dualpose fuse --calibration`` reads).  The computation is
:func:`dualpose.pipelines.calibrate_camera_imu.calibrate_camera_imu_files`; see docs/euroc.md.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

PROG = "dualpose calibrate camera-imu"


def add_subparser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose calibrate camera-imu`` under ``dualpose calibrate``."""
    p = subparsers.add_parser(
        "camera-imu",
        help="camera-IMU extrinsic, time offset, biases and gravity from a calibration-target recording",
        description=(
            "Estimate the pose of a camera in the IMU frame, the camera-IMU time offset, the IMU biases and the "
            "gravity direction in the target frame from an IMU file (EuRoC CSV), the camera's target-corner "
            "detections (timestamp [ns], u, v, X, Y, Z, tag_id, corner_idx) and the rig's sensors.yaml."
        ),
    )
    p.add_argument("imu", metavar="IMU.csv", help="IMU samples (EuRoC CSV: ns, gyro xyz, accel xyz)")
    p.add_argument("detections", metavar="DETECTIONS.csv", help="target-corner detections of the camera")
    p.add_argument("--sensors", required=True, metavar="SENSORS.yaml", help="intrinsics, IMU noise, gravity")
    p.add_argument("--camera", default="cam0", help="camera name in SENSORS.yaml (cam0)")
    p.add_argument("--bias-model", choices=("random_walk", "constant"), default="random_walk",
                   help="IMU biases: a random walk with a knot per frame, or constant (random_walk)")  # fmt: skip
    p.add_argument("--imu-model", choices=("calibrated", "scale_misalignment", "scale_misalignment_size_effect"),
                   default="scale_misalignment",
                   help="IMU model: white noise + bias random walk (calibrated), and also the gyro and accelerometer "
                   "axis matrices (scale_misalignment, the default), and also the positions of the y and z "
                   "accelerometer axes (scale_misalignment_size_effect, Kalibr's size effect)")  # fmt: skip
    p.add_argument("--min-frames", type=int, default=40, metavar="N", help="refuse with fewer usable frames (40)")
    p.add_argument("--window", type=float, nargs=2, default=None, metavar=("START", "END"),
                   help="use only the frames between START and END s after the first IMU sample")  # fmt: skip
    p.add_argument("--json", dest="camera_imu_json", action="store_true", help="print one JSON object")
    return p


def _table(m: dict[str, Any]) -> str:
    from dualpose.cli._output import aligned_rows

    s = m["std"]
    rows = [
        ("camera", m["camera"]),
        ("rotation camera->IMU (xyzw)", " ".join(f"{v:+.6f}" for v in m["rotation_xyzw"])),
        ("  σ about IMU x y z [deg]", " ".join(f"{v:.4f}" for v in s["rotation_deg"])),
        ("translation (camera in IMU) [m]", " ".join(f"{v:+.5f}" for v in m["translation_m"])),
        ("  σ [mm]", " ".join(f"{1e3 * v:.2f}" for v in s["translation_m"])),
        ("time offset τ [ms]", f"{1e3 * m['time_offset_s']:+.3f} ± {1e3 * s['time_offset_s']:.3f}"),
        ("gyro bias (mean) [rad/s]", " ".join(f"{v:+.5f}" for v in m["gyro_bias"])),
        ("accel bias (mean) [m/s²]", " ".join(f"{v:+.4f}" for v in m["accel_bias"])),
        ("gravity in target [m/s²]", " ".join(f"{v:+.4f}" for v in m["gravity_target"])),
        ("  σ direction [deg]", f"{s['gravity_target_deg']:.4f}"),
        ("reprojection RMS [px]", f"{m['reprojection_rms_px']:.3f}  (robust σ {m['pixel_sigma_px']:.3f})"),
        ("IMU factors χ²/dof", f"{m['imu_chi2_per_dof']:.2f}"),
        ("frames used / total", f"{m['frames_used']} / {m['outliers']['frames_total']}"),
        ("corners rejected", f"{m['outliers']['corners_rejected']} of {m['outliers']['corners_total']}"),
        ("worst translation σ [mm]", f"{1e3 * m['excitation']['translation_std_m'][0]:.3f}"),
        ("iterations / runtime [s]", f"{m['iterations']} / {m['runtime_s']:.1f}"),
    ]
    for key, name in (("gyro_axes_matrix", "gyro M − I [‰] (rows)"), ("accel_axes_matrix", "accel M − I [‰] (rows)")):
        if key in m:
            rows.append((name, "; ".join(" ".join(f"{1e3 * (v - (i == j)):+.2f}" for j, v in enumerate(r))
                                         for i, r in enumerate(m[key]))))  # fmt: skip
    rows += [("warning", w) for w in m["warnings"]]
    return aligned_rows(rows)


def run(args: argparse.Namespace) -> int:
    if args.min_frames < 10:
        print(f"{PROG}: error: --min-frames must be >= 10; got {args.min_frames}", file=sys.stderr)
        return 2
    if args.window is not None and not args.window[1] > args.window[0]:
        print(f"{PROG}: error: --window END must be after START; got {args.window}", file=sys.stderr)
        return 2
    from dualpose.pipelines.calibrate_camera_imu import UnknownCamera, calibrate_camera_imu_files

    try:
        window = None if args.window is None else tuple(args.window)
        m = calibrate_camera_imu_files(args.imu, args.detections, args.sensors, args.camera, args.bias_model,
                                       args.min_frames, window, args.imu_model)  # fmt: skip
    except UnknownCamera as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return 2
    except (OSError, ValueError) as exc:
        print(f"{PROG}: error: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", file=sys.stderr)
        return 1
    print(json.dumps(m) if args.camera_imu_json else _table(m))
    for w in m["warnings"]:
        print(f"{PROG}: warning: {w}", file=sys.stderr)
    return 0
