"""``dualpose calibrate hand-eye CAMERA.csv BODY.csv``: hand–eye transform and time offset from two pose files.

CAMERA.csv holds the camera's pose in a calibration target, BODY.csv the pose of the body it is mounted on (a
motion-capture marker, a robot hand) in its reference frame, each ``t, x, y, z, qx, qy, qz, qw`` in its own clock.
Prints ``X`` (the camera pose in the body frame), the time offset ``τ`` (camera time ``t`` ↔ body time ``t + τ``),
the RMS loop residuals (never above those of the closed form the final refinement started from, also printed), the
residual the streams' own noise predicts and the coarse rate correlation, and first-order standard deviations; one
JSON object with ``--json``.  Exit status 1 also when the match is not credible (a rotation residual far above the
streams' noise: two unrelated recordings); a doubtful match is printed with a warning and ``"credibility"``.
The computation is :func:`dualpose.calibration.calibrate_hand_eye_streams`; see ``docs/hand-eye.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from typing import TYPE_CHECKING, Any

from dualpose.cli._args import add_bag_time_argument

if TYPE_CHECKING:
    from dualpose.calibration import CleaningReport

PROG = "dualpose calibrate hand-eye"


def add_subparser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose calibrate hand-eye`` under ``dualpose calibrate``."""
    p = subparsers.add_parser(
        "hand-eye",
        help="hand-eye transform and time offset from two unsynchronised pose files",
        description=(
            "Estimate the camera's pose in the body (marker/hand) frame and the time offset between the two "
            "clocks from a camera-in-target pose file and a body pose file (lines 't, x, y, z, qx, qy, qz, qw')."
        ),
    )
    p.add_argument("camera", metavar="CAMERA.csv", help="camera poses in the calibration-target frame (or a ROS bag "
                   "topic FILE.bag:/topic, FILE.bag:/tf:TARGET:CAMERA)")  # fmt: skip
    p.add_argument("body", metavar="BODY.csv", help="body (marker/hand) poses in its reference frame (or a bag topic)")
    add_bag_time_argument(p)
    p.add_argument("--time-offset", type=float, default=None, metavar="S",
                   help="start value of τ (s) instead of the rate correlation")  # fmt: skip
    p.add_argument("--fix-time-offset", action="store_true", help="keep τ at --time-offset")
    p.add_argument("--min-pair-angle", type=float, default=10.0, metavar="DEG", help="pair rotation, deg (10)")
    p.add_argument("--max-pair-dt", type=float, default=2.0, metavar="S", help="longest pair interval, s (2)")
    p.add_argument("--seed", type=int, default=0, help="seed of the robust sampler (0)")
    p.add_argument("--json", dest="hand_eye_json", action="store_true", help="print one JSON object")
    return p


def _usage_error(args: argparse.Namespace) -> str | None:
    if args.fix_time_offset and args.time_offset is None:
        return "--fix-time-offset needs --time-offset"
    if not 0 < args.min_pair_angle < 180:
        return f"--min-pair-angle must be in (0, 180) deg; got {args.min_pair_angle}"
    if not args.max_pair_dt > 0:
        return f"--max-pair-dt must be > 0 s; got {args.max_pair_dt}"
    return None


