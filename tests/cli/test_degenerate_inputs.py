"""Numerically degenerate inputs through real processes: ``dualpose eval`` refuses an alignment the data do not
determine (exit 1, one line), warns about and flags a poorly determined one; ``dualpose calibrate hand-eye`` refuses
two recordings of different motions and reports the credibility of a true pair (docs/refusals.md)."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from _pipes import dualpose_process

_spec = importlib.util.spec_from_file_location(
    "handeye_sim", Path(__file__).parents[1] / "calibration" / "handeye_sim.py"
)
sim = importlib.util.module_from_spec(_spec)
sys.modules.setdefault(_spec.name, sim)  # dataclasses look their module up in sys.modules
_spec.loader.exec_module(sim)


def _run(*args: str) -> tuple[int, str, str]:
    proc = dualpose_process(*args, stdin=None)
    out, err = proc.communicate(timeout=120)
    return proc.returncode, out, err


def _tum(path: Path, positions: np.ndarray) -> str:
    lines = [f"{0.1 * k:.3f} {p[0]:.6f} {p[1]:.6f} {p[2]:.6f} 0 0 0 1\n" for k, p in enumerate(positions)]
    path.write_text("".join(lines))
    return str(path)


def _one_error_line(err: str, prog: str = "dualpose eval") -> str:
    lines = [s for s in err.splitlines() if s.strip()]
    assert "Traceback" not in err and "RuntimeWarning" not in err, err
    assert len(lines) == 1 and lines[0].startswith(f"{prog}: error: "), err
    return lines[0]


def test_eval_refuses_a_still_reference_with_jitter_and_a_nearly_straight_path(tmp_path):
    rng = np.random.default_rng(5)
    n = 300
    still = np.array([1.0, 2.0, 3.0]) + rng.normal(0.0, 1e-4, (n, 3))  # 0.1 mm jitter: not "exactly" still
    s = np.linspace(0.0, 10.0, n)
    moving = 0.5 * np.column_stack([np.cos(s), np.sin(s), 0.1 * s]) + rng.normal(0.0, 0.02, (n, 3))
    ref, est = _tum(tmp_path / "ref.tum", still), _tum(tmp_path / "est.tum", moving)
    for align in ("sim3", "posyaw"):  # (se3 and scale: tests/evaluation/test_alignment_conditioning.py)
        code, out, err = _run("eval", ref, est, "--align", align, "--quiet")
        assert code == 1 and out == ""
        assert "not determined by the data" in _one_error_line(err)
    for k in (3, 11):  # a nearly straight path: the rotation about it is fitted to the noise
        t = np.linspace(0.0, 10.0, k)
        truth = np.column_stack([t, 0.01 * np.sin(t), 0.0 * t])
        ref = _tum(tmp_path / f"line{k}.tum", truth)
        est = _tum(tmp_path / f"noisy{k}.tum", truth + rng.normal(0.0, 0.02, (k, 3)))
        code, _, err = _run("eval", ref, est, "--align", "se3", "--quiet")
        assert code == 1 and "standard deviation" in _one_error_line(err)
    code, _, err = _run("eval", ref, est, "--align", "none", "--quiet")  # nothing fitted: a meaningful number
    assert code == 0, err


def test_eval_warns_about_and_flags_a_poorly_determined_alignment(tmp_path):
    rng = np.random.default_rng(6)
    s = np.linspace(0.0, 2.0, 40)
    truth = np.column_stack([s, 0.3 * np.sin(2.0 * s), 0.2 * np.cos(3.0 * s)])
    ref = _tum(tmp_path / "ref.tum", truth)
    est = _tum(tmp_path / "est.tum", truth + rng.normal(0.0, 0.05, truth.shape))
    code, out, err = _run("eval", ref, est, "--align", "se3", "--json", "--quiet")
    assert code == 0, err
    warn = [s for s in err.splitlines() if s.strip()]
    assert len(warn) == 1 and warn[0].startswith("dualpose eval: warning: the se3 alignment is poorly determined")
    cond = json.loads(out)["alignment"]["conditioning"]
    assert cond["well_determined"] is False and 2.9 < cond["rotation_std_deg"] < 29.0
    # the same path without the noise is well determined, and the table says how well
    est = _tum(tmp_path / "est0.tum", truth + rng.normal(0.0, 1e-4, truth.shape))
    code, out, err = _run("eval", ref, est, "--quiet")
    assert code == 0 and err == ""
    assert "alignment  determined to rotation" in out and "POORLY" not in out


@pytest.fixture(scope="module")
def handeye_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("handeye")
    a = sim.simulate(3600.0123, 21, duration=12.0, gaps=())
    b = sim.simulate(3600.0123, 22, duration=12.0, gaps=())
    sim.write_rows(d / "cam.csv", a.camera)
    sim.write_rows(d / "body.csv", a.body)
    sim.write_rows(d / "other_body.csv", b.body)
    return d


def test_hand_eye_refuses_two_unrelated_recordings(handeye_files):
    cam, other = str(handeye_files / "cam.csv"), str(handeye_files / "other_body.csv")
    code, out, err = _run("calibrate", "hand-eye", cam, other)
    assert code == 1 and out == ""
    line = _one_error_line(err, "dualpose calibrate hand-eye")
    assert "not credible" in line and "the streams' own noise predicts" in line


def test_hand_eye_reports_the_credibility_of_a_true_pair(handeye_files):
    code, out, err = _run("calibrate", "hand-eye", str(handeye_files / "cam.csv"), str(handeye_files / "body.csv"),
                          "--json")  # fmt: skip
    assert code == 0 and err == ""
    m = json.loads(out)
    assert m["credible"] is True and m["credibility"] == "credible"
    assert 0.3 < m["residual_to_noise"] < 2.5 and m["coarse_correlation"] > 0.6
    assert m["rotation_residual_deg"] == pytest.approx(m["residual_to_noise"] * m["expected_rotation_residual_deg"])
