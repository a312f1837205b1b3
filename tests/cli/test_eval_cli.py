"""``dualpose eval``: table, JSON, plot (never overwritten without --force) and bad-file errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dualpose.cli.main import main
from dualpose.evaluation.metrics import evaluate
from dualpose.io import read_trajectory
from realdata import data_dir

DATA = data_dir("tum")


@pytest.fixture(scope="module")
def files() -> tuple[str, str]:
    if not DATA.is_dir():
        pytest.skip(f"data directory {DATA} missing")
    return str(DATA / "V102_groundtruth.csv"), str(DATA / "V102.txt")


def test_json_equals_the_library_result(files, capsys):
    ref, est = files
    assert main(["eval", ref, est, "--align", "sim3", "--rpe-delta", "0.5", "--rpe-unit", "m", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    ev = evaluate(read_trajectory(ref), read_trajectory(est), align="sim3", rpe_delta=0.5, rpe_unit="m")
    assert out["ate_rmse_m"] == ev.ate_stats.rmse
    assert out["rpe_rmse_m"] == ev.rpe_translation_stats.rmse
    assert out["orientation_rmse_deg"] == ev.orientation_stats.rmse
    assert out["ate_m"]["max"] == ev.ate_stats.max and out["matched_poses"] == len(ev.ate)
    assert out["alignment"]["method"] == "sim3" and out["alignment"]["scale"] == ev.alignment.scale
    assert out["settings"]["reference_format"] == "euroc_groundtruth" and out["settings"]["estimate_format"] == "tum"


def test_table_lists_every_statistic(files, capsys):
    ref, est = files
    assert main(["eval", ref, est]) == 0
    out = capsys.readouterr().out
    ev = evaluate(read_trajectory(ref), read_trajectory(est))
    line = next(ln for ln in out.splitlines() if ln.startswith("ATE translation [m]"))
    values = [float(x) for x in line.split()[3:]]
    s = ev.ate_stats
    np.testing.assert_allclose(values, [s.rmse, s.mean, s.median, s.std, s.min, s.max], atol=5e-7)
    for head in ("rmse", "mean", "median", "std", "min", "max", "orientation [deg]", "RPE translation [m]"):
        assert head in out
    assert "euroc_groundtruth" in out and "alignment se3" in out


def test_plot_written_and_never_overwritten_without_force(files, tmp_path, capsys):
    ref, est = files
    png = tmp_path / "eval.png"
    assert main(["eval", ref, est, "--plot", str(png)]) == 0
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
    capsys.readouterr()
    png.write_bytes(b"mine")
    assert main(["eval", ref, est, "--plot", str(png)]) == 2  # refused before anything is read
    assert "file exists" in capsys.readouterr().err and png.read_bytes() == b"mine"
    assert main(["eval", ref, est, "--plot", str(png), "--force", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["plot"] == str(png)
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_bad_files_report_file_and_line(tmp_path, capsys):
    good = tmp_path / "good.txt"
    good.write_text("".join(f"{k * 0.1} {k} {k % 3} {k % 5} 0 0 0 1\n" for k in range(20)))
    bad = tmp_path / "bad.txt"
    bad.write_text("# header\n1.0 0 0 0 0 0 0 1\n1.1 0 0 0 0 0 0\n")
    assert main(["eval", str(good), str(bad)]) == 1
    assert f"{bad}:3: expected 8 fields" in capsys.readouterr().err
    assert main(["eval", str(good), str(tmp_path / "missing.txt")]) == 1
    assert "missing.txt" in capsys.readouterr().err
    shifted = tmp_path / "late.txt"
    shifted.write_text("".join(f"{100 + k * 0.1} {k} {k % 3} {k % 5} 0 0 0 1\n" for k in range(20)))
    assert main(["eval", str(good), str(shifted)]) == 1
    assert "no matching timestamps" in capsys.readouterr().err
    # the same file against itself: zero error, and an offset that undoes a clock shift works
    assert main(["eval", str(good), str(shifted), "--offset", "-100", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["ate_rmse_m"] < 1e-12


@pytest.mark.parametrize(("align", "n"), [("origin", None), ("scale", 50), ("none", None)])
def test_other_alignments_reach_the_library(files, capsys, align, n):
    ref, est = files
    argv = ["eval", ref, est, "--align", align, "--json"] + (["--n-align", str(n)] if n else [])
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    ev = evaluate(read_trajectory(ref), read_trajectory(est), align=align, align_first_n=n)
    assert out["ate_rmse_m"] == ev.ate_stats.rmse and out["alignment"]["method"] == align
    assert out["settings"]["align_first_n"] == n


def test_interpolate_flag(files, capsys):
    ref, est = files
    assert main(["eval", ref, est, "--interpolate", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    ev = evaluate(read_trajectory(ref), read_trajectory(est), sync="interpolate")
    assert out["ate_rmse_m"] == ev.ate_stats.rmse and out["settings"]["sync"] == "interpolate"
