"""The main job behind ``dualpose fuse``: run a camera-IMU filter on a recording and evaluate it.

Only the built-in simulated eight-shaped run (Hol 2008, :func:`dualpose.fusion.sim.simulate_eight`) is supported as
input for now.  The filter starts without the truth: static accelerometer alignment over the first 0.9 s of rest
(gyro bias) + PnP of the first frame (pose), zero velocity -- the same start as ``benchmarks/fusion_accuracy.py``.
The estimate at every IMU time is compared with the simulator's ground truth by :func:`dualpose.fusion.metrics.evaluate`
(ATE after SE(3) Umeyama alignment, orientation RMSE, RPE over 0.5 m of path).  With ``smooth=True`` the
error-state filter's run is also smoothed offline (RTS, :func:`dualpose.fusion.smoother.rts_smooth`) and the same
metrics are reported for the smoothed trajectory under ``metrics["smoothed"]``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from dualpose.io import Trajectory

__all__ = ["FILTERS", "FuseResult", "run_fuse"]

#: filters ``run_fuse`` accepts
FILTERS: tuple[str, ...] = ("eskf", "hol22")

#: seconds of rest at the start of the simulated run used for the static alignment
_REST_S = 0.9

#: RPE step, metres of travelled path
_RPE_DELTA_M = 0.5

_STAGES = ("simulate", "initialise", "filter", "evaluate")


@dataclass
class FuseResult:
    """Output of :func:`run_fuse`.

    Attributes
    ----------
    estimate, truth : Trajectory
        Estimated and true body poses (position in the earth frame, m; ``q_wb`` xyzw body -> earth) at the IMU
        times (N,).
    metrics : dict
        JSON-ready: ``ate_rmse_m``, ``orientation_rmse_deg``, ``rpe_rmse_m``, ``rpe_rotation_rmse_deg``,
        ``nis_fraction_inside``, ``realtime_factor``, ``filter``, ``data``, ``seed``, ``duration_s``,
        ``position_rmse_unaligned_m`` and ``orientation_rmse_unaligned_deg`` (in the simulator's earth frame, no
        alignment -- the SE(3) alignment fitted to the positions adds attitude error), the innovation
        summary and the full evaluation statistics under ``evaluation``.
    position_error : ndarray, shape (N, 3)
        Estimate minus truth, earth frame, m (no alignment).
    orientation_error_deg : ndarray, shape (N,)
        Angle between estimated and true attitude, degrees (no alignment).
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
        As ``position_error`` (N, 3) and ``orientation_error_deg`` (N,) for the smoothed trajectory.
    """

    estimate: Trajectory
    truth: Trajectory
    metrics: dict
    position_error: np.ndarray
    orientation_error_deg: np.ndarray
    position_sigma: np.ndarray
    orientation_sigma_deg: np.ndarray | None
    nis: np.ndarray
    nis_accepted: np.ndarray
    nis_bounds: tuple[float, float]
    smoothed: Trajectory | None = None
    smoothed_position_error: np.ndarray | None = None
    smoothed_orientation_error_deg: np.ndarray | None = None


def run_fuse(
    data: str = "sim",
    filter: str = "eskf",  # noqa: A002 -- the CLI option's name
    seed: int = 0,
    progress: Callable[[int, int, str], None] | None = None,
    smooth: bool = False,
) -> FuseResult:
    """Run ``filter`` on ``data`` and evaluate it against the ground truth.

    Parameters
    ----------
    data : str
        "sim": the simulated eight-shaped run with default sensors.  File input is not implemented yet.
    filter : {"eskf", "hol22"}
        :class:`~dualpose.fusion.eskf.ErrorStateEKF` (recommended) or :class:`~dualpose.fusion.hol22.Hol22EKF`.
    seed : int
        Seed of the simulation's noise.
    progress : callable, optional
        Called as ``progress(done, total, stage)`` after each stage (simulate, initialise, filter, evaluate).
    smooth : bool
        Also run the RTS smoother over the filtered run (``filter="eskf"`` only) and report its metrics under
        ``metrics["smoothed"]`` (see :func:`_smoothed_metrics`).

    Returns
    -------
    FuseResult

    Raises
    ------
    ValueError
        Unknown ``filter``, ``data`` other than "sim", or ``smooth`` with a filter other than "eskf".
    """
    from dualpose.fusion import eskf, hol22, initialization, sim
    from dualpose.fusion.metrics import evaluate

    if filter not in FILTERS:
        raise ValueError(f"filter must be one of {FILTERS}; got {filter!r}")
    _check_smooth(filter, smooth)
    if data != "sim":
        raise ValueError(f"data must be 'sim' (file input is not implemented yet); got {data!r}")

    def step(k: int) -> None:
        if progress is not None:
            progress(k + 1, len(_STAGES), _STAGES[k])

    run = sim.simulate_eight(int(seed))
    step(0)
    x, P0 = initialization.initial_state_from_run(run, _REST_S)
    step(1)
    if filter == "eskf":

        def make() -> eskf.ErrorStateEKF:
            return eskf.ErrorStateEKF.for_run(run, x[0:3], x[3:6], x[6:10], P0, gyro_bias=x[10:13])

        # load the compiled kernel on a throw-away two-sample run, so that ``realtime_factor`` times the filtering
        no_frames = (np.zeros(0), np.zeros(1, np.int64), np.zeros((0, 2)), np.zeros((0, 3)))
        make().run(run.t[:2], run.gyro[:2], run.accel[:2], *no_frames)
        res = make().run_simulation(run, record_nodes=smooth)
        pos_var = np.diagonal(res.covariance[:, 0:3, 0:3], axis1=1, axis2=2)
        att_var = np.trace(res.covariance[:, 6:9, 6:9], axis1=1, axis2=2)
        ori_sigma = np.degrees(np.sqrt(att_var))
    else:
        res = hol22.Hol22EKF.from_eskf_state(x, P0, run).run_simulation(run)
        pos_var = np.diagonal(res.covariance[:, 0:3, 0:3], axis1=1, axis2=2)
        ori_sigma = None
    step(2)
    truth = Trajectory(run.t, run.truth["position"], run.truth["quat"], name="truth")
    estimate = Trajectory(res.t, res.position, res.quat, name=f"dualpose fuse --filter {filter}")
    ev = evaluate(truth, estimate, align="se3", rpe_delta=_RPE_DELTA_M, rpe_unit="m")
    duration = float(run.t[-1] - run.t[0])
    rep = res.innovation
    metrics = {
        "data": data,
        "filter": filter,
        "seed": int(seed),
        "duration_s": duration,
        "imu_samples": int(len(run.t)),
        "camera_frames": int(len(run.frames)),
        "filter_wall_time_s": float(res.wall_time),
        "realtime_factor": duration / float(res.wall_time),
    }
    ed = ev.as_dict()
    for key in ("ate_rmse_m", "orientation_rmse_deg", "rpe_rmse_m", "rpe_rotation_rmse_deg"):
        metrics[key] = ed[key]
    metrics.update(rep.summary())
    pos_err, ori_err, unaligned = _unaligned_errors(res.position, res.quat, run.truth)
    metrics.update(unaligned)
    metrics["evaluation"] = ed
    smoothed = _smoothed_metrics(res, run.truth, truth, filter) if smooth else {}
    if smooth:
        metrics["smoothed"] = smoothed.pop("metrics")
    step(3)
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
        **smoothed,
    )


def _unaligned_errors(position: np.ndarray, quat: np.ndarray, truth: dict) -> tuple[np.ndarray, np.ndarray, dict]:
    """Position error (N, 3) m and attitude-error angle (N,) deg against the simulator's truth (no alignment), and
    their RMSE as ``{"position_rmse_unaligned_m", "orientation_rmse_unaligned_deg"}``."""
    import dualpose as dp

    pos_err = position - truth["position"]
    ori_err = np.degrees(dp.quat_angle(quat, truth["quat"]))
    rmse = {
        "position_rmse_unaligned_m": float(np.sqrt(np.mean(np.sum(pos_err**2, axis=1)))),
        "orientation_rmse_unaligned_deg": float(np.sqrt(np.mean(ori_err**2))),
    }
    return pos_err, ori_err, rmse


def _check_smooth(filter: str, smooth: bool) -> None:  # noqa: A002
    if smooth and filter != "eskf":
        raise ValueError(
            f"smooth=True (--smooth) needs filter 'eskf': the RTS smoother runs over the error-state filter's "
            f"stored nodes; got filter {filter!r}"
        )


def _smoothed_metrics(res, truth_arrays: dict, truth: Trajectory, filter: str) -> dict:  # noqa: ANN001, A002
    """RTS-smooth the filter result ``res`` (recorded nodes) and evaluate it like the filter.

    Returns the extra :class:`FuseResult` fields plus ``"metrics"``: ``ate_rmse_m``, ``orientation_rmse_deg``,
    ``rpe_rmse_m``, ``rpe_rotation_rmse_deg`` (as the filter's, SE(3)-aligned), ``position_rmse_unaligned_m``,
    ``orientation_rmse_unaligned_deg`` and ``smoother_wall_time_s`` (backward pass only).
    """
    from dualpose.fusion.metrics import evaluate
    from dualpose.fusion.smoother import rts_smooth

    sm = rts_smooth(res)
    traj = Trajectory(sm.t, sm.position, sm.quat, name=f"dualpose fuse --filter {filter} --smooth")
    ed = evaluate(truth, traj, align="se3", rpe_delta=_RPE_DELTA_M, rpe_unit="m").as_dict()
    pos_err, ori_err, unaligned = _unaligned_errors(sm.position, sm.quat, truth_arrays)
    metrics = {key: ed[key] for key in ("ate_rmse_m", "orientation_rmse_deg", "rpe_rmse_m", "rpe_rotation_rmse_deg")}
    metrics.update(unaligned)
    metrics["smoother_wall_time_s"] = float(sm.wall_time)
    return {
        "metrics": metrics,
        "smoothed": traj,
        "smoothed_position_error": pos_err,
        "smoothed_orientation_error_deg": ori_err,
    }
