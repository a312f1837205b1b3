"""Diagnostic: how much linear acceleration passes the accelerometer's low-pass horizontally and vertically on the
BROAD trials?  (Uses the optical reference: a diagnostic, not a method; docs/broad.md, "Twelve trials", (d).)

Run ``.venv/bin/python benchmarks/diag_broad_isotropy.py``.  The filter adds to its accelerometer noise a term from
``| |ā| − g |``, which sees the filtered linear acceleration along the vertical only, and uses it for each horizontal
axis.  Here the specific force is rotated into the earth frame with the *reference* orientation (NaN samples: the
last valid one), the rest period's median magnitude is subtracted from the vertical, and the result goes through the
continuous 2nd-order Butterworth with DC group delay 1.5 s (the filter's default, ``window / 2``; bilinear transform).
Printed per trial: the RMS over the movement samples of the low-passed linear acceleration per horizontal axis and
along the vertical, their ratio, and the same for the raw linear acceleration.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.signal import butter, lfilter

import dualpose as dp
from dualpose.io import load_broad

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"


def main() -> int:
    print(
        "| trial | low-passed, per horizontal axis (m/s²) | low-passed, vertical | ratio | raw, per horizontal axis "
        "| raw, vertical |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for path in sorted(DATA.glob("*.mat")):
        t = load_broad(path)
        ok = np.all(np.isfinite(t.quat), axis=1)
        last = np.maximum.accumulate(np.where(ok, np.arange(len(ok)), 0))
        q = t.quat[last]
        q[~ok[last]] = [0.0, 0.0, 0.0, 1.0]  # before the first valid reference sample
        a = dp.quat_rotate(q, t.acc)
        a[:, 2] -= np.median(np.linalg.norm(t.acc[: t.static_start], axis=1))
        wc = math.sqrt(2.0) / 1.5  # rad/s: the Butterworth whose DC group delay is 1.5 s
        b, den = butter(2, wc / (2.0 * math.pi), fs=t.rate)
        lp = lfilter(b, den, a, axis=0)
        m = t.movement
        h = math.sqrt(np.mean(lp[m, 0] ** 2 + lp[m, 1] ** 2) / 2.0)
        v = math.sqrt(np.mean(lp[m, 2] ** 2))
        rh = math.sqrt(np.mean(a[m, 0] ** 2 + a[m, 1] ** 2) / 2.0)
        rv = math.sqrt(np.mean(a[m, 2] ** 2))
        print(f"| {t.name[:2]} | {h:.3f} | {v:.3f} | {h / v:.2f} | {rh:.2f} | {rv:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
