"""Diagnostic: how still are the breaks of BROAD's "with breaks" trials?  (Uses the optical reference: a diagnostic
of the data, not a method; docs/broad.md, "Twelve trials".)

Run ``.venv/bin/python benchmarks/diag_broad_breaks.py``.  For every quiet spell of at least 3 s after the initial rest
of the trials in ``../shared/data/broad`` whose name says "with_breaks" (the samples BROAD does not flag as movement):
the mean gyroscope rate over the spell from 1.5 s after its start (the rest detector's window) to its end; the
gyroscope bias the real-time 6D filter without the rest update (``AhrsConfig(rest_window=0)``) holds at the spell's
start, i.e. the bias it learnt in motion; and the body's true mean rotation rate over the same samples from the
optical reference, rotation vector of ``q_ref(a)* ⊗ q_ref(b)`` divided by the time (the residual rotation of a
"still" object, which a rest measurement takes for bias).  Last line: the per-axis RMS of the optical rates over all
spells with a reference at both ends.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import dualpose as dp
from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation
from dualpose.io import load_broad

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"


def main() -> int:
    rates = []
    print("| trial | spell (s) | gyroscope mean (°/s) | bias learnt in motion (°/s) | optical rotation rate (°/s) |")
    print("|---|---|---|---|---|")
    for path in sorted(DATA.glob("*with_breaks*.mat")):
        t = load_broad(path)
        r = estimate_orientation(t.gyr, t.acc, None, t.rate, use_mag=False, n_rest=t.static_start,
                                 config=AhrsConfig(rest_window=0.0))  # fmt: skip
        idx = np.flatnonzero(~t.movement[t.static_start :]) + t.static_start
        for spell in np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1):
            if len(spell) < 3 * t.rate:
                continue
            a, b = spell[0] + int(1.5 * t.rate), spell[-1]
            gyr = np.degrees(t.gyr[a:b].mean(axis=0))
            bias = np.degrees(r.gyroscope_bias[spell[0] - 1])
            opt = "no reference"
            if np.all(np.isfinite(t.quat[[a, b]])):
                axis, angle = dp.axis_angle_from_quat(dp.quat_mul(dp.quat_conj(t.quat[a]), t.quat[b]))
                rate = np.degrees(axis * angle) / ((b - a) / t.rate)
                rates.append(rate)
                opt = " ".join(f"{x:+.4f}" for x in rate)
            print(f"| {t.name} | {a / t.rate:.1f}–{b / t.rate:.1f} | " + " ".join(f"{x:+.4f}" for x in gyr) + " | "
                  + " ".join(f"{x:+.4f}" for x in bias) + f" | {opt} |")
    if rates:
        print(f"\nPer-axis RMS of the optical rotation rate over {len(rates)} spells: "
              f"{np.sqrt(np.mean(np.square(rates))):.4f} °/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
