"""Start-up of a fresh process: ``import dualpose``, and import plus the first call of kernels of every layer.

Run ``.venv/bin/python benchmarks/bench_startup.py [--rounds 7]``; prints a markdown table (best of the rounds, each
round a new interpreter) for: the bare interpreter, ``import dualpose``, the first-use script of
``tests/test_processes.py`` (quat_from_rotvec, quat_mul, dualquat_sclerp, register_pose, integrate_attitude), the
installed command ``dualpose --version`` (``--command PATH`` times another one), and the same peers' imports for
scale (scipy.spatial.transform, pytransform3d when installed).
"""

from __future__ import annotations

import argparse
import importlib.util
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
    p.add_argument("--command", type=Path, default=Path(sys.executable).parent / "dualpose",
                   help="the dualpose command to time (default: the environment's)")
    args = p.parse_args(argv)
    print(f"| process | seconds (best of {args.rounds}) |")
    print("|---|---|")
    for label, code in CASES:
        print(f"| {label} | {seconds([sys.executable, '-c', code, '0'], args.rounds):.3f} |")  # 0: SCRIPT's argument
    print(f"| `dualpose --version` ({args.command}) | {seconds([str(args.command), '--version'], args.rounds):.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
