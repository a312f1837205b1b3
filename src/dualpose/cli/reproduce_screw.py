"""``dualpose reproduce screw-vector``: leader-follower relative pose with the 1-, 2- and 3-sample screw-vector
algorithms (Adv. Mech. Eng. 2019; docs/inertial.md).

Prints a summary table (or ``--json``); ``--out DIR`` writes PNG figures of attitude and position error vs time per
algorithm and of a long run of the 3-sample position-error norm (needs matplotlib).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from dualpose.cli._args import float_in

#: longest simulated run, s (1e7 s of the 3-sample algorithm take minutes)
MAX_DURATION_S = 1e7
_PROG = "dualpose reproduce screw-vector"

_DESCRIPTION = """\
Leader-follower relative pose with the 1-, 2- and 3-sample screw-vector algorithms (Adv. Mech. Eng. 2019; see
docs/inertial.md for the method and the motion). Prints a summary table (or JSON with --json). With --out DIR it
also writes summary.json and PNG figures: attitude and position error vs time for each algorithm, a comparison,
and the 3-sample position-error norm over a long run (--long-duration, default 1e5 s; 0 skips it). The figures
need matplotlib (pip install 'dualpose[plot]').
"""

TARGETS: dict[str, str] = {
    "screw-vector": "leader-follower relative pose with 1-, 2-, 3-sample screw-vector algorithms",
}


def add_target(targets: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    """Register ``dualpose reproduce screw-vector``."""
    p = targets.add_parser("screw-vector", help=TARGETS["screw-vector"], description=_DESCRIPTION,
                           formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    p.add_argument("--out", type=Path, help="directory for PNG figures and summary.json")
    p.add_argument("--json", action="store_true", help="print the summary as JSON instead of a table")
    p.add_argument("--force", action="store_true", help="replace an earlier run's --out directory as a whole")
    p.add_argument("--duration", type=float_in(0.0, MAX_DURATION_S, lo_open=True), default=200.0,
                   help=f"seconds simulated per algorithm (default 200; > 0, <= {MAX_DURATION_S:g})")
    p.add_argument("--long-duration", type=float_in(0.0, MAX_DURATION_S), default=1e5,
                   help=f"seconds of the 3-sample long run (default 1e5; 0 skips it; <= {MAX_DURATION_S:g})")
    p.add_argument("--samples", type=int, nargs="+", default=[1, 2, 3], choices=[1, 2, 3, 4], help="N values")
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    return p


def _simulate(sc: Any, n: int, duration: float, label: str, show: bool) -> dict[str, Any]:
    from contextlib import nullcontext

    from dualpose.cli._progress import FractionSteps, progress_bar
    from dualpose.pipelines.reproduce.screw_vector import simulate

    with progress_bar(10, f"{_PROG}: {label}") if show else nullcontext() as bar:  # 10 % steps
        return simulate(sc, n, duration, progress=FractionSteps(bar, 10))


def _figures(out: Path, runs: dict[int, dict[str, Any]], long_run: dict[str, Any] | None) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = []
    for n, r in runs.items():
        fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
        ax[0].plot(r["t"], r["attitude_error"], label="screw vector (real part)")
        ax[0].plot(r["t"], r["attitude_error_rotvec"], "--", label="rotation vector")
        ax[0].set_ylabel("relative attitude error [rad]")
        ax[0].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0))
        ax[1].plot(r["t"], r["position_error"])
        ax[1].set_ylabel("relative position error [m]")
        ax[1].set_xlabel("time [s]")
        fig.suptitle(f"{n}-sample screw-vector algorithm (leader-follower)")
        files.append(out / f"screw_vector_{n}_sample.png")
        fig.savefig(files[-1], dpi=100, bbox_inches="tight")
        plt.close(fig)
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for n, r in runs.items():
        ax[0].semilogy(r["t"], r["attitude_error"] + 1e-18, label=f"N={n}")
        ax[1].semilogy(r["t"], r["position_error"] + 1e-18, label=f"N={n}")
    ax[0].set_ylabel("relative attitude error [rad]")
    ax[1].set_ylabel("relative position error [m]")
    for a in ax:
        a.set_xlabel("time [s]")
    ax[1].legend(loc="upper left", bbox_to_anchor=(1.02, 1.0))
    fig.suptitle("screw-vector algorithms compared: relative attitude and position error")
    files.append(out / "screw_vector_comparison.png")
    fig.savefig(files[-1], dpi=100, bbox_inches="tight")
    plt.close(fig)
    if long_run is not None:
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(long_run["t"], long_run["position_error"])
        ax.set_xlabel("time [s]")
        ax.set_ylabel("position error norm [m]")
        ax.set_title("3-sample screw-vector algorithm, long run")
        files.append(out / "screw_vector_long_run.png")
        fig.savefig(files[-1], dpi=100, bbox_inches="tight")
        plt.close(fig)
    return files


def _table(summary: dict[str, Any]) -> str:
    rows = [
        "| algorithm | duration [s] | attitude err final [rad] | position err final [m] | position err max [m] "
        "| growth [m/s] | rotvec - screw attitude err [rad] |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, s in summary["runs"].items():
        rows.append(
            f"| {name} | {s['duration_s']:.0f} | {s['attitude_error_final_rad']:.3e} | "
            f"{s['position_error_final_m']:.3e} | {s['position_error_max_m']:.3e} | "
            f"{s['position_error_growth_m_per_s']:.2e} | {s['rotvec_minus_screw_attitude_error_max_rad']:.1e} |"
        )
    return "\n".join(rows)


def run_screw_vector(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from dualpose.cli._output import OutputError, output_directory
    from dualpose.pipelines.reproduce.screw_vector import Scenario, summarize

    out: Path | None = args.out
    names = [f"screw_vector_{n}_sample.png" for n in args.samples]
    names += ["screw_vector_comparison.png", "summary.json"] + (
        ["screw_vector_long_run.png"] if args.long_duration > 0 else []
    )
    if out is not None:
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            print(f"{_PROG}: error: --out writes PNG figures, which need matplotlib: pip install 'dualpose[plot]'",
                  file=sys.stderr)  # fmt: skip
            return 2
        try:
            target = output_directory(out, names + ["screw_vector_long_run.png"], args.force, ())
        except OutputError as exc:
            print(f"{_PROG}: error: {exc}", file=sys.stderr)
            return 2
    sc = Scenario()
    show = not args.no_progress
    runs = {n: _simulate(sc, n, args.duration, f"{n}-sample, {args.duration:g} s", show) for n in args.samples}
    long_run = None
    if args.long_duration > 0:
        long_run = _simulate(sc, 3, args.long_duration, f"3-sample, {args.long_duration:g} s", show)
    summary: dict[str, Any] = {
        "scenario": {
            "leader": asdict(sc.leader),
            "follower": asdict(sc.follower),
            "h_s": sc.h,
            "note": "leader: classical coning (attitude only); follower: dual coning (a + eps d)",
        },
        "runs": {f"{n}-sample": summarize(r) for n, r in runs.items()},
    }
    if long_run is not None:
        summary["runs"]["3-sample long run"] = summarize(long_run)
    if out is not None:
        with target.writing() as stage:
            files = _figures(stage, runs, long_run)
            (stage / "summary.json").write_text(json.dumps(summary, indent=2))
        summary["files"] = [str(out / f.name) for f in files] + [str(out / "summary.json"), str(out / "manifest.json")]
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(_table(summary))
        if out is not None:
            print(f"\nfigures and summary.json written to {out}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Entry point of ``dualpose reproduce screw-vector``."""
    return run_screw_vector(args)
