"""The AHRS next to VQF on a magnet attached to the IMU (a constant field offset in the sensor frame), synthetic.

Run ``.venv/bin/python benchmarks/bench_ahrs_magnet.py`` (docs/broad.md, "Twelve trials", attached magnet).

Data: :func:`dualpose.sim.rest_breaks.rest_break_recording` with no breaks (5 s rest, 120 s of slow rotation up to
~17 °/s, 100 Hz, bias random walk, no drift), seeds 0–5, and a body-fixed offset h of |h| µT in a seeded random
direction added to the magnetometer either from 20 s to 100 s of the movement ("attached after the rest", the
protocol of BROAD's trial 33) or over the whole recording ("attached from the start": the rest period's field, i.e.
the filter's reference field and initial heading, includes it).  The earth field is 49 µT with a dip of 65°
(``dualpose.sim._imu_truth.FIELD_ENU``), so |h| = 3 µT deflects the horizontal field by up to ~8°.  dualpose 9D
real-time default, VQF 2.x ``updateBatch`` defaults; total RMSE over every sample after the rest.  The "reference
oracle" row gives dualpose the true earth field's norm and dip as its disturbance reference instead of the rest
period's (a test of reference re-acquisition, not a method).
"""

from __future__ import annotations

import math

import numpy as np
import vqf

import dualpose.estimation.ahrs.batch as ahrs_batch
from dualpose import _native
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.evaluation.orientation_errors import orientation_rmse
from dualpose.sim.rest_breaks import FIELD_ENU, rest_break_recording

SEEDS = range(6)


def _oracle_setup(*args, **kwargs):
    setup = _filter_setup(*args, **kwargs)
    fe = np.asarray(FIELD_ENU, dtype=float)
    setup.params[_native.AHRS_P_MAG_NORM] = float(np.linalg.norm(fe))
    setup.params[_native.AHRS_P_MAG_DIP] = math.atan2(-fe[2], math.hypot(fe[0], fe[1]))
    return setup


_filter_setup = ahrs_batch.filter_setup


def run(h_norm: float, from_start: bool) -> dict[str, float]:
    out: dict[str, list[float]] = {"dualpose": [], "dualpose, reference oracle": [], "VQF": []}
    for seed in SEEDS:
        rec = rest_break_recording(seed, n_breaks=0, segment=120.0, drift=0.0)
        h = np.random.default_rng(100 + seed).normal(size=3)
        h *= h_norm / np.linalg.norm(h)
        mag = rec.mag.copy()
        k0, k1 = (0, len(mag)) if from_start else (rec.n_rest + int(20 * rec.rate), rec.n_rest + int(100 * rec.rate))
        mag[k0:k1] += h
        for name, oracle in (("dualpose", False), ("dualpose, reference oracle", True)):
            ahrs_batch.filter_setup = _oracle_setup if oracle else _filter_setup
            try:
                r = estimate_orientation(rec.gyr, rec.acc, mag, rec.rate, n_rest=rec.n_rest)
            finally:
                ahrs_batch.filter_setup = _filter_setup
            out[name].append(orientation_rmse(r.quat, rec.quat, rec.scored).total_rmse_deg)
        v = vqf.VQF(1.0 / rec.rate).updateBatch(rec.gyr, rec.acc, np.ascontiguousarray(mag))
        out["VQF"].append(orientation_rmse(v["quat9D"][:, [1, 2, 3, 0]], rec.quat, rec.scored).total_rmse_deg)
    return {k: float(np.mean(v)) for k, v in out.items()}


def main() -> int:
    print("9D total RMSE (°), mean over seeds 0–5:\n")
    print("| magnet | abs(h) (µT) | dualpose | dualpose, reference oracle | VQF |")
    print("|---|---:|---:|---:|---:|")
    for from_start in (False, True):
        for h in (0.0, 3.0, 6.0, 25.0):
            if from_start and h == 0.0:
                continue
            r = run(h, from_start)
            label = "attached from the start" if from_start else "attached 20–100 s after the rest"
            print(f"| {label if h else 'none'} | {h:.0f} | {r['dualpose']:.3f} | "
                  f"{r['dualpose, reference oracle']:.3f} | {r['VQF']:.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
