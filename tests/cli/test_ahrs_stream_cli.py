"""``dualpose ahrs --stream`` through real pipes: the printed orientations are ``AhrsStream``'s (and the batch
estimator's) bit for bit, one flushed line per input line, a malformed line stops it with a message naming the line
after everything before it was written, and a reader that goes away ends it quietly with exit 141."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from _pipes import LineReader, dualpose_process, head_then_close, run_lines

from dualpose.cli.main import main
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.pipelines.ahrs_stream import format_row, parse_imu_line, stream_ahrs_lines
from dualpose.sim import simulate_eight

RATE = 100.0
N_REST = 100  # the default --rest-seconds 1 at 100 Hz
FIELDS_6D = "expected 7 fields (t, gx, gy, gz, ax, ay, az)"


def synthetic(seed: int = 3):
    """One second at rest (a constant tilt, seeded sensor noise), then Hol's eight (``simulate_eight(0)``); 6D."""
    run = simulate_eight(0)
    rng = np.random.default_rng(seed)
    g_rest = rng.normal(scale=0.002, size=(N_REST, 3)) + [0.01, -0.02, 0.015]
    a_dir = run.accel[0] / np.linalg.norm(run.accel[0])
    a_rest = 9.81 * a_dir + rng.normal(scale=0.05, size=(N_REST, 3))
    t = np.arange(N_REST + len(run.t)) / RATE
    return t, np.vstack([g_rest, run.gyro]), np.vstack([a_rest, run.accel])


def lines_of(t, *columns) -> list[str]:
    """Input lines ``t, gx, ...`` with every number as its exact repr."""
    data = np.column_stack([t, *columns])
    return [", ".join(repr(x) for x in row) + "\n" for row in data.tolist()]


def parse_output(text: str) -> np.ndarray:
    rows = [[float(x) for x in line.split(",")] for line in text.splitlines()]
    return np.array(rows, dtype=np.float64).reshape(-1, 5)


def dualpose_stream(*args: str, stdin=subprocess.PIPE) -> subprocess.Popen:
    """``python -m dualpose.cli.main ahrs --stream ARGS`` with pipes (the dualpose this test imported)."""
    return dualpose_process("ahrs", "--stream", *args, stdin=stdin)


def run_stream(lines: list[str], *args: str) -> tuple[int, str, str]:
    return run_lines(lines, "ahrs", "--stream", *args)


def stream_reference(t, gyr, acc, mag, rate, n_rest) -> np.ndarray:
    """AhrsStream.update_imu per sample (every output at its own sample, the rest period's included)."""
    s = AhrsStream(rate, use_mag=mag is not None, n_rest=n_rest)
    return np.array([s.update_imu(t[k], gyr[k], acc[k], None if mag is None else mag[k]) for k in range(len(t))])


# ---- the line formats -----------------------------------------------------------------------------------------------


def test_parse_imu_line_separators_comments():
    assert parse_imu_line("0.5, 1, 2, 3, 4, 5, 6\n", use_mag=False) == [0.5, 1, 2, 3, 4, 5, 6]
    assert parse_imu_line("0.5 1\t2 3  4 5 6 # note, with a comma", use_mag=False) == [0.5, 1, 2, 3, 4, 5, 6]
    assert parse_imu_line("  # a comment", use_mag=True) is None
    assert parse_imu_line("   \n", use_mag=True) is None
    with pytest.raises(ValueError, match=r"expected 10 fields \(t, gx, gy, gz, ax, ay, az, mx, my, mz\), got 7"):
        parse_imu_line("0 1 2 3 4 5 6", use_mag=True)
    with pytest.raises(ValueError, match=r"field 3 \(gy\): 'x' is not a number"):
        parse_imu_line("0, 1, x, 3, 4, 5, 6", use_mag=False)
    with pytest.raises(ValueError, match=r"field 7 \(az\): non-finite value 'inf'"):
        parse_imu_line("0, 1, 2, 3, 4, 5, inf", use_mag=False)


def test_format_row_is_repr_exact():
    q = np.array([0.1, -0.2, 1 / 3, np.sqrt(0.5)])
    line = format_row(0.01, q)
    assert line.endswith("\n") and line.count(",") == 4
    assert np.array_equal(parse_output(line)[0, 1:], q) and parse_output(line)[0, 0] == 0.01


def test_pipeline_yields_one_line_per_sample_also_inside_the_rest_period():
    t, gyr, acc = synthetic()
    lines = lines_of(t, gyr, acc)
    it = stream_ahrs_lines(iter(lines[: N_REST + 2]), RATE, use_mag=False, n_rest=N_REST)
    out = list(it)
    assert len(out) == N_REST + 2 and all(o.count("\n") == 1 for o in out)  # nothing held
    assert np.array_equal(parse_output("".join(out))[:, 1:], stream_reference(t, gyr, acc, None, RATE, N_REST)[:102])
    # input ending inside the rest period: every sample already has its line
    assert len(list(stream_ahrs_lines(iter(lines[:40]), RATE, use_mag=False, n_rest=N_REST))) == 40


