"""``dualpose reproduce screw-vector`` (short durations; the full run is documented in docs/inertial.md)."""

import json
import math

import numpy as np
import pytest

from dualpose.cli.main import main
from dualpose.inertial.motions import coning_drift
from dualpose.pipelines.reproduce.screw_vector import Scenario, simulate

ARGS = ["reproduce", "screw-vector", "--duration", "20", "--long-duration", "60", "--no-progress"]


def test_json_summary_orders_the_algorithms(capsys):
    assert main([*ARGS, "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    runs = s["runs"]
    pos = [runs[f"{n}-sample"]["position_error_final_m"] for n in (1, 2, 3)]
    assert pos[0] > 100 * pos[1] > 100 * pos[2]
    assert runs["3-sample long run"]["duration_s"] == pytest.approx(60.0)
    # the real part of the screw-vector update is the rotation-vector update: identical attitude errors
    assert all(r["rotvec_minus_screw_attitude_error_max_rad"] < 1e-15 for r in runs.values())


def test_single_sample_drift_matches_dual_coning_prediction():
    sc = Scenario()
    r = simulate(sc, 1, 50.0)
    f = sc.follower
    rate = 2 * f.a * f.d * coning_drift(1.0, f.Omega, sc.h, 1)  # 2 a d ρ_1 Ω (ΩT)²
    slope = np.dot(r["t"], r["position_error"]) / np.dot(r["t"], r["t"])
    assert slope == pytest.approx(rate, rel=0.05)
    assert r["position_error"][-1] == pytest.approx(50.0 * rate, rel=0.1)
    assert math.isclose(r["t"][-1], 50.0)


def test_out_writes_figures_and_refuses_to_overwrite(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "figs"
    assert main([*ARGS, "--samples", "1", "3", "--out", str(out)]) == 0
    names = {p.name for p in out.iterdir()}
    assert {
        "screw_vector_1_sample.png",
        "screw_vector_3_sample.png",
        "screw_vector_comparison.png",
        "screw_vector_long_run.png",
        "summary.json",
    } <= names
    assert (out / "screw_vector_1_sample.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "| 1-sample |" in capsys.readouterr().out
    assert main([*ARGS, "--samples", "1", "--out", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    assert main([*ARGS, "--samples", "1", "--out", str(out), "--force"]) == 0
