"""The main job behind ``dualpose fuse``: run a camera-IMU filter on a recording and evaluate it.

Inputs (:func:`load_recording`): the built-in simulated eight-shaped run (Hol 2008,
:func:`dualpose.sim.simulate_eight`), a recording on disk in the format of ``docs/fusion.md``
(:func:`dualpose.io.recording.read_recording`), or a BROAD trial ``.mat`` fused with pseudo-vision
(:func:`dualpose.sim.broad_vision.recording_from_broad`).  The filter starts without the truth: static
accelerometer alignment over the leading rest period (gyro bias; 0.9 s for the simulated run, given or detected
for files) + PnP of the first frame during the rest (pose), zero velocity -- the same start as
``benchmarks/fusion_accuracy.py``.  When the recording has ground truth, the estimate at every IMU time is compared
with it by :func:`dualpose.evaluation.metrics.evaluate` (timestamp association within 10 ms, ATE after SE(3) Umeyama
alignment, orientation RMSE, RPE over 0.5 m of path); without it those metrics are None.  With ``smooth=True`` the
error-state filter's run is also smoothed offline (RTS, :func:`dualpose.estimation.smoother.rts_smooth`) and the same
metrics are reported for the smoothed trajectory under ``metrics["smoothed"]``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

import dualpose as dp
from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation.eskf import ErrorStateEKF, FilterResult
from dualpose.estimation.hol22 import Hol22EKF, Hol22Result
from dualpose.estimation.smoother import rts_smooth
from dualpose.evaluation.metrics import evaluate
from dualpose.io import load_broad
from dualpose.io.recording import RecordingError, read_recording
from dualpose.pipelines._checks import check_before_fuse, check_gravity_after_alignment
from dualpose.sim.broad_vision import recording_from_broad
from dualpose.types import Recording, SensorSetup, Trajectory

__all__ = ["FILTERS", "EstimatorFactory", "FuseResult", "load_recording", "run_fuse"]

#: ``factory(recording, x, P) -> ErrorStateEKF | Hol22EKF``: a filter for the recording's sensors, started from
#: the error-state start ``x`` (:data:`~dualpose.estimation.state.ESKF_STATE`) and ``P`` (over
#: :data:`~dualpose.estimation.state.ESKF_ERROR`) of the static alignment and first-frame PnP
EstimatorFactory = Callable[[Recording | SensorSetup, np.ndarray, np.ndarray], ErrorStateEKF | Hol22EKF]


def _eskf_for(rec: Recording | SensorSetup, x: np.ndarray, P: np.ndarray) -> ErrorStateEKF:
    return ErrorStateEKF.from_state(rec, x, P)


def _hol22_for(rec: Recording | SensorSetup, x: np.ndarray, P: np.ndarray) -> Hol22EKF:
    return Hol22EKF.from_eskf_state(x, P, rec)


#: the camera-IMU filters ``run_fuse`` knows by name (``dualpose fuse --filter``); any other
#: :data:`EstimatorFactory` can be passed to :func:`run_fuse` directly
FILTERS: Mapping[str, EstimatorFactory] = MappingProxyType({"eskf": _eskf_for, "hol22": _hol22_for})

#: seconds of rest at the start of the simulated run used for the static alignment
_REST_S = 0.9

#: metrics that need ground truth (None without it)
TRUTH_METRICS: tuple[str, ...] = (
    "ate_rmse_m",
    "orientation_rmse_deg",
    "rpe_rmse_m",
    "rpe_rotation_rmse_deg",
    "position_rmse_unaligned_m",
    "orientation_rmse_unaligned_deg",
    "alignment_well_determined",
)

#: RPE step, metres of travelled path
_RPE_DELTA_M = 0.5

_STAGES = ("simulate", "initialise", "filter", "evaluate")


@dataclass
class FuseResult:
    """Output of :func:`run_fuse`.

    Attributes
    ----------
    estimate : Trajectory
        Estimated body poses (position in the world frame, m; ``q_wb`` xyzw body -> world) at the IMU times (N,).
    truth : Trajectory or None
        The ground-truth poses matched to the estimate (K,) (all N for the simulated run); None without truth.
    metrics : dict
        JSON-ready: ``ate_rmse_m``, ``orientation_rmse_deg``, ``rpe_rmse_m``, ``rpe_rotation_rmse_deg``,
        ``nis_fraction_inside``, ``realtime_factor``, ``filter``, ``data``, ``seed``, ``duration_s``,
        ``position_rmse_unaligned_m`` and ``orientation_rmse_unaligned_deg`` (in the recording's world frame, no
        alignment -- the SE(3) alignment fitted to the positions adds attitude error), the innovation
        summary and the full evaluation statistics under ``evaluation``, and ``input_doubts``: what the checks on
        the input doubted (each ``{"code", "message"}``, also warned as a
        :class:`~dualpose.types.recording.RecordingWarning`; docs/refusals.md), empty when nothing was.  Without
        ground truth the metrics in ``TRUTH_METRICS`` and ``evaluation`` are None.
    position_error : ndarray, shape (K, 3), or None
        Estimate minus truth at the matched poses, world frame, m (no alignment).
    orientation_error_deg : ndarray, shape (K,), or None
        Angle between estimated and true attitude at the matched poses, degrees (no alignment).
    position_sigma : ndarray, shape (N, 3)
        1σ of the position from the filter's covariance, m.
    orientation_sigma_deg : ndarray, shape (N,) or None
        1σ of the attitude-error angle (square root of the trace of the 3 x 3 attitude-error covariance), degrees;
        None for ``hol22`` whose quaternion covariance is not an angle covariance.
    nis : ndarray, shape (M,)
        NIS of every camera correspondence update (2 dof), in processing order.
    nis_accepted : ndarray of bool, shape (M,)
        False for the correspondences the χ² gate rejected.
    nis_bounds : tuple of float
        Two-sided 95 % χ²(2) interval.
    smoothed : Trajectory or None
        The RTS-smoothed poses at the IMU times (``smooth=True`` only).
    smoothed_position_error, smoothed_orientation_error_deg : ndarray or None
        As ``position_error`` (K, 3) and ``orientation_error_deg`` (K,) for the smoothed trajectory.
    error_index : ndarray of int, shape (K,), or None
        Rows of ``estimate`` (and of the sigma arrays) that ``truth`` and the error arrays belong to.
    filtered : Trajectory or None
        The causal filter's poses when ``estimate`` is a smoothed output (calibration-target recordings,
        :func:`dualpose.pipelines.track_target.run_track`); None otherwise.
    """

    estimate: Trajectory
    truth: Trajectory | None
    metrics: dict[str, Any]
    position_error: np.ndarray | None
    orientation_error_deg: np.ndarray | None
    position_sigma: np.ndarray
    orientation_sigma_deg: np.ndarray | None
    nis: np.ndarray
    nis_accepted: np.ndarray
    nis_bounds: tuple[float, float]
    smoothed: Trajectory | None = None
    smoothed_position_error: np.ndarray | None = None
    smoothed_orientation_error_deg: np.ndarray | None = None
    filtered: Trajectory | None = None
    error_index: np.ndarray | None = None


def load_recording(data: str | os.PathLike[str] | Recording = "sim", seed: int = 0) -> Recording:
    """The :class:`~dualpose.types.recording.Recording` ``dualpose fuse --data`` names.

    Parameters
    ----------
    data : str, path-like or Recording
        "sim": the simulated eight-shaped run (seeded by ``seed``, 0.9 s rest used for the alignment); a path
        ending in ``.mat``: a BROAD trial with pseudo-vision (:func:`dualpose.sim.broad_vision.recording_from_broad`,
        ``seed`` seeds the pixel noise); any other path: a recording directory or its sensor file
        (:func:`dualpose.io.recording.read_recording`).  A Recording is returned as is.

    Raises
    ------
    dualpose.io.recording.RecordingError
        (a ValueError) for a missing or malformed input, naming the file and line.
    """
    if isinstance(data, Recording):
        return data
    if isinstance(data, str) and data == "sim":
        return sim.recording_from_simulation(sim.simulate_eight(int(seed)), rest_seconds=_REST_S)
    if not isinstance(data, (str, os.PathLike)):
        raise TypeError(f"data must be 'sim', a path or a Recording; got {type(data).__name__}")
    if str(data).lower().endswith(".mat"):
        try:
            trial = load_broad(os.fspath(data))
        except (FileNotFoundError, ValueError) as exc:
            raise RecordingError(str(exc)) from None  # load_broad's messages name the file as given
        try:
            return recording_from_broad(trial, seed=int(seed), name=str(data))
        except ValueError as exc:
            text = str(exc).removeprefix(f"{trial.name}: ")  # the file once, not the file and the trial's name
            raise RecordingError(f"{data}: {text}") from None
    return read_recording(data)


def _truth_metrics(
    truth: Trajectory | None, estimate: Trajectory
) -> tuple[dict[str, Any], dict[str, Any] | None, tuple[np.ndarray, Trajectory, np.ndarray, np.ndarray] | None]:
    """Metrics against the ground truth (``TRUTH_METRICS``, None without truth), the evaluation dict and the
    per-pose arrays ``(error_index, truth matched, position_error, orientation_error_deg)``."""
    if truth is None:
        return dict.fromkeys(TRUTH_METRICS), None, None
    # a diverged estimate has no determined alignment: keep its numbers, warned about and flagged
    ev = evaluate(truth, estimate, align="se3", rpe_delta=_RPE_DELTA_M, rpe_unit="m", undetermined="warn")
    ed = ev.as_dict()
    out = {key: ed[key] for key in TRUTH_METRICS[:4]}
    matched = truth.take(ev.idx_ref)
    pos_err = estimate.positions[ev.idx_est] - matched.positions
    ori_err = np.degrees(dp.quat_angle(estimate.quats[ev.idx_est], matched.quats))
    out["position_rmse_unaligned_m"] = float(np.sqrt(np.mean(np.sum(pos_err**2, axis=1))))
    out["orientation_rmse_unaligned_deg"] = float(np.sqrt(np.mean(ori_err**2)))
    cond = ev.alignment.conditioning
    out["alignment_well_determined"] = bool(cond is None or cond.well_determined)
    return out, ed, (ev.idx_est, matched, pos_err, ori_err)


def run_fuse(
    data: str | os.PathLike[str] | Recording = "sim",
    filter: str | EstimatorFactory = "eskf",
    seed: int = 0,
    progress: Callable[[int, int, str], None] | None = None,
    smooth: bool = False,
) -> FuseResult:
    """Run ``filter`` on ``data`` and evaluate it against the ground truth when there is one.

    Parameters
    ----------
    data : str, path-like or Recording
        "sim" (the simulated eight-shaped run with default sensors), a recording directory / sensor file, a BROAD
        ``.mat`` trial, or a :class:`~dualpose.types.recording.Recording` (see :func:`load_recording`).
    filter : {"eskf", "hol22"} or EstimatorFactory
        :class:`~dualpose.estimation.eskf.ErrorStateEKF` (recommended), :class:`~dualpose.estimation.hol22.Hol22EKF`,
        or a factory of any :class:`~dualpose.estimation.interface.Estimator` with a ``position`` state block and a
        batch ``run`` / ``run_recording`` (:data:`FILTERS`).
    seed : int
        Seed of the simulation's noise (of the pseudo-vision for a BROAD trial).
    progress : callable, optional
        Called as ``progress(done, total, stage)`` after each stage (simulate or load, initialise, filter,
        evaluate).
    smooth : bool
        Also run the RTS smoother over the filtered run (``filter="eskf"`` only) and report its metrics under
        ``metrics["smoothed"]`` (see ``_smoothed_metrics``).

    Returns
    -------
    FuseResult

    Raises
    ------
    ValueError
        Unknown ``filter``, or ``smooth`` with a filter other than "eskf".
    dualpose.io.recording.RecordingError
        (a ValueError) for an unreadable or malformed recording, or one the filter cannot be started on (no
        frame with >= 6 correspondences during the rest period).
    """
    if isinstance(filter, str):
        if filter not in FILTERS:
            raise ValueError(f"filter must be one of {tuple(FILTERS)} or an estimator factory; got {filter!r}")
        name, factory = filter, FILTERS[filter]
        _check_smooth(factory, smooth, filter)
    elif callable(filter):
        name, factory = getattr(filter, "__name__", type(filter).__name__), filter
    else:
        raise TypeError(f"filter must be a name in {tuple(FILTERS)} or a callable factory; got {type(filter)}")
    stages = _STAGES if isinstance(data, str) and data == "sim" else ("load",) + _STAGES[1:]

    def step(k: int) -> None:
        if progress is not None:
            progress(k + 1, len(stages), stages[k])

    run = load_recording(data, seed)
    doubts = check_before_fuse(run)  # too short, rest too long, g units: RecordingError; doubts: RecordingWarning
    step(0)
    try:
        x, P0 = initialization.initial_state_from_run(run, run.rest_seconds)
    except ValueError as exc:
        raise RecordingError(f"{run.name}: cannot start the filter: {exc}") from None
    gravity_sigma, more = check_gravity_after_alignment(run, x)  # up or undetermined: RecordingError; doubts
    doubts += more
    step(1)
    est = factory(run, x, P0)
    if "position" not in est.state_layout.names:
        raise ValueError(f"filter {name!r}: run_fuse needs an estimator with a position state; got {type(est)}")
    _check_smooth(type(est), smooth, name)
    # load the compiled kernel on a throw-away two-sample run, so that ``realtime_factor`` times the filtering
    no_frames = (np.zeros(0), np.zeros(1, np.int64), np.zeros((0, 2)), np.zeros((0, 3)))
    factory(run, x, P0).run(run.t[:2], run.gyro[:2], run.accel[:2], *no_frames)
    # smooth: an ErrorStateEKF (_check_smooth)
    if smooth and isinstance(est, ErrorStateEKF):
        res: FilterResult | Hol22Result = est.run_recording(run, record_nodes=True)
    else:
        res = est.run_recording(run)
    cov = est.covariance_layout
    pos_var = np.diagonal(cov.cov(res.covariance, "position"), axis1=1, axis2=2)
    ori_sigma = None
    if "attitude" in cov.names:
        ori_sigma = np.degrees(np.sqrt(np.trace(cov.cov(res.covariance, "attitude"), axis1=1, axis2=2)))
    step(2)
    estimate = Trajectory(res.t, res.position, res.quat, run.stamps_ns, name=f"dualpose fuse --filter {name}")
    truth_metrics, ed, per_pose = _truth_metrics(run.ground_truth, estimate)
    duration = run.duration
    rep = res.innovation
    metrics = {
        "data": run.name if not isinstance(data, (str, os.PathLike)) else str(data),
        "filter": name,
        "seed": int(seed),
        "duration_s": duration,
        "imu_samples": int(len(run.t)),
        "camera_frames": int(len(run.frames)),
        "filter_wall_time_s": float(res.wall_time),
        "realtime_factor": duration / float(res.wall_time),
        "input_doubts": [d.as_dict() for d in doubts],
        "gravity_sigma_deg": math.degrees(gravity_sigma),
    }
    for key in TRUTH_METRICS[:4]:
        metrics[key] = truth_metrics[key]
    metrics.update(rep.summary())
    for key in TRUTH_METRICS[4:]:
        metrics[key] = truth_metrics[key]
    metrics["evaluation"] = ed
    # (smooth: the error-state filter's result)
    smoothed = _smoothed_metrics(res, run.ground_truth, estimate) if smooth and isinstance(res, FilterResult) else {}
    if smooth:
        metrics["smoothed"] = smoothed.pop("metrics")
    step(3)
    idx, truth, pos_err, ori_err = per_pose if per_pose is not None else (None, None, None, None)
    return FuseResult(
        estimate=estimate,
        truth=truth,
        metrics=metrics,
        position_error=pos_err,
        orientation_error_deg=ori_err,
        position_sigma=np.sqrt(np.maximum(pos_var, 0.0)),
        orientation_sigma_deg=ori_sigma,
        nis=np.asarray(rep.nis),
        nis_accepted=np.asarray(rep.accepted, dtype=bool),
        nis_bounds=(float(rep.bounds[0]), float(rep.bounds[1])),
        error_index=idx,
        **smoothed,
    )


def _check_smooth(kind: object, smooth: bool, name: str) -> None:
    """``smooth`` needs the error-state filter (its node record): ``kind`` is its factory or its class."""
    if smooth and kind not in (_eskf_for, ErrorStateEKF):
        raise ValueError(
            f"smooth=True (--smooth) needs filter 'eskf': the RTS smoother runs over the error-state filter's "
            f"stored nodes; got filter {name!r}"
        )


def _smoothed_metrics(res: FilterResult, truth: Trajectory | None, estimate: Trajectory) -> dict[str, Any]:
    """RTS-smooth the filter result ``res`` (recorded nodes) and evaluate it like the filter.

    Returns the extra :class:`FuseResult` fields plus ``"metrics"``: the :data:`TRUTH_METRICS` of the smoothed
    trajectory (as the filter's; None without ground truth) and ``smoother_wall_time_s`` (backward pass only).
    """
    sm = rts_smooth(res)
    traj = Trajectory(sm.t, sm.position, sm.quat, estimate.stamps_ns, name=f"{estimate.name} --smooth")
    metrics, _, per_pose = _truth_metrics(truth, traj)
    metrics["smoother_wall_time_s"] = float(sm.wall_time)
    _, _, pos_err, ori_err = per_pose if per_pose is not None else (None, None, None, None)
    return {
        "metrics": metrics,
        "smoothed": traj,
        "smoothed_position_error": pos_err,
        "smoothed_orientation_error_deg": ori_err,
    }
