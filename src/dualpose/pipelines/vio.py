"""The visual–inertial odometry job of ``dualpose fuse --data <feature tracks>`` (docs/vio.md).

The scene is unknown (feature tracks, no landmark positions), so the estimator is the MSCKF
(:class:`~dualpose.estimation.msckf.MsckfVio`), started from the rest period at the start of the recording
(:meth:`~dualpose.estimation.msckf.MsckfVio.from_rest`); no ground truth is used in the run.  Output: the IMU pose
at every IMU sample in the gravity-aligned start frame (``trajectory.tum``, absolute seconds), and, given a ground
truth, the metrics of visual–inertial odometry (Zhang & Scaramuzza 2018): ATE and orientation RMSE after the 4-DoF
(position + yaw) alignment and after the SE(3) alignment, and the final position error in percent of the path
length, over the poses after the rest period.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from dualpose.estimation.msckf import MsckfOptions, MsckfVio, VioResult
from dualpose.evaluation.align import posyaw_alignment
from dualpose.evaluation.metrics import associate, evaluate
from dualpose.io.detect import read_trajectory
from dualpose.io.feature_tracks import is_eqvio_csv, read_eqvio_csv
from dualpose.pipelines._checks import warned
from dualpose.types.features import TrackRecording
from dualpose.types.trajectory import Trajectory

__all__ = ["VioRun", "is_track_data", "run_vio", "vio_metrics", "PIXEL_SIGMA", "OUTPUT_FILES"]

#: σ of a tracked feature, pixels (OpenVINS' default ``up_msckf_sigma_px`` and ``up_slam_sigma_px``), over the focal
#: length (docs/vio.md "Measurement noise"; ``MsckfOptions.adaptive_sigma`` estimates it online instead)
PIXEL_SIGMA = 1.0
#: files ``--out`` writes
OUTPUT_FILES = ("trajectory.tum", "metrics.json", "trajectory.png")
#: stamps of the estimate and the ground truth match within this, s
MAX_DIFF = 0.003


@dataclass
class VioRun:
    """What :func:`run_vio` returns: the recording, the filter output, the estimate after the rest period as a
    :class:`~dualpose.types.Trajectory` (absolute seconds), the metrics dict, the ground truth (or None)."""

    recording: TrackRecording
    result: VioResult
    estimate: Trajectory
    metrics: dict[str, Any]
    truth: Trajectory | None


def is_track_data(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is feature-track data ``dualpose fuse`` runs the VIO on (the EqVIO replay CSV)."""
    return os.path.isfile(path) and is_eqvio_csv(path)


def vio_metrics(truth: Trajectory, estimate: Trajectory) -> dict[str, Any]:
    """ATE, orientation RMSE after the 4-DoF (``posyaw``) and SE(3) alignments, final position error (4-DoF
    aligned) in m and in percent of the ground-truth path length over the matched poses."""
    out: dict[str, Any] = {}
    aligns: tuple[tuple[str, Literal["posyaw", "se3"]], ...] = (("4dof", "posyaw"), ("se3", "se3"))
    for name, align in aligns:
        ev = evaluate(truth, estimate, align=align, max_diff=MAX_DIFF, undetermined="warn")  # flagged, not refused
        out[f"ate_rmse_{name}_m"] = float(ev.ate_stats.rmse)
        out[f"orientation_rmse_{name}_deg"] = float(ev.orientation_stats.rmse)
    ir, ie = associate(truth.stamps, estimate.stamps, MAX_DIFF, 0.0)
    p_ref = truth.positions[ir]
    al = posyaw_alignment(p_ref, estimate.positions[ie], "warn")
    p_est, _ = al.apply(estimate.positions[ie], estimate.quats[ie])
    path = float(np.sum(np.linalg.norm(np.diff(p_ref, axis=0), axis=1)))
    final = float(np.linalg.norm(p_est[-1] - p_ref[-1]))
    out.update(final_error_m=final, path_length_m=path, final_drift_percent=100.0 * final / path,
               n_matched=int(len(ir)))  # fmt: skip
    return out


