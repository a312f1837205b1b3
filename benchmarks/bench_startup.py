"""Start-up of a fresh process: ``import dualpose``, and import plus the first call of kernels of every layer.

Run ``.venv/bin/python benchmarks/bench_startup.py [--rounds 7]``; prints a markdown table (best of the rounds, each
round a new interpreter) for: the bare interpreter, ``import dualpose``, the first-use script of
``tests/test_processes.py`` (quat_from_rotvec, quat_mul, dualquat_sclerp, register_pose, integrate_attitude), the
installed command ``dualpose --version`` (``--command PATH``, repeatable, times others, interleaved round by round;
best and median), and the same peers' imports for scale (scipy.spatial.transform, pytransform3d when installed).
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_processes import SCRIPT

CASES = [
    ("python -c pass", "pass"),
    ('python -c "import dualpose"', "import dualpose"),
    ("first use: import + first call of every layer's kernels", SCRIPT),
    ('python -c "import scipy.spatial.transform"', "import scipy.spatial.transform"),
]
if importlib.util.find_spec("pytransform3d") is not None:
    CASES.append(('python -c "import pytransform3d.trajectories"', "import pytransform3d.trajectories"))


def seconds(command: list[str], rounds: int) -> float:
    """Best wall time over ``rounds`` fresh processes running ``command``."""
    best = float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - t0)
    return best


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--command", type=Path, action="append",
                   help="a dualpose command to time (repeatable; default: the environment's)")
    args = p.parse_args(argv)
    print(f"| process | seconds (best of {args.rounds}) |")
    print("|---|---|")
    for label, code in CASES:
        print(f"| {label} | {seconds([sys.executable, '-c', code, '0'], args.rounds):.3f} |")  # 0: SCRIPT's argument
    commands = args.command or [Path(sys.executable).parent / "dualpose"]
    times: list[list[float]] = [[] for _ in commands]
    for _ in range(args.rounds):  # interleaved: a change of load hits every command alike
        for cmd, t in zip(commands, times, strict=True):
            t.append(seconds([str(cmd), "--version"], 1))
    for cmd, t in zip(commands, times, strict=True):
        print(f"| `dualpose --version` ({cmd}) | {min(t):.3f} (median {statistics.median(t):.3f}) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
