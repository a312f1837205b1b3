"""Cost of the streaming AHRS (dualpose.estimation.ahrs.stream.AhrsStream) on the BROAD trials, next to VQF.

Run ``.venv/bin/python benchmarks/bench_ahrs_stream.py`` (VQF is timed if ``vqf`` is importable: the ``bench``
extra).  Per trial, best of 3, in one process:

* ``update_imu``: wall time of a Python loop calling ``AhrsStream.update_imu(t, gyro, accel, mag)`` once per sample
  after the rest period (9D, default settings, rows of the trial's arrays as given, ``t`` a Python float), divided by
  the samples: the per-call cost a Python caller pays, loop included (the rest period is fed with ``update_batch``
  first);
* batch: :func:`dualpose.estimation.ahrs.estimate_orientation`'s kernel time per sample (``AhrsResult.us_per_sample``,
  9D, default settings: online magnetometer time offset), the native whole-recording loop over the same per-sample
  step; "batch, τ = 0": the same with ``mag_time_offset=0.0`` (no time-offset compensation or estimate), the cost
  without the online estimate;
* ``update_batch``: ``AhrsStream.update_batch`` over the whole trial, per sample;
* VQF: a Python loop calling ``vqf.VQF(Ts).update(gyr, acc, mag)`` per sample over the whole trial (Laidig & Seel
  2023, default parameters; VQF needs no initialisation period), and its ``updateBatch`` per sample.

``--label`` only names the batch column (to put the numbers of two builds side by side).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

from dualpose.estimation.ahrs import estimate_orientation
from dualpose.io import load_broad

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"


def _loop_stream(trial) -> float:
    from dualpose.estimation.ahrs.stream import AhrsStream

    n, r = len(trial.gyr), trial.static_start
    t = np.arange(n) / trial.rate
    g, a, m = trial.gyr, trial.acc, trial.mag
    s = AhrsStream(trial.rate, n_rest=r)
    s.update_batch(t[:r], g[:r], a[:r], m[:r])  # the rest period (initialisation), not timed
    t = t.tolist()
    update = s.update_imu
    t0 = time.perf_counter()
    for k in range(r, n):
        update(t[k], g[k], a[k], m[k])
    return 1e6 * (time.perf_counter() - t0) / (n - r)


def _batch_stream(trial) -> float:
    from dualpose.estimation.ahrs.stream import AhrsStream

    n = len(trial.gyr)
    s = AhrsStream(trial.rate, n_rest=trial.static_start)
    t0 = time.perf_counter()
    s.update_batch(np.arange(n) / trial.rate, trial.gyr, trial.acc, trial.mag)
    return 1e6 * (time.perf_counter() - t0) / n


def _batch(trial) -> float:
    return estimate_orientation(trial.gyr, trial.acc, trial.mag, trial.rate, n_rest=trial.static_start).us_per_sample


def _batch_tau0(trial) -> float:
    r = estimate_orientation(
        trial.gyr, trial.acc, trial.mag, trial.rate, n_rest=trial.static_start, mag_time_offset=0.0
    )
    return r.us_per_sample


def _vqf_loop(trial) -> float:
    import vqf

    f = vqf.VQF(1.0 / trial.rate)
    g, a, m = (np.ascontiguousarray(x) for x in (trial.gyr, trial.acc, trial.mag))
    update = f.update
    t0 = time.perf_counter()
    for k in range(len(g)):
        update(g[k], a[k], m[k])
    return 1e6 * (time.perf_counter() - t0) / len(g)


def _vqf_batch(trial) -> float:
    import vqf

    f = vqf.VQF(1.0 / trial.rate)
    g, a, m = (np.ascontiguousarray(x) for x in (trial.gyr, trial.acc, trial.mag))
    t0 = time.perf_counter()
    f.updateBatch(g, a, m)
    return 1e6 * (time.perf_counter() - t0) / len(g)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--label", default="batch", help="name of the batch column")
    ap.add_argument("--batch-only", action="store_true", help="only the batch column (for an older build)")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"BROAD data not found in {DATA}", file=sys.stderr)
        return 1
    try:
        import vqf  # noqa: F401

        have_vqf = True
    except ImportError:
        have_vqf = False
    cols = [(f"{args.label} µs/sample", _batch)]
    if not args.batch_only:
        cols += [("batch, τ = 0 µs/sample", _batch_tau0), ("update_imu µs/call", _loop_stream),
                 ("update_batch µs/sample", _batch_stream)]
        if have_vqf:
            cols += [("VQF update µs/call", _vqf_loop), ("VQF updateBatch µs/sample", _vqf_batch)]
    print(f"<!-- {platform.python_implementation()} {platform.python_version()}, numpy {np.__version__} -->")
    print("| trial | samples | " + " | ".join(c for c, _ in cols) + " |")
    print("|---|---:|" + "---:|" * len(cols))
    for path in sorted(DATA.glob("*.mat")):
        trial = load_broad(path)
        vals = [min(fn(trial) for _ in range(3)) for _, fn in cols]
        print(f"| {path.stem} | {len(trial.gyr)} | " + " | ".join(f"{v:.2f}" for v in vals) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