# ---- through pipes --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("rest_seconds", [None, "0"])
def test_stream_equals_ahrs_stream_and_batch_synthetic(rest_seconds):
    t, gyr, acc = synthetic()
    lines = lines_of(t, gyr, acc)
    lines[5] = lines[5].replace(", ", " ")  # whitespace separated
    lines[7:7] = ["# a comment line\n", "\n"]  # no output for these
    args = ["--rate", "100", "--no-mag"] + ([] if rest_seconds is None else ["--rest-seconds", rest_seconds])
    code, out, err = run_stream(lines, *args)
    assert code == 0 and err == ""
    got = parse_output(out)
    n_rest = N_REST if rest_seconds is None else 0
    assert got.shape == (len(t), 5) and np.array_equal(got[:, 0], t)
    assert np.array_equal(got[:, 1:], stream_reference(t, gyr, acc, None, RATE, n_rest))
    batch = estimate_orientation(gyr, acc, None, RATE, use_mag=False, n_rest=n_rest)
    assert np.array_equal(got[:, 1:], batch.quat)


def test_stream_equals_batch_on_broad_9d(trial):
    n = len(trial.gyr)
    t = np.arange(n) / trial.rate
    code, out, err = run_stream(lines_of(t, trial.gyr, trial.acc, trial.mag), "--rate", repr(trial.rate))
    assert code == 0 and err == ""
    got = parse_output(out)
    n_rest = round(trial.rate)  # --rest-seconds 1
    # the defaults on both sides: online magnetometer time offset, causal rest period
    batch = estimate_orientation(trial.gyr, trial.acc, trial.mag, trial.rate, n_rest=n_rest)
    assert 0.005 < batch.mag_time_offset < 0.02  # the online estimate is at work (BROAD: ~11 ms)
    assert got.shape == (n, 5) and np.array_equal(got[:, 0], t)
    assert np.array_equal(got[:, 1:], batch.quat)


def test_one_flushed_line_per_input_line():
    t, gyr, acc = synthetic()
    lines = lines_of(t, gyr, acc)[: N_REST + 5]
    ref = stream_reference(t[: N_REST + 5], gyr, acc, None, RATE, N_REST)
    proc = dualpose_stream("--rate", "100", "--no-mag")
    reader = LineReader(proc)
    got = []
    for line in lines:  # one line per line, before the next is sent, also inside the rest period
        proc.stdin.write(line)
        proc.stdin.flush()
        got.append(reader.readline())
    proc.stdin.close()
    assert reader.readline() == "" and proc.wait() == 0
    assert np.array_equal(parse_output("".join(got))[:, 1:], ref)


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        ("0.1 2 3\n", f"stdin line 153: {FIELDS_6D}, got 3"),
        ("9.0, 0, 0, nope, 0, 0, 9.81\n", "stdin line 153: field 4 (gz): 'nope' is not a number"),
        ("9.0, 0, 0, 0, 0, nan, 9.81\n", "stdin line 153: field 6 (ay): non-finite value 'nan'"),
        ("1.0, 0, 0, 0, 0, 0, 9.81\n", "stdin line 153: t must be finite and increase strictly: got 1.0 after 1.49"),
    ],
)
def test_malformed_line_in_the_middle(bad, message):
    t, gyr, acc = synthetic()
    lines = lines_of(t, gyr, acc)
    lines[3:3] = ["# header, counted as a line\n", "\n"]  # line numbers count every input line
    lines.insert(152, bad)  # after 150 samples: line 153
    code, out, err = run_stream(lines, "--rate", "100", "--no-mag")
    assert code == 1
    assert err.splitlines() == [f"dualpose ahrs: error: {message}"]
    got = parse_output(out)
    assert got.shape == (150, 5)  # every sample before the bad line was written
    assert np.array_equal(got[:, 1:], stream_reference(t, gyr, acc, None, RATE, N_REST)[:150])


def test_input_ending_inside_the_rest_period():
    t, gyr, acc = synthetic()
    code, out, err = run_stream(lines_of(t, gyr, acc)[:40], "--rate", "100", "--no-mag")
    assert code == 0 and err == ""
    assert np.array_equal(parse_output(out)[:, 1:], stream_reference(t, gyr, acc, None, RATE, N_REST)[:40])


def test_reader_closing_early_exits_141_quietly(tmp_path):
    rng = np.random.default_rng(11)
    n = 20000  # ~1.8 MB of output, far more than a pipe holds: the writer meets the closed pipe
    t = np.arange(n) / RATE
    gyr = rng.normal(scale=0.01, size=(n, 3))
    acc = np.array([0.0, 0.0, 9.81]) + rng.normal(scale=0.05, size=(n, 3))
    src = tmp_path / "imu.csv"
    src.write_text("".join(lines_of(t, gyr, acc)))
    head, err, code = head_then_close(src, "ahrs", "--stream", "--rate", "100", "--no-mag", "--rest-seconds", "0")
    assert code == 141
    assert "Traceback" not in err and "BrokenPipeError" not in err and err == ""
    assert parse_output("".join(head)).shape == (5, 5)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["ahrs", "--stream", "trial.mat", "--rate", "100"], "--stream reads standard input: no file argument"),
        (["ahrs"], "a BROAD trial file, or --stream"),
        (["ahrs", "--stream"], "--stream needs the sampling rate: --rate HZ"),
        (["ahrs", "trial.mat", "--rate", "100"], "--rate is only used with --stream"),
        (["ahrs", "trial.mat", "--rest-seconds", "2"], "--rest-seconds is only used with --stream"),
        (["ahrs", "--stream", "--rate", "100", "--json"], "--json and --mag-calibration are not used with --stream"),
        (["ahrs", "--stream", "--rate", "100", "--rest-seconds", "0.05"], "is 5 samples; the rest period needs"),
    ],
)
def test_usage_errors_exit_2(argv, message, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("dualpose ahrs: error: ") and message in err
