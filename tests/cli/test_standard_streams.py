"""The console script on unusual standard streams, as real processes: Ctrl-C stops a stream with exit 130 and no
traceback (lines already written kept), a closed stdin reads as empty, a closed stdout writes nowhere, and an output
encoding without ``σ``/``≈`` gets escapes instead of a ``UnicodeEncodeError``."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from _pipes import LineReader, dualpose_process

import dualpose as dp

#: one 6D sample line of ``dualpose ahrs --stream --no-mag`` (t, gyro rad/s, specific force m/s²)
SAMPLE = "{t:.2f}, 0.01, -0.02, 0.03, 0.1, 0.2, 9.8\n"


def _run(args: list[str], *, env: dict | None = None, encoding: str = "utf-8",
         **streams) -> subprocess.CompletedProcess:
    src = str(Path(dp.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]), **(env or {}))
    return subprocess.run([sys.executable, "-m", "dualpose.cli.main", *args], env=env, capture_output=not streams,
                          encoding=encoding, timeout=120, **streams)  # fmt: skip


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_stops_a_stream_quietly_with_exit_130() -> None:
    # a child inherits an ignored SIGINT from a background job (as a CI runner may start us), and Python then leaves
    # it ignored: give the child the default disposition, as a terminal's foreground process has
    proc = dualpose_process("ahrs", "--stream", "--rate", "100", "--no-mag", "--rest-seconds", "0",
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # fmt: skip
    reader = LineReader(proc)
    for k in range(3):
        proc.stdin.write(SAMPLE.format(t=0.01 * k))
        proc.stdin.flush()
        assert reader.readline().count(",") >= 4  # each line is out before the next goes in
    proc.send_signal(signal.SIGINT)
    code = proc.wait(timeout=60)
    err = proc.stderr.read()
    assert code == 130
    assert "Traceback" not in err and "KeyboardInterrupt" not in err


def _console_script() -> list[str]:
    """The installed ``dualpose`` console script, or what its wrapper runs (``from ENTRY import main;
    sys.exit(main())``) when the tests run without one."""
    from importlib.metadata import entry_points

    (entry,) = entry_points(group="console_scripts", name="dualpose")
    assert entry.value == "_dualpose_cli:main"  # the entry imports nothing heavy before its Ctrl-C guard
    script = Path(sys.executable).parent / "dualpose"
    if script.is_file():
        return [str(script)]
    return [sys.executable, "-c", "import sys; from _dualpose_cli import main; sys.exit(main())"]


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_while_starting_exits_quietly() -> None:
    # Ctrl-C while `import dualpose` loads NumPy (before the command's own guard runs) is quiet too: exit 130, never a
    # traceback through dualpose.  Before the entry point is called, the interpreter's start (`site`) and the
    # installer's two-line wrapper are CPython's and pip's: a traceback there has no frame of ours (docs/refusals.md)
    import time

    src = Path(dp.__file__).resolve().parents[1]
    ours = (str(src / "dualpose"), str(src / "_dualpose_cli"))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(src), os.environ.get("PYTHONPATH", "")]))
    codes = []
    for delay_ms in (0, 5, 10, 20, 35, 50, 75, 100, 150, 200, 300, 400):
        proc = subprocess.Popen([*_console_script(), "ahrs", "--help"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                env=env, text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(delay_ms / 1000)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        frames = [ln for ln in err.splitlines() if ln.strip().startswith("File ")]
        assert not [ln for ln in frames if any(p in ln for p in ours)], (delay_ms, err)
        if "Traceback" not in err:
            assert proc.returncode in (0, 130, -signal.SIGINT), (delay_ms, err)
        codes.append(proc.returncode)
    assert 130 in codes  # some Ctrl-C came while dualpose was loading, and was caught there


def test_closed_stdin_reads_as_empty_input() -> None:
    res = _run(["ahrs", "--stream", "--rate", "100", "--no-mag"], stdin=subprocess.DEVNULL,
               stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip
    assert res.returncode == 0 and res.stdout == ""
    # the stream started without a standard input at all (``<&-``): Python gives sys.stdin = None
    code = "import sys; sys.stdin.close(); sys.stdin = None; from dualpose.cli.main import main; " \
           "sys.exit(main(['ahrs', '--stream', '--rate', '100', '--no-mag']))"  # fmt: skip
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env=dict(os.environ, PYTHONPATH=str(Path(dp.__file__).resolve().parents[1])))  # fmt: skip
    assert res.returncode == 0 and "Traceback" not in res.stderr


def test_closed_stdout_writes_nowhere() -> None:
    code = "import sys; sys.stdout.close(); sys.stdout = None; from dualpose.cli.main import main; " \
           "sys.exit(main(['demo']))"  # fmt: skip
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env=dict(os.environ, PYTHONPATH=str(Path(dp.__file__).resolve().parents[1])))  # fmt: skip
    assert res.returncode == 0 and "Traceback" not in res.stderr


@pytest.mark.parametrize("encoding", ["ascii", "cp1252"])
def test_output_encoding_without_greek_letters(encoding: str) -> None:
    res = _run(["calibrate", "--poses", "2", "--seed", "1"], env={"PYTHONIOENCODING": encoding}, encoding=encoding)
    assert res.returncode == 0, res.stderr
    assert "UnicodeEncodeError" not in res.stderr and "Traceback" not in res.stderr
    assert "\\u03c3" in res.stdout  # the σ of the table, escaped
