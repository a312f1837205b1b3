"""``dualpose fuse``: camera-IMU pose tracking on the simulated eight-shaped run or a recording, evaluated against the
ground truth when there is one.

``--data`` is "sim" (default), a recording directory or its ``sensors.json`` (format: ``docs/fusion.md``), or a BROAD
trial ``.mat`` (pseudo-vision, ``docs/broad-pose.md``). Prints a summary table (or one JSON object with ``--json``);
with ``--out DIR`` writes ``trajectory.tum`` (the estimate, TUM format), ``metrics.json`` and PNG figures (top view,
errors with 3σ bounds, NIS vs χ² bounds) and ``manifest.json``, as one set renamed into place when complete; an
earlier run's set is replaced as a whole with ``--force`` and never otherwise (docs/refusals.md). ``--smooth``
(ESKF only) also runs the offline RTS smoother: the table and JSON (``"smoothed"``) report filter and smoother side
by side and ``--out`` adds ``trajectory_smoothed.tum``.  The output directory is checked (a directory or creatable,
writable) before anything is computed.  Warnings about the input (IMU gaps, a doubtful gravity vector; docs/fusion.md
"Checks on the input") are printed on stderr, one line each.  Exit status: 0 on success, 2 on bad arguments, an
unusable output location or an output file that exists, 1 on a missing, malformed or unusable input (the message
names the file and line).

``dualpose fuse --stream --calibration FILE [--filter eskf|hol22]``: the filter on IMU and camera-correspondence lines
read from standard input, one pose line written (and flushed) per IMU line as soon as it is known; the calibration
file (a recording's sensor file with ``imu.update_rate`` and an ``initial_state``), the line formats and the exit
statuses are in docs/fusion.md, "Streaming" (the job is :func:`dualpose.pipelines.fuse_stream.stream_fusion_lines`).

Calibration-target recordings (docs/fusion.md, "Tracking on EuRoC imu_april"): ``dualpose fuse --data DIR --camera
cam0 --calibration CALIB.json`` where DIR holds ``imu0.csv``, ``camN_aprilgrid.csv`` and ``sensors.yaml``; CALIB.json
is the camera-IMU calibration (``dualpose calibrate camera-imu ... --json``).  The world is the target frame; scored
against another camera's per-frame PnP when DIR has its detections (:mod:`dualpose.pipelines.track_target`).  An
offline run: ``trajectory.tum`` is the RTS-smoothed track (``--output smoothed``, the default with the ESKF; one
smoothing segment per filter start or re-lock) and ``trajectory_filter.tum`` the causal filter's; ``--output filter``
writes the causal filter only (the default with Hol22, which has no smoother).  ``--outage A:B`` (repeatable)
deletes the camera's detections over [A, B) s from the first IMU sample.  Streaming: ``dualpose fuse --stream
--sensors sensors.yaml --camera cam0 --calibration CALIB.json`` (camera lines with the measured, distorted pixels):
causal, the poses of ``trajectory_filter.tum`` bit for bit.  ``--calibration`` is thus the camera-IMU calibration
with ``--data DIR`` or ``--sensors``, and the sensor file with a filter start with a plain ``--stream``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from dualpose.cli._args import int_in, seed
from dualpose.cli._batch import add_scheduler_arguments
from dualpose.cli._stream import EXIT_DOUBTFUL, write_flushed

if TYPE_CHECKING:
    from dualpose.io._output import OutputDirectory
    from dualpose.pipelines.fuse import FuseResult

#: formats of ``--out-bag``
_BAGS = ("bag", "db3", "mcap")
#: files ``--out`` writes (besides ``manifest.json``, docs/refusals.md "Outputs")
OUTPUT_FILES: tuple[str, ...] = ("trajectory.tum", "metrics.json", "top_view.png", "errors.png", "nis.png")


_STREAM_HELP = """\
streaming (--stream --calibration FILE): read lines from standard input, one IMU sample or camera frame each:
  imu, t, gx, gy, gz, ax, ay, az                  (s IMU clock, rad/s, m/s^2; body frame)
  cam, t, n, u1, v1, X1, Y1, Z1, ..., un, vn, Xn, Yn, Zn
                                                  (s camera clock; n correspondences: undistorted pixel u, v (px),
                                                   landmark X, Y, Z in the world frame (m))
