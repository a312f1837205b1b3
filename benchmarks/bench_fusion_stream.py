"""Cost of the streaming camera–IMU filters (``EskfStream``, ``Hol22Stream``) next to their batch ``run``.

Run ``.venv/bin/python benchmarks/bench_fusion_stream.py``.  On the simulated eight (``sim.simulate_eight(seed)``,
100 Hz IMU, 12.5 Hz camera, 20 correspondences per frame; the ``dualpose fuse`` start), in one process, best of
``--repeat`` (default 7) per filter, seeds 0-4 pooled:

* ``update_imu``: a Python loop calling ``update_imu(t, gyro, accel)`` once per IMU sample (no frames), ``t`` a Python
  float and the rows of the run's arrays as given; wall time / samples: what a Python caller pays, loop included;
* camera frame: a Python loop over the run's lines in time order (``update_camera`` per frame, ``update_imu`` per
  sample); (its wall time − samples × the ``update_imu`` cost) / frames: the cost of one frame (queueing and the
  update at the next sample, through the slower path that sample takes);
* ``update_batch``: the whole run in one call, per IMU sample (frames included);
* batch ``run``: ``ErrorStateEKF.run`` / ``Hol22EKF.run`` (``FilterResult.wall_time``), per IMU sample
  (``--batch-only``: this column alone, which also runs on a build without the streams).
"""

from __future__ import annotations

import argparse
import importlib
import platform
import sys
import time

import numpy as np

from _common import emit
from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation.eskf import ErrorStateEKF
from dualpose.estimation.hol22 import Hol22EKF

FILTERS = {
    "ESKF": (lambda run, x, P: ErrorStateEKF.from_state(run, x, P), "dualpose.estimation.eskf", "EskfStream"),
    "Hol22": (lambda run, x, P: Hol22EKF.from_eskf_state(x, P, run), "dualpose.estimation.hol22", "Hol22Stream"),
}


def runs(seeds: range) -> list[tuple]:
    out = []
    for seed in seeds:
        run = sim.recording_from_simulation(sim.simulate_eight(seed), rest_seconds=0.9)
        x, P = initialization.initial_state_from_run(run, 0.9)
        f = run.frames
        events = [(float(t), 1, k) for k, t in enumerate(run.t)]
        events += [(float(t + run.time_offset), 0, j) for j, t in enumerate(f.t)]
        out.append((run, x, P, sorted(events)))
    return out


def imu_loop(make, stream_cls, data) -> float:
    """Seconds of the update_imu loops over all runs (no frames)."""
    total = 0.0
    for run, x, P, _ in data:
        s = stream_cls(make(run, x, P))
        t, g, a = run.t.tolist(), run.gyro, run.accel
        up = s.update_imu
        t0 = time.perf_counter()
        for k in range(len(t)):
            up(t[k], g[k], a[k])
        total += time.perf_counter() - t0
    return total


def event_loop(make, stream_cls, data) -> float:
    """Seconds of the loops over the lines of all runs (update_camera per frame, update_imu per sample)."""
    total = 0.0
    for run, x, P, events in data:
        s = stream_cls(make(run, x, P))
        f = run.frames
        frames = [(float(f.t[j]), *f.frame(j)) for j in range(len(f.t))]
        t, g, a = run.t.tolist(), run.gyro, run.accel
        up, cam = s.update_imu, s.update_camera
        t0 = time.perf_counter()
        for _, kind, i in events:
            if kind:
                up(t[i], g[i], a[i])
            else:
                cam(*frames[i])
        total += time.perf_counter() - t0
    return total


def block(make, stream_cls, data) -> float:
    total = 0.0
    for run, x, P, _ in data:
        s = stream_cls(make(run, x, P))
        f = run.frames
        t0 = time.perf_counter()
        s.update_batch(run.t, run.gyro, run.accel, f.t, f.offsets, f.pixels, f.points)
        total += time.perf_counter() - t0
    return total


def batch(make, data) -> float:
    return sum(make(run, x, P).run_recording(run).wall_time for run, x, P, _ in data)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="best of this many (default 7)")
    ap.add_argument("--batch-only", action="store_true",
                    help="only the batch run column (runs on a build without the streams, for a before/after)")
    ap.add_argument("--markdown", help="also write the table to this file (never overwritten)")
    args = ap.parse_args(argv)
    data = runs(range(5))
    n = sum(len(d[0].t) for d in data)
    nf = sum(len(d[0].frames.t) for d in data)
    m = sum(len(d[0].frames.pixels) for d in data)
    out = [
        f"Simulated eight, seeds 0-4: {n} IMU samples, {nf} frames, {m / nf:.0f} correspondences per frame; best of "
        f"{args.repeat}; Python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}",
        "",
        "| filter | update_imu µs/call | camera frame µs/frame | update_batch µs/sample | batch run µs/sample |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, (make, module, cls_name) in FILTERS.items():
        batch(make, data[:1])  # warm-up
        t_run = min(batch(make, data) for _ in range(args.repeat))
        if args.batch_only:
            out.append(f"| {name} | | | | {1e6 * t_run / n:.2f} |")
            continue
        cls = getattr(importlib.import_module(module), cls_name)  # absent in a build without the streams
        t_imu = min(imu_loop(make, cls, data) for _ in range(args.repeat))
        t_ev = min(event_loop(make, cls, data) for _ in range(args.repeat))
        t_blk = min(block(make, cls, data) for _ in range(args.repeat))
        out.append(f"| {name} | {1e6 * t_imu / n:.2f} | {1e6 * (t_ev - t_imu) / nf:.1f} | {1e6 * t_blk / n:.2f} | "
                   f"{1e6 * t_run / n:.2f} |")  # fmt: skip
    return emit("\n".join(out), args.markdown)


if __name__ == "__main__":
    sys.exit(main())
