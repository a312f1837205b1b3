"""``dualpose fuse``: camera-IMU pose tracking on the simulated eight-shaped run or a recording, evaluated against the
ground truth when there is one.

``--data`` is "sim" (default), a recording directory or its ``sensors.json`` (format: ``docs/fusion.md``), or a BROAD
trial ``.mat`` (pseudo-vision, ``docs/broad-pose.md``). Prints a summary table (or one JSON object with ``--json``);
with ``--out DIR`` writes ``trajectory.tum`` (the estimate, TUM format), ``metrics.json`` and PNG figures (top view,
errors with 3σ bounds, NIS vs χ² bounds). An existing output file is never replaced unless ``--force``. ``--smooth``
(ESKF only) also runs the offline RTS smoother: the table and JSON (``"smoothed"``) report filter and smoother side
by side and ``--out`` adds ``trajectory_smoothed.tum``. Exit status: 0 on success, 2 on bad arguments, a missing or
malformed input file (the message names the file and line) or an output file that exists.
"""

from __future__ import annotations

import argparse
import json
import sys

#: files ``--out`` writes
OUTPUT_FILES: tuple[str, ...] = ("trajectory.tum", "metrics.json", "top_view.png", "errors.png", "nis.png")


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``dualpose fuse``."""
    p = subparsers.add_parser(
        "fuse",
        help="camera-IMU tracking (ESKF or Hol's 22-state EKF) on the simulated eight-shaped run or a recording",
        description=(
            "Run a camera-IMU filter on the built-in simulated eight-shaped run (Hol 2008) or on a recording, "
            "starting from static alignment + first-frame PnP, and report ATE (SE(3)-aligned), RPE, orientation "
            "RMSE (when the recording has ground truth), NIS coverage and the real-time factor."
        ),
    )
    p.add_argument(
        "--data",
        default="sim",
        help="input: 'sim' (default), a recording directory or its sensors.json (docs/fusion.md), or a BROAD .mat",
    )
    p.add_argument("--filter", choices=("eskf", "hol22"), default="eskf", help="filter (default eskf)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulation or of BROAD's pseudo-vision (0)")
    p.add_argument("--out", metavar="DIR", help="write trajectory.tum, metrics.json and PNG figures into DIR")
    p.add_argument("--force", action="store_true", help="replace existing output files")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument(
        "--smooth",
        action="store_true",
        help="also run the offline RTS smoother (eskf only) and report its metrics next to the filter's; with --out "
        "writes trajectory_smoothed.tum",
    )
    return p


def _progress(done: int, total: int, stage: str) -> None:
    width = 24
    filled = width * done // total
    end = "\n" if done == total else ""
    print(f"\r[{'#' * filled}{'.' * (width - filled)}] {done}/{total} {stage:<10s}", end=end, file=sys.stderr)
    sys.stderr.flush()


def _table(m: dict) -> str:
    def num(key: str, spec: str) -> str:
        return "n/a (no ground truth)" if m[key] is None else format(m[key], spec)

    if "smoothed" in m:
        return _table_smoothed(m, num)
    rows = [
        ("data", m["data"]),
        ("filter", m["filter"]),
        ("ATE RMSE (SE(3)) [m]", num("ate_rmse_m", ".6f")),
        ("orientation RMSE (SE(3)) [deg]", num("orientation_rmse_deg", ".4f")),
        ("RPE RMSE (0.5 m) [m]", num("rpe_rmse_m", ".6f")),
        ("position RMSE, unaligned [m]", num("position_rmse_unaligned_m", ".6f")),
        ("orientation RMSE, unaligned [deg]", num("orientation_rmse_unaligned_deg", ".4f")),
        ("NIS inside 95% band", f"{m['nis_fraction_inside']:.3f}"),
        ("correspondences rejected", f"{m['n_rejected']} of {m['n_correspondences']}"),
        ("real-time factor", f"{m['realtime_factor']:.1f}x"),
    ]
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"{name:<{width}}  {value}" for name, value in rows)


#: rows of the filter-vs-smoother table: label, metrics key, format
_SMOOTHED_ROWS = (
    ("ATE RMSE (SE(3)) [m]", "ate_rmse_m", ".6f"),
    ("orientation RMSE (SE(3)) [deg]", "orientation_rmse_deg", ".4f"),
    ("RPE RMSE (0.5 m) [m]", "rpe_rmse_m", ".6f"),
    ("position RMSE, unaligned [m]", "position_rmse_unaligned_m", ".6f"),
    ("orientation RMSE, unaligned [deg]", "orientation_rmse_unaligned_deg", ".4f"),
)


def _table_smoothed(m: dict, num) -> str:
    """The summary table with a filter and a smoother column (``--smooth``)."""
    s = m["smoothed"]
    rows = [("data", m["data"], ""), ("method", "filter", "RTS smoother")]
    rows += [
        (label, num(key, fmt), "n/a" if s[key] is None else format(s[key], fmt)) for label, key, fmt in _SMOOTHED_ROWS
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


def _figures(result, out, paths: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    has_truth = result.truth is not None
    # errors exist at the estimate rows matched to the truth; without truth only the filter's 3σ bounds are drawn
    idx = result.error_index if has_truth else np.arange(len(result.estimate))
    t = result.truth.stamps if has_truth else result.estimate.stamps
    fig, ax = plt.subplots(figsize=(6, 5))
    if has_truth:
        ax.plot(result.truth.positions[:, 0], result.truth.positions[:, 1], "k-", label="truth")
    ax.plot(result.estimate.positions[:, 0], result.estimate.positions[:, 1], "r--", label="estimate")
    if result.smoothed is not None:
        ax.plot(result.smoothed.positions[:, 0], result.smoothed.positions[:, 1], "g:", label="smoothed")
    ax.set(xlabel="x [m]", ylabel="y [m]", title=f"top view ({result.metrics['filter']})", aspect="equal")
    ax.legend()
    fig.savefig(paths["top_view.png"], dpi=100)
    plt.close(fig)

    fig, axs = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    for i, name in enumerate("xyz"):
        s3 = 3e3 * result.position_sigma[idx, i]
        if has_truth:
            axs[i].plot(t, 1e3 * result.position_error[:, i], "b-", label="error")
            if result.smoothed_position_error is not None:
                axs[i].plot(t, 1e3 * result.smoothed_position_error[:, i], "g-", lw=0.8, label="smoothed")
        axs[i].fill_between(t, -s3, s3, color="0.8", label="±3σ")
        axs[i].set_ylabel(f"{name} error [mm]")
    axs[0].legend(loc="upper right")
    if not has_truth:
        axs[0].set_title("no ground truth: the filter's 3σ bounds only")
    if has_truth:
        axs[3].plot(t, result.orientation_error_deg, "b-", label="attitude error")
        if result.smoothed_orientation_error_deg is not None:
            axs[3].plot(t, result.smoothed_orientation_error_deg, "g-", lw=0.8, label="smoothed")
    if result.orientation_sigma_deg is not None:
        axs[3].plot(t, 3 * result.orientation_sigma_deg[idx], "k--", label="3σ")
    axs[3].set(ylabel="attitude error [deg]", xlabel="t [s]")
    axs[3].legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(paths["errors.png"], dpi=100)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(8, 4))
    k = np.arange(len(result.nis))
    acc = result.nis_accepted
    ax.semilogy(k[acc], result.nis[acc], ".", ms=2, label="NIS (accepted)")
    if np.any(~acc):
        ax.semilogy(k[~acc], result.nis[~acc], "rx", label="rejected")
    lo, hi = result.nis_bounds
    ax.axhline(lo, color="k", ls="--", label="95% χ²(2) bounds")
    ax.axhline(hi, color="k", ls="--")
    ax.set(
        xlabel="correspondence update", ylabel="NIS", title=f"NIS, {result.metrics['nis_fraction_inside']:.1%} inside"
    )
    ax.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(paths["nis.png"], dpi=100)
    plt.close(fig)


def _run_job(args: argparse.Namespace):
    """``run_fuse`` on ``--data``; a bad input file is reported on stderr (file and line) and gives None."""
    from dualpose.io.recording import RecordingError
    from dualpose.pipelines.fuse import run_fuse

    try:
        return run_fuse(data=args.data, filter=args.filter, seed=args.seed, progress=_progress, smooth=args.smooth)
    except RecordingError as exc:
        print(f"\ndualpose fuse: error: {exc}", file=sys.stderr)
        return None


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose fuse``."""
    from pathlib import Path

    if args.smooth and args.filter != "eskf":
        print(f"dualpose fuse: error: --smooth needs --filter eskf (got {args.filter!r}): the RTS smoother runs "
              "over the error-state filter's stored nodes", file=sys.stderr)  # fmt: skip
        return 2
    paths: dict[str, Path] = {}
    if args.out:
        out = Path(args.out)
        if out.exists() and not out.is_dir():
            print(f"dualpose fuse: error: {out}: not a directory", file=sys.stderr)
            return 2
        paths = {name: out / name for name in _output_files(args.smooth)}
        if not args.force:
            for path in paths.values():
                if path.exists():
                    print(f"dualpose fuse: error: {path}: file exists; use --force to replace it", file=sys.stderr)
                    return 2
    result = _run_job(args)
    if result is None:
        return 2
    metrics = result.metrics
    if paths:
        from dualpose.io import write_tum

        out.mkdir(parents=True, exist_ok=True)
        write_tum(paths["trajectory.tum"], result.estimate, overwrite=args.force)
        if result.smoothed is not None:
            write_tum(paths["trajectory_smoothed.tum"], result.smoothed, overwrite=args.force)
        paths["metrics.json"].write_text(json.dumps(metrics, indent=2) + "\n")
        _figures(result, out, paths)
    if args.json:
        summary = {k: v for k, v in metrics.items() if k != "evaluation"}
        if paths:
            summary["out"] = str(out)
        print(json.dumps(summary, indent=2))
        return 0
    print(_table(metrics))
    if paths:
        print(f"\nwritten to {out}: " + ", ".join(paths))
    return 0