comma or whitespace separated; '#' starts a comment; blank and comment lines are skipped.  Lines in time order: a
cam line comes before the imu line at or after its time (t + camera.timeshift_cam_imu on the IMU clock) and is
filtered there.  One line per imu line is written to standard output and flushed at once:
  t, px, py, pz, qx, qy, qz, qw                   (body position in the world, m; q_wb xyzw body -> world;
                                                   repr: exact float64)
FILE is a recording's sensor file (docs/fusion.md: camera, imu, gravity) that also gives imu.update_rate and
  "initial_state": {"position": [x, y, z], "quat": [qx, qy, qz, qw], "velocity": ..., "gyro_bias": ...,
                    "accel_bias": ..., "position_sigma": m, "velocity_sigma": m/s, "attitude_sigma_deg": deg}
(position and quat required).  Exit status: 0 at the end of the input; 1 on an unreadable or invalid FILE, or a
malformed line (unknown tag, wrong number of fields, not a number, non-finite, out of time order), with
'stdin line N: ...' on stderr and every line before it already written; 2 on bad arguments; 141 when the reader of
standard output goes away.

calibration-target recordings (docs/fusion.md, "Tracking on EuRoC imu_april"):
  dualpose fuse --data DIR --camera cam0 --calibration CALIB.json [--filter ...] [--output smoothed|filter]
                [--outage A:B ...] [--out OUT]
    DIR holds imu0.csv, camN_aprilgrid.csv, sensors.yaml; CALIB.json is the camera-IMU calibration
    (keys camera, rotation_xyzw, translation_m, time_offset_s, reprojection_rms_px, optional gyro_bias,
    accel_bias, gravity_target, std).  World = target frame; gravity estimated at start-up; scored against
    another camera's per-frame PnP when DIR has its detections.  --outage A:B deletes the camera's frames in
    [A, B) s from the first IMU sample (bridging test).  Offline output: OUT/trajectory.tum is the RTS-smoothed
    track (default with eskf; one segment per filter start or re-lock), OUT/trajectory_filter.tum the causal
    filter's; --output filter writes the causal filter as trajectory.tum (default with hol22).
  dualpose fuse --stream --sensors sensors.yaml --camera cam0 --calibration CALIB.json
    the causal filter on stdin lines (trajectory_filter.tum's poses); cam lines carry the MEASURED (distorted)
    pixels and target-frame corners; the first pose line comes once the start-up window (10 s of frames) has been
    read.
"""


def _outage(text: str) -> tuple[float, float]:
    """``A:B`` seconds, B > A >= 0, for ``--outage``."""
    try:
        a, b = (float(v) for v in text.split(":"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected A:B (seconds, e.g. 20:21); got {text!r}") from None
    if not (a >= 0 and b > a and b < 1e9):
        raise argparse.ArgumentTypeError(f"expected 0 <= A < B (seconds); got {text!r}")
    return a, b


def add_parser(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose fuse``."""
    p = subparsers.add_parser(
        "fuse",
        help="camera-IMU tracking (ESKF or Hol's 22-state EKF) on the simulated eight-shaped run or a recording",
        description=(
            "Run a camera-IMU filter on the built-in simulated eight-shaped run (Hol 2008) or on a recording, "
            "starting from static alignment + first-frame PnP, and report ATE (SE(3)-aligned), RPE, orientation "
            "RMSE (when the recording has ground truth), NIS coverage and the real-time factor; or, with --stream, "
            "on IMU and camera lines read from standard input, printing one pose per IMU line."
        ),
        epilog=_STREAM_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--data",
        default=None,
        help="input: 'sim' (default), a recording directory or its sensors.json (docs/fusion.md), or a BROAD .mat",
    )
    p.add_argument("--filter", choices=("eskf", "hol22"), default="eskf", help="filter (default eskf)")
    p.add_argument("--seed", type=seed, default=None,
                   help="seed of the simulation or of BROAD's pseudo-vision (0; >= 0)")  # fmt: skip
    p.add_argument("--stream", action="store_true",
                   help="read IMU and camera lines from stdin, write one pose line per IMU line (see below)")
    p.add_argument("--calibration", metavar="FILE",
                   help="with --stream: sensor set-up and filter start (a sensor file with imu.update_rate and "
                   "initial_state; see below); with a target recording (--data DIR) or --sensors: the camera-IMU "
                   "calibration JSON")  # fmt: skip
    p.add_argument("--camera", metavar="NAME",
                   help="target recordings: the tracked camera (default cam0)")
    p.add_argument("--sensors", metavar="FILE",
                   help="with --stream: a rig's sensors.yaml (camera models, IMU noise) for a target stream")
    p.add_argument("--outage", metavar="A:B", action="append", type=_outage, default=None,
                   help="target recordings: delete the camera's detections over [A, B) s from the first IMU sample "
                   "(repeatable)")
    p.add_argument("--monte-carlo", type=int_in(1, 10**6), metavar="N", default=None,
                   help="N Monte-Carlo runs of the error-state filter on the simulator, seeds S..S+N-1 (--seed S, "
                   "default 0): NEES / NIS consistency and ATE distributions; --out DIR writes the tables, "
                   "nees.png and runs.png (docs/scaling.md)")  # fmt: skip
    add_scheduler_arguments(p)
    p.add_argument("--out", metavar="DIR", help="write trajectory.tum, metrics.json and PNG figures into DIR")
    p.add_argument("--out-bag", choices=_BAGS, metavar="FORMAT",
                   help="with --out: also write the estimate as DIR/trajectory.FORMAT, a ROS bag (bag: ROS 1; db3, "
                   "mcap: ROS 2) of geometry_msgs/PoseStamped on /dualpose/pose in frame world")  # fmt: skip
    p.add_argument("--force", action="store_true", help="replace an earlier run's --out directory as a whole")
    p.add_argument("--truth", metavar="FILE",
                   help="ground-truth trajectory (TUM, EuRoC) to score feature-track (VIO) data against")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument(
        "--smooth",
        action="store_true",
        help="also run the offline RTS smoother (eskf only) and report its metrics next to the filter's; with --out "
        "writes trajectory_smoothed.tum",
    )
    p.add_argument(
        "--output",
        choices=("smoothed", "filter"),
        default=None,
        help="calibration-target recordings (--data DIR): the trajectory written as trajectory.tum and scored in the "
        "summary -- 'smoothed' (default with eskf: the offline RTS smoother, one segment per filter start or "
        "re-lock; --out also writes the causal filter's as trajectory_filter.tum) or 'filter' (the causal filter, "
        "as --stream writes; the default with hol22, which has no smoother)",
    )
    return p


#: rows of the summary tables scored against the ground truth: label, metrics key, format
_ERROR_ROWS = (
    ("ATE RMSE (SE(3)) [m]", "ate_rmse_m", ".6f"),
    ("orientation RMSE (SE(3)) [deg]", "orientation_rmse_deg", ".4f"),
    ("RPE RMSE (0.5 m) [m]", "rpe_rmse_m", ".6f"),
    ("position RMSE, unaligned [m]", "position_rmse_unaligned_m", ".6f"),
    ("orientation RMSE, unaligned [deg]", "orientation_rmse_unaligned_deg", ".4f"),
)


def _doubt_rows(m: dict[str, Any]) -> list[tuple[str, str]]:
    """The summary row naming the codes of ``m["input_doubts"]`` (none without doubts)."""
    if not m.get("input_doubts"):
        return []
    return [("input doubts (see warnings)", ", ".join(d["code"] for d in m["input_doubts"]))]


def _table(m: dict[str, Any]) -> str:
    from dualpose.cli._output import aligned_rows

    def num(key: str, spec: str) -> str:
        return "n/a (no ground truth)" if m[key] is None else format(m[key], spec)

    if "smoothed" in m:
        return _table_smoothed(m, num)
    rows = [
        ("data", m["data"]),
        ("filter", m["filter"]),
        *((label, num(key, fmt)) for label, key, fmt in _ERROR_ROWS),
        ("NIS inside 95% band", f"{m['nis_fraction_inside']:.3f}"),
        ("correspondences rejected", f"{m['n_rejected']} of {m['n_correspondences']}"),
        ("real-time factor", f"{m['realtime_factor']:.1f}x"),
    ]
    return aligned_rows(rows + _doubt_rows(m))


def _table_smoothed(m: dict[str, Any], num: Callable[[str, str], str]) -> str:
    """The summary table with a filter and a smoother column (``--smooth``)."""
    s = m["smoothed"]
    rows = [("data", m["data"], ""), ("method", "filter", "RTS smoother")]
    rows += [
        (label, num(key, fmt), "n/a" if s[key] is None else format(s[key], fmt)) for label, key, fmt in _ERROR_ROWS
    ]
    rows += [
        ("NIS inside 95% band", f"{m['nis_fraction_inside']:.3f}", ""),
        ("correspondences rejected", f"{m['n_rejected']} of {m['n_correspondences']}", ""),
        ("real-time factor", f"{m['realtime_factor']:.1f}x", ""),
        ("backward pass [s]", "", f"{s['smoother_wall_time_s']:.4f}"),
    ]
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    w2 = max(len(r[2]) for r in rows)
    return "\n".join(f"{a:<{w0}}  {b:>{w1}}  {c:>{w2}}".rstrip() for a, b, c in rows)


def _output_files(smooth: bool) -> tuple[str, ...]:
    """The files ``--out`` writes (``trajectory_smoothed.tum`` too with ``--smooth``)."""
    return OUTPUT_FILES + (("trajectory_smoothed.tum",) if smooth else ())


def _run_job(args: argparse.Namespace) -> FuseResult | None:
    """``run_fuse`` on ``--data`` with a progress bar; warnings about the input are printed one line each, a bad
    input is reported on stderr (file and line) and gives None."""
    import warnings

    from dualpose.cli._progress import progress_bar
    from dualpose.io.recording import RecordingError
    from dualpose.pipelines.fuse import run_fuse

    with warnings.catch_warnings(record=True) as caught, progress_bar(4, "dualpose fuse") as bar:
        warnings.simplefilter("always", UserWarning)

        def progress(done: int, total: int, stage: str) -> None:
            bar.set_postfix_str(stage)
            bar.update(1)

        try:
            result: FuseResult | Exception = run_fuse(
                data="sim" if args.data is None else args.data, filter=args.filter,
                seed=0 if args.seed is None else args.seed, progress=progress, smooth=args.smooth,
            )  # fmt: skip
        except (RecordingError, ValueError) as exc:
            result = exc
    for w in caught:
        text = " ".join(str(w.message).split())
        print(f"dualpose fuse: warning: {text}", file=sys.stderr)
    if isinstance(result, Exception):
        print(f"dualpose fuse: error: {' '.join(str(result).split())}", file=sys.stderr)
        return None
    return result


def _usage_error(message: str) -> int:
    print(f"dualpose fuse: error: {message}", file=sys.stderr)
    return 2


def run_stream(args: argparse.Namespace) -> int:
    """``dualpose fuse --stream``: stdin lines in, one flushed pose line per IMU line out."""
    if args.calibration is None:
        if args.sensors is not None:
            return _usage_error("--stream --sensors needs the camera-IMU calibration: --calibration CALIB.json")
        return _usage_error("--stream needs the sensor set-up and filter start: --calibration FILE")
    used = [name for name, given in (("--data", args.data is not None), ("--seed", args.seed is not None),
                                     ("--out", args.out), ("--force", args.force), ("--json", args.json),
                                     ("--smooth", args.smooth), ("--out-bag", args.out_bag),
                                     ("--outage", args.outage), ("--truth", args.truth),
                                     ("--output", args.output)) if given]  # fmt: skip
    if used:
        return _usage_error(f"{', '.join(used)}: not used with --stream (it reads standard input; the stream is the "
                            "causal filter)")  # fmt: skip
    if args.sensors is not None:
        return _run_target_stream(args)
    if args.camera is not None:
        return _usage_error("--camera with --stream needs the rig's sensor file: --sensors sensors.yaml")
    from dualpose.io.recording import RecordingError, read_sensor_setup
    from dualpose.pipelines.fuse_stream import stream_filter, stream_fusion_lines

    try:
        setup = read_sensor_setup(args.calibration)
        stream = stream_filter(setup, args.filter)
    except (RecordingError, ValueError) as exc:
        print(f"dualpose fuse: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    from dualpose.io._text import bounded_lines

    return write_flushed(stream_fusion_lines(bounded_lines(), stream, rate=setup.imu_noise.update_rate,
                                             gravity=setup.gravity), "fuse")


def _run_target_stream(args: argparse.Namespace) -> int:
    """``dualpose fuse --stream --sensors sensors.yaml --camera NAME --calibration CALIB.json``."""
    from dualpose.io.recording import RecordingError
    from dualpose.io.sensors_yaml import read_rig_sensors
    from dualpose.io.target.recording import read_camera_imu_calibration
    from dualpose.pipelines.track_target import TrackStream, stream_track_lines

    try:
        rig = read_rig_sensors(args.sensors)
        cal = read_camera_imu_calibration(args.calibration)
        stream = TrackStream(rig, args.camera or "cam0", cal, args.filter)
    except (RecordingError, ValueError, OSError) as exc:
        print(f"dualpose fuse: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    from dualpose.io._text import bounded_lines

    return write_flushed(stream_track_lines(bounded_lines(), stream), "fuse")


#: rows of the target-tracking summary: label, metrics key path, format
_TARGET_ROWS = (
    ("position RMSE vs reference [m]", ("position_rmse_m",), ".6f"),
    ("rotation RMSE vs reference [deg]", ("rotation_rmse_deg",), ".4f"),
    ("camera-only PnP: position RMSE [m]", ("camera_pnp", "position_rmse_m"), ".6f"),
    ("camera-only PnP: rotation RMSE [deg]", ("camera_pnp", "rotation_rmse_deg"), ".4f"),
    ("position NEES (3 dof) vs reference", ("nees_position",), ".2f"),
)


def _target_table(m: dict[str, Any]) -> str:
    from dualpose.cli._output import aligned_rows

    def get(path: Sequence[str]) -> Any:
        v: Any = m
        for k in path:
            v = None if v is None else v.get(k)
        return v

    ref = m["reference"]
    rows = [("data", m["data"]), ("camera", m["camera"]), ("filter", m["filter"]),
            ("output (trajectory.tum)", "RTS-smoothed, " + f"{m['smoother']['segments']} segment(s)"
             if m["output"] == "smoothed" else "causal filter"),
            ("reference", "none (no other camera's detections)" if ref is None else
             f"{ref['camera']} per-frame PnP, {ref['frames_scored']} frames")]  # fmt: skip
    for label, path, fmt in _TARGET_ROWS:
        v = get(path)
        rows.append((label, "n/a" if v is None else format(v, fmt)))
    cf = m.get("causal_filter")
    if cf is not None and cf["position_rmse_m"] is not None:
        rows.append(("causal filter: position / rotation RMSE", f"{cf['position_rmse_m']:.6f} m / "
                     f"{cf['rotation_rmse_deg']:.4f} deg"))  # fmt: skip
    for i, w in enumerate(m["outages"] or []):
        if w["frames"]:
            text = f"{w['position_max_m']:.4f} m / {w['rotation_max_deg']:.3f} deg ({w['frames']} frames)"
            if cf is not None:
                c = cf["outages"][i]
                text += f"; filter {c['position_max_m']:.4f} m / {c['rotation_max_deg']:.3f} deg"
            rows.append((f"outage {w['start_s']:g}-{w['end_s']:g} s: max position / rotation error", text))
    su = m["startup"]
    ang = su["gravity_angle_to_calibration_deg"]
    rows += [
        ("gravity (start-up) [m/s^2]", " ".join(f"{v:.4f}" for v in su["gravity_target"])
         + f" (sigma {su['gravity_sigma_deg']:.3f} deg" + ("" if ang is None else f", {ang:.3f} deg from CALIB") + ")"),
        ("NIS inside 95% band", f"{m['nis_fraction_inside']:.3f}"),
        ("correspondences rejected", f"{m['n_rejected']} of {m['n_correspondences']}"),
        ("re-locks", f"{m['relocks']}"),
        ("real-time factor (wall / CPU)", f"{m['realtime_factor']:.1f}x / {m['realtime_factor_cpu']:.1f}x"),
    ]  # fmt: skip
    return aligned_rows(rows + _doubt_rows(m))


def _report(args: argparse.Namespace, result: Any, out: OutputDirectory | None,
            table: Callable[[dict[str, Any]], str]) -> int:  # fmt: skip
    """Write ``--out``'s files (``out``: the :class:`~dualpose.io._output.OutputDirectory`, or None) of a
    :class:`~dualpose.pipelines.fuse.FuseResult` and print ``table(metrics)`` or, with ``--json``, the metrics
    (without the full evaluation)."""
    metrics = result.metrics
    written: list[str] = []
    if out is not None:
        from dualpose.evaluation.fuse_figures import fuse_figures
        from dualpose.io import write_tum

        with out.writing() as stage:
            write_tum(stage / "trajectory.tum", result.estimate)
            if result.smoothed is not None:
                write_tum(stage / "trajectory_smoothed.tum", result.smoothed)
            if result.filtered is not None:
                write_tum(stage / "trajectory_filter.tum", result.filtered)
            if args.out_bag:
                from dualpose.io.rosbag import write_trajectory_bag

                bag = stage / f"trajectory.{args.out_bag}"
                write_trajectory_bag(bag, result.estimate, "/dualpose/pose", "world")
            (stage / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
            fuse_figures(result, stage / "top_view.png", stage / "errors.png", stage / "nis.png")
            written = sorted(os.listdir(stage))
    if args.json:
        summary = {k: v for k, v in metrics.items() if k != "evaluation"}
        if out is not None:
            summary["out"] = str(out.path)
        print(json.dumps(summary, indent=2))
        return 0
    print(table(metrics))
    if out is not None:
        print(f"\nwritten to {out.path}: " + ", ".join(written + ["manifest.json"]))
    return 0


def _inputs(args: argparse.Namespace) -> list[str | None]:
    """The input files and directories of ``args`` (a recording's sensor file stands for its directory too)."""
    from pathlib import Path

    from dualpose.io.recording import SENSORS_FILE

    data = None if args.data in (None, "sim") else args.data
    found = [data, args.calibration, args.sensors, args.truth]
    if data is not None and Path(data).name == SENSORS_FILE:
        found.append(str(Path(data).parent))
    return found


def _output(args: argparse.Namespace, names: tuple[str, ...]) -> OutputDirectory | None:
    """The ``--out`` directory for ``names`` (None without ``--out``); :class:`OutputError` when it cannot take
    them."""
    from dualpose.cli._output import output_directory

    if not args.out:
        return None
    return output_directory(args.out, names, args.force, _inputs(args))


def run_target(args: argparse.Namespace) -> int:
    """``dualpose fuse --data DIR --camera NAME --calibration CALIB.json`` on a calibration-target recording."""

    if args.calibration is None:
        return _usage_error(f"{args.data} is a calibration-target recording: give the camera-IMU calibration with "
                            "--calibration CALIB.json (dualpose calibrate camera-imu ... --json)")  # fmt: skip
    used = [n for n, v in (("--seed", args.seed is not None), ("--smooth", args.smooth), ("--sensors", args.sensors),
                           ("--truth", args.truth)) if v]  # fmt: skip
    if used:
        return _usage_error(f"{', '.join(used)}: not used with a calibration-target recording")
    if args.out_bag and not args.out:
        return _usage_error("--out-bag writes into the --out directory: give --out DIR")
    from dualpose.cli._output import OutputError

    try:
        out = _output(args, OUTPUT_FILES + ("trajectory_filter.tum",) + tuple(f"trajectory.{b}" for b in _BAGS))
    except OutputError as exc:
        return _usage_error(str(exc))
    if args.output == "smoothed" and args.filter != "eskf":
        return _usage_error(f"--output smoothed needs --filter eskf (got {args.filter!r}): the RTS smoother runs over "
                            "the error-state filter's stored nodes")  # fmt: skip
    from dualpose.io.recording import RecordingError
    from dualpose.pipelines.track_target import prepare_track, run_track

    outages = tuple(args.outage or ())
    try:
        setup = prepare_track(args.data, args.calibration, args.camera or "cam0", outages)
        result = run_track(setup, args.filter, outages=outages, output=args.output)
    except (RecordingError, ValueError) as exc:
        print(f"dualpose fuse: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    code = _report(args, result, out, _target_table)
    return EXIT_DOUBTFUL if code == 0 and result.metrics.get("input_doubts") else code


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose fuse``."""
    from dualpose.cli._output import OutputError
    from dualpose.io.target.recording import is_target_recording

    if args.monte_carlo is not None:
        return run_monte_carlo(args)
    used = [n for n, v in (("--scheduler", args.scheduler), ("--workers", args.workers)) if v]
    if used:
        return _usage_error(f"{', '.join(used)}: only used with --monte-carlo")
    if args.stream:
        return run_stream(args)
    if args.data is not None and is_target_recording(args.data):
        return run_target(args)
    if args.calibration is not None:
        return _usage_error("--calibration is only used with --stream or with a calibration-target recording (--data "
                            "DIR holding imu0.csv, camN_aprilgrid.csv and sensors.yaml); a recording with "
                            "sensors.json has its own sensor file")  # fmt: skip
    used = [n for n, v in (("--camera", args.camera), ("--outage", args.outage), ("--sensors", args.sensors),
                           ("--output", args.output)) if v]  # fmt: skip
    if used:
        return _usage_error(f"{', '.join(used)}: only used with a calibration-target recording (--data DIR holding "
                            "imu0.csv, camN_aprilgrid.csv and sensors.yaml)")  # fmt: skip

    if args.data is not None:
        from dualpose.pipelines.vio import is_track_data

        if is_track_data(args.data):  # feature tracks of an unknown scene: visual-inertial odometry (docs/vio.md)
            from dualpose.cli._vio import run_vio_job

            return run_vio_job(args)
    if args.truth is not None:
        return _usage_error("--truth is only used with feature-track data (docs/vio.md); recordings carry theirs")
    if args.smooth and args.filter != "eskf":
        print(f"dualpose fuse: error: --smooth needs --filter eskf (got {args.filter!r}): the RTS smoother runs "
              "over the error-state filter's stored nodes", file=sys.stderr)  # fmt: skip
        return 2
    if args.out_bag and not args.out:
        return _usage_error("--out-bag writes into the --out directory: give --out DIR")
    try:
        out = _output(args, _output_files(True) + tuple(f"trajectory.{b}" for b in _BAGS))
    except OutputError as exc:
        return _usage_error(str(exc))
    result = _run_job(args)
    if result is None:
        return 1
    code = _report(args, result, out, _table)
    return EXIT_DOUBTFUL if code == 0 and result.metrics.get("input_doubts") else code


#: figures of ``fuse --monte-carlo --out``
_MC_FIGURES = ("nees.png", "runs.png")


def run_monte_carlo(args: argparse.Namespace) -> int:
    """``dualpose fuse --monte-carlo N [--seed S] [--out DIR]``: N seeded runs of the filter on the simulator."""
    from pathlib import Path

    from dualpose.cli._batch import finish_job, job_progress, scheduler_of
    from dualpose.cli._output import OutputError, output_directory
    from dualpose.estimation.state import ESKF_ERROR
    from dualpose.jobs.figures import distribution_plot, job_output_names, nees_plot
    from dualpose.jobs.monte_carlo import run_monte_carlo as run_mc
    from dualpose.jobs.table import Cell

    used = [n for n, v in (("--data", args.data), ("--stream", args.stream), ("--calibration", args.calibration),
                           ("--camera", args.camera), ("--sensors", args.sensors), ("--outage", args.outage),
                           ("--out-bag", args.out_bag), ("--truth", args.truth), ("--json", args.json),
                           ("--smooth", args.smooth), ("--output", args.output)) if v]  # fmt: skip
    if used:
        return _usage_error(f"--monte-carlo runs the simulator: not with {', '.join(used)}")
    if args.filter != "eskf":
        return _usage_error(f"--monte-carlo runs the error-state filter (15-state NEES); got --filter {args.filter}")
    try:
        out = None if args.out is None else output_directory(args.out, job_output_names(_MC_FIGURES), args.force, [])
    except OutputError as exc:
        return _usage_error(str(exc))
    first = 0 if args.seed is None else args.seed
    try:
        with job_progress(args.monte_carlo, "fuse") as step:
            result = run_mc(args.monte_carlo, first, scheduler=scheduler_of(args, "fuse"), workers=args.workers,
                            progress=step)  # fmt: skip
    except (OSError, ValueError, ImportError) as exc:
        print(f"dualpose fuse: error: {exc}", file=sys.stderr)
        return 1
    runs = len(result.table) - result.failed
    lo, hi = result.nees_band
    inside = float(((result.average_nees >= lo) & (result.average_nees <= hi)).mean()) if runs else float("nan")
    print(f"{runs} runs (seeds {first}..{first + args.monte_carlo - 1}); average NEES inside its 95 % band "
          f"[{lo:.3f}, {hi:.3f}] at {100 * inside:.1f} % of the {result.t.size} IMU times\n")  # fmt: skip

    def ok(r: dict[str, Cell]) -> bool:
        return r["status"] == "ok"

    def nees_figure(path: Path) -> None:
        nees_plot(result.t, result.average_nees, result.nees_band, runs, ESKF_ERROR.dim, path)

    def runs_figure(path: Path) -> None:
        distribution_plot(result.table, (("mean_nees", "mean NEES (15 dof)"), ("mean_nis", "mean NIS (2 dof)"),
                                         ("ate_rmse_m", "ATE RMSE [m]"), ("orientation_rmse_deg",
                                                                          "orientation RMSE [deg]")),
                          path, ok=ok)  # fmt: skip

    return finish_job("fuse", result, lambda r: f"seed {r['seed']}", out,
                      {"nees.png": nees_figure, "runs.png": runs_figure})
