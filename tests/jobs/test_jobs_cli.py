"""The many-run commands end to end: ``eval --batch``, ``fuse --monte-carlo``, ``ahrs --batch`` -- outputs written,
failed rows reported with their reason and counted in exit status 1, the default local process pool writing the
same bytes as the serial scheduler, usage errors (exit 2), progress lines off a terminal."""

from __future__ import annotations

from pathlib import Path

import pytest

from dualpose.cli.main import main
from dualpose.jobs.table import has_parquet
from realdata import data_dir

TABLES = ["results.csv", "summary.csv"] + (["results.parquet", "summary.parquet"] if has_parquet() else [])


def test_eval_batch_on_the_local_pool_equals_serial(eval_manifest: Path, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    pytest.importorskip("distributed", reason="dask.distributed is not installed (the test extra installs it)")
    pool, serial = tmp_path / "pool", tmp_path / "serial"
    assert main(["eval", "--batch", str(eval_manifest), "--align", "sim3", "--out", str(pool), "--workers", "2"]) == 1
    out, err = capsys.readouterr()
    assert "MH_01 / ghost / run 0" in err and "missing_estimate.txt" in err
    assert "dualpose eval: 1 of 13 rows failed" in err
    assert "dualpose eval: 13/13 tasks done" in err  # plain progress lines off a terminal
    assert out.splitlines()[0].split()[:4] == ["dataset", "algorithm", "metric", "runs"]
    assert sorted(p.name for p in pool.iterdir()) == sorted([*TABLES, "ate_rmse.png", "rpe_translation.png",
                                                             "manifest.json"])  # fmt: skip
    assert main(["eval", "--batch", str(eval_manifest), "--align", "sim3", "--out", str(serial), "--scheduler",
                 "serial", "--quiet"]) == 1  # fmt: skip
    assert "tasks done" not in capsys.readouterr().err
    for name in TABLES:
        assert (pool / name).read_bytes() == (serial / name).read_bytes(), name
    assert main(["eval", "--batch", str(eval_manifest), "--out", str(serial), "--scheduler", "serial"]) == 2
    assert "holds an earlier run's output" in capsys.readouterr().err
    assert main(["eval", "--batch", str(eval_manifest), "--out", str(serial), "--scheduler", "serial", "--force"]) == 1


def test_eval_batch_rpg_folder(rpg_results: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "--batch", str(rpg_results), "--scheduler", "serial"]) == 0
    out = capsys.readouterr().out
    assert "vio_mono" in out and "vio_stereo" in out and "ate_rmse_m" in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["eval", "--batch", "m.csv", "ref.txt"], "--batch reads the pairs from its manifest: not with a reference"),
        (["eval"], "give the reference and the estimate trajectory (or --batch MANIFEST)"),
        (["eval", "r.txt", "e.txt", "--scheduler", "serial"], "--scheduler: only used with --batch"),
        (["fuse", "--monte-carlo", "2", "--filter", "hol22"], "--monte-carlo runs the error-state filter"),
        (["fuse", "--monte-carlo", "2", "--data", "x"], "--monte-carlo runs the simulator: not with --data"),
        (["fuse", "--workers", "2"], "--workers: only used with --monte-carlo"),
        (["ahrs", "--batch", "x.mat", "--json"], "--batch names its recordings: not with --json"),
        (["ahrs", "f.mat", "--out", "d"], "--out: only used with --batch"),
    ],
)
def test_usage_errors(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    assert message in capsys.readouterr().err


def test_fuse_monte_carlo_writes_tables_and_figures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "mc"
    assert main(["fuse", "--monte-carlo", "3", "--seed", "5", "--scheduler", "serial", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "3 runs (seeds 5..7); average NEES inside its 95 % band" in text and "mean_nees" in text
    assert sorted(p.name for p in out.iterdir()) == sorted([*TABLES, "nees.png", "runs.png", "manifest.json"])
    lines = (out / "results.csv").read_text(encoding="utf-8").splitlines()
    assert [line.split(",")[1] for line in lines[1:]] == ["5", "6", "7"]


def test_ahrs_batch_counts_the_bad_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    trial = data_dir("broad") / "24_disturbed_tapping_A.mat"
    if not trial.is_file():
        pytest.skip(f"BROAD trial missing ({trial})")
    out = tmp_path / "fleet"
    code = main(["ahrs", "--batch", str(trial), str(tmp_path / "none.mat"), "--scheduler", "serial", "--out", str(out)])
    assert code == 1
    err = capsys.readouterr().err
    assert "none.mat: no such file" in err and "1 of 2 rows failed" in err
    assert (out / "rmse.png").is_file() and (out / "results.csv").read_text(encoding="utf-8").count("\n") == 3


def test_without_dask_the_job_runs_serially(monkeypatch: pytest.MonkeyPatch,
                                            capsys: pytest.CaptureFixture[str]) -> None:  # fmt: skip
    from dualpose.jobs import scheduler

    monkeypatch.setattr(scheduler, "default_scheduler", lambda: "serial")  # as without dask installed
    assert main(["fuse", "--monte-carlo", "2"]) == 0
    out, err = capsys.readouterr()
    assert "dask is not installed (pip install 'dualpose[dask]'): running the tasks serially" in err
    assert "2 runs (seeds 0..1)" in out
