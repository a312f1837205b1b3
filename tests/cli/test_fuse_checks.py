"""``dualpose fuse`` on bad inputs and bad output locations: one-line errors (exit 1 data, 2 usage), warnings about
IMU gaps, plain progress lines off a terminal (docs/fusion.md, "Checks on the input")."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from dualpose.cli.main import main


@pytest.fixture(scope="module")
def good(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from dualpose.io import write_recording
    from dualpose.sim import recording_from_simulation, simulate_eight

    d = tmp_path_factory.mktemp("rec") / "good"
    write_recording(d, recording_from_simulation(simulate_eight(0)))
    return d


def _copy(good: Path, tmp_path: Path) -> Path:
    d = tmp_path / "rec"
    shutil.copytree(good, d)
    return d


def _imu_rows(d: Path) -> tuple[list[str], list[str]]:
    lines = (d / "imu.csv").read_text().splitlines()
    return [s for s in lines if s.startswith("#")], [s for s in lines if not s.startswith("#")]


def _sensors(d: Path, edit) -> None:
    s = json.loads((d / "sensors.json").read_text())
    edit(s)
    (d / "sensors.json").write_text(json.dumps(s))


def _error_line(capsys) -> str:
    err = [s for s in capsys.readouterr().err.splitlines() if "error" in s]
    assert len(err) == 1, err
    return err[0]


def test_huge_imu_value_names_the_imu_file(good, tmp_path, capsys):
    d = _copy(good, tmp_path)
    head, rows = _imu_rows(d)
    cells = rows[50].split(",")
    cells[4] = "1e300"
    rows[50] = ",".join(cells)
    (d / "imu.csv").write_text("\n".join(head + rows) + "\n")
    assert main(["fuse", "--data", str(d)]) == 1
    line = _error_line(capsys)
    assert line.startswith("dualpose fuse: error: ") and "imu.csv" in line and "accel: sample 50" in line


def test_too_few_imu_rows(good, tmp_path, capsys):
    d = _copy(good, tmp_path)
    head, rows = _imu_rows(d)
    (d / "imu.csv").write_text("\n".join(head + rows[:19]) + "\n")
    assert main(["fuse", "--data", str(d)]) == 1
    assert "19 samples" in _error_line(capsys)


def test_huge_noise_density_names_the_sensor_file(good, tmp_path, capsys):
    d = _copy(good, tmp_path)
    _sensors(d, lambda s: s["imu"].__setitem__("gyroscope_noise_density", 1e300))
    assert main(["fuse", "--data", str(d)]) == 1
    line = _error_line(capsys)
    assert "sensors.json" in line and "gyroscope_noise_density" in line


def test_gravity_pointing_up_is_refused(good, tmp_path, capsys):
    d = _copy(good, tmp_path)
    _sensors(d, lambda s: s.__setitem__("gravity", [0.0, 0.0, 9.81]))
    assert main(["fuse", "--data", str(d)]) == 1
    line = _error_line(capsys)
    assert "points up" in line and str(d) in line


def test_imu_gap_is_warned_with_its_times(good, tmp_path, capsys):
    d = _copy(good, tmp_path)
    head, rows = _imu_rows(d)
    (d / "imu.csv").write_text("\n".join(head + rows[:300] + rows[500:]) + "\n")  # 2 s without IMU data
    assert main(["fuse", "--data", str(d), "--json"]) == 3  # finished, on an input it doubts
    out, err = capsys.readouterr()
    warn = [s for s in err.splitlines() if s.startswith("dualpose fuse: warning: ")]
    assert any("1 IMU gap(s)" in w and "2.990-5.000 s" in w for w in warn)
    assert [d["code"] for d in json.loads(out)["input_doubts"]] == ["imu_gap"]
    # the estimate drifts across the gap: its se3 alignment to the truth is not determined, warned about and flagged
    assert len(warn) == 2 and any("alignment (se3) is not determined" in w for w in warn)
    assert json.loads(out)["alignment_well_determined"] is False
    assert "\r" not in err  # progress: plain lines off a terminal
    assert "dualpose fuse: 4/4 evaluate" in err


@pytest.mark.parametrize("out", ["FILE/sub", "/proc/dualpose-out", "/sys/dualpose-out"])
def test_unwritable_output_is_refused_before_computing(out, tmp_path, capsys):
    (tmp_path / "FILE").write_text("x")
    out = out.replace("FILE", str(tmp_path / "FILE"))
    assert main(["fuse", "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("dualpose fuse: error: --out ")  # no progress: nothing computed


def test_negative_seed_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["fuse", "--seed", "-1"])
    assert exc.value.code == 2
    assert "argument --seed: must be an integer in [0," in capsys.readouterr().err


def test_top_view_is_drawn_in_the_plane_the_eight_spans():
    from dualpose.evaluation.fuse_figures import motion_plane
    from dualpose.sim import simulate_eight

    assert motion_plane(simulate_eight(0).truth["position"]) == (0, 2)  # x-z: the eight faces the wall y = 0