def run_vio(data: str | os.PathLike[str] | TrackRecording, truth: str | os.PathLike[str] | Trajectory | None = None,
            options: MsckfOptions | None = None, pixel_sigma: float = PIXEL_SIGMA) -> VioRun:  # fmt: skip
    """Run the MSCKF on feature-track ``data`` (an EqVIO replay CSV or a :class:`~dualpose.types.TrackRecording`),
    scored against ``truth`` (a trajectory file any :func:`~dualpose.io.read_trajectory` format reads, e.g. EuRoC
    ground truth, or a Trajectory) when given.  The feature σ is ``pixel_sigma`` over the focal length when the
    recording knows it, the recording's own ``feature_sigma`` otherwise (metrics ``adapted_sigma_px``: its final
    value, the same unless ``options.adaptive_sigma``)."""
    gt = None  # read first: a bad truth file is reported before the filter runs
    if truth is not None:
        gt = truth if isinstance(truth, Trajectory) else read_trajectory(truth)
    t0 = time.perf_counter()
    rec = data if isinstance(data, TrackRecording) else read_eqvio_csv(data)
    if np.isfinite(rec.focal_length) and rec.focal_length > 0:
        rec.feature_sigma = pixel_sigma / rec.focal_length
    t_read = time.perf_counter() - t0
    f, k = MsckfVio.from_rest(rec, options=options)  # a rest period that leaves gravity undetermined: ValueError
    doubts = warned(*f.doubts)
    res = f.run(rec, k)
    after = res.t >= res.t_start
    est = Trajectory(res.t[after] + rec.t0, res.position[after], res.quat[after], name="msckf")
    duration = float(rec.t[-1] - rec.t[k])
    metrics: dict[str, Any] = {
        "data": rec.name, "estimator": "msckf", "start_s": float(rec.t[k]), "rest_s": float(rec.t[k] - rec.t[0]),
        "features_used": res.n_used, "features_gated": res.n_gated, "features_failed": res.n_failed,
        "features_undetermined": res.n_undetermined,
        "slam_features": f.n_slam_init,
        "mean_nis_per_dof": float(np.mean(res.nis / res.nis_dof)) if len(res.nis) else None,
        "feature_sigma_px": float(rec.feature_sigma * rec.focal_length),
        "adapted_sigma_px": float(f.feature_sigma * rec.focal_length), "read_s": t_read,
        "filter_s": res.wall_time, "realtime_factor": duration / res.wall_time if res.wall_time > 0 else float("inf"),
        "filter_cpu_s": res.cpu_time,
        "realtime_factor_cpu": duration / res.cpu_time if res.cpu_time > 0 else float("inf"),
        "gravity_sigma_deg": math.degrees(f.start_alignment.gravity_sigma) if f.start_alignment else None,
        "input_doubts": [d.as_dict() for d in doubts],
    }  # fmt: skip
    if gt is not None:
        metrics.update(vio_metrics(gt, est))
    return VioRun(rec, res, est, metrics, gt)


def trajectory_figure(run: VioRun, path: str | os.PathLike[str]) -> None:
    """Top view (x–y) of the estimate, 4-DoF-aligned to the ground truth when there is one, over the ground truth;
    PNG at 90 dpi (a few tens of kB)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    est = run.estimate
    fig = Figure(figsize=(6.0, 4.6))
    ax = fig.add_subplot(1, 1, 1)
    p = est.positions
    if run.truth is not None:
        ir, ie = associate(run.truth.stamps, est.stamps, MAX_DIFF, 0.0)
        al = posyaw_alignment(run.truth.positions[ir], est.positions[ie])
        p, _ = al.apply(est.positions, est.quats)
        g = run.truth.positions[ir]
        ax.plot(g[:, 0], g[:, 1], color="0.3", lw=2.0, label="ground truth")
    ax.plot(p[:, 0], p[:, 1], color="tab:red", lw=1.0, label="MSCKF (4-DoF aligned)" if run.truth else "MSCKF")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3)
    ax.legend(loc="best", fontsize=8)
    m = run.metrics
    if "ate_rmse_4dof_m" in m:
        ax.set_title(f"{m['data']}: ATE (4-DoF) {100 * m['ate_rmse_4dof_m']:.2f} cm, final drift "
                     f"{m['final_drift_percent']:.2f} % of {m['path_length_m']:.1f} m", fontsize=9)  # fmt: skip
    fig.tight_layout()
    fig.savefig(Path(path), dpi=90)
