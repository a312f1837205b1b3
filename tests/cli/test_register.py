"""``dualpose register``: end to end on CSV files, JSON output, RANSAC, and clear errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

import dualpose as dp
from dualpose.cli.main import main


def _write(path, arr, header="x,y,z"):
    arr = np.atleast_2d(np.asarray(arr).T).T if np.ndim(arr) == 1 else arr
    lines = [header] if header else []
    lines += [",".join(repr(float(v)) for v in np.atleast_1d(row)) for row in arr]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@pytest.fixture
def problem(tmp_path):
    rng = np.random.default_rng(4)
    q = dp.quat_canonical(dp.quat_normalize(rng.normal(size=4)))
    t = np.array([0.5, -1.5, 2.0])
    p0 = rng.normal(size=(12, 3)) * 3
    p1 = dp.quat_rotate(q, p0) + t
    return q, t, p0, p1, _write(tmp_path / "model.csv", p0), _write(tmp_path / "meas.csv", p1, header=None)


def test_json_output(problem, capsys):
    q, t, _, _, fm, fs = problem
    assert main(["register", fm, fs, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert np.abs(np.array(out["quat_xyzw"]) - q).max() <= 1e-12
    assert np.abs(np.array(out["translation"]) - t).max() <= 1e-12
    m = np.array(out["matrix"])
    assert np.abs(m[:3, :3] - dp.matrix_from_quat(q)).max() <= 1e-12 and out["degeneracy"] == "none"


def test_text_output_with_directions_and_weights(problem, tmp_path, capsys):
    q, _, p0, p1, fm, fs = problem
    d0 = np.eye(3)[:2]
    fd0 = _write(tmp_path / "d0.csv", d0)
    fd1 = _write(tmp_path / "d1.csv", dp.quat_rotate(q, d0))
    fw = _write(tmp_path / "w.csv", np.ones((12, 1)), header="w")
    assert main(["register", fm, fs, "--directions", fd0, fd1, "--weights", fw, "--method", "horn"]) == 0
    out = capsys.readouterr().out
    assert "quaternion [x, y, z, w]" in out and "4x4 matrix" in out and "12 point(s), 2 direction(s)" in out


def test_ransac(tmp_path, capsys):
    rng = np.random.default_rng(2)
    q = dp.quat_normalize(rng.normal(size=4))
    p0 = rng.uniform(-5, 5, size=(30, 3))
    p1 = dp.quat_rotate(q, p0) + 1.0
    p1[:8] = rng.uniform(-20, 20, size=(8, 3))
    fm, fs = _write(tmp_path / "a.csv", p0), _write(tmp_path / "b.csv", p1)
    assert main(["register", fm, fs, "--ransac", "--threshold", "0.01", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["inliers"] == list(range(8, 30))
    assert main(["register", fm, fs, "--ransac"]) == 2
    assert "--threshold" in capsys.readouterr().err


def test_bad_files(problem, tmp_path, capsys):
    _, _, p0, _, fm, _ = problem
    short = _write(tmp_path / "short.csv", p0[:5])
    assert main(["register", fm, short]) == 2
    assert "has 12 point(s) but" in capsys.readouterr().err
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("x,y,z\n1,2,3\n4,5\n")
    assert main(["register", str(ragged), fm]) == 2
    assert "line 3: expected 3 column(s)" in capsys.readouterr().err
    cell = tmp_path / "cell.csv"
    cell.write_text("1,2,3\n4,5,six\n")
    assert main(["register", fm, str(cell)]) == 2
    assert "line 2, column 3: 'six' is not a number" in capsys.readouterr().err
    two = _write(tmp_path / "two.csv", p0[:2])
    assert main(["register", two, two]) == 2
    assert "not enough correspondences" in capsys.readouterr().err
