"""``dualpose fuse --stream`` through real pipes: the printed poses are the streaming filter's (and the batch filter's)
bit for bit, one flushed line per IMU line, a malformed line stops it with a message naming the line after
everything before it was written, a reader that goes away ends it quietly with exit 141, and bad arguments exit 2."""

from __future__ import annotations

import numpy as np
import pytest
from _pipes import LineReader, dualpose_process, head_then_close, run_lines

from dualpose import sim
from dualpose.cli.main import main
from dualpose.estimation import initialization
from dualpose.estimation.state import ESKF_STATE
from dualpose.io.recording import read_sensor_setup, write_sensor_setup
from dualpose.pipelines.fuse_stream import (
    filter_for_setup,
    format_pose,
    parse_fusion_line,
    recording_lines,
    stream_filter,
)
from dualpose.types import FilterStart, SensorSetup

RUN = sim.recording_from_simulation(sim.simulate_eight(2), rest_seconds=0.9)
LINES = recording_lines(RUN)
N_IMU = len(RUN.t)


@pytest.fixture(scope="module")
def calibration(tmp_path_factory):
    """The simulated run's sensor file with the static-alignment + PnP start (its state; default sigmas)."""
    x, _ = initialization.initial_state_from_run(RUN, 0.9)
    start = FilterStart(**{k: ESKF_STATE.get(x, k) for k in ESKF_STATE.names}, attitude_sigma=np.radians(1.0))
    return str(write_sensor_setup(tmp_path_factory.mktemp("cal") / "calibration.json", SensorSetup.of(RUN, start)))


def parse_output(text: str) -> np.ndarray:
    return np.array([[float(x) for x in line.split(",")] for line in text.splitlines()]).reshape(-1, 8)


def run_stream(lines: list[str], *args: str) -> tuple[int, str, str]:
    return run_lines(lines, "fuse", "--stream", *args)


def reference(calibration: str, kind: str) -> np.ndarray:
    """(N, 8) t, position, q_wb of the streaming filter fed the lines in process."""
    s = stream_filter(calibration, kind)
    rows = []
    for line in LINES:
        tag, t, a, b = parse_fusion_line(line)
        if tag == "cam":
            s.update_camera(t, a, b)
        else:
            x = s.update_imu(t, a, b)
            L = s.state_layout
            q = L.get(x, "quat") if kind == "eskf" else L.get(x, "quat_be") * [-1, -1, -1, 1]
            rows.append([t, *L.get(x, "position"), *q])
    return np.array(rows)


# ---- the line formats -----------------------------------------------------------------------------------------------


def test_parse_fusion_line():
    tag, t, g, a = parse_fusion_line("imu, 0.5, 1, 2, 3, 4, 5, 6\n")
    assert (tag, t) == ("imu", 0.5) and g == [1, 2, 3] and a == [4, 5, 6]
    tag, t, pix, pts = parse_fusion_line("cam 0.25 2  10 20 1 2 3\t11 21 4 5 6  # two points")
    assert (tag, t) == ("cam", 0.25) and pix.tolist() == [[10, 20], [11, 21]] and pts.tolist() == [[1, 2, 3], [4, 5, 6]]
    assert parse_fusion_line("cam, 1.0, 0")[2].shape == (0, 2)
    assert parse_fusion_line("  # a comment") is None and parse_fusion_line("\n") is None
    bad = [
        ("gps, 1, 2", "field 1: expected 'imu' or 'cam'; got 'gps'"),
        ("imu, 1, 2, 3", "an imu line has 8 fields (imu, t, gx, gy, gz, ax, ay, az); got 4"),
        ("imu, 1, 2, x, 4, 5, 6, 7", "field 4 (gy): 'x' is not a number"),
        ("imu, 1, 2, 3, 4, 5, 6, inf", "field 8 (az): non-finite value 'inf'"),
        ("cam, 1", "a cam line starts with cam, t, n"),
        ("cam, 1, 1.5, 1, 2, 3, 4, 5", "field 3 (n): the number of correspondences must be a whole number >= 0"),
        ("cam, 1, 2, 1, 2, 3, 4, 5", "a cam line with n = 2 has 13 fields"),
        ("cam, 1, 1, 1, 2, 3, nan, 5", "field 7 (Y1): non-finite value 'nan'"),
    ]
    for line, message in bad:
        with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
            parse_fusion_line(line)


def test_format_pose_is_repr_exact():
    line = format_pose(0.01, np.array([1 / 3, -2.0, 1e-17]), np.array([0.1, -0.2, 1 / 7, np.sqrt(0.5)]))
    back = parse_output(line)[0]
    assert line.endswith("\n") and back[0] == 0.01 and back[1] == 1 / 3 and back[3] == 1e-17 and back[6] == 1 / 7


def test_recording_lines_cover_the_run():
    assert sum(line.startswith("imu") for line in LINES) == N_IMU
    assert sum(line.startswith("cam") for line in LINES) == len(RUN.frames.t)


def test_sensor_setup_round_trip(calibration):
    s = read_sensor_setup(calibration)
    assert s.imu_noise == RUN.imu_noise and np.array_equal(s.q_bc, RUN.q_bc) and np.array_equal(s.p_bc, RUN.p_bc)
    c, r = s.camera, RUN.camera
    assert (c.fx, c.fy, c.cx, c.cy, c.width, c.height) == (r.fx, r.fy, r.cx, r.cy, r.width, r.height)
    x, _ = initialization.initial_state_from_run(RUN, 0.9)
    assert np.array_equal(s.start.position, ESKF_STATE.get(x, "position"))
    assert np.array_equal(s.start.quat, ESKF_STATE.get(x, "quat"))


