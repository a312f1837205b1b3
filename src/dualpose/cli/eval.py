"""``dualpose eval``: trajectory accuracy (ATE, orientation error, RPE) of an estimate against a reference.

Like ``evo_ape`` + ``evo_rpe`` in one command, with the formats (TUM, KITTI, EuRoC ground-truth CSV) detected from
the files.  Exit status: 0 on success, 1 when a file cannot be read or evaluated (the message names file and line),
2 for usage errors (contradictory options).  Warnings (unsorted stamps, duplicate poses) go to stderr as
``dualpose eval: warning: ...``; progress of slow stages too (``--quiet`` turns it off).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import warnings
from typing import Any

from dualpose.cli._args import add_bag_time_argument
from dualpose.cli._batch import add_scheduler_arguments
from dualpose.cli._progress import Progress, add_quiet_argument

_STAGES = ("read reference", "read estimate", "associate, align, ATE, RPE", "plot")


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose eval``."""
    p = subparsers.add_parser(
        "eval",
        help="ATE / RPE / orientation error of an estimated trajectory (TUM, KITTI, EuRoC files or ROS bag topics)",
        description=(
            "Associate the poses by timestamp, align the estimate to the reference (Umeyama), and print statistics "
            "of the absolute trajectory error (ATE), the orientation error and the relative pose error (RPE). "
            "The numbers equal those of evo_ape / evo_rpe with the same settings. KITTI pose files carry no stamps: "
            "give them with --ref-times / --est-times (one number of seconds per line, KITTI's times.txt), "
            "otherwise pose i is at i seconds."
        ),
    )
    p.add_argument("reference", nargs="?", help="reference trajectory: TUM file, KITTI pose file, EuRoC ground-truth "
                   "CSV or a ROS bag topic FILE.bag:/topic or FILE.bag:/tf:PARENT:CHILD (.db3, .mcap too)")  # fmt: skip
    p.add_argument("estimate", nargs="?", help="estimated trajectory: as the reference")
    p.add_argument("--batch", metavar="MANIFEST",
                   help="evaluate many pairs instead: a CSV manifest with the columns reference, estimate, algorithm, "
                   "dataset, run, or an rpg_trajectory_evaluation results folder (PLATFORM/ALG/PLATFORM_ALG_DATASET/"
                   "stamped_groundtruth.txt, stamped_traj_estimate[N].txt); prints the summary per dataset and "
                   "algorithm, --out DIR writes the tables and box plots (docs/scaling.md)")  # fmt: skip
    p.add_argument("--out", metavar="DIR", help="with --batch: write results.csv, summary.csv (and .parquet with "
                   "pyarrow) and box plots (ate_rmse.png, rpe_translation.png) into DIR")  # fmt: skip
    add_scheduler_arguments(p)
    p.add_argument("--ref-times", metavar="FILE", help="stamps of a KITTI reference, s (default: pose index)")
    p.add_argument("--est-times", metavar="FILE", help="stamps of a KITTI estimate, s (default: pose index)")
    p.add_argument(
        "--align",
        choices=("se3", "sim3", "scale", "origin", "posyaw", "none"),
        default="se3",
        help="alignment of the estimate: Umeyama rigid (se3, default), with scale (sim3), scale only (scale), "
        "first poses made equal (origin), position + yaw about z (posyaw, 4-DoF for VIO), or none",
    )
    p.add_argument("--n-align", type=int, metavar="N", help="estimate the alignment from the first N matched poses")
    p.add_argument("--max-diff", type=float, default=0.01, help="largest time difference to associate, s (0.01)")
    p.add_argument("--offset", type=float, default=0.0, help="seconds added to the estimate's stamps (0)")
    p.add_argument("--t-start", type=float, metavar="T", help="use only poses stamped at or after T s (evo --t_start)")
    p.add_argument("--t-end", type=float, metavar="T", help="use only poses stamped at or before T s (evo --t_end)")
    p.add_argument(
        "--interpolate",
        action="store_true",
        help="interpolate the denser trajectory at the matched stamps instead of taking its nearest poses",
    )
    p.add_argument("--rpe-delta", type=float, default=1, help="RPE step: frames, or metres with --rpe-unit m (1)")
    p.add_argument("--rpe-unit", choices=("frames", "m"), default="frames", help="unit of --rpe-delta (frames)")
    p.add_argument("--rpe-all-pairs", action="store_true", help="RPE over a pair starting at every pose")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="draw both trajectories and the errors (needs matplotlib); the format follows the extension "
        "(.png, .pdf, .svg, ...)",
    )
    p.add_argument("--force", action="store_true", help="replace an existing --plot file (never an input file)")
    add_bag_time_argument(p)
    add_quiet_argument(p)
    return p


