"""Diagnostic: what a Ctrl-C (SIGINT) prints at each moment of ``dualpose``'s start (docs/refusals.md, "Ctrl-C
before dualpose runs").

Run ``.venv/bin/python benchmarks/diag_startup_sigint.py [--max-ms 60] [--repeats 3]``.  Starts the installed
command (``dualpose --version``) with SIGINT at its default disposition, as a terminal's foreground process
has it, sends SIGINT after 0, 1, 2, ... ``--max-ms`` ms and sorts the outcomes: *quiet* (no traceback: killed by the
signal before CPython installed its handler, exit 130 from dualpose's guards, or finished), *CPython's message*
(a traceback or ``Fatal Python error`` with no frame of dualpose's: the interpreter's start or the installer's
wrapper) and *dualpose's* (a frame of ``dualpose`` or ``_dualpose_cli``: a defect).  Prints one row per millisecond
range.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import time
from pathlib import Path

SCRIPT = Path(sys.executable).parent / "dualpose"


def outcome(delay_ms: float) -> str:
    proc = subprocess.Popen([str(SCRIPT), "--version"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # fmt: skip
    time.sleep(delay_ms / 1000.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    if "Traceback" not in err and "Fatal Python error" not in err:
        return "quiet"
    frames = [ln for ln in err.splitlines() if ln.strip().startswith("File ")]
    ours = ("/dualpose/", "/_dualpose_cli/")  # the package and the entry module, not the wrapper script "bin/dualpose"
    return "dualpose" if any(p in ln for ln in frames for p in ours) else "cpython"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--max-ms", type=int, default=60)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--bucket", type=int, default=5, help="milliseconds per row")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    for _ in range(5):
        subprocess.run([str(SCRIPT), "--version"], capture_output=True, check=True)
    print(f"`dualpose --version` takes {(time.perf_counter() - t0) / 5 * 1e3:.0f} ms (mean of 5)\n")
    print("| SIGINT after [ms] | runs | quiet | CPython's message | through dualpose |\n|---|---|---|---|---|")
    for lo in range(0, args.max_ms + 1, args.bucket):
        got = [outcome(ms) for ms in range(lo, min(lo + args.bucket, args.max_ms + 1)) for _ in range(args.repeats)]
        print(f"| {lo}–{min(lo + args.bucket, args.max_ms + 1) - 1} | {len(got)} | {got.count('quiet')} | "
              f"{got.count('cpython')} | {got.count('dualpose')} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
