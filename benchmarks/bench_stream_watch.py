"""Per-sample cost of the streams' own watch on their IMU stamps (gaps, and the stated rate against the first 200
stamps: ``GapWatch`` of ``dualpose.estimation._stream``, docs/refusals.md).

Run ``.venv/bin/python benchmarks/bench_stream_watch.py [--repeat 7]``.  On the simulated eight (``sim.simulate_eight``,
100 Hz IMU, the ``dualpose fuse`` start), a Python loop calling ``update_imu(t, gyro, accel)`` once per IMU sample
(no frames) of ``EskfStream``, ``Hol22Stream`` and a 6D ``AhrsStream`` (no rest period), best of ``--repeat``: the mean
over the first 200 samples (while the stamps are collected for the rate check) and over the samples after them, µs
per call.  The script uses only the public API, so it runs unchanged on a build from before the watch to compare.
"""

from __future__ import annotations

import argparse
import time
import warnings

from dualpose import sim
from dualpose.estimation import initialization
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.estimation.eskf import ErrorStateEKF, EskfStream
from dualpose.estimation.hol22 import Hol22EKF, Hol22Stream

FIRST = 200


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="best of this many (default 7)")
    args = ap.parse_args()
    run = sim.recording_from_simulation(sim.simulate_eight(0), rest_seconds=0.9)
    x0, p0 = initialization.initial_state_from_run(run, 0.9)
    t, g, a = run.t.tolist(), list(run.gyro), list(run.accel)
    n = len(t)
    makers = {
        "EskfStream": lambda: EskfStream(ErrorStateEKF.from_state(run, x0, p0)),
        "Hol22Stream": lambda: Hol22Stream(Hol22EKF.from_eskf_state(x0, p0, run)),
        "AhrsStream (6D)": lambda: AhrsStream(1.0 / run.nominal_period(), use_mag=False, n_rest=0),
    }
    print(f"{n} samples per run; best of {args.repeat}; µs per update_imu call")
    print("| stream | first 200 samples | after them |\n|---|---|---|")
    for name, make in makers.items():
        best_first = best_rest = float("inf")
        for _ in range(args.repeat):
            s = make()
            up = s.update_imu
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t0 = time.perf_counter()
                for k in range(FIRST):
                    up(t[k], g[k], a[k])
                t1 = time.perf_counter()
                for k in range(FIRST, n):
                    up(t[k], g[k], a[k])
                t2 = time.perf_counter()
            best_first = min(best_first, (t1 - t0) / FIRST)
            best_rest = min(best_rest, (t2 - t1) / (n - FIRST))
        print(f"| {name} | {1e6 * best_first:.2f} | {1e6 * best_rest:.2f} |")


if __name__ == "__main__":
    main()
