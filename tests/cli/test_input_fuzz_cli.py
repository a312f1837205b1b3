"""Fuzzing the command line's input checks through real processes and pipes (docs/refusals.md, "Inputs: samples,
parameters, saved states, set-ups").

Every case ends in a correct result or one line naming the argument, file or input line: exit 1 for bad data, 2 for
bad options, 3 for a run that finished on an input it doubts (a ``warning:`` line each); never a Python traceback and
never a NaN in the output.  ``ahrs --stream`` and ``fuse --stream`` get a valid stream with one corrupted line at a
random place (hypothesis, through the command's entry point in this process; a few of them also through real
processes and pipes); the set-up files and ``fuse --data`` recordings get the implausible values of each kind.
"""

from __future__ import annotations

import io
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from _pipes import run_lines
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dualpose import sim
from dualpose.cli.main import main
from dualpose.estimation import initialization
from dualpose.estimation.state import ESKF_STATE
from dualpose.io.recording import write_sensor_setup
from dualpose.pipelines.fuse_stream import recording_lines
from dualpose.types import FilterStart, SensorSetup

FUZZ = settings(max_examples=25, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])  # fmt: skip

#: the corruptions of one input line and the exit status each must give (None: depends on where it is)
CORRUPTIONS = {
    "huge_gyro": 1, "huge_accel": 1, "nan": 1, "word": 1, "backwards": 1, "gap": 3, "zero_force": None,
}  # fmt: skip


def corrupt(fields: list[str], kind: str, t_prev: float) -> list[str]:
    """``fields`` (t, gx, gy, gz, ax, ay, az, ...) of one IMU line with the corruption ``kind``."""
    f = list(fields)
    if kind == "huge_gyro":
        f[1] = "1e300"
    elif kind == "huge_accel":
        f[5] = "-1e300"
    elif kind == "nan":
        f[2] = "nan"
    elif kind == "word":
        f[3] = "fast"
    elif kind == "backwards":
        f[0] = repr(t_prev - 0.5)
    elif kind == "gap":
        f[0] = repr(float(f[0]) + 1e6)
    elif kind == "zero_force":
        f[4:7] = ["0", "0", "0"]
    return f


def run_main(lines: list[str], *args: str) -> tuple[int, str, str]:
    """Exit status, stdout and stderr of ``dualpose ARGS`` run in this process on ``lines`` as its stdin (the
    command's whole code path but the interpreter start; the real-process cases below cover that)."""
    old = sys.stdin, sys.stdout, sys.stderr
    sys.stdin, sys.stdout, sys.stderr = io.StringIO("".join(lines)), io.StringIO(), io.StringIO()
    try:
        code = main(list(args))
        return code, sys.stdout.getvalue(), sys.stderr.getvalue()
    finally:
        sys.stdin, sys.stdout, sys.stderr = old


def check_outcome(code: int, out: str, err: str, command: str, bad_line: int, n_before: int, n_all: int,
                  width: int) -> None:  # fmt: skip
    """The invariants of every case: a known exit status, no traceback, finite output lines, and for exit 1 one error
    line naming the bad input line after exactly the outputs of the lines before it."""
    assert "Traceback" not in err
    assert code in (0, 1, 3), err
    rows = [line.split(",") for line in out.splitlines()]
    assert all(len(r) == width and all(math.isfinite(float(x)) for x in r) for r in rows), out[-500:]
    errors = [s for s in err.splitlines() if ": error: " in s]
    warnings = [s for s in err.splitlines() if ": warning: " in s]
    assert len(errors) + len(warnings) == len(err.splitlines()), err
    if code == 1:
        assert len(errors) == 1 and errors[0].startswith(f"dualpose {command}: error: stdin line {bad_line}: "), err
        assert len(rows) == n_before
    else:
        assert not errors and len(rows) == n_all
        assert (code == 3) == bool(warnings), err


# ---------------------------------------------------------------------------------------------------- ahrs


def ahrs_lines(n: int = 200) -> list[str]:
    rng = np.random.default_rng(3)
    t = np.arange(n) / 100.0
    gyr = rng.normal(0.0, 2e-3, (n, 3))
    acc = np.array([0.0, 0.0, 9.81]) + rng.normal(0.0, 2e-2, (n, 3))
    return [", ".join(map(repr, row)) + "\n" for row in np.column_stack([t, gyr, acc]).tolist()]


def corrupted_ahrs(kind: str, at: int) -> tuple[list[str], int]:
    """The AHRS lines with line ``at`` corrupted, and the exit status wanted."""
    lines = ahrs_lines()
    prev = float(lines[at - 1].split(",")[0]) if at else 0.0
    lines[at] = ", ".join(corrupt(lines[at].rstrip("\n").split(", "), kind, prev)) + "\n"
    if kind == "gap":  # the lines after a gap are late by as much: keep them in order
        lines[at + 1 :] = [", ".join([repr(float(s.split(", ")[0]) + 1e6), *s.split(", ")[1:]])
                           for s in lines[at + 1 :]]  # fmt: skip
    want = CORRUPTIONS[kind]
    if kind == "zero_force":
        want = 1 if at == 0 else 0  # later, the running mean at rest still has a direction
    if kind == "gap" and at == 0:
        want = 0  # the first line has nothing to be apart from
    if kind == "backwards" and at == 0:
        want = 3  # the first line half a second early: a gap before the second
    return lines, want


