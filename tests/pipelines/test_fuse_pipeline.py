"""``dualpose.pipelines.fuse.run_fuse``: the accuracy bars of docs/fusion.md on the default simulated run, metrics
consistent with the arrays they summarise, and bad arguments."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from dualpose.pipelines.fuse import run_fuse


@pytest.fixture(scope="module")
def eskf_result():
    calls = []
    res = run_fuse("sim", "eskf", seed=0, progress=lambda done, total, stage: calls.append((done, total, stage)))
    return res, calls


def test_eskf_meets_the_documented_bars(eskf_result):
    m = eskf_result[0].metrics
    assert m["ate_rmse_m"] <= 0.01
    assert m["orientation_rmse_deg"] <= 0.5
    assert m["filter"] == "eskf" and m["data"] == "sim"
    assert m["realtime_factor"] > 0
    for key in ("ate_rmse_m", "orientation_rmse_deg", "rpe_rmse_m", "nis_fraction_inside", "realtime_factor"):
        assert np.isfinite(m[key])


def test_metrics_agree_with_the_error_arrays(eskf_result):
    res = eskf_result[0]
    np.testing.assert_array_equal(res.estimate.stamps, res.truth.stamps)
    # the SE(3)-aligned ATE cannot exceed the unaligned position RMSE (Umeyama minimises it)
    unaligned = np.sqrt(np.mean(np.sum(res.position_error**2, axis=1)))
    assert res.metrics["ate_rmse_m"] <= unaligned + 1e-12
    assert res.metrics["position_rmse_unaligned_m"] == pytest.approx(unaligned, rel=1e-12)
    assert res.metrics["orientation_rmse_unaligned_deg"] <= 0.5
    np.testing.assert_allclose(res.position_error, res.estimate.positions - res.truth.positions, rtol=0, atol=1e-15)
    # NIS coverage recomputed from the per-update NIS with scipy's chi2(2) quantiles
    lo, hi = chi2.ppf([0.025, 0.975], 2)
    np.testing.assert_allclose(res.nis_bounds, (lo, hi), rtol=1e-12)
    v = res.nis[res.nis_accepted]
    assert res.metrics["nis_fraction_inside"] == pytest.approx(np.mean((v >= lo) & (v <= hi)), abs=1e-15)
    assert 0.85 <= res.metrics["nis_fraction_inside"] <= 1.0
    # the filter's 3-sigma bounds contain the error most of the time
    assert np.mean(np.abs(res.position_error) <= 3 * res.position_sigma) > 0.9
    assert np.mean(res.orientation_error_deg <= 3 * res.orientation_sigma_deg) > 0.9


def test_progress_reports_every_stage_in_order(eskf_result):
    calls = eskf_result[1]
    assert [c[0] for c in calls] == [1, 2, 3, 4]
    assert {c[1] for c in calls} == {4}


def test_hol22_runs_and_tracks():
    res = run_fuse(filter="hol22", seed=0)
    m = res.metrics
    assert m["filter"] == "hol22"
    assert m["ate_rmse_m"] <= 0.02 and m["orientation_rmse_deg"] <= 1.0
    assert res.orientation_sigma_deg is None
    assert res.position_sigma.shape == res.position_error.shape


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"filter": "ukf"}, "filter must be one of"), ({"data": "no/such/run"}, "no/such/run: no such file")],
)
def test_bad_arguments_raise(kwargs, match):
    with pytest.raises(ValueError, match=match):
        run_fuse(**kwargs)
