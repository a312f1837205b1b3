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


def test_features_whose_depth_the_pixel_noise_leaves_undetermined_are_counted_not_used(euroc_v101) -> None:
    """The triangulation's depth test scales with the pixel σ: at 1 px every triangulated feature of V1_01 is
    determined (bit for bit the run without the test); at 3 px a few are not, and are counted apart from the failed
    and gated ones.  The rest period's gravity σ is reported and far below the 1° doubt."""
    from dualpose.estimation.msckf import MsckfOptions
    from dualpose.pipelines.vio import run_vio

    csv, gt = euroc_v101
    m = run_vio(csv, truth=gt).metrics
    off = run_vio(csv, truth=gt, options=MsckfOptions(depth_test=False)).metrics
    assert m["features_undetermined"] == 0 and m["ate_rmse_4dof_m"] == off["ate_rmse_4dof_m"]
    assert 0.0 < m["gravity_sigma_deg"] < 1.0 and m["input_doubts"] == []
    coarse = run_vio(csv, truth=gt, pixel_sigma=3.0).metrics
    assert coarse["features_undetermined"] > 0


def test_a_rest_period_that_does_not_determine_gravity_is_doubted_or_refused(euroc_v101) -> None:
    """The MSCKF levels its start from the rest period (1000 samples): shaken by 8 m/s² (white, per axis) the gravity
    direction is doubted (σ 1.9°; ``gravity_sigma`` in ``input_doubts``: exit status 3 on the command line), by
    40 m/s² refused (σ 9.9°) naming the rest period."""
    import dataclasses
    import warnings

    import pytest

    from dualpose.io.feature_tracks import read_eqvio_csv
    from dualpose.pipelines.vio import run_vio
    from dualpose.types.recording import RecordingWarning

    csv, _ = euroc_v101
    rec = read_eqvio_csv(csv)
    rest = rec.t < rec.t[0] + 4.0  # inside the detected rest period (4-5.2 s)
    rng = np.random.default_rng(5)

    def shaken(noise: float):
        accel = rec.accel.copy()
        accel[rest] += noise * rng.standard_normal((int(rest.sum()), 3))
        return dataclasses.replace(rec, accel=accel, t=rec.t.copy())

    with pytest.warns(RecordingWarning, match="gravity direction"):
        m = run_vio(shaken(8.0)).metrics
    assert 1.0 < m["gravity_sigma_deg"] < 5.0 and [d["code"] for d in m["input_doubts"]] == ["gravity_sigma"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match="rest period of .* the gravity direction is not determined"):
            run_vio(shaken(40.0))
