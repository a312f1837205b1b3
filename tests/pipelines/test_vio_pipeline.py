"""``dualpose fuse --data <EqVIO CSV> --truth <ground truth> --out DIR``: the visual–inertial job end to end."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from dualpose.io import read_tum


def _fuse(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "dualpose.cli.main", "fuse", *args], capture_output=True, text=True)


def test_fuse_runs_the_msckf_on_feature_tracks(tmp_path, euroc_v101) -> None:
    csv, gt = euroc_v101
    out = tmp_path / "out"
    p = _fuse("--data", str(csv), "--truth", str(gt), "--out", str(out), "--json")
    assert p.returncode == 0, p.stderr
    m = json.loads(p.stdout)
    assert m["estimator"] == "msckf" and m["ate_rmse_4dof_m"] < 0.08
    saved = json.loads((out / "metrics.json").read_text())
    assert saved["ate_rmse_se3_m"] == m["ate_rmse_se3_m"]
    traj = read_tum(out / "trajectory.tum")
    assert traj.stamps[0] > 1.4e9 and np.all(np.diff(traj.stamps) > 0)  # absolute seconds, IMU rate
    np.testing.assert_allclose(traj.positions[0], 0.0, atol=1e-2)  # the gravity-aligned start frame
    assert (out / "trajectory.png").stat().st_size < 300_000
    again = _fuse("--data", str(csv), "--out", str(out))
    assert again.returncode == 2 and "earlier run's output" in again.stderr
    bad = _fuse("--data", str(csv), "--smooth")
    assert bad.returncode == 2 and "--smooth" in bad.stderr


def test_metrics_are_strict_json_when_no_feature_was_used(tmp_path, euroc_v101) -> None:
    from dualpose.pipelines.vio import run_vio

    csv, _ = euroc_v101
    lines = csv.read_text().splitlines()
    rest = [lines[0]] + [r for r in lines[1:] if r.startswith("meta") or float(r.split(",")[2]) < 3.0]  # at rest
    short = tmp_path / "rest.csv"
    short.write_text("\n".join(rest) + "\n")
    m = run_vio(short).metrics
    assert m["features_used"] == 0
    json.dumps(m, allow_nan=False)  # no NaN in metrics.json / --json


def test_a_missing_truth_file_is_reported_before_the_filter_runs(tmp_path, euroc_v101, monkeypatch) -> None:
    import pytest

    from dualpose.estimation.msckf import MsckfVio
    from dualpose.pipelines.vio import run_vio

    def no_run(*args, **kwargs):
        raise AssertionError("the filter ran before the truth file was read")

    monkeypatch.setattr(MsckfVio, "run", no_run)
    csv, _ = euroc_v101
    with pytest.raises(OSError, match="missing.csv"):
        run_vio(csv, truth=tmp_path / "missing.csv")
