"""The console script on unusual standard streams, as real processes: Ctrl-C stops a stream with exit 130 and no
traceback (lines already written kept), a closed stdin reads as empty, a closed stdout writes nowhere, and an output
encoding without ``σ``/``≈`` gets escapes instead of a ``UnicodeEncodeError``."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
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


def _command() -> str:
    """The installed ``dualpose`` command: on POSIX the compiled launcher (src/launcher/dualpose.c)."""
    command = Path(sys.executable).parent / "dualpose"
    assert command.is_file(), f"{command}: the install puts the dualpose command next to the interpreter"
    assert command.read_bytes()[:4] == b"\x7fELF" or sys.platform == "darwin", "not the compiled launcher"
    return str(command)


def _src_env() -> dict[str, str]:
    """The environment in which a child imports the dualpose the tests imported."""
    src = str(Path(dp.__file__).resolve().parents[1])
    return dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))


def _interrupted_at(delay_ms: float, args: list[str]) -> tuple[int, str]:
    """Exit status and stderr of the installed command sent SIGINT ``delay_ms`` after its start."""
    import time

    proc = subprocess.Popen([_command(), *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_src_env(),
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # fmt: skip
    time.sleep(delay_ms / 1000)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    return proc.returncode, err


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_while_starting_exits_quietly() -> None:
    # Ctrl-C at any moment of the start: the launcher's own microseconds (killed by the signal, silently), CPython's
    # start-up (`site`, the .pth hook of an editable install: SIGINT is blocked, pending), the import of dualpose and
    # NumPy (the entry point's handler), the command (its guard).  Never a traceback; 130 once dualpose has it
    rng = np.random.default_rng(20261203)
    delays = [*np.sort(rng.uniform(0.0, 80.0, 24)), 100, 150, 200, 300, 400]
    codes = []
    for delay_ms in delays:
        code, err = _interrupted_at(delay_ms, ["ahrs", "--help"])
        assert "Traceback" not in err and "Fatal Python error" not in err and "KeyboardInterrupt" not in err, (
            delay_ms, err)  # fmt: skip
        assert code in (0, 130, -signal.SIGINT), (delay_ms, code, err)
        codes.append(code)
    assert 130 in codes  # some Ctrl-C came while dualpose was starting, and was held for it


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_an_ignored_ctrl_c_stays_ignored() -> None:
    # a background job inherits SIGINT ignored: the launcher neither blocks nor unblocks it, and the command runs on
    proc = subprocess.Popen([_command(), "ahrs", "--stream", "--rate", "100", "--no-mag", "--rest-seconds", "0"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=_src_env(),
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))  # fmt: skip
    reader = LineReader(proc)
    proc.stdin.write(SAMPLE.format(t=0.0))
    proc.stdin.flush()
    assert reader.readline().count(",") >= 4
    proc.send_signal(signal.SIGINT)
    proc.stdin.write(SAMPLE.format(t=0.01))
    proc.stdin.flush()
    assert reader.readline().count(",") >= 4  # still running
    proc.stdin.close()
    assert proc.wait(timeout=60) == 0


@pytest.mark.parametrize("args", [
    ["--version"],
    ["--no-such-option"],
    ["eval", "a file with spaces ü σ 名.tum", "another one.tum"],
    ["register", "--help"],
    ["ahrs", "--rate", "-1", "x y"],
])  # fmt: skip
def test_the_command_runs_as_the_module_does(args: list[str]) -> None:
    # arguments (spaces, non-ASCII), exit status, stdout and stderr as ``python -m dualpose.cli.main`` gives them
    mine = subprocess.run([_command(), *args], capture_output=True, text=True, env=_src_env(), timeout=120)
    module = _run(args)
    assert (mine.returncode, mine.stdout, mine.stderr) == (module.returncode, module.stdout, module.stderr)
    if len(args) > 1 and args[0] == "eval":
        assert mine.returncode != 0 and args[1] in mine.stderr


def test_the_command_on_pipes_and_in_any_folder(tmp_path: Path) -> None:
    # a stream from a pipe to a pipe; run from a folder whose files shadow the entry module and the package, which
    # the installer's wrapper never imports (its sys.path[0] is its own folder) and the launcher does not either
    (tmp_path / "_dualpose_cli.py").write_text("raise SystemExit('shadowed')\n")
    (tmp_path / "dualpose").mkdir()
    (tmp_path / "dualpose" / "__init__.py").write_text("raise SystemExit('shadowed')\n")
    lines = "".join(SAMPLE.format(t=0.01 * k) for k in range(5))
    args = ["ahrs", "--stream", "--rate", "100", "--no-mag", "--rest-seconds", "0"]
    mine = subprocess.run([_command(), *args], input=lines, capture_output=True, text=True, cwd=tmp_path,
                          env=dict(os.environ), timeout=120)  # fmt: skip
    module = _run(args, input=lines, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert mine.returncode == 0, mine.stderr
    assert mine.stdout == module.stdout and len(mine.stdout.splitlines()) == 5


def test_the_command_away_from_its_environment(tmp_path: Path) -> None:
    # a copy with no interpreter next to it falls back on the interpreter that built it
    copy = tmp_path / "dualpose"
    copy.write_bytes(Path(_command()).read_bytes())
    copy.chmod(0o755)
    res = subprocess.run([str(copy), "--version"], capture_output=True, text=True, env=_src_env(), timeout=120)
    assert res.returncode == 0 and res.stdout.startswith("dualpose "), res.stderr


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
