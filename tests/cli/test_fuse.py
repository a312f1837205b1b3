"""``dualpose fuse``: JSON keys, table, --out files, no overwrite without --force, bad --data."""

from __future__ import annotations

import json

import pytest

from dualpose.cli.fuse import OUTPUT_FILES
from dualpose.cli.main import main

KEYS = ("ate_rmse_m", "orientation_rmse_deg", "rpe_rmse_m", "nis_fraction_inside", "realtime_factor", "filter", "data")


def test_json_has_the_documented_keys_and_meets_the_bars(capsys):
    assert main(["fuse", "--json"]) == 0
    cap = capsys.readouterr()
    out = json.loads(cap.out)
    for key in KEYS:
        assert key in out
    assert out["filter"] == "eskf" and out["data"] == "sim"
    assert out["ate_rmse_m"] <= 0.01 and out["orientation_rmse_deg"] <= 0.5
    assert "4/4" in cap.err  # progress bar on stderr


def test_out_writes_files_refuses_overwrite_and_force_replaces(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["fuse", "--filter", "hol22", "--out", str(out)]) == 0
    table = capsys.readouterr().out
    assert "ATE RMSE" in table and "hol22" in table
    for name in OUTPUT_FILES:
        assert (out / name).stat().st_size > 0
    assert (out / "top_view.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["filter"] == "hol22"
    rows = [r for r in (out / "trajectory.tum").read_text().splitlines() if not r.startswith("#")]
    assert len(rows) == metrics["imu_samples"] and len(rows[0].split()) == 8

    before = (out / "metrics.json").stat().st_mtime_ns
    assert main(["fuse", "--filter", "hol22", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "holds an earlier run's output" in err and "--force" in err and str(out) in err
    assert (out / "metrics.json").stat().st_mtime_ns == before

    (out / "metrics.json").write_text("{}")  # changed after the run: no longer what dualpose wrote
    assert main(["fuse", "--filter", "hol22", "--out", str(out), "--force"]) == 2
    assert "metrics.json and manifest.json disagree" in capsys.readouterr().err
    (out / "metrics.json").unlink()
    assert main(["fuse", "--filter", "hol22", "--out", str(out), "--force"]) == 0
    assert json.loads((out / "metrics.json").read_text())["filter"] == "hol22"


@pytest.mark.parametrize("data", ["recording.csv", "euroc/"])
def test_missing_input_is_rejected_clearly(data, capsys):
    assert main(["fuse", "--data", data]) == 1
    err = capsys.readouterr().err
    assert "no such file or directory" in err and data in err
