"""Reading a big ``geometry_msgs/PoseStamped`` bag: dualpose's reader against evo's, in one process.

Run ``.venv/bin/python benchmarks/bench_rosbag.py [--messages 1e6] [--formats .bag .mcap .db3] [--markdown FILE
[--force]]``.

For each format a temporary bag with N ``PoseStamped`` messages (100 Hz, frame_id ``"world"``, random unit
quaternions) is written with :func:`dualpose.io.rosbag.write_trajectory_bag` and read by

* dualpose: :func:`dualpose.io.rosbag.read_bag_trajectory` (raw messages, fields parsed with NumPy);
* evo: ``evo.tools.file_interface.read_bag_trajectory`` on an open ``rosbags`` reader (one deserialized message
  object per message; evo's documented way of reading a bag, rosbags underneath both).

Both readers run in this process, one after the other, each timed over one full read (best of ``--repeats``), and
then once more under ``tracemalloc`` for the peak of the memory the read allocates (rosbags' message index
included).  Both results are checked to be equal.  "arrays" is the size of the trajectory dualpose returns: stamps
(int64 ns and float64 s), positions and quaternions, 72 bytes per message; the target is a peak <= 3x the arrays and
a read at least as fast as evo's.  ``--markdown FILE`` writes the table (never over an existing file unless
``--force``).
"""

from __future__ import annotations

import argparse
import gc
import os
import platform
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

import dualpose as dp
from dualpose.io import Trajectory, seconds_from_ns
from dualpose.io.rosbag import read_bag_trajectory, write_trajectory_bag


def _evo_read(path: Path, topic: str):
    from evo.tools.file_interface import read_bag_trajectory as evo_read
    from rosbags.rosbag1 import Reader as Reader1
    from rosbags.rosbag2 import Reader as Reader2

    reader = Reader1(path) if path.suffix == ".bag" else Reader2(path)
    with reader:
        return evo_read(reader, topic)


def _ours(path: Path, topic: str):
    return read_bag_trajectory(f"{path}:{topic}")


def _measure(fn, repeats: int) -> tuple[float, float, object]:
    best = float("inf")
    out = None
    for _ in range(repeats):
        out = None
        gc.collect()
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    out = None
    gc.collect()
    tracemalloc.start()
    out = fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return best, peak / 2**20, out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--messages", type=float, default=1e6)
    ap.add_argument("--formats", nargs="+", default=[".bag", ".mcap", ".db3"], choices=(".bag", ".mcap", ".db3"))
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--markdown", metavar="FILE")
    ap.add_argument("--force", action="store_true")
    args = ap.parse_args(argv)
    if args.markdown and Path(args.markdown).exists() and not args.force:
        print(f"{args.markdown}: exists; --force to replace it", file=sys.stderr)
        return 2
    n = int(args.messages)
    rng = np.random.default_rng(7)
    ns = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 10_000_000
    traj = Trajectory(seconds_from_ns(ns), rng.normal(size=(n, 3)), dp.quat_normalize(rng.normal(size=(n, 4))), ns)
    arrays_mb = n * (8 + 8 + 24 + 32) / 2**20
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for suffix in args.formats:
            path = Path(tmp) / f"poses{suffix}"
            t0 = time.perf_counter()
            write_trajectory_bag(path, traj, "/pose", "world")
            t_write = time.perf_counter() - t0
            ours_s, ours_mb, ours = _measure(lambda p=path: _ours(p, "/pose"), args.repeats)
            evo_s, evo_mb, evo = _measure(lambda p=path: _evo_read(p, "/pose"), args.repeats)
            assert len(ours) == n and np.array_equal(ours.positions, traj.positions)
            np.testing.assert_array_equal(evo.positions_xyz, ours.positions)
            np.testing.assert_array_equal(evo.orientations_quat_wxyz[:, [1, 2, 3, 0]], ours.quats)
            np.testing.assert_allclose(evo.timestamps, ours.stamps, rtol=0, atol=1e-6)
            row = (suffix, n, os.path.getsize(path) / 2**20, t_write, ours_s, evo_s, evo_s / ours_s, ours_mb, evo_mb,
                   ours_mb / arrays_mb)  # fmt: skip
            rows.append(row)
            print(
                f"{suffix:6s} {n} msgs ({row[2]:.0f} MiB, written in {t_write:.1f} s): dualpose {ours_s:.2f} s, "
                f"evo {evo_s:.2f} s (x{row[6]:.1f}); peak dualpose {ours_mb:.0f} MiB = {row[9]:.2f} x arrays "
                f"({arrays_mb:.0f} MiB), evo {evo_mb:.0f} MiB",
                flush=True,
            )
            del ours, evo
            path.unlink()
    import evo
    import rosbags

    head = (
        f"`.venv/bin/python benchmarks/bench_rosbag.py --messages {args.messages:g} --formats {' '.join(args.formats)}`"
        f"; {platform.processor() or platform.machine()}, {os.cpu_count()} cores (shared), Python "
        f"{platform.python_version()}, rosbags {_version('rosbags', rosbags)}, evo {evo.__version__}; arrays = "
        f"{arrays_mb:.0f} MiB (stamps ns and s, positions, quaternions)\n\n"
        "| bag | messages | size [MiB] | dualpose read [s] | evo read [s] | evo / dualpose | "
        "peak dualpose [MiB] | peak evo [MiB] | dualpose peak / arrays |\n|---|---|---|---|---|---|---|---|---|\n"
    )
    table = head + "".join(
        f"| {r[0]} | {r[1]:.0e} | {r[2]:.0f} | {r[4]:.2f} | {r[5]:.2f} | {r[6]:.1f} | {r[7]:.0f} | {r[8]:.0f} | "
        f"{r[9]:.2f} |\n"
        for r in rows
    )
    print(table)
    if args.markdown:
        Path(args.markdown).write_text(table)
    return 0


def _version(name: str, module) -> str:
    from importlib.metadata import version

    try:
        return version(name)
    except Exception:  # pragma: no cover - a source checkout without metadata
        return getattr(module, "__version__", "?")


if __name__ == "__main__":
    raise SystemExit(main())
