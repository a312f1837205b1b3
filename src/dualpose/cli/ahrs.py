"""``dualpose ahrs FILE [--mag/--no-mag] [--json]``: orientation-only filter on a BROAD trial, scored with BROAD's
metric (total / heading / inclination RMSE over the movement samples) when the file has a reference.

``dualpose ahrs --stream --rate HZ [--no-mag] [--rest-seconds S]``: the same filter on IMU samples read as text lines
from standard input, one orientation line written (and flushed) per input line as soon as it is known; the line
formats, the rest period and the exit statuses are in docs/broad.md, "Streaming" (the job is
:func:`dualpose.pipelines.ahrs_stream.stream_ahrs_lines`).

``dualpose ahrs FILE --offline``: the offline orientation, the filter's RTS smoother (forward filter, backward
pass; :mod:`dualpose.estimation.ahrs.smoother`, job in :func:`dualpose.pipelines.ahrs_offline.smooth_broad_trial`),
scored next to the forward filter's (``forward_*`` keys); the magnetometer self-calibration decision is on by default
there (``--no-mag-calibration`` switches it off); docs/broad.md, "Offline (smoothed)".

9D (``--mag``, default) is scored as BROAD publishes it, in the magnetic ENU frame without alignment; 6D
(``--no-mag``) has no absolute heading, so one constant heading offset is removed first (see
:mod:`dualpose.evaluation.orientation_errors`); it does not need the file's ``imu_mag`` field.  Exit status: 0, 2 on
bad arguments, 1 on an unreadable or invalid file (the message names the file and the field; docs/broad.md).
"""

from __future__ import annotations

import argparse
import json
import sys

from dualpose.cli._args import add_bag_time_argument, float_in
from dualpose.cli._batch import add_scheduler_arguments
from dualpose.cli._stream import write_flushed

