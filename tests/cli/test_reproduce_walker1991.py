"""``dualpose reproduce walker1991`` (quick mode): JSON schema, SVD == DQ, plausible statistics, --out safety."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dualpose.cli.main import main
from dualpose.pipelines.reproduce.walker1991 import feeder_vertices
from dualpose.registration import register_pose


def test_feeder_geometry():
    v = feeder_vertices()
    assert v.shape == (32, 3)
    assert np.allclose(v.min(0), 0) and np.allclose(v.max(0), [322, 84, 151])
    on_face = np.isclose(v, 0) | np.isclose(v, [322, 84, 151])
    assert on_face.any(axis=1).all()  # every vertex lies on a face of the box


def test_json_rows_and_honest_comparison(capsys):
    assert main(["reproduce", "walker1991", "--quick", "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    rows = res["rows"]
    assert {(r["n_points"], r["method"]) for r in rows} == {(n, m) for n in (5, 10, 20, 30) for m in ("svd", "dq")}
    for r in rows:
        assert set(r) >= {"n_points", "method", "std_x", "std_y", "std_z", "std_theta_deg"}
        assert r["max_abs_diff_svd_vs_dq"] <= 1e-9  # identical estimates: both are the exact LS optimum
    by = {(r["n_points"], r["method"]): r for r in rows}
    for n in (5, 10, 20, 30):
        assert by[(n, "svd")]["std_x"] == pytest.approx(by[(n, "dq")]["std_x"], rel=1e-9)
    # the noise is 0.5 per coordinate: the translation stds are of that order, the angle std a fraction of a degree
    assert 0.05 < by[(30, "dq")]["std_x"] < 0.5 and by[(30, "dq")]["std_theta_deg"] < 0.2
    # normals help when there are few points
    mixed = {(r["n_points"], r["n_directions"]): r for r in res["mixed"]}
    assert mixed[(3, 3)]["rot_err_rms_deg"] < mixed[(3, 0)]["rot_err_rms_deg"]
    tm = res["timing"]
    assert len(tm["samples"]) == len(tm["seconds"]) and tm["fit_slope_s_per_sample"] > 0


def test_out_dir_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "res"
    assert main(["reproduce", "walker1991", "--quick", "--out", str(out)]) == 0
    md = (out / "walker1991.md").read_text()
    assert "Table 3" in md and "not reproduced" in md
    data = json.loads((out / "walker1991.json").read_text())
    assert data["experiment"] == "walker1991"
    capsys.readouterr()
    assert main(["reproduce", "walker1991", "--quick", "--out", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    assert main(["reproduce", "walker1991", "--quick", "--out", str(out), "--force"]) == 0


def test_single_estimate_on_the_feeder_is_exact_without_noise():
    import dualpose as dp

    v = feeder_vertices()
    q = dp.quat_from_axis_angle(np.array([3.0, 4.0, 6.0]), np.deg2rad(36.0))
    est = register_pose(v, dp.quat_rotate(q, v) + [7.0, 8.0, 13.0])
    assert np.abs(est.translation - [7, 8, 13]).max() <= 1e-11
    assert abs(np.rad2deg(dp.quat_angle(est.quat, dp.quat_identity())) - 36.0) <= 1e-11
