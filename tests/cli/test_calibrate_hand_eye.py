"""``dualpose calibrate hand-eye``: JSON keys and values on a simulated recording, one-line errors for bad input."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np

import dualpose as dp
from dualpose.cli.main import main

_spec = importlib.util.spec_from_file_location(
    "handeye_sim", Path(__file__).parents[1] / "calibration" / "handeye_sim.py"
)
sim = importlib.util.module_from_spec(_spec)
sys.modules.setdefault(_spec.name, sim)  # dataclasses look their module up in sys.modules
_spec.loader.exec_module(sim)

KEYS = {"rotation_xyzw", "translation_m", "time_offset_s", "rotation_residual_deg", "translation_residual_m",
        "pairs_used", "rotation_sigma_deg", "translation_sigma_m", "time_offset_sigma_s", "start_method",
        "start_rotation_residual_deg", "start_translation_residual_m"}  # fmt: skip


def test_json_on_simulated_files(tmp_path, capsys):
    rec = sim.simulate(3600.0123, 21, duration=30.0, gaps=((10.0, 12.0),))
    sim.write_rows(tmp_path / "cam.csv", rec.camera, ", ")
    sim.write_rows(tmp_path / "body.csv", rec.body, " ")
    assert main(["calibrate", "hand-eye", str(tmp_path / "cam.csv"), str(tmp_path / "body.csv"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert KEYS <= set(out)
    assert abs(out["time_offset_s"] - 3600.0123) < 2e-3
    assert np.degrees(dp.quat_angle(out["rotation_xyzw"], rec.quat)) < 0.2
    assert np.linalg.norm(np.subtract(out["translation_m"], rec.translation)) < 3e-3
    assert out["camera_rows"]["exact_duplicates"] > 0
    assert out["rotation_residual_deg"] <= out["start_rotation_residual_deg"]
    assert out["translation_residual_m"] <= out["start_translation_residual_m"]
    assert main(["calibrate", "hand-eye", str(tmp_path / "cam.csv"), str(tmp_path / "body.csv")]) == 0
    assert "time offset τ [s]" in capsys.readouterr().out


def test_bad_inputs_give_one_line_errors(tmp_path, capsys):
    good = tmp_path / "good.csv"
    good.write_text("".join(f"{k * 0.01}, 0, 0, 0, 0, 0, 0, 1\n" for k in range(50)))
    bad = tmp_path / "bad.csv"
    bad.write_text("0, 0, 0, 0, 0, 0, 0, 1\n0.1, 0, 0, 0, 0, 0, zero, 1\n")
    few = tmp_path / "few.csv"
    few.write_text("0, 0, 0, 0, 0, 0, 0, 1\n0.1, 0, 0, 0, 0, 0, 0, 1\n")
    cases = [
        ([str(tmp_path / "missing.csv"), str(good)], 1, "missing.csv"),
        ([str(bad), str(good)], 1, "bad.csv:2:"),
        ([str(few), str(good)], 1, "need at least 3"),
        ([str(good), str(good), "--time-offset", "1000"], 1, "no overlap in time"),
        ([str(good), str(good), "--fix-time-offset"], 2, "--fix-time-offset needs --time-offset"),
    ]
    for args, code, text in cases:
        assert main(["calibrate", "hand-eye", *args]) == code
        err = capsys.readouterr().err
        assert err.startswith("dualpose calibrate hand-eye: error: ") and text in err and err.count("\n") == 1