# ---- through pipes --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["eskf", "hol22"])
def test_stream_equals_stream_class_and_batch(calibration, kind):
    lines = list(LINES)
    lines[3] = lines[3].replace(", ", " ")  # whitespace separated
    lines[7:7] = ["# a comment line\n", "\n"]  # no output for these
    code, out, err = run_stream(lines, "--calibration", calibration, "--filter", kind)
    assert code == 0 and err == ""
    got = parse_output(out)
    assert got.shape == (N_IMU, 8) and np.array_equal(got[:, 0], RUN.t)
    assert np.array_equal(got, reference(calibration, kind))
    batch = filter_for_setup(calibration, kind).run_recording(RUN)
    assert np.array_equal(got[:, 1:4], batch.position) and np.array_equal(got[:, 4:], batch.quat)
    assert np.sqrt(np.mean(np.sum((got[:, 1:4] - RUN.ground_truth.positions) ** 2, axis=1))) < 0.02  # it tracks


def test_one_flushed_line_per_imu_line(calibration):
    proc = dualpose_process("fuse", "--stream", "--calibration", calibration)
    reader = LineReader(proc)
    got = []
    for line in LINES[:200]:
        proc.stdin.write(line)
        proc.stdin.flush()
        if line.startswith("imu"):  # its pose comes before the next line is sent; a cam line gives none
            got.append(reader.readline())
    proc.stdin.close()
    assert reader.readline() == "" and proc.wait() == 0
    ref = reference(calibration, "eskf")
    assert np.array_equal(parse_output("".join(got)), ref[: len(got)])


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        ("imu, 9.0, 0, 0\n", "stdin line 153: an imu line has 8 fields (imu, t, gx, gy, gz, ax, ay, az); got 4"),
        ("imu, 9.0, 0, 0, nope, 0, 0, 9.81\n", "stdin line 153: field 5 (gz): 'nope' is not a number"),
        ("camera, 9.0, 0\n", "stdin line 153: field 1: expected 'imu' or 'cam'; got 'camera'"),
        ("cam, 9.0, 2, 1, 2, 3, 4, 5\n", "stdin line 153: a cam line with n = 2 has 13 fields"),
        ("imu, 0.5, 0, 0, 0, 0, 0, 9.81\n", "stdin line 153: t must be finite and increase strictly: got 0.5 after"),
        ("cam, 0.5, 0\n", "stdin line 153: frame at IMU time 0.5 is not after the last IMU sample"),
    ],
)
def test_malformed_line_in_the_middle(calibration, bad, message):
    lines = list(LINES)
    lines[3:3] = ["# header, counted as a line\n", "\n"]  # line numbers count every input line
    lines.insert(152, bad)
    n_before = sum(line.startswith("imu") for line in lines[:152])
    code, out, err = run_stream(lines, "--calibration", calibration)
    assert code == 1
    assert len(err.splitlines()) == 1 and err.startswith(f"dualpose fuse: error: {message}")
    got = parse_output(out)
    assert got.shape == (n_before, 8)  # every IMU line before the bad one was answered
    assert np.array_equal(got, reference(calibration, "eskf")[:n_before])


def test_reader_closing_early_exits_141_quietly(calibration, tmp_path):
    src = tmp_path / "lines.txt"
    src.write_text("".join(LINES) + "".join(_shifted_copies(40)))  # ~28000 lines: more than a pipe holds
    head, err, code = head_then_close(src, "fuse", "--stream", "--calibration", calibration)
    assert code == 141 and err == ""
    assert parse_output("".join(head)).shape == (5, 8)


def _shifted_copies(k: int) -> list[str]:
    """IMU lines continuing the run in time (the last sample repeated at later times), k runs' worth."""
    dt = float(RUN.t[1] - RUN.t[0])
    rows = np.column_stack([RUN.t[-1] + dt * np.arange(1, k * N_IMU + 1), np.tile(RUN.gyro[-1], (k * N_IMU, 1)),
                            np.tile(RUN.accel[-1], (k * N_IMU, 1))])  # fmt: skip
    return ["imu, " + ", ".join(repr(v) for v in row) + "\n" for row in rows.tolist()]


def test_bad_calibration_file_exits_1(tmp_path):
    code, out, err = run_stream([], "--calibration", str(tmp_path / "missing.json"))
    assert code == 1 and out == "" and "missing.json: no such file or directory" in err
    path = tmp_path / "cal.json"
    path.write_text(open(write_sensor_setup(tmp_path / "full.json", _setup())).read().replace('"update_rate"', '"x"'))
    code, out, err = run_stream([], "--calibration", str(path))
    assert code == 1 and "imu.x: unknown key" in err


def _setup() -> SensorSetup:
    return SensorSetup.of(RUN, FilterStart(position=np.zeros(3), quat=np.array([0.0, 0.0, 0.0, 1.0])))


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["fuse", "--stream"], "--stream needs the sensor set-up and filter start: --calibration FILE"),
        (["fuse", "--calibration", "cal.json"], "--calibration is only used with --stream"),
        (["fuse", "--stream", "--calibration", "c.json", "--data", "sim"], "--data: not used with --stream"),
        (["fuse", "--stream", "--calibration", "c.json", "--out", "d", "--json"], "--out, --json: not used with"),
        (["fuse", "--stream", "--calibration", "c.json", "--smooth", "--seed", "1"], "--seed, --smooth: not used"),
    ],
)
def test_usage_errors_exit_2(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("dualpose fuse: error: ") and message in err


def test_help_documents_the_line_formats():
    out = dualpose_process("fuse", "--help").communicate()[0]
    for text in ("imu, t, gx, gy, gz, ax, ay, az", "cam, t, n, u1, v1, X1, Y1, Z1", "t, px, py, pz, qx, qy, qz, qw",
                 "initial_state", "141"):  # fmt: skip
        assert text in out
