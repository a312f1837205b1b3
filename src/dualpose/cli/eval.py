"""``dualpose eval``: trajectory accuracy (ATE, orientation error, RPE) of an estimate against a reference.

Like ``evo_ape`` + ``evo_rpe`` in one command, with the formats (TUM, EuRoC ground-truth CSV) detected from the
files.  Exit status: 0 on success, 1 when a file cannot be read or evaluated (the message names file and line).
"""

from __future__ import annotations

import argparse
import json
import sys


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``dualpose eval``."""
    p = subparsers.add_parser(
        "eval",
        help="ATE / RPE / orientation error of an estimated trajectory (TUM or EuRoC files)",
        description=(
            "Associate the poses by timestamp, align the estimate to the reference (Umeyama), and print statistics "
            "of the absolute trajectory error (ATE), the orientation error and the relative pose error (RPE). "
            "The numbers equal those of evo_ape / evo_rpe with the same settings."
        ),
    )
    p.add_argument("reference", help="reference trajectory: TUM file or EuRoC ground-truth CSV")
    p.add_argument("estimate", help="estimated trajectory: TUM file or EuRoC ground-truth CSV")
    p.add_argument(
        "--align",
        choices=("se3", "sim3", "scale", "origin", "none"),
        default="se3",
        help="alignment of the estimate: Umeyama rigid (se3, default), with scale (sim3), scale only (scale), "
        "first poses made equal (origin), or none",
    )
    p.add_argument("--n-align", type=int, metavar="N", help="estimate the alignment from the first N matched poses")
    p.add_argument("--max-diff", type=float, default=0.01, help="largest time difference to associate, s (0.01)")
    p.add_argument("--offset", type=float, default=0.0, help="seconds added to the estimate's stamps (0)")
    p.add_argument(
        "--interpolate",
        action="store_true",
        help="interpolate the denser trajectory at the matched stamps instead of taking its nearest poses",
    )
    p.add_argument("--rpe-delta", type=float, default=1, help="RPE step: frames, or metres with --rpe-unit m (1)")
    p.add_argument("--rpe-unit", choices=("frames", "m"), default="frames", help="unit of --rpe-delta (frames)")
    p.add_argument("--rpe-all-pairs", action="store_true", help="RPE over a pair starting at every pose")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--plot", metavar="FILE.png", help="draw both trajectories and the errors (needs matplotlib)")
    p.add_argument("--force", action="store_true", help="replace an existing --plot file")
    return p


def _table(result: dict) -> str:
    rows = [
        ("ATE translation [m]", result["ate_m"]),
        ("orientation [deg]", result["orientation_deg"]),
        ("RPE translation [m]", result["rpe_translation_m"]),
        ("RPE rotation [deg]", result["rpe_rotation_deg"]),
    ]
    keys = ("rmse", "mean", "median", "std", "min", "max")
    head = f"{'':22s}" + "".join(f"{k:>12s}" for k in keys)
    lines = [head] + [f"{name:22s}" + "".join(f"{stats[k]:12.6f}" for k in keys) for name, stats in rows]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose eval``."""
    from pathlib import Path

    from dualpose.evaluation.metrics import evaluate
    from dualpose.io import detect_format, read_trajectory

    if args.plot and Path(args.plot).exists() and not args.force:
        print(f"dualpose eval: error: {args.plot}: file exists; use --force to replace it", file=sys.stderr)
        return 1
    try:
        fmt_ref, fmt_est = detect_format(args.reference), detect_format(args.estimate)
        reference = read_trajectory(args.reference, fmt_ref)
        estimate = read_trajectory(args.estimate, fmt_est)
        ev = evaluate(
            reference,
            estimate,
            align=args.align,
            align_first_n=args.n_align,
            max_diff=args.max_diff,
            offset=args.offset,
            sync="interpolate" if args.interpolate else "nearest",
            rpe_delta=args.rpe_delta,
            rpe_unit=args.rpe_unit,
            rpe_all_pairs=args.rpe_all_pairs,
        )
    except (OSError, ValueError) as exc:
        print(f"dualpose eval: error: {exc}", file=sys.stderr)
        return 1
    result = ev.as_dict()
    result["settings"]["reference_format"] = fmt_ref
    result["settings"]["estimate_format"] = fmt_est
    if args.plot:
        from dualpose.evaluation.plot import plot_evaluation

        try:
            plot_evaluation(ev, args.plot, overwrite=args.force)
        except (OSError, ImportError) as exc:
            print(f"dualpose eval: error: {exc}", file=sys.stderr)
            return 1
        result["plot"] = str(args.plot)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    a = ev.alignment
    print(f"reference  {args.reference} ({fmt_ref}, {len(reference)} poses)")
    print(f"estimate   {args.estimate} ({fmt_est}, {len(estimate)} poses)")
    print(
        f"matched    {result['matched_poses']} poses (max diff {args.max_diff} s, offset {args.offset} s"
        + (", interpolated" if args.interpolate else "")
        + "); "
        f"alignment {a.method}"
        + (f", scale {a.scale:.6f}" if a.method in ("sim3", "scale") else "")
        + (f" from the first {args.n_align} poses" if args.n_align and a.method not in ("none", "origin") else "")
    )
    print(f"RPE        {result['rpe_pairs']} pairs, delta {args.rpe_delta:g} {args.rpe_unit}\n")
    print(_table(result))
    if args.plot:
        print(f"\nplot written to {args.plot}")
    return 0