def run_hand_eye(args: argparse.Namespace) -> dict[str, Any]:
    """Read, clean and calibrate; returns the dictionary printed with ``--json``."""
    from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream
    from dualpose.io.pose_csv import read_pose_stream

    camera, cam_rep = clean_pose_stream(*read_pose_stream(args.camera, bag_time=args.bag_time), args.camera, min_rows=3)
    body, body_rep = clean_pose_stream(*read_pose_stream(args.body, bag_time=args.bag_time), args.body, min_rows=2)
    r = calibrate_hand_eye_streams(
        camera, body, time_offset=args.time_offset, fix_time_offset=args.fix_time_offset,
        min_pair_angle=math.radians(args.min_pair_angle), max_pair_dt=args.max_pair_dt, seed=args.seed,
    )  # fmt: skip
    return {
        "rotation_xyzw": r.quat.tolist(),
        "translation_m": r.translation.tolist(),
        "time_offset_s": r.time_offset,
        "rotation_residual_deg": r.rotation_rmse_deg,
        "translation_residual_m": r.translation_rmse_m,
        "start_method": r.start_method,
        "start_rotation_residual_deg": r.start_rotation_rmse_deg,
        "start_translation_residual_m": r.start_translation_rmse_m,
        "pairs_used": r.pairs_used,
        "pairs_total": r.pairs_total,
        "rotation_sigma_deg": r.rotation_sigma_deg.tolist(),
        "translation_sigma_m": r.translation_sigma_m.tolist(),
        "time_offset_sigma_s": r.time_offset_sigma,
        "coarse_time_offset_s": r.coarse_time_offset,
        "coarse_correlation": None if math.isnan(r.coarse_correlation) else r.coarse_correlation,
        "expected_rotation_residual_deg": None if math.isnan(r.expected_rotation_rmse_deg)
        else r.expected_rotation_rmse_deg,
        "residual_to_noise": None if math.isnan(r.residual_to_noise) else r.residual_to_noise,
        "credible": r.credible,
        "credibility": r.credibility,
        "camera_rows": _rows(cam_rep),
        "body_rows": _rows(body_rep),
    }  # fmt: skip


def _rows(rep: CleaningReport) -> dict[str, Any]:
    return {"read": rep.rows_in, "kept": rep.rows_out, "exact_duplicates": rep.exact_duplicates,
            "merged_stamps": rep.merged_stamps, "was_sorted": rep.was_sorted}  # fmt: skip


def _table(m: dict[str, Any]) -> str:
    from dualpose.cli._output import aligned_rows

    q, t, sq, st = m["rotation_xyzw"], m["translation_m"], m["rotation_sigma_deg"], m["translation_sigma_m"]
    rows = [
        ("rotation X (xyzw)", " ".join(f"{v:+.6f}" for v in q)),
        ("  σ about x y z [deg]", " ".join(f"{v:.3f}" for v in sq)),
        ("translation X [m]", " ".join(f"{v:+.5f}" for v in t)),
        ("  σ [mm]", " ".join(f"{1e3 * v:.2f}" for v in st)),
        ("time offset τ [s]", f"{m['time_offset_s']:.6f} ± {m['time_offset_sigma_s']:.6f}"),
        ("  coarse (rate correlation) [s]", f"{m['coarse_time_offset_s']:.6f}"),
        ("rotation residual RMSE [deg]", f"{m['rotation_residual_deg']:.4f}"),
        ("translation residual RMSE [mm]", f"{1e3 * m['translation_residual_m']:.3f}"),
        (
            "  started from (closed form)",
            f"{m['start_method']}: {m['start_rotation_residual_deg']:.4f} deg, "
            f"{1e3 * m['start_translation_residual_m']:.3f} mm",
        ),
        ("  expected from the noise [deg]", "-" if m["expected_rotation_residual_deg"] is None
         else f"{m['expected_rotation_residual_deg']:.4f} (ratio {m['residual_to_noise']:.2f})"),
        ("  coarse rate correlation", "-" if m["coarse_correlation"] is None else f"{m['coarse_correlation']:.3f}"),
        ("match", m["credibility"]),
        ("pairs used / valid", f"{m['pairs_used']} / {m['pairs_total']}"),
        ("camera rows read / kept", f"{m['camera_rows']['read']} / {m['camera_rows']['kept']}"),
        ("body rows read / kept", f"{m['body_rows']['read']} / {m['body_rows']['kept']}"),
    ]
    return aligned_rows(rows)


def run(args: argparse.Namespace) -> int:
    message = _usage_error(args)
    if message is not None:
        print(f"{PROG}: error: {message}", file=sys.stderr)
        return 2
    from dualpose.registration import HandEyeWarning

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", HandEyeWarning)
            m = run_hand_eye(args)
    except (OSError, ValueError, ImportError) as exc:
        print(f"{PROG}: error: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}", file=sys.stderr)
        return 1
    if not m["credible"]:  # the streams do not record the same motion: no calibration to report
        print(f"{PROG}: error: the match is {m['credibility']}", file=sys.stderr)
        return 1
    for w in caught:
        if issubclass(w.category, HandEyeWarning):
            print(f"{PROG}: warning: {w.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    print(json.dumps(m) if args.hand_eye_json else _table(m))
    return 0