def _table(result: dict[str, Any]) -> str:
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


def _error(message: object, code: int) -> int:
    print(f"dualpose eval: error: {message}", file=sys.stderr)
    return code


def _usage_problem(args: argparse.Namespace) -> str | None:
    """The first contradictory or invalid option, or None."""
    for name in ("max_diff", "offset", "rpe_delta", "t_start", "t_end"):
        v = getattr(args, name)
        if v is not None and not math.isfinite(v):
            return f"--{name.replace('_', '-')} must be a finite number; got {v}"
    if args.rpe_unit == "frames" and not (args.rpe_delta >= 1 and args.rpe_delta == int(args.rpe_delta)):
        return f"--rpe-delta must be a whole number of frames >= 1 (--rpe-unit frames); got {args.rpe_delta:g}"
    if args.rpe_unit == "m" and not args.rpe_delta > 0:
        return f"--rpe-delta must be a distance > 0 m (--rpe-unit m); got {args.rpe_delta:g}"
    if args.max_diff < 0:
        return f"--max-diff must be >= 0; got {args.max_diff}"
    if args.t_start is not None and args.t_end is not None and args.t_start >= args.t_end:
        return f"--t-start ({args.t_start}) must be smaller than --t-end ({args.t_end})"
    if args.n_align is not None:
        if args.align in ("none", "origin"):
            return (f"--n-align applies to --align se3, sim3, scale or posyaw; it has no effect with --align "
                    f"{args.align}")  # fmt: skip
        if args.n_align < 3:
            return f"--n-align must be >= 3 (an alignment needs 3 points); got {args.n_align}"
    if args.plot:
        from pathlib import Path

        ext = Path(args.plot).suffix.lower().lstrip(".")
        known = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp", "pgf")
        if ext not in known:
            return f"--plot {args.plot}: unknown figure format {ext!r}; use one of .{', .'.join(known)}"
    return None


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose eval``."""
    from dualpose.evaluation.metrics import evaluate
    from dualpose.io import detect_format, read_trajectory

    plot_file = None
    if args.plot:
        from dualpose.cli._output import OutputError, output_file

        try:  # checked before anything is read or computed
            plot_file = output_file(args.plot, "--plot", args.force,
                                    [args.reference, args.estimate, args.ref_times, args.est_times])  # fmt: skip
        except OutputError as exc:
            return _error(exc, 2)
    problem = _usage_problem(args)
    if problem:
        return _error(problem, 2)
    if args.batch is not None:
        return run_batch(args)
    if args.reference is None or args.estimate is None:
        return _error("give the reference and the estimate trajectory (or --batch MANIFEST)", 2)
    used = [n for n, v in (("--out", args.out), ("--scheduler", args.scheduler), ("--workers", args.workers)) if v]
    if used:
        return _error(f"{', '.join(used)}: only used with --batch", 2)
    stages = _STAGES if args.plot else _STAGES[:-1]
    with warnings.catch_warnings(record=True) as caught, Progress(
        "eval", stages, enabled=False if args.quiet else None
    ) as progress:
        warnings.simplefilter("always")
        try:
            with progress.stage("read reference"):
                fmt_ref = detect_format(args.reference)
                reference = read_trajectory(args.reference, fmt_ref, args.ref_times, bag_time=args.bag_time)
            with progress.stage("read estimate"):
                fmt_est = detect_format(args.estimate)
                estimate = read_trajectory(args.estimate, fmt_est, args.est_times, bag_time=args.bag_time)
            with progress.stage("associate, align, ATE, RPE"):
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
                    t_start=args.t_start,
                    t_end=args.t_end,
                )
        except (OSError, ValueError, ImportError) as exc:
            return _error(exc, 1)
        finally:
            for w in caught:
                print(f"dualpose eval: warning: {w.message}", file=sys.stderr)
            caught.clear()
        result = ev.as_dict()
        result["settings"]["reference_format"] = fmt_ref
        result["settings"]["estimate_format"] = fmt_est
        if plot_file is not None:
            from dualpose.evaluation.plot import plot_evaluation

            try:
                with progress.stage("plot"), plot_file.writing() as tmp:
                    plot_evaluation(ev, tmp, overwrite=True)
            except (OSError, ImportError, ValueError) as exc:
                return _error(exc, 1)
            result["plot"] = str(args.plot)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    a = ev.alignment
    print(f"reference  {args.reference} ({fmt_ref}, {len(reference)} poses)")
    print(f"estimate   {args.estimate} ({fmt_est}, {len(estimate)} poses)")
    window = ""
    if args.t_start is not None or args.t_end is not None:
        window = f", window [{args.t_start if args.t_start is not None else '-inf'}, "
        window += f"{args.t_end if args.t_end is not None else 'inf'}] s"
    print(
        f"matched    {result['matched_poses']} poses (max diff {args.max_diff} s, offset {args.offset} s"
        + (", interpolated" if args.interpolate else "")
        + window
        + "); "
        f"alignment {a.method}"
        + (f", scale {a.scale:.6f}" if a.method in ("sim3", "scale") else "")
        + (f" from the first {args.n_align} poses" if args.n_align and a.method not in ("none", "origin") else "")
    )
    if a.conditioning is not None:
        c = a.conditioning
        print(
            f"alignment  determined to rotation {math.degrees(c.rotation_std_rad):.3g} deg, translation "
            f"{c.translation_std_m:.3g} m" + (f", scale {c.scale_std:.3g}" if a.method in ("sim3", "scale") else "")
            + f" (1 sigma, residual noise {c.noise_m:.3g} m)" + ("" if c.well_determined else "; POORLY DETERMINED")
        )
    print(f"RPE        {result['rpe_pairs']} pairs, delta {args.rpe_delta:g} {args.rpe_unit}\n")
    print(_table(result))
    if args.plot:
        print(f"\nplot written to {args.plot}")
    return 0


#: figures of ``eval --batch --out``: file name -> (metric column, axis label)
_BATCH_FIGURES = {"ate_rmse.png": ("ate_rmse_m", "ATE RMSE [m]"),
                  "rpe_translation.png": ("rpe_translation_rmse_m", "RPE translation RMSE [m]")}  # fmt: skip


def run_batch(args: argparse.Namespace) -> int:
    """``dualpose eval --batch MANIFEST [--out DIR]``: every pair of the manifest on the scheduler."""
    from collections.abc import Callable
    from pathlib import Path

    from dualpose.cli._batch import finish_job, job_progress, scheduler_of
    from dualpose.cli._output import OutputError, output_directory
    from dualpose.jobs.eval_batch import EvalSettings, read_eval_manifest, run_eval_batch
    from dualpose.jobs.figures import box_plot, job_output_names

    used = [n for n, v in (("a reference", args.reference), ("an estimate", args.estimate), ("--plot", args.plot),
                           ("--json", args.json), ("--ref-times", args.ref_times), ("--est-times", args.est_times))
            if v]  # fmt: skip
    if used:
        return _error(f"--batch reads the pairs from its manifest: not with {', '.join(used)}", 2)
    try:
        out = None if args.out is None else output_directory(args.out, job_output_names(tuple(_BATCH_FIGURES)),
                                                             args.force, [args.batch])  # fmt: skip
    except OutputError as exc:
        return _error(exc, 2)
    settings = EvalSettings(
        align=args.align, n_align=args.n_align, max_diff=args.max_diff, offset=args.offset,
        interpolate=args.interpolate, rpe_delta=args.rpe_delta, rpe_unit=args.rpe_unit,
        rpe_all_pairs=args.rpe_all_pairs, t_start=args.t_start, t_end=args.t_end,
    )  # fmt: skip
    try:
        pairs = read_eval_manifest(args.batch, settings)
        with job_progress(len(pairs), "eval", args.quiet) as step:
            result = run_eval_batch(pairs, scheduler=scheduler_of(args, "eval"), workers=args.workers, progress=step)
    except (OSError, ValueError, ImportError) as exc:
        return _error(exc, 1)

    def figure(metric: str, label: str) -> Callable[[Path], None]:
        return lambda path: box_plot(result.table, metric, path, ok=lambda r: r["status"] == "ok", ylabel=label)

    figures = {name: figure(metric, label) for name, (metric, label) in _BATCH_FIGURES.items()}
    return finish_job("eval", result, lambda r: f"{r['dataset']} / {r['algorithm']} / run {r['run']}", out,
                      figures)
