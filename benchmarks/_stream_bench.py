"""The pipe harness of the streaming CLI benchmarks (``bench_ahrs_cli_stream.py``, ``bench_fuse_cli_stream.py``).

* :func:`paced`: line ``k`` is written (one ``write`` per line) at ``send_at[k]`` seconds after the start, as a
  sensor would; one loop (no threads) writes on schedule and, in between, waits on the output pipe with ``select``
  and time-stamps every output line as it is read;
* :func:`flood`: all lines written as fast as the pipe takes them (a writer thread); throughput = output lines after
  the first ``skip`` / time between reading the first and the last of them;
* :func:`latency`: statistics of (read time of an output line − write time of the input line it answers);
* :func:`spawn`: the process under test (or :data:`BASELINE`) with the pipes these expect.
"""

from __future__ import annotations

import math
import os
import selectors
import subprocess
import sys
import threading
import time

import numpy as np

#: the baseline process: ``cat`` echoes each line at once (the harness and the pipes alone)
BASELINE = ["cat"]


def spawn(command: list[str]) -> subprocess.Popen:
    """``command`` started with binary, unbuffered stdin/stdout pipes (what :func:`paced` and :func:`flood` drive);
    a command starting with ``"dualpose"`` runs the CLI of this interpreter (``python -m dualpose.cli.main``)."""
    if command[0] == "dualpose":
        command = [sys.executable, "-m", "dualpose.cli.main", *command[1:]]
    return subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, bufsize=0)


def paced(
    proc: subprocess.Popen, lines: list[bytes], send_at: np.ndarray, lead: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Write ``lines[k]`` at ``send_at[k]`` s (from ``lead`` s after the call: the interpreter starts meanwhile) to
    ``proc`` (binary pipes, ``bufsize=0``) while reading its output; returns the write times (n,), the read times of
    the output lines and how far each write fell behind its schedule (n,), ``perf_counter`` seconds.  Raises
    RuntimeError when the process fails."""
    fd_in, fd_out = proc.stdin.fileno(), proc.stdout.fileno()
    os.set_blocking(fd_in, False)  # never block on a full input pipe while the output pipe waits to be read
    sel = selectors.DefaultSelector()
    sel.register(fd_out, selectors.EVENT_READ)
    n = len(lines)
    sent, got = np.full(n, np.nan), []
    k_in = 0
    buf = b""
    t0 = time.perf_counter() + lead
    while True:
        due = t0 + send_at[k_in] if k_in < n else math.inf
        if time.perf_counter() >= due:
            try:
                os.write(fd_in, lines[k_in])  # a line is shorter than PIPE_BUF: written whole or not at all
                sent[k_in] = time.perf_counter()
                k_in += 1
                if k_in == n:
                    proc.stdin.close()
            except BlockingIOError:
                pass
        late = k_in < n and time.perf_counter() >= t0 + send_at[k_in]
        wait = 0.0 if late else (1.0 if k_in == n else max(0.0, t0 + send_at[k_in] - time.perf_counter()))
        if sel.select(timeout=wait):
            chunk = os.read(fd_out, 1 << 16)
            stamp = time.perf_counter()
            if not chunk:
                break
            buf += chunk
            m = buf.count(b"\n")
            got += [stamp] * m
            buf = buf[buf.rindex(b"\n") + 1 :] if m else buf
    code = proc.wait()
    if code != 0 or k_in != n:
        raise RuntimeError(f"{proc.args[:6]} exited {code} after reading {k_in} of {n} lines")
    behind = sent - (t0 + np.asarray(send_at))  # how far each write fell behind the schedule
    return sent, np.array(got), behind


def latency(sent: np.ndarray, got: np.ndarray, behind: np.ndarray, name: str) -> dict[str, float]:
    """Median, p99, max latency (µs) and the largest write delay (ms) of output lines ``got`` answering input lines
    written at ``sent`` (same length), keys prefixed with ``name``."""
    lat = 1e6 * (got - sent)
    return {f"{name}_lines": len(lat), f"{name}_median_us": float(np.median(lat)),
            f"{name}_p99_us": float(np.percentile(lat, 99)), f"{name}_max_us": float(lat.max()),
            f"{name}_behind_ms": 1e3 * float(behind.max()), f"{name}_over_1ms": int(np.sum(lat > 1e3))}  # fmt: skip


def flood(proc: subprocess.Popen, lines: list[bytes], skip: int, expect: int) -> float:
    """Write all lines as fast as the pipe takes them; output lines per second after the first ``skip`` (of
    ``expect`` output lines in all)."""
    data = b"".join(lines)

    def feed() -> None:
        proc.stdin.write(data)
        proc.stdin.close()

    writer = threading.Thread(target=feed)
    writer.start()
    k_out, t_first, t_last = 0, None, 0.0
    fd_out = proc.stdout.fileno()
    while True:
        chunk = os.read(fd_out, 1 << 16)
        if not chunk:
            break
        k_out += chunk.count(b"\n")
        t_last = time.perf_counter()
        if t_first is None and k_out > skip:
            t_first = t_last
    writer.join()
    code = proc.wait()
    if code != 0 or k_out != expect or t_first is None:
        raise RuntimeError(f"{proc.args[:6]} exited {code} after {k_out} of {expect} lines")
    return (expect - skip) / (t_last - t_first)
