"""``dualpose fuse --smooth``: filter and smoother side by side in the table and JSON, trajectory_smoothed.tum,
no overwrite without --force, a clear error for --filter hol22."""

from __future__ import annotations

import json

from dualpose.cli.fuse import OUTPUT_FILES
from dualpose.cli.main import main


def test_json_reports_filter_and_smoother(capsys):
    assert main(["fuse", "--smooth", "--json", "--seed", "2"]) == 0
    out = json.loads(capsys.readouterr().out)
    s = out["smoothed"]
    for key in ("ate_rmse_m", "orientation_rmse_deg", "position_rmse_unaligned_m", "orientation_rmse_unaligned_deg"):
        assert s[key] < out[key]
    assert out["filter"] == "eskf"


def test_table_and_out_files(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["fuse", "--smooth", "--out", str(out)]) == 0
    table = capsys.readouterr().out
    assert "RTS smoother" in table
    ate_row = next(r for r in table.splitlines() if r.startswith("ATE RMSE"))
    filt, smooth = (float(v) for v in ate_row.split()[-2:])
    metrics = json.loads((out / "metrics.json").read_text())
    assert filt == round(metrics["ate_rmse_m"], 6) and smooth == round(metrics["smoothed"]["ate_rmse_m"], 6)
    for name in (*OUTPUT_FILES, "trajectory_smoothed.tum"):
        assert (out / name).stat().st_size > 0
    rows = [r for r in (out / "trajectory_smoothed.tum").read_text().splitlines() if not r.startswith("#")]
    assert len(rows) == metrics["imu_samples"] and len(rows[0].split()) == 8
    assert rows != [r for r in (out / "trajectory.tum").read_text().splitlines() if not r.startswith("#")]
    # only the smoothed trajectory is left of the earlier set: still refused without --force
    for name in OUTPUT_FILES:
        (out / name).unlink()
    assert main(["fuse", "--smooth", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "trajectory_smoothed.tum" in err and "--force" in err
    assert main(["fuse", "--smooth", "--out", str(out), "--force"]) == 0


def test_smooth_with_hol22_is_a_clear_error(capsys):
    assert main(["fuse", "--smooth", "--filter", "hol22"]) == 2
    err = capsys.readouterr().err
    assert "--smooth needs --filter eskf" in err and "hol22" in err
