"""Helpers of the streaming CLI tests: the dualpose command on real pipes, and reading a child's output line by line
straight from the pipe (so that a line that was not flushed is a failure, not a hang)."""

from __future__ import annotations

import os
import selectors
import subprocess
import sys
from pathlib import Path

import pytest

import dualpose as dp


def dualpose_process(*args: str, stdin=subprocess.PIPE, preexec_fn=None) -> subprocess.Popen:
    """``python -m dualpose.cli.main ARGS`` with text pipes (the dualpose the tests imported); ``preexec_fn`` runs in
    the child before it starts (POSIX)."""
    src = str(Path(dp.__file__).resolve().parents[1])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))
    cmd = [sys.executable, "-m", "dualpose.cli.main", *args]
    return subprocess.Popen(cmd, stdin=stdin, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True,
                            preexec_fn=preexec_fn)  # fmt: skip


def run_lines(lines: list[str], *args: str) -> tuple[int, str, str]:
    """Exit status, stdout and stderr of ``dualpose ARGS`` fed ``lines`` on stdin."""
    proc = dualpose_process(*args)
    out, err = proc.communicate("".join(lines))
    return proc.returncode, out, err


def head_then_close(stdin_path: str | os.PathLike, *args: str, n: int = 5) -> tuple[list[str], str, int]:
    """``dualpose ARGS < stdin_path`` whose reader takes ``n`` lines and goes away (as ``| head -n`` does): the
    lines read, the child's stderr and its exit status."""
    with open(stdin_path) as f:
        proc = dualpose_process(*args, stdin=f)
        head = [proc.stdout.readline() for _ in range(n)]
        proc.stdout.close()
        err = proc.stderr.read()
        code = proc.wait()
    return head, err, code


class LineReader:
    """Lines of a child's stdout read straight from the pipe (no read-ahead buffer to hide them from ``select``);
    fails (rather than hangs) when no line comes, i.e. when the child did not flush it."""

    def __init__(self, proc: subprocess.Popen) -> None:
        self.proc, self.fd, self.buf = proc, proc.stdout.fileno(), b""
        self.sel = selectors.DefaultSelector()
        self.sel.register(self.fd, selectors.EVENT_READ)

    def readline(self) -> str:
        while b"\n" not in self.buf:
            if not self.sel.select(timeout=120):
                self.proc.kill()
                pytest.fail("no output line: the stream did not flush")
            chunk = os.read(self.fd, 1 << 16)
            if not chunk:
                return ""
            self.buf += chunk
        line, _, self.buf = self.buf.partition(b"\n")
        return line.decode() + "\n"