_STREAM_HELP = """\
streaming (--stream): read IMU samples from standard input, one per line:
  t, gx, gy, gz, ax, ay, az[, mx, my, mz]      (s, rad/s, m/s^2, any field unit; 6 IMU fields with --no-mag)
comma or whitespace separated; '#' starts a comment; blank and comment lines are skipped and give no output.
The filter steps by 1/--rate (the time stamps must only increase).  One line per input sample is written to
standard output and flushed at once:
  t, qx, qy, qz, qw                             (orientation IMU -> earth (ENU), xyzw, repr: exact float64)
Every output is causal and written at its own input line.  The first --rest-seconds (default 1 s) initialise the
filter: inside them the output is the orientation of the running mean specific force and field so far; at their
last sample the filter starts from the rest statistics (--rest-seconds 0: from the first sample).  The
magnetometer-gyroscope time offset is estimated online and compensated.
Exit status: 0 at the end of the input; 1 on a malformed line (wrong number of fields, not a number, non-finite,
time not increasing), with 'stdin line N: ...' on stderr and every line before it already written; 2 on bad
arguments; 141 when the reader of standard output goes away.
"""


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose ahrs``."""
    p = subparsers.add_parser(
        "ahrs",
        help="orientation-only filter (gyro + acc [+ mag]) on a BROAD trial, scored with BROAD's metric",
        description="Run dualpose's orientation-only error-state filter on a BROAD .mat trial and print its RMSE "
        "against the optical reference (total / heading / inclination, degrees, movement samples); or, with "
        "--stream, on IMU samples read line by line from standard input, printing one orientation per line.",
        epilog=_STREAM_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("file", nargs="?", help="BROAD trial file (.mat), or a sensor_msgs/Imu topic of a ROS bag "
                   "FILE.bag:/topic (.db3, .mcap too; no reference: nothing scored); not with --stream")  # fmt: skip
    p.add_argument("--mag-topic", metavar="TOPIC",
                   help="with a bag: its sensor_msgs/MagneticField topic (9D); without it a bag runs 6D")  # fmt: skip
    add_bag_time_argument(p)
    p.add_argument("--stream", action="store_true",
                   help="read IMU sample lines from stdin, write one orientation line per sample (see below)")
    p.add_argument("--rate", type=float_in(0.0, 1e9, lo_open=True), metavar="HZ",
                   help="sampling rate of the streamed samples, Hz (required with --stream)")
    p.add_argument("--rest-seconds", type=float_in(0.0, 1e6), default=None, metavar="S",
                   help="with --stream or a bag: leading seconds at rest that initialise the filter (default 1; "
                   "0: none)")  # fmt: skip
    p.add_argument("--mag", dest="mag", action=argparse.BooleanOptionalAction, default=True,
                   help="use the magnetometer (9D, default) or not (--no-mag: 6D)")
    p.add_argument("--offline", action="store_true",
                   help="smooth the whole recording (RTS smoother over the filter; not with --stream)")
    p.add_argument("--mag-calibration", action=argparse.BooleanOptionalAction, default=None,
                   help="self-calibrate the magnetometer (hard/soft iron) when the recording supports it "
                   "(default: off)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--batch", nargs="+", metavar="SOURCE",
                   help="run over many recordings: BROAD .mat files, EuRoC IMU CSVs (imu0/data.csv), directories of "
                   "them, glob patterns, or a manifest CSV with a 'recording' (and 'dataset') column; prints the "
                   "summary per dataset, --out DIR writes the tables and rmse.png (docs/scaling.md)")  # fmt: skip
    p.add_argument("--out", metavar="DIR", help="with --batch: write results.csv, summary.csv (and .parquet with "
                   "pyarrow) and rmse.png into DIR")  # fmt: skip
    p.add_argument("--force", action="store_true", help="with --batch --out: replace existing output files")
    add_scheduler_arguments(p)
    return p


def _usage_error(message: str) -> int:
    print(f"dualpose ahrs: error: {message}", file=sys.stderr)
    return 2


def run_stream(args: argparse.Namespace) -> int:
    """``dualpose ahrs --stream``: stdin lines in, one flushed orientation line per sample out."""
    from dualpose.pipelines.ahrs_stream import stream_ahrs_lines

    if args.file is not None:
        return _usage_error(f"--stream reads standard input: no file argument ({args.file!r})")
    if args.rate is None:
        return _usage_error("--stream needs the sampling rate: --rate HZ")
    if args.offline:
        return _usage_error("--offline smooths a whole recording file: not with --stream")
    if args.json or args.mag_calibration is not None:
        return _usage_error("--json and --mag-calibration are not used with --stream")
    from dualpose.types._inputs import check_rate, check_rest_samples

    rest_seconds = 1.0 if args.rest_seconds is None else args.rest_seconds  # the documented default
    n_rest = round(rest_seconds * args.rate)
    try:  # the checks AhrsStream makes, as usage errors naming the options (docs/refusals.md)
        check_rate(args.rate, "--rate")
        check_rest_samples(n_rest, args.rate, "--rest-seconds")
    except ValueError as exc:
        return _usage_error(str(exc))
    if 0 < n_rest < 10:
        return _usage_error(f"--rest-seconds {rest_seconds:g} at --rate {args.rate:g} is {n_rest} samples; "
                            "the rest period needs at least 10 samples, or 0 for none")  # fmt: skip
    from dualpose.io._text import bounded_lines

    return write_flushed(stream_ahrs_lines(bounded_lines(), args.rate, use_mag=args.mag, n_rest=n_rest), "ahrs")


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose ahrs``."""
    if args.batch is not None:
        return run_batch(args)
    used = [n for n, v in (("--out", args.out), ("--force", args.force), ("--scheduler", args.scheduler),
                           ("--workers", args.workers)) if v]  # fmt: skip
    if used:
        return _usage_error(f"{', '.join(used)}: only used with --batch")
    if args.stream:
        return run_stream(args)
    if args.file is None:
        return _usage_error("a BROAD trial file, or --stream to read IMU samples from standard input")
    if args.rate is not None:
        return _usage_error("--rate is only used with --stream (a BROAD file has its own rate)")
    from dualpose.io.rosbag import is_bag_source, read_bag_imu_trial

    bag = is_bag_source(args.file)
    if args.rest_seconds is not None and not bag:
        return _usage_error("--rest-seconds is only used with --stream or a bag (a BROAD file marks its own static "
                            "start)")  # fmt: skip
    if args.mag_topic is not None and not bag:
        return _usage_error("--mag-topic names a topic of the bag: only with a bag FILE.bag:/topic")

    from dualpose.estimation.ahrs import estimate_orientation
    from dualpose.io import load_broad
    from dualpose.pipelines.ahrs_offline import broad_scores, smooth_broad_trial

    try:
        if bag:
            rest = 1.0 if args.rest_seconds is None else args.rest_seconds
            trial = read_bag_imu_trial(args.file, args.mag_topic if args.mag else None, stamps=args.bag_time,
                                       rest_seconds=rest)  # fmt: skip
        else:
            trial = load_broad(args.file)
    except (OSError, ValueError, ImportError) as exc:
        msg = str(exc)
        if args.file not in msg:
            msg = f"{args.file}: {msg}"
        print(f"dualpose ahrs: error: {msg}", file=sys.stderr)
        return 1
    if args.mag and not trial.has_mag:
        what = "no --mag-topic (magnetometer)" if bag else "no field imu_mag (magnetometer)"
        print(f"dualpose ahrs: error: {args.file}: {what}: use --no-mag for 6D", file=sys.stderr)
        return 1
    calibrate = bool(args.mag_calibration)
    smoothed = scores = None
    try:
        if not bag:
            trial.require_finite(("imu_gyr", "imu_acc", "imu_mag") if args.mag else ("imu_gyr", "imu_acc"))
        if args.offline:
            mag_cal = "auto" if calibrate else None
            smoothed, scores = smooth_broad_trial(trial, use_mag=args.mag, mag_calibration=mag_cal)
            result = smoothed.forward
        else:
            result = estimate_orientation(
                trial.gyr, trial.acc, trial.mag if args.mag else None, trial.rate, use_mag=args.mag,
                n_rest=max(trial.static_start, 10), mag_calibration="auto" if calibrate else None,
            )  # fmt: skip
        if not args.offline:
            scores = broad_scores(result.quat, trial, use_mag=args.mag)
    except ValueError as exc:
        print(f"dualpose ahrs: error: {args.file}: {exc}", file=sys.stderr)
        return 1
    out: dict[str, object] = {
        "file": str(args.file),
        "mode": "9D" if args.mag else "6D",
        "offline": bool(args.offline),
        "samples": int(result.quat.shape[0]),
        "rate_hz": trial.rate,
        # offline: forward and backward pass together
        "us_per_sample": smoothed.us_per_sample if smoothed is not None else result.us_per_sample,
        "acc_rejected": result.acc_rejected,
        "mag_rejected": result.mag_rejected,
        # samples the rest detector flagged after the initial rest period, and the bias updates made there
        "rest_samples": result.rest_samples,
        "rest_updates": result.rest_updates,
        # compensated magnetometer lag behind the gyroscope, from the IMU data alone: estimated online (causally),
        # the estimate after the last sample; --offline: estimated from the whole recording (None in 6D)
        "mag_time_offset_ms": result.mag_time_offset_ms if args.mag else None,
        # magnetometer self-calibration (--mag-calibration): applied only when the data support it (None in 6D)
        "mag_calibration_applied": result.mag_calibration_applied if args.mag else None,
    }
    if args.mag and result.mag_calibration is not None:
        out.update(result.mag_calibration.as_dict())
    has_ref = scores is not None
    if scores is not None:
        out.update(scores)
    else:
        out.update(total_rmse_deg=None, heading_rmse_deg=None, inclination_rmse_deg=None)
    if args.json:
        print(json.dumps(out))
        return 0
    kind = ", offline: RTS smoother" if args.offline else ""
    print(f"dualpose ahrs: {trial.name} ({out['mode']}{kind}, {out['samples']} samples at {trial.rate:.1f} Hz)")
    if has_ref:
        for label, key in (("total", "total_rmse_deg"), ("heading", "heading_rmse_deg"),
                           ("inclination", "inclination_rmse_deg")):  # fmt: skip
            line = f"  {label + ' RMSE':<18}{out[key]:8.3f} deg"
            print(line + (f"   (forward filter {out['forward_' + key]:.3f} deg)" if args.offline else ""))
        if not args.mag:
            print(f"  heading offset removed (6D): {out['heading_offset_deg']:.2f} deg")
    else:
        print("  no reference orientation on the movement samples: nothing scored")
    if args.mag:
        how = ("estimated from the whole recording's IMU data, compensated" if args.offline
               else "estimated online from the IMU data, compensated; value after the last sample")  # fmt: skip
        print(f"  mag time offset   {out['mag_time_offset_ms']:8.3f} ms ({how})")
    if args.mag and result.mag_calibration is not None:
        cal = result.mag_calibration
        print(f"  mag calibration   {'applied' if cal.applied else 'not applied'} ({cal.reason})")
    print(f"  {'smoother' if args.offline else 'filter'} time{'' if args.offline else '  '}     "
          f"{out['us_per_sample']:8.3f} us/sample")
    return 0


