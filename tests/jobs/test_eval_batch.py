"""eval --batch as a function: manifests and rpg_trajectory_evaluation folders read into pairs, each row equal to
``evaluate`` on the pair alone, a bad row failed with its reason while the others complete, the same table serially
and on a LocalCluster of worker processes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from jobfiles import ALGORITHMS, DATASETS, RUNS

from dualpose.evaluation.metrics import evaluate
from dualpose.io import read_tum
from dualpose.jobs.eval_batch import (
    EVAL_COLUMNS,
    EvalSettings,
    read_eval_manifest,
    rpg_pairs,
    run_eval_batch,
)


def test_manifest_pairs_resolve_paths_and_keep_bad_rows(eval_manifest: Path, tmp_path: Path) -> None:
    pairs = read_eval_manifest(eval_manifest)
    assert len(pairs) == len(DATASETS) * len(ALGORITHMS) * RUNS + 1
    assert Path(pairs[0].reference) == tmp_path / "MH_01_gt.txt"
    assert (pairs[0].dataset, pairs[0].algorithm, pairs[0].run) == ("MH_01", "vio_mono", "0")
    bad = tmp_path / "bad.csv"
    bad.write_text("reference,estimate,algorithm,dataset\na,b,c,d\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"bad\.csv:1: manifest header lacks the column\(s\) run"):
        read_eval_manifest(bad)
    bad.write_text("reference,estimate,algorithm,dataset,run\na,,c,d,0\n", encoding="utf-8")
    (pair,) = read_eval_manifest(bad)
    assert pair.problem is not None and pair.problem.endswith("bad.csv:2: empty field(s) estimate")
    bad.write_text("# only a comment\n", encoding="utf-8")
    with pytest.raises(ValueError, match="no header line"):
        read_eval_manifest(bad)


def test_rows_equal_evaluate_on_each_pair_and_the_bad_row_fails(eval_manifest: Path) -> None:
    settings = EvalSettings(align="sim3", rpe_delta=5)
    pairs = read_eval_manifest(eval_manifest, settings)
    res = run_eval_batch(pairs, scheduler="serial")
    assert res.table.columns == EVAL_COLUMNS and len(res.table) == len(pairs)
    assert res.failed == 1
    for pair, row in zip(pairs[:-1], res.table.rows[:-1], strict=True):
        ev = evaluate(read_tum(pair.reference), read_tum(pair.estimate), align="sim3", rpe_delta=5)
        assert row["status"] == "ok" and row["error"] == ""
        assert row["ate_rmse_m"] == ev.ate_stats.rmse
        assert row["orientation_rmse_deg"] == ev.orientation_stats.rmse
        assert row["rpe_translation_rmse_m"] == ev.rpe_translation_stats.rmse
        assert row["scale"] == ev.alignment.scale and row["matched_poses"] == 200
    bad = res.table.rows[-1]
    assert bad["status"] == "failed" and "missing_estimate.txt" in str(bad["error"])
    assert np.isnan(bad["ate_rmse_m"])
    # the noisier algorithm has the larger ATE in every dataset
    mean = {(r["dataset"], r["algorithm"]): r["mean"] for r in res.summary.rows if r["metric"] == "ate_rmse_m"}
    for d in DATASETS:
        assert mean[(d, "vio_mono")] > 2 * mean[(d, "vio_stereo")]
    ghost = [r for r in res.summary.rows if r["algorithm"] == "ghost"]
    assert ghost and all(r["runs"] == 0 and r["failed"] == 1 and np.isnan(r["mean"]) for r in ghost)


def test_summary_statistics_over_runs(eval_manifest: Path) -> None:
    res = run_eval_batch(read_eval_manifest(eval_manifest), scheduler="serial")
    for s in res.summary.rows:
        if s["algorithm"] == "ghost":
            continue
        v = np.array([r[s["metric"]] for r in res.table.rows
                      if (r["dataset"], r["algorithm"]) == (s["dataset"], s["algorithm"])])  # fmt: skip
        assert s["runs"] == RUNS and s["failed"] == 0
        assert (s["mean"], s["median"], s["std"], s["min"], s["max"]) == (
            np.mean(v), np.median(v), np.std(v), np.min(v), np.max(v))  # fmt: skip


def test_rpg_layout_runs_labels_and_alignment(rpg_results: Path) -> None:
    pairs = rpg_pairs(rpg_results)
    mono = [p for p in pairs if p.algorithm == "vio_mono"]
    stereo = [p for p in pairs if p.algorithm == "vio_stereo"]
    assert [(p.dataset, p.run) for p in mono] == [(d, str(r)) for d in DATASETS for r in range(RUNS)]
    assert [(p.dataset, p.run) for p in stereo] == [(d, "0") for d in DATASETS]
    assert {p.settings.align for p in mono} == {"se3"}  # eval_cfg.yaml
    assert {p.settings.align for p in stereo} == {"sim3"}  # the toolbox's default without it
    res = run_eval_batch(pairs, scheduler="serial")
    assert res.failed == 0 and set(res.table.column("alignment")) == {"se3", "sim3"}
    cfg = rpg_results / "vio_mono" / "laptop_vio_mono_MH_01" / "eval_cfg.yaml"
    cfg.write_text("align_type: affine\n", encoding="utf-8")
    res = run_eval_batch(rpg_pairs(rpg_results), scheduler="serial")
    assert res.failed == RUNS
    assert all("align_type must be one of" in str(r["error"]) for r in res.table.rows if r["status"] != "ok")
    with pytest.raises(ValueError, match="no rpg_trajectory_evaluation result folders"):
        rpg_pairs(rpg_results / "vio_mono")


def test_serial_and_cluster_tables_are_identical(eval_manifest: Path, cluster_address: str) -> None:
    pairs = read_eval_manifest(eval_manifest)
    serial = run_eval_batch(pairs, scheduler="serial")
    parallel = run_eval_batch(pairs, scheduler=cluster_address)
    assert parallel.table.to_csv_text() == serial.table.to_csv_text()
    assert parallel.summary.to_csv_text() == serial.summary.to_csv_text()
    assert parallel.failed == serial.failed == 1
    distributed = pytest.importorskip("distributed", reason="dask.distributed is not installed")
    with distributed.Client(cluster_address, set_as_default=False) as client:  # a connected client of the caller's
        on_client = run_eval_batch(pairs, client=client)
        assert client.status == "running"
    assert on_client.table.to_csv_text() == serial.table.to_csv_text()
