"""Reading big TUM files and ``dualpose eval`` on them: rows per second and peak memory.

Run ``.venv/bin/python benchmarks/bench_io.py [--rows 1e6 5e6] [--eval] [--markdown FILE [--force]]``.

For each size a temporary TUM file is written (stamps ``1.4e9 + 0.01 k`` with 6 decimals, positions with 4 and
quaternions with 9 decimals, a comment header: what trackers and ground-truth tools write) and read by
:func:`dualpose.io.read_tum` in a fresh subprocess, which reports its wall time and its peak resident memory
(a second run under ``tracemalloc``, to which numpy reports its buffers: the peak of the memory the operation
allocates; and the process's peak resident size, ``VmHWM`` of ``/proc/self/status``, imports and kernels
included -- not ``getrusage``'s ``ru_maxrss``, which Linux carries over from the forking parent across exec).
"arrays" is the size of the parsed float64 data, N x 8 x 8 bytes per file; the target is >= 5e6 rows/s and a
peak <= 3x the arrays.  With
``--eval`` a second file of the same size (the first one plus noise, offset by 2 ms) is written and
``dualpose eval A B --json`` is timed the same way.  ``--markdown FILE`` writes the table (never over an existing
file unless ``--force``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

_CHILD = r"""
import contextlib, inspect, io, json, sys, time, tracemalloc
from dualpose.io import read_tum
from dualpose.cli.main import main
mode, small, paths = sys.argv[1], sys.argv[2], sys.argv[3:]
read_tum(small)  # imports, and the parser kernel loaded, outside the measurement
rows = None
def op():
    global rows
    if mode == "read":
        rows = len(read_tum(paths[0]))
    else:
        quiet = ["--quiet"] if "--quiet" in inspect.getsource(sys.modules["dualpose.cli.eval"]) else []  # older
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["eval", *paths, "--json", *quiet]) == 0
t0 = time.perf_counter()
op()
dt = time.perf_counter() - t0
# VmHWM, not ru_maxrss: Linux carries ru_maxrss over from the forking parent across exec
rss = next(int(ln.split()[1]) for ln in open("/proc/self/status") if ln.startswith("VmHWM")) / 1024
tracemalloc.start()  # a second run for the memory: numpy reports its buffers to tracemalloc
op()
peak = tracemalloc.get_traced_memory()[1] / 2**20
tracemalloc.stop()
print(json.dumps({"seconds": dt, "rows": rows, "traced_peak_mb": peak, "max_rss_mb": rss}))
"""


def _fixed(values: np.ndarray, decimals: int, width: int) -> np.ndarray:
    """Fixed-point text of ``values`` (N,) as a uint8 array (N, width), right-aligned, '-' for negatives."""
    total = np.round(np.abs(values) * 10.0**decimals).astype(np.int64)
    frac, whole = total % 10**decimals, total // 10**decimals
    out = np.full((values.shape[0], width), ord(" "), dtype=np.uint8)
    for k in range(decimals):
        out[:, width - 1 - k] = (frac % 10).astype(np.uint8) + ord("0")
        frac //= 10
    out[:, width - 1 - decimals] = ord(".")
    col = width - 2 - decimals
    out[:, col] = (whole % 10).astype(np.uint8) + ord("0")
    whole //= 10
    while whole.any():
        col -= 1
        out[:, col] = np.where(whole > 0, (whole % 10).astype(np.uint8) + ord("0"), ord(" "))
        whole //= 10
    neg = values < 0
    first = np.argmax(out != ord(" "), axis=1)
    out[np.flatnonzero(neg), first[neg] - 1] = ord("-")
    return out


def write_tum_fast(path: Path, stamps: np.ndarray, pos: np.ndarray, quat: np.ndarray) -> None:
    """Write a TUM file quickly with fixed-width numbers (vectorised; ``np.savetxt`` takes minutes at 5e6 rows)."""
    cols = [_fixed(stamps, 6, 18)] + [_fixed(pos[:, i], 4, 10) for i in range(3)]
    cols += [_fixed(quat[:, i], 9, 13) for i in range(4)]
    parts = []
    for c in cols:
        parts += [c, np.full((c.shape[0], 1), ord(" "), dtype=np.uint8)]
    parts[-1] = np.full((stamps.shape[0], 1), ord("\n"), dtype=np.uint8)
    body = np.hstack(parts)
    with open(path, "wb") as f:
        f.write(b"# timestamp tx ty tz qx qy qz qw\n")
        f.write(body.tobytes())


def _trajectory(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = 1.4e9 + 0.01 * np.arange(n)
    s = np.linspace(0.0, 60.0, n)
    pos = np.column_stack([10 * np.cos(s / 7), 10 * np.sin(s / 5), 0.5 * np.sin(s)]) + rng.normal(0, 1e-3, (n, 3))
    half = 0.5 * s
    quat = np.column_stack([0.1 * np.sin(half), 0.2 * np.cos(half), np.sin(0.3 * half), np.full(n, 1.0)])
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    return t, pos, quat


def _child(args: list[str]) -> dict:
    env = dict(os.environ)
    src = str(Path(__file__).resolve().parents[1] / "src")
    env["PYTHONPATH"] = src + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run([sys.executable, "-c", _CHILD, *args], capture_output=True, text=True, env=env, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rows", type=float, nargs="+", default=[1e6, 5e6], help="file sizes in rows (1e6 5e6)")
    ap.add_argument("--eval", action="store_true", help="also time dualpose eval on two files of each size")
    ap.add_argument("--markdown", help="write the table to this file")
    ap.add_argument("--force", action="store_true", help="replace an existing --markdown file")
    args = ap.parse_args(argv)
    if args.markdown and Path(args.markdown).exists() and not args.force:
        print(f"bench_io.py: error: {args.markdown}: file exists; use --force to replace it", file=sys.stderr)
        return 2
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        small = Path(tmp) / "small.txt"
        write_tum_fast(small, *_trajectory(100, 1))
        for n in (int(r) for r in args.rows):
            path_a = Path(tmp) / f"a_{n}.txt"
            t, p, q = _trajectory(n, 2)
            write_tum_fast(path_a, t, p, q)
            mb_file = path_a.stat().st_size / 2**20
            arrays = n * 64 / 2**20
            r = _child(["read", str(small), str(path_a)])
            assert r["rows"] == n, r
            rows.append(
                f"| read_tum | {n:.0e} | {mb_file:.0f} | {r['seconds']:.2f} | {n / r['seconds'] / 1e6:.2f} | "
                f"{r['traced_peak_mb']:.0f} | {r['traced_peak_mb'] / arrays:.2f} | {r['max_rss_mb']:.0f} |"
            )
            print(rows[-1], flush=True)
            if args.eval:
                path_b = Path(tmp) / f"b_{n}.txt"
                rng = np.random.default_rng(3)
                write_tum_fast(path_b, t + 0.002, p + rng.normal(0, 0.01, p.shape), q)
                del t, p, q
                r = _child(["eval", str(small), str(path_a), str(path_b)])
                rows.append(
                    f"| eval (2 files) | {n:.0e} | {2 * mb_file:.0f} | {r['seconds']:.2f} | "
                    f"{2 * n / r['seconds'] / 1e6:.2f} | {r['traced_peak_mb']:.0f} | "
                    f"{r['traced_peak_mb'] / (2 * arrays):.2f} | {r['max_rss_mb']:.0f} |"
                )
                print(rows[-1], flush=True)
                path_b.unlink()
            path_a.unlink()
    head = (
        f"Python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, "
        f"{os.cpu_count()} cores (shared)\n\n"
        "| what | rows per file | file(s) [MiB] | wall [s] | rows/s [1e6] | traced peak [MiB] | peak / arrays | "
        "max RSS [MiB] |\n|---|---:|---:|---:|---:|---:|---:|---:|"
    )
    text = head + "\n" + "\n".join(rows)
    print("\n" + text)
    if args.markdown:
        with open(args.markdown, "w" if args.force else "x", encoding="utf-8") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
