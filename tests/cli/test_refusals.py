"""What the console script refuses, as real processes (docs/refusals.md, "Outputs" and "Files and messages"): an
output set is always one run's (Ctrl-C leaves the earlier set, ``--force`` replaces it whole), never an input among
the outputs, an unusable output place refused before the computation, and devices, directories and endless input
refused fast with one line and the documented exit status (2 usage, 1 data, 130 interrupt)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from _pipes import dualpose_process, run_lines

import dualpose as dp


def _run(*args: str, stdin=subprocess.DEVNULL, timeout: float = 60) -> tuple[int, str, str]:
    src = str(Path(dp.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-m", "dualpose.cli.main", *args], stdin=stdin, capture_output=True,
                          text=True, env=env, timeout=timeout)  # fmt: skip
    return proc.returncode, proc.stdout, proc.stderr


def _one_line(err: str, prefix: str) -> str:
    """The single error line of ``err`` (progress lines aside); no traceback."""
    assert "Traceback" not in err, err
    errors = [ln for ln in err.splitlines() if ln.startswith(f"{prefix}: error: ")]
    assert len(errors) == 1, err
    return errors[0]


def _listing(out: Path) -> dict[str, bytes]:
    return {n: (out / n).read_bytes() for n in sorted(os.listdir(out))}


def _no_leftovers(parent: Path) -> None:
    assert [n for n in os.listdir(parent) if ".dualpose-" in n] == []


def _manifest_is_the_listing(out: Path) -> None:
    manifest = json.loads((out / "manifest.json").read_text())
    assert sorted([e["name"] for e in manifest["files"]] + ["manifest.json"]) == sorted(os.listdir(out))


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_an_out_set_is_always_one_runs_ctrl_c_and_force_included(tmp_path):
    """Ctrl-C during ``fuse --out --force`` leaves the earlier set whole (or, when the run was done, the new set
    whole); ``--force`` replaces the whole earlier set, so no stale ``trajectory_smoothed.tum`` survives."""
    out = tmp_path / "run"
    code, _, err = _run("fuse", "--smooth", "--out", str(out))
    assert code == 0 and (out / "trajectory_smoothed.tum").exists(), err
    code, _, err = _run("fuse", "--out", str(out))
    assert code == 2 and "earlier run's output" in _one_line(err, "dualpose fuse")
    before = _listing(out)
    codes = set()
    for delay in (0.0, 1.0):  # after the first stage line: simulation / filtering
        proc = dualpose_process("fuse", "--filter", "hol22", "--out", str(out), "--force", stdin=subprocess.DEVNULL,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # fmt: skip
        first = proc.stderr.readline()  # the command is running (past Python's start-up)
        assert "fuse" in first, first
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        # a signal that arrives while the interpreter shuts down, after the command has returned, finds SIGINT's
        # default action restored and ends the process by the signal: a shell reports 128 + 2 = 130 as well
        code = 130 if proc.returncode == -signal.SIGINT else proc.returncode
        codes.add(code)
        assert code in (0, 130) and "Traceback" not in err, err
        _no_leftovers(tmp_path)
        if proc.returncode == 130:
            assert _listing(out) == before  # the earlier run's set, untouched
        else:  # finished before the signal: the new set, whole
            _manifest_is_the_listing(out)
            before = _listing(out)
    assert 130 in codes
    code, _, err = _run("fuse", "--filter", "hol22", "--out", str(out), "--force")
    assert code == 0, err
    assert not (out / "trajectory_smoothed.tum").exists()  # no file of the earlier run survives
    _manifest_is_the_listing(out)
    assert json.loads((out / "metrics.json").read_text())["filter"] == "hol22"
    assert "fuse --filter hol22" in json.loads((out / "manifest.json").read_text())["command"]
    _no_leftovers(tmp_path)


def test_fuse_refuses_an_out_that_is_inside_or_contains_its_input(tmp_path, capsys):
    from dualpose.cli.main import main
    from dualpose.io import write_recording
    from dualpose.sim import recording_from_simulation, simulate_eight

    data = tmp_path / "rec"
    write_recording(data, recording_from_simulation(simulate_eight(0)))
    before = _listing(data)
    for given, out, reason in [(data, data, "is the input directory"),
                               (data, data / "results", "lies inside the input directory"),
                               (data, tmp_path, "contains the input"),
                               (data / "sensors.json", data, "contains the input file")]:  # fmt: skip
        assert main(["fuse", "--data", str(given), "--out", str(out), "--force"]) == 2
        assert reason in _one_line(capsys.readouterr().err, "dualpose fuse")
    assert _listing(data) == before


def test_plot_to_an_unwritable_place_fails_before_the_evaluation(tmp_path):
    ref = tmp_path / "ref.tum"
    ref.write_text("".join(f"{k} {k} 0 0 0 0 0 1\n" for k in range(50)))
    code, _, err = _run("eval", str(ref), str(ref), "--plot", "/proc/dualpose/plot.png")
    assert code == 2 and "--plot /proc/dualpose/plot.png" in _one_line(err, "dualpose eval")
    assert "read reference" not in err  # nothing was read


@pytest.mark.parametrize("args", [("eval", "/dev/zero", "/dev/zero"), ("eval", "{dir}", "{dir}"),
                                  ("register", "/dev/zero", "/dev/zero"), ("fuse", "--data", "/dev/zero")])  # fmt: skip
def test_devices_and_directories_as_inputs_are_refused_at_once(tmp_path, args):
    code, _, err = _run(*(a.format(dir=tmp_path) for a in args), timeout=30)
    line = _one_line(err, f"dualpose {args[0]}")
    assert code in (1, 2) and ("character device" in line or "directory" in line), err


def test_an_endless_standard_input_ends_with_one_line(tmp_path):
    with open("/dev/zero", "rb") as zero:
        code, _, err = _run("ahrs", "--stream", "--rate", "100", "--no-mag", stdin=zero, timeout=60)
    assert code == 1 and "stdin line 1: longer than" in _one_line(err, "dualpose ahrs")


def test_standard_input_with_a_bom_reads_like_a_file():
    lines = "\ufeff" + "".join(f"{0.01 * k:.2f}, 0.01, -0.02, 0.03, 0.1, 0.2, 9.8\n" for k in range(3))
    proc = dualpose_process("ahrs", "--stream", "--rate", "100", "--no-mag", "--rest-seconds", "0")
    out, err = proc.communicate(lines, timeout=60)
    assert proc.returncode == 0 and len(out.splitlines()) == 3, err


def test_a_pipe_given_as_a_file_is_read(tmp_path):
    rows = "".join(f"{k} {k} {k % 3} 0 0 0 0 1\n" for k in range(40))
    ref = tmp_path / "ref.tum"
    ref.write_text(rows)
    for name in ("-", "/dev/stdin"):
        proc = dualpose_process("eval", str(ref), name, "--json")
        out, err = proc.communicate(rows, timeout=60)
        assert proc.returncode == 0, err
        assert json.loads(out)["matched_poses"] == 40


def test_a_numpy_warning_reaches_the_user_as_one_line():
    src = str(Path(dp.__file__).resolve().parents[1])
    code = ("import numpy as np; from dualpose.cli.main import one_line_warnings; one_line_warnings('dualpose x'); "
            "np.log(np.zeros(1))")  # fmt: skip
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                          env=dict(os.environ, PYTHONPATH=src))  # fmt: skip
    assert proc.stderr == "dualpose x: warning: divide by zero encountered in log (RuntimeWarning)\n"


def test_an_unexpected_exception_is_one_line_with_exit_1(monkeypatch, capsys):
    from dualpose.cli import demo
    from dualpose.cli.main import main

    def broken(args):
        raise TypeError("an internal bug")

    monkeypatch.setattr(demo, "run", broken)
    monkeypatch.delenv("DUALPOSE_TRACEBACK", raising=False)
    assert main(["demo"]) == 1
    err = capsys.readouterr().err
    assert err == ("dualpose demo: error: internal error (TypeError: an internal bug); DUALPOSE_TRACEBACK=1 shows "
                   "where\n")  # fmt: skip
    monkeypatch.setenv("DUALPOSE_TRACEBACK", "1")
    with pytest.raises(TypeError):
        main(["demo"])


@pytest.mark.parametrize("args, message", [
    (["eval", "{ref}", "{ref}", "--rpe-delta", "0.5"], "--rpe-delta must be a whole number of frames"),
    (["eval", "{ref}", "{ref}", "--rpe-delta", "0", "--rpe-unit", "m"], "--rpe-delta must be a distance > 0"),
    (["register", "{pts}", "{pts}", "--ransac", "--threshold", "0.1"], None),
])  # fmt: skip
def test_option_and_small_input_messages(tmp_path, capsys, args, message):
    from dualpose.cli.main import main

    ref, pts = tmp_path / "ref.tum", tmp_path / "pts.csv"
    ref.write_text("".join(f"{k} {k} 0 0 0 0 0 1\n" for k in range(20)))
    pts.write_text("0,0,0\n1,0,0\n0,1,0\n")  # three points: RANSAC's one triple
    code = main([a.format(ref=ref, pts=pts) for a in args])
    err = capsys.readouterr().err
    if message is None:
        assert code == 0 and err == ""
    else:
        assert code == 2 and message in _one_line(err, f"dualpose {args[0]}")


@pytest.mark.parametrize("offline", [False, True])
def test_broad_with_an_all_zero_magnetometer_names_the_magnetometer(tmp_path, capsys, offline):
    from scipy.io import savemat

    from dualpose.cli.main import main

    n, rng = 600, np.random.default_rng(5)
    savemat(tmp_path / "t.mat", {
        "imu_gyr": rng.normal(0.0, 1e-3, (n, 3)), "imu_acc": [0.0, 0.0, 9.81] + rng.normal(0.0, 1e-2, (n, 3)),
        "imu_mag": np.zeros((n, 3)), "opt_quat": np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), "opt_pos": np.zeros((n, 3)),
        "movement": (np.arange(n) >= n // 2).astype(np.uint8), "sampling_rate": 2000.0 / 7.0,
    })  # fmt: skip
    assert main(["ahrs", str(tmp_path / "t.mat"), *(["--offline"] if offline else [])]) == 1
    line = _one_line(capsys.readouterr().err, "dualpose ahrs")
    assert "mag: every sample is zero" in line and "--no-mag" in line and "gyroscope" not in line


@pytest.mark.parametrize("offline", [False, True])
@pytest.mark.parametrize("zero_rows", ["one", "all but one", "every other"])
def test_broad_magnetometer_with_zero_samples_names_the_first(tmp_path, capsys, offline, zero_rows):
    # a zero magnetometer sample carries no field (no direction to normalise): refused naming the trial's first such
    # sample, in both modes, before filtering -- never a NaN orientation blamed on the scorer or the gyroscope
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
    from test_broad import write_synthetic_trial

    from dualpose.cli.main import main

    n = 600
    mag = np.array([0.0, 20.0, -40.0]) + np.random.default_rng(2).normal(0.0, 0.1, (n, 3))
    rows = {"one": [450], "all but one": np.r_[0:300, 301:n], "every other": np.arange(1, n, 2)}[zero_rows]
    mag[rows] = 0.0
    mag[7] *= 1e-160 if zero_rows == "every other" else 1.0  # underflows when squared: no direction either
    path = write_synthetic_trial(tmp_path / "z.mat", imu_mag=mag)
    assert main(["ahrs", str(path), *(["--offline"] if offline else [])]) == 1
    line = _one_line(capsys.readouterr().err, "dualpose ahrs")
    first = int(np.flatnonzero(~(np.einsum("ij,ij->i", mag, mag) > 0))[0])
    assert f"z.mat: mag: sample {first} is zero" in line and "--no-mag" in line
    assert "NaN" not in line and "gyroscope" not in line
    assert main(["ahrs", str(path), "--no-mag", *(["--offline"] if offline else [])]) == 0  # 6D does not need it
    capsys.readouterr()


def test_stream_magnetometer_zero_sample_is_refused_with_its_line():
    rows = [f"{k / 100:.2f} 0 0 0 0 0 9.81 0 20 -40\n" for k in range(50)]
    rows[30] = "0.30 0 0 0 0 0 9.81 0 0 0\n"
    code, out, err = run_lines(rows, "ahrs", "--stream", "--rate", "100", "--rest-seconds", "0.1")
    assert code == 1 and len(out.splitlines()) == 30  # the lines before it are kept
    line = _one_line(err, "dualpose ahrs")
    assert "stdin line 31: mag: the sample is zero" in line and "--no-mag" in line


def test_ahrs_stream_api_refuses_a_zero_field_sample():
    from dualpose.estimation.ahrs import AhrsStream

    s = AhrsStream(100.0, n_rest=10)
    mag = np.tile([0.0, 20.0, -40.0], (20, 1))
    mag[16] = 0.0
    with pytest.raises(ValueError, match="mag: sample 16 is zero"):
        s.update_batch(np.arange(20) / 100, np.zeros((20, 3)), np.tile([0, 0, 9.81], (20, 1)), mag)
    assert s.samples == 0  # refused before any change to the stream
    with pytest.raises(ValueError, match="mag: the sample is zero"):
        s.update_imu(0.0, [0, 0, 0], [0, 0, 9.81], [0.0, 0.0, 0.0])
