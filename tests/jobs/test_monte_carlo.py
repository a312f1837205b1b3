"""fuse --monte-carlo as a function: run k is seed S + k on its own, the average NEES and its χ² band are those of
the Monte-Carlo test of Bar-Shalom et al. (the filter is consistent on the simulator), and serial ≡ cluster."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from dualpose.jobs.monte_carlo import MC_COLUMNS, monte_carlo_run, run_monte_carlo


def test_runs_are_their_seeds_and_the_average_is_in_order() -> None:
    res = run_monte_carlo(4, 7, scheduler="serial")
    assert res.table.columns == MC_COLUMNS
    assert res.table.column("seed") == [7, 8, 9, 10] and res.failed == 0
    total = np.zeros_like(res.t)
    for row, seed in zip(res.table.rows, range(7, 11), strict=True):
        one = monte_carlo_run(seed)
        assert row["mean_nees"] == float(np.mean(one["nees"]))
        assert row["ate_rmse_m"] == one["ate_rmse_m"]
        total += one["nees"]
    assert res.average_nees.tobytes() == (total / 4).tobytes()
    # the band is chi2 of runs x 15 dof over the runs (Bar-Shalom et al. 2001, §5.4.2)
    assert res.nees_band == pytest.approx((chi2.ppf(0.025, 60) / 4, chi2.ppf(0.975, 60) / 4), rel=1e-12)


def test_filter_is_consistent_over_twelve_runs() -> None:
    res = run_monte_carlo(12, 0, scheduler="serial")
    lo, hi = res.nees_band
    assert lo < float(np.mean(res.average_nees)) < hi
    assert np.mean((res.average_nees >= lo) & (res.average_nees <= hi)) > 0.85
    nis = {r["metric"]: r for r in res.summary.rows}["mean_nis"]
    assert nis["runs"] == 12 and 1.8 < nis["mean"] < 2.2  # NIS of 2-dof pixel residuals


def test_bad_arguments_are_refused() -> None:
    with pytest.raises(ValueError, match="runs must be an integer >= 1"):
        run_monte_carlo(0)
    with pytest.raises(ValueError, match="seed must be an integer >= 0"):
        run_monte_carlo(2, -1)
    with pytest.raises(ValueError, match="seed must be an integer >= 0"):
        monte_carlo_run(True)  # type: ignore[arg-type]


def test_serial_and_cluster_results_are_identical(cluster_address: str) -> None:
    serial = run_monte_carlo(8, 3, scheduler="serial")
    parallel = run_monte_carlo(8, 3, scheduler=cluster_address)
    assert parallel.table.to_csv_text() == serial.table.to_csv_text()
    assert parallel.summary.to_csv_text() == serial.summary.to_csv_text()
    assert parallel.average_nees.tobytes() == serial.average_nees.tobytes()
