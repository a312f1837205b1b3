"""Monte-Carlo consistency study of the error-state filter on the simulator: the job behind ``dualpose fuse
--monte-carlo N [--seed S]`` (docs/scaling.md, "Many runs").

Run ``k`` (seed ``S + k``) simulates Hol's eight-shaped run (:func:`dualpose.sim.simulate_eight`, all sensor noise
seeded by the seed) and runs :class:`~dualpose.estimation.eskf.ErrorStateEKF` on it from a draw of its own prior
(:func:`dualpose.estimation.consistency.filter_from_prior`, generator seeded by ``[seed, 7]``) -- the set-up of a
NEES test (Bar-Shalom, Li and Kirubarajan 2001, §5.4): the initial error is distributed as the filter believes.
Per run: the 15-dimensional NEES at every IMU time against the truth, the NIS of the camera updates (2 dof), and the
ATE / orientation RMSE after SE(3) alignment (:func:`dualpose.evaluation.metrics.evaluate`).  Over the runs: the
average NEES at every time with its two-sided 95 % band ``χ²_{runs·15}`` / runs
(:func:`dualpose.estimation.consistency.nees_band`) and the distributions of the per-run numbers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from dualpose import sim
from dualpose.estimation import consistency
from dualpose.estimation.state import ESKF_ERROR
from dualpose.evaluation.metrics import evaluate
from dualpose.jobs.scheduler import TaskFailure, run_tasks
from dualpose.jobs.table import Cell, JobResult, ResultsTable, outcome_rows, summarize
from dualpose.types import Trajectory

if TYPE_CHECKING:
    import distributed

__all__ = ["MC_COLUMNS", "MC_METRICS", "MonteCarloResult", "monte_carlo_run", "run_monte_carlo"]

#: per-run numbers (summarised over the runs)
MC_METRICS: tuple[str, ...] = (
    "mean_nees", "nees_fraction_inside", "mean_nis", "nis_fraction_inside", "ate_rmse_m", "orientation_rmse_deg",
)  # fmt: skip

#: columns of the results table of :func:`run_monte_carlo`
MC_COLUMNS: tuple[str, ...] = ("run", "seed", "filter", "status", "error", "imu_samples", "n_correspondences",
                               "n_rejected", *MC_METRICS)  # fmt: skip

#: the two-sided probability of the NEES and NIS bands
_P = 0.95


def monte_carlo_run(seed: int) -> dict[str, object]:
    """One Monte-Carlo run (module docstring): the task of :func:`run_monte_carlo`, pure in ``seed``.

    Returns
    -------
    dict
        The per-run columns of :data:`MC_COLUMNS` from ``imu_samples`` on, plus ``t`` (N,) IMU times (s) and
        ``nees`` (N,) the NEES at those times.  ``nees_fraction_inside``: the fraction of times at which the run's
        own NEES lies in the two-sided 95 % χ²(15) interval.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0; got {seed!r}")
    run = sim.simulate_eight(int(seed))
    res = consistency.filter_from_prior(run, np.random.default_rng([int(seed), 7])).run_recording(run)
    nees = np.asarray(consistency.nees_against_truth(run.truth, res), dtype=np.float64)
    lo, hi = consistency.nees_band(ESKF_ERROR.dim, 1, _P)
    truth = Trajectory(run.t, run.truth["position"], run.truth["quat"], name="truth")
    est = Trajectory(res.t, res.position, res.quat, name="estimate")
    ev = evaluate(truth, est, align="se3")
    rep = res.innovation.summary()
    return {
        "imu_samples": int(run.t.shape[0]),
        "n_correspondences": int(rep["n_correspondences"]),
        "n_rejected": int(rep["n_rejected"]),
        "mean_nees": float(np.mean(nees)),
        "nees_fraction_inside": float(np.mean((nees >= lo) & (nees <= hi))),
        "mean_nis": float(rep["mean_nis"]),
        "nis_fraction_inside": float(rep["nis_fraction_inside"]),
        "ate_rmse_m": ev.ate_stats.rmse,
        "orientation_rmse_deg": ev.orientation_stats.rmse,
        "t": np.asarray(run.t, dtype=np.float64),
        "nees": nees,
    }


@dataclass
class MonteCarloResult(JobResult):
    """Output of :func:`run_monte_carlo`.

    Attributes
    ----------
    table : ResultsTable
        One row per run (:data:`MC_COLUMNS`), in seed order; a failed run has ``status`` "failed", its reason in
        ``error`` and NaN metrics.
    summary : ResultsTable
        Mean, median, std, min, max of :data:`MC_METRICS` over the runs (:func:`dualpose.jobs.table.summarize`).
    t : ndarray, shape (N,)
        IMU times of the simulated run, s (the same for every seed).
    average_nees : ndarray, shape (N,)
        The NEES averaged over the successful runs at every time (summed in seed order).
    nees_band : tuple of float
        Two-sided 95 % band of ``average_nees`` for that many runs (``χ²_{runs·15}`` / runs).
    failed : int
        Runs that failed.
    """

    t: NDArray[np.float64]
    average_nees: NDArray[np.float64]
    nees_band: tuple[float, float]


def run_monte_carlo(
    runs: int,
    seed: int = 0,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    client: distributed.Client | None = None,
) -> MonteCarloResult:
    """``runs`` Monte-Carlo runs with the seeds ``seed .. seed + runs - 1`` on a scheduler.

    Parameters
    ----------
    runs : int
        Number of runs, >= 1.
    seed : int
        The first seed, >= 0.
    scheduler, workers, progress, client
        As :func:`dualpose.jobs.scheduler.run_tasks`.

    Returns
    -------
    MonteCarloResult
        The same ``runs`` and ``seed`` give the same result, bit for bit, on any scheduler.

    Raises
    ------
    ValueError
        ``runs`` < 1 or ``seed`` < 0.
    """
    for name, value, low in (("runs", runs, 1), ("seed", seed, 0)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{name} must be an integer >= {low}; got {value!r}")
    seeds = [int(seed) + k for k in range(int(runs))]
    outcomes = run_tasks(monte_carlo_run, seeds, scheduler=scheduler, workers=workers, progress=progress,
                         client=client)
    base: list[dict[str, Cell]] = [{"run": k, "seed": s, "filter": "eskf"} for k, s in enumerate(seeds)]
    rows = outcome_rows(MC_COLUMNS, base, outcomes, {"imu_samples": 0, "n_correspondences": 0, "n_rejected": 0})
    total: NDArray[np.float64] | None = None
    t: NDArray[np.float64] = np.zeros(0)
    for out in outcomes:  # the average NEES, summed in seed order
        if not isinstance(out, TaskFailure):
            nees = np.asarray(out["nees"], dtype=np.float64)
            if total is None:
                total, t = nees.copy(), np.asarray(out["t"], dtype=np.float64)
            else:
                total += nees
    ok = sum(r["status"] == "ok" for r in rows)
    table = ResultsTable(MC_COLUMNS, rows)
    summary = summarize(table, ("filter",), MC_METRICS, lambda r: r["status"] == "ok")
    average = total / ok if total is not None else np.zeros(0)
    band = consistency.nees_band(ESKF_ERROR.dim, max(ok, 1), _P)
    return MonteCarloResult(table, summary, len(rows) - ok, t, average, band)