@FUZZ
@given(kind=st.sampled_from(sorted(CORRUPTIONS)), at=st.integers(0, 199))
def test_ahrs_stream_with_one_corrupted_line(kind, at):
    lines, want = corrupted_ahrs(kind, at)
    code, out, err = run_main(lines, "ahrs", "--stream", "--rate", "100", "--no-mag")
    check_outcome(code, out, err, "ahrs", at + 1, at, len(lines), 5)
    assert code == want, err


@pytest.mark.parametrize(("kind", "at"), [("huge_gyro", 150)])
def test_ahrs_stream_corrupted_line_through_a_real_pipe(kind, at):
    lines, want = corrupted_ahrs(kind, at)
    code, out, err = run_lines(lines, "ahrs", "--stream", "--rate", "100", "--no-mag")
    check_outcome(code, out, err, "ahrs", at + 1, at, len(lines), 5)
    assert code == want, err


@pytest.mark.parametrize("args", [("--rate", "1e-100"), ("--rate", "1e9", "--rest-seconds", "100")])
def test_ahrs_stream_implausible_options_are_usage_errors(args):
    code, out, err = run_main(ahrs_lines(20), "ahrs", "--stream", "--no-mag", *args)
    assert code == 2 and out == "" and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("dualpose ahrs: ") and "--r" in err


# ---------------------------------------------------------------------------------------------------- fuse --stream

RUN = sim.recording_from_simulation(sim.simulate_eight(2), rest_seconds=0.9)
FUSE_LINES = recording_lines(RUN)[:260]


@pytest.fixture(scope="module")
def calibration(tmp_path_factory) -> Path:
    x, _ = initialization.initial_state_from_run(RUN, 0.9)
    start = FilterStart(**{k: ESKF_STATE.get(x, k) for k in ESKF_STATE.names})
    return write_sensor_setup(tmp_path_factory.mktemp("cal") / "calibration.json", SensorSetup.of(RUN, start))


def corrupted_fuse(kind: str, at: int) -> tuple[list[str], int, int, int]:
    """The fusion lines with the IMU line nearest ``at`` corrupted: the lines, the bad line's number, the IMU lines
    before it and in all."""
    lines = list(FUSE_LINES)
    imu = [k for k, s in enumerate(lines) if s.startswith("imu")]
    k = imu[min(range(len(imu)), key=lambda i: abs(imu[i] - at))]
    prev = float(lines[imu[imu.index(k) - 1]].split(",")[1]) if imu.index(k) else 0.0
    fields = lines[k].rstrip("\n").split(", ")
    lines[k] = ", ".join(["imu", *corrupt(fields[1:], kind, prev)]) + "\n"
    if kind == "gap":  # the lines after a gap are late by as much: keep them in order
        lines = lines[: k + 1] + [s for s in lines[k + 1 :] if s.startswith("imu")]
        lines[k + 1 :] = [", ".join(["imu", repr(float(s.split(", ")[1]) + 1e6), *s.split(", ")[2:]])
                          for s in lines[k + 1 :]]  # fmt: skip
    return lines, k + 1, sum(s.startswith("imu") for s in lines[:k]), sum(s.startswith("imu") for s in lines)


def check_fuse(kind: str, code: int, err: str, n_before: int) -> None:
    if kind in ("huge_gyro", "huge_accel", "nan", "word") or (kind == "backwards" and n_before):
        assert code == 1, err
    if kind == "gap" and n_before:
        assert code == 3 and "IMU gap" in err


@FUZZ
@given(kind=st.sampled_from(sorted(CORRUPTIONS)), at=st.integers(1, 259))
def test_fuse_stream_with_one_corrupted_imu_line(calibration, kind, at):
    lines, bad, n_before, n_all = corrupted_fuse(kind, at)
    code, out, err = run_main(lines, "fuse", "--stream", "--calibration", str(calibration))
    check_outcome(code, out, err, "fuse", bad, n_before, n_all, 8)
    check_fuse(kind, code, err, n_before)


@pytest.mark.parametrize(("kind", "at"), [("gap", 150)])
def test_fuse_stream_corrupted_line_through_a_real_pipe(calibration, kind, at):
    lines, bad, n_before, n_all = corrupted_fuse(kind, at)
    code, out, err = run_lines(lines, "fuse", "--stream", "--calibration", str(calibration))
    check_outcome(code, out, err, "fuse", bad, n_before, n_all, 8)
    check_fuse(kind, code, err, n_before)