def run_batch(args: argparse.Namespace) -> int:
    """``dualpose ahrs --batch SOURCE... [--no-mag] [--offline] [--out DIR]``: the filter over many recordings."""
    from pathlib import Path

    from dualpose.cli._batch import finish_job, job_progress, scheduler_of
    from dualpose.cli._output import OutputError, output_directory
    from dualpose.jobs.ahrs_batch import ahrs_recordings, run_ahrs_batch
    from dualpose.jobs.figures import box_plot, job_output_names

    used = [n for n, v in (("a file argument", args.file), ("--stream", args.stream), ("--rate", args.rate is not None),
                           ("--rest-seconds", args.rest_seconds is not None), ("--mag-topic", args.mag_topic),
                           ("--json", args.json)) if v]  # fmt: skip
    if used:
        return _usage_error(f"--batch names its recordings: not with {', '.join(used)}")
    try:
        out = None if args.out is None else output_directory(args.out, job_output_names(("rmse.png",)), args.force,
                                                             args.batch)  # fmt: skip
    except OutputError as exc:
        return _usage_error(str(exc))
    try:
        recs = ahrs_recordings(args.batch, use_mag=args.mag, offline=args.offline,
                               mag_calibration=bool(args.mag_calibration))  # fmt: skip
        with job_progress(len(recs), "ahrs") as step:
            result = run_ahrs_batch(recs, scheduler=scheduler_of(args, "ahrs"), workers=args.workers, progress=step)
    except (OSError, ValueError, ImportError) as exc:
        print(f"dualpose ahrs: error: {exc}", file=sys.stderr)
        return 1

    def rmse_figure(path: Path) -> None:
        box_plot(result.table, "total_rmse_deg", path, hue="mode", ok=lambda r: r["status"] == "ok",
                 ylabel="total orientation RMSE [deg]")  # fmt: skip

    return finish_job("ahrs", result, lambda r: str(r["recording"]), out, {"rmse.png": rmse_figure})
