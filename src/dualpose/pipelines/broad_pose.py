"""Full pose on real IMU data: a BROAD trial's real IMU fused with pseudo-vision by the error-state filter.

The recording (real IMU, virtual camera seeing a landmark field through the optical reference pose) is built by
:func:`dualpose.sim.broad_vision.recording_from_broad` (its module docstring gives the noise model and clocks);
this pipeline runs :func:`dualpose.pipelines.fuse.run_fuse` on it and scores the result with BROAD's metric
(position and orientation RMSE over the movement samples).  Results: docs/broad-pose.md.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any

import numpy as np

from dualpose.io.broad import BroadTrial, load_broad
from dualpose.pipelines.fuse import FuseResult, run_fuse
from dualpose.sim.broad_vision import recording_from_broad

__all__ = ["BroadPoseResult", "run_broad_pose"]


@dataclass
class BroadPoseResult:
    """Output of :func:`run_broad_pose`.

    ``metrics`` (JSON-ready): ``trial``, ``dropout`` ([length, period] or None), ``n_dropouts``, ``ate_rmse_m``
    (SE(3)-aligned, all reference samples), ``position_rmse_m`` and ``orientation_rmse_deg`` (no alignment, ENU,
    over the movement samples with a finite reference -- BROAD's scoring set), ``position_max_m``,
    ``position_rmse_in_dropouts_m`` (movement samples inside the dropout windows; None without dropouts),
    ``nis_fraction_inside``, ``n_rejected``, ``n_correspondences``, ``camera_frames``, ``duration_s``,
    ``realtime_factor``, the noise densities used.  ``fuse`` is the full :class:`~dualpose.pipelines.fuse.FuseResult`.
    """

    metrics: dict[str, Any]
    fuse: FuseResult


def run_broad_pose(
    trial: BroadTrial | str | os.PathLike[str],
    dropout: tuple[float, float] | None = None,
    seed: int = 0,
    **options: Any,
) -> BroadPoseResult:
    """Fuse a BROAD trial's real IMU with pseudo-vision (error-state filter) and score it against the optical
    reference: :func:`recording_from_broad` + :func:`dualpose.pipelines.fuse.run_fuse`.

    Parameters
    ----------
    trial : BroadTrial or path to a BROAD ``.mat``
    dropout : (length, period) seconds, optional
        Vision dropouts, e.g. ``(2.0, 10.0)``: 2 s without frames every 10 s of the movement phase.
    seed : int
        Seeds the landmark field and the pixel noise.
    **options
        ``noise_inflation``, ``time_offset`` for :func:`recording_from_broad`.
    """
    if not isinstance(trial, BroadTrial):
        trial = load_broad(os.fspath(trial))
    rec = recording_from_broad(trial, seed=seed, dropout=dropout, **options)
    res = run_fuse(rec, "eskf", seed=seed)
    idx, position_error, ori_err = res.error_index, res.position_error, res.orientation_error_deg
    assert idx is not None and position_error is not None and ori_err is not None  # a BROAD trial has a reference
    t = res.estimate.stamps[idx]
    mov = rec.info["movement"][idx]
    pos_err = np.linalg.norm(position_error, axis=1)

    def rms(x: np.ndarray) -> float | None:
        return float(np.sqrt(np.mean(x**2))) if x.size else None

    in_drop = np.zeros(len(t), bool)
    for a, b in rec.info["dropouts"]:
        in_drop |= (t >= a) & (t < b)
    m = res.metrics
    n = rec.imu_noise
    metrics = {
        "trial": trial.name,
        "dropout": None if dropout is None else [float(dropout[0]), float(dropout[1])],
        "n_dropouts": len(rec.info["dropouts"]),
        "ate_rmse_m": m["ate_rmse_m"],
        "position_rmse_m": rms(pos_err[mov]),
        "orientation_rmse_deg": rms(ori_err[mov]),
        "position_max_m": float(pos_err[mov].max()) if mov.any() else None,
        "position_rmse_in_dropouts_m": rms(pos_err[mov & in_drop]) if dropout is not None else None,
        "nis_fraction_inside": m["nis_fraction_inside"],
        "n_rejected": m["n_rejected"],
        "n_correspondences": m["n_correspondences"],
        "camera_frames": m["camera_frames"],
        "duration_s": m["duration_s"],
        "realtime_factor": m["realtime_factor"],
        "gyroscope_noise_density": n.gyroscope_noise_density,
        "accelerometer_noise_density": n.accelerometer_noise_density,
    }
    return BroadPoseResult(metrics=metrics, fuse=res)