def _edited(calibration: Path, tmp_path: Path, edit) -> Path:
    s = json.loads(calibration.read_text())
    edit(s)
    p = tmp_path / "calibration.json"
    p.write_text(json.dumps(s))
    return p


@pytest.mark.parametrize(("edit", "match"), [
    (lambda s: s["initial_state"].__setitem__("position_sigma", 1e300), "position_sigma"),
    (lambda s: s["initial_state"].__setitem__("velocity", [1e300, 0, 0]), "velocity"),
    (lambda s: s["camera"].__setitem__("timeshift_cam_imu", 1e300), "timeshift_cam_imu"),
    (lambda s: s["camera"].__setitem__("cx", 1e6), "principal point"),
    (lambda s: s["camera"].__setitem__("q_bc", [0, 0, 0, 0]), "q_bc"),
    (lambda s: s["camera"].__setitem__("pixel_sigma", -1), "pixel_sigma"),
])  # fmt: skip
def test_fuse_stream_implausible_calibration_is_one_line(calibration, tmp_path, edit, match):
    cal = _edited(calibration, tmp_path, edit)
    code, out, err = run_main(FUSE_LINES[:20], "fuse", "--stream", "--calibration", str(cal))
    assert code == 1 and out == "" and len(err.splitlines()) == 1, err
    assert str(cal) in err and match in err and "Traceback" not in err


def test_fuse_stream_gravity_pointing_up_is_refused_at_the_first_sample(calibration, tmp_path):
    cal = _edited(calibration, tmp_path, lambda s: s.__setitem__("gravity", [0.0, 0.0, 9.81]))
    code, out, err = run_main(FUSE_LINES, "fuse", "--stream", "--calibration", str(cal))
    first = next(k for k, s in enumerate(FUSE_LINES) if s.startswith("imu")) + 1
    assert code == 1 and out == "" and err.startswith(f"dualpose fuse: error: stdin line {first}: the set-up: gravity")
    assert "points up" in err and len(err.splitlines()) == 1


def test_fuse_stream_camera_never_used_is_a_doubt(calibration, tmp_path):
    cal = _edited(calibration, tmp_path, lambda s: s["camera"].__setitem__("timeshift_cam_imu", 1e6))
    code, out, err = run_main(FUSE_LINES, "fuse", "--stream", "--calibration", str(cal))
    assert code == 3 and "camera frames were never used" in err and "Traceback" not in err
    assert len(out.splitlines()) == sum(s.startswith("imu") for s in FUSE_LINES)


# ---------------------------------------------------------------------------------------------------- fuse --data


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    from dualpose.io import write_recording

    d = tmp_path_factory.mktemp("rec") / "good"
    write_recording(d, sim.recording_from_simulation(sim.simulate_eight(0)))
    return d


def _recording(good: Path, tmp_path: Path, imu=None, sensors=None) -> Path:
    d = tmp_path / "rec"
    shutil.copytree(good, d)
    if imu is not None:
        lines = (d / "imu.csv").read_text().splitlines()
        rows = [s for s in lines if not s.startswith("#")]
        data = np.array([[float(x) for x in s.split(",")] for s in rows])
        data = imu(data)
        text = [s for s in lines if s.startswith("#")] + [",".join([str(int(r[0]))] + [repr(float(x)) for x in r[1:]])
                                                          for r in data]  # fmt: skip
        (d / "imu.csv").write_text("\n".join(text) + "\n")
    if sensors is not None:
        s = json.loads((d / "sensors.json").read_text())
        sensors(s)
        (d / "sensors.json").write_text(json.dumps(s))
    return d


def _scale(cols: slice, factor: float):
    def f(data: np.ndarray) -> np.ndarray:
        data[:, cols] *= factor
        return data

    return f


@pytest.mark.parametrize(("imu", "sensors", "code", "what"), [
    (_scale(slice(4, 7), 1 / 9.80665), None, 1, "the accelerometer is in g"),
    (None, lambda s: s.__setitem__("rest_duration_s", 1e6), 1, "not shorter than the recording"),
    (_scale(slice(1, 4), 180 / np.pi), None, 3, "gyro_unit"),
    (None, lambda s: s["imu"].__setitem__("update_rate", 37.0), 3, "imu_rate_mismatch"),
])  # fmt: skip
def test_fuse_data_implausible_setups_are_refused_or_flagged(good, tmp_path, capsys, imu, sensors, code, what):
    d = _recording(good, tmp_path, imu, sensors)
    assert main(["fuse", "--data", str(d), "--json"]) == code
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    if code == 1:
        errors = [s for s in err.splitlines() if ": error: " in s]
        assert len(errors) == 1 and what in errors[0] and str(d) in errors[0]
    else:
        assert what in [x["code"] for x in json.loads(out)["input_doubts"]]
        assert any(s.startswith("dualpose fuse: warning: ") for s in err.splitlines())
