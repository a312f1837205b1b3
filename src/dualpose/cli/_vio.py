"""``dualpose fuse --data <feature tracks> [--truth FILE] [--out DIR]``: the visual–inertial odometry job
(:func:`dualpose.pipelines.vio.run_vio`, docs/vio.md); prints a summary table or, with ``--json``, one JSON object.
``--out DIR`` writes ``trajectory.tum`` (IMU pose in the gravity-aligned start frame, absolute seconds),
``metrics.json`` and ``trajectory.png``; an existing file is replaced only with ``--force``.  Exit status 0, 2 on
bad arguments or an output file that exists, 1 on a malformed input (the message names the file and line) or a rest
period that does not determine the gravity direction, 3 when the run completed on an input it doubts (``input_doubts``
in the metrics, each also a ``warning:`` line).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any


def _table(m: dict[str, Any]) -> str:
    from dualpose.cli._output import aligned_rows

    rows = [("data", m["data"]), ("estimator", "MSCKF (unknown scene)"),
            ("rest period [s]", f"{m['rest_s']:.2f}")]  # fmt: skip
    if "ate_rmse_4dof_m" in m:
        rows += [
            ("ATE RMSE (4-DoF) [m]", f"{m['ate_rmse_4dof_m']:.4f}"),
            ("orientation RMSE (4-DoF) [deg]", f"{m['orientation_rmse_4dof_deg']:.3f}"),
            ("ATE RMSE (SE(3)) [m]", f"{m['ate_rmse_se3_m']:.4f}"),
            ("final drift [% of path]", f"{m['final_drift_percent']:.3f} ({m['path_length_m']:.2f} m)"),
        ]
    rows += [("features used / gated / failed / undetermined", f"{m['features_used']} / {m['features_gated']} / "
              f"{m['features_failed']} / {m['features_undetermined']}"),
             ("real-time factor", f"{m['realtime_factor']:.0f}x")]  # fmt: skip
    if m.get("input_doubts"):
        rows += [("input doubts (see warnings)", ", ".join(d["code"] for d in m["input_doubts"]))]
    return aligned_rows(rows)


def run_vio_job(args: argparse.Namespace) -> int:
    """Run the VIO job for ``dualpose fuse`` (arguments of :mod:`dualpose.cli.fuse`)."""
    from dualpose.cli._output import OutputError, output_directory
    from dualpose.cli._stream import EXIT_DOUBTFUL
    from dualpose.pipelines.vio import OUTPUT_FILES, run_vio, trajectory_figure

    unused = [name for name, given in (("--smooth", args.smooth), ("--seed", args.seed is not None),
                                       ("--filter", args.filter != "eskf"),
                                       ("--out-bag", args.out_bag)) if given]  # fmt: skip
    if unused:
        print(f"dualpose fuse: error: {', '.join(unused)}: not used with feature-track data (the MSCKF runs)",
              file=sys.stderr)  # fmt: skip
        return 2
    out = None
    if args.out:
        try:
            out = output_directory(args.out, OUTPUT_FILES, args.force, [args.data, args.truth])
        except OutputError as exc:
            print(f"dualpose fuse: error: {exc}", file=sys.stderr)
            return 2
    try:
        run = run_vio(args.data, truth=args.truth)
    except (ValueError, OSError) as exc:
        print(f"dualpose fuse: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1
    if out is not None:
        from dualpose.io import write_tum

        with out.writing() as stage:
            write_tum(stage / "trajectory.tum", run.estimate)
            (stage / "metrics.json").write_text(json.dumps(run.metrics, indent=2) + "\n")
            trajectory_figure(run, stage / "trajectory.png")
    code = EXIT_DOUBTFUL if run.metrics.get("input_doubts") else 0
    if args.json:
        print(json.dumps({**run.metrics, **({"out": str(out.path)} if out is not None else {})}, indent=2))
        return code
    print(_table(run.metrics))
    if out is not None:
        print(f"\nwritten to {out.path}: " + ", ".join((*OUTPUT_FILES, "manifest.json")))
    return code
