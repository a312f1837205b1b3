"""Cost of the AHRS's rest-bias offset and accelerometer impulse clipping, interleaved against the same build with
them off (docs/broad.md, "Twelve trials"): what they add per sample, measurable on a loaded machine.

Run ``.venv/bin/python benchmarks/bench_ahrs_changes.py``.  Trial 01 of ``../shared/data/broad``, 9D, default
settings vs ``AhrsConfig(acc_clip=0)`` vs ``AhrsConfig(acc_clip=0, rest_bias_sigma=0)``: the batch kernel's time per
sample (``AhrsResult.us_per_sample``, best of 9 interleaved rounds) and ``AhrsStream.update_imu`` per call from a
Python loop (best of 15 interleaved rounds of 2000 consecutive samples after the rest period, each configuration on
its own stream).  Interleaving puts every configuration under the same machine load (``_common.best_of_interleaved``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from _common import best_of_interleaved
from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation
from dualpose.estimation.ahrs.stream import AhrsStream
from dualpose.io import load_broad

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"
CONFIGS = {"default": AhrsConfig(), "acc_clip=0": AhrsConfig(acc_clip=0.0),
           "acc_clip=0, rest_bias_sigma=0": AhrsConfig(acc_clip=0.0, rest_bias_sigma=0.0)}  # fmt: skip
CALLS = 2000


def main() -> int:
    t = load_broad(DATA / "01_undisturbed_slow_rotation_A.mat")
    batch = dict.fromkeys(CONFIGS, np.inf)
    for _ in range(9):
        for name, c in CONFIGS.items():
            r = estimate_orientation(t.gyr, t.acc, t.mag, t.rate, n_rest=t.static_start, config=c)
            batch[name] = min(batch[name], r.seconds)
    ts = np.arange(len(t.gyr)) / t.rate
    k0 = t.static_start + 1

    def stream_loop(c: AhrsConfig):
        s = AhrsStream(t.rate, n_rest=t.static_start, config=c)
        s.update_batch(ts[:k0], t.gyr[:k0], t.acc[:k0], t.mag[:k0])
        pos = [k0]

        def f() -> None:
            a = pos[0]
            pos[0] += CALLS
            for j in range(a, a + CALLS):
                s.update_imu(ts[j], t.gyr[j], t.acc[j], t.mag[j])

        return f

    calls = best_of_interleaved({name: stream_loop(c) for name, c in CONFIGS.items()}, 15)
    print("| configuration | batch µs/sample | update_imu µs/call |")
    print("|---|---:|---:|")
    for name in CONFIGS:
        print(f"| {name} | {1e6 * batch[name] / len(t.gyr):.3f} | {1e6 * calls[name] / CALLS:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
