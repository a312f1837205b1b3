"""``dualpose ahrs FILE [--mag/--no-mag] [--json]``: orientation-only filter on a BROAD trial, scored with BROAD's
metric (total / heading / inclination RMSE over the movement samples) when the file has a reference.

9D (``--mag``, default) is scored as BROAD publishes it, in the magnetic ENU frame without alignment; 6D
(``--no-mag``) has no absolute heading, so one constant heading offset is removed first (see
:mod:`dualpose.evaluation.orientation_errors`); it does not need the file's ``imu_mag`` field.  Exit status: 0, 2 on
bad arguments, 1 on an unreadable or invalid file (the message names the file and the field; docs/broad.md).
"""

from __future__ import annotations

import argparse
import json
import sys


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``dualpose ahrs``."""
    p = subparsers.add_parser(
        "ahrs",
        help="orientation-only filter (gyro + acc [+ mag]) on a BROAD trial, scored with BROAD's metric",
        description="Run dualpose's orientation-only error-state filter on a BROAD .mat trial and print its RMSE "
        "against the optical reference (total / heading / inclination, degrees, movement samples).",
    )
    p.add_argument("file", help="BROAD trial file (.mat)")
    p.add_argument("--mag", dest="mag", action=argparse.BooleanOptionalAction, default=True,
                   help="use the magnetometer (9D, default) or not (--no-mag: 6D)")
    p.add_argument("--mag-calibration", action="store_true",
                   help="self-calibrate the magnetometer (hard/soft iron) when the recording supports it")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    return p


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose ahrs``."""
    import numpy as np

    from dualpose.estimation.ahrs import estimate_orientation
    from dualpose.evaluation.orientation_errors import orientation_rmse
    from dualpose.io import load_broad

    try:
        trial = load_broad(args.file)
    except (OSError, ValueError, ImportError) as exc:
        msg = str(exc)
        if args.file not in msg:
            msg = f"{args.file}: {msg}"
        print(f"dualpose ahrs: error: {msg}", file=sys.stderr)
        return 1
    if args.mag and not trial.has_mag:
        print(f"dualpose ahrs: error: {args.file}: no field imu_mag (magnetometer): use --no-mag for 6D",
              file=sys.stderr)  # fmt: skip
        return 1
    try:
        result = estimate_orientation(
            trial.gyr, trial.acc, trial.mag if args.mag else None, trial.rate, use_mag=args.mag,
            n_rest=max(trial.static_start, 10), mag_calibration="auto" if args.mag_calibration else None,
        )  # fmt: skip
    except ValueError as exc:
        print(f"dualpose ahrs: error: {args.file}: {exc}", file=sys.stderr)
        return 1
    out: dict[str, object] = {
        "file": str(args.file),
        "mode": "9D" if args.mag else "6D",
        "samples": int(result.quat.shape[0]),
        "rate_hz": trial.rate,
        "us_per_sample": result.us_per_sample,
        "acc_rejected": result.acc_rejected,
        "mag_rejected": result.mag_rejected,
        # compensated magnetometer lag behind the gyroscope, estimated from the IMU data alone (None in 6D)
        "mag_time_offset_ms": result.mag_time_offset_ms if args.mag else None,
        # magnetometer self-calibration (--mag-calibration): applied only when the data support it (None in 6D)
        "mag_calibration_applied": result.mag_calibration_applied if args.mag else None,
    }
    if args.mag and result.mag_calibration is not None:
        out.update(result.mag_calibration.as_dict())
    has_ref = bool(np.isfinite(trial.quat[trial.movement]).all(axis=1).any())
    if has_ref:
        score = orientation_rmse(result.quat, trial.quat, trial.movement, fit_heading_offset=not args.mag)
        out.update(score.as_dict())
    else:
        out.update(total_rmse_deg=None, heading_rmse_deg=None, inclination_rmse_deg=None)
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"dualpose ahrs: {trial.name} ({out['mode']}, {out['samples']} samples at {trial.rate:.1f} Hz)")
    if has_ref:
        print(f"  total RMSE        {out['total_rmse_deg']:8.3f} deg")
        print(f"  heading RMSE      {out['heading_rmse_deg']:8.3f} deg")
        print(f"  inclination RMSE  {out['inclination_rmse_deg']:8.3f} deg")
        if not args.mag:
            print(f"  heading offset removed (6D): {out['heading_offset_deg']:.2f} deg")
    else:
        print("  no reference orientation on the movement samples: nothing scored")
    if args.mag:
        print(f"  mag time offset   {out['mag_time_offset_ms']:8.3f} ms (estimated from the IMU data, compensated)")
    if args.mag and result.mag_calibration is not None:
        cal = result.mag_calibration
        print(f"  mag calibration   {'applied' if cal.applied else 'not applied'} ({cal.reason})")
    print(f"  filter time       {out['us_per_sample']:8.3f} us/sample")
    return 0
