"""Diagnostic: in which frequency band is the 6D inclination error of dualpose and VQF on the BROAD trials?  (Uses the
optical reference: a diagnostic of the filters' errors, not a method; docs/broad.md, "Twelve trials", (d).)

Run ``.venv/bin/python benchmarks/diag_broad_bands.py [--markdown docs/broad.md] [TRIAL ...]`` (needs the ``bench``
extra for ``vqf``; default: the twelve trials of ``bench_broad.py``).  For each trial: the real-time 6D filters
(:func:`dualpose.estimation.ahrs.estimate_orientation` with its defaults and ``n_rest=trial.static_start``;
``vqf.VQF(Ts).updateBatch(gyr, acc)["quat6D"]`` with its defaults and with ``tauAcc`` = 1.5 s, the delay of
dualpose's accelerometer low-pass) and their **inclination error vector in the reference's earth frame**,
``R_ref (ĝ_est × ĝ_ref)`` with ``ĝ = R(q)ᵀ e_z`` the vertical in body axes (heading-free, so the 6D heading offset does
not enter; for small errors its norm is the inclination error of :mod:`dualpose.evaluation.orientation_errors`).
Over the movement samples (NaN reference samples and the rest set to zero) the vector is split by an FFT into the
bands below 0.1 Hz (drift and the slow error, periods > 10 s), 0.1–0.33 Hz, 0.33–1 Hz, 1–3.3 Hz and above 3.3 Hz;
each column is the RMS of the band-passed vector over the movement samples (the squares add up to the total's
square).  A constant body-frame error would show at the rotation frequencies; in the earth frame the error of a slow
drift stays in the lowest band.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

import dualpose as dp
from _common import write_marked_block
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.io import load_broad

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"
TRIALS = ("01", "06", "10", "15", "21", "24", "28", "05", "09", "14", "27", "33")
#: band edges, Hz
EDGES = (0.0, 0.1, 1.0 / 3.0, 1.0, 10.0 / 3.0, np.inf)
BEGIN, END = "<!-- diag_broad_bands:begin -->", "<!-- diag_broad_bands:end -->"


def earth_tilt_error(q_est: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """Inclination error vectors (n, 3), degrees, in the reference's earth frame: ``R_ref (ĝ_est × ĝ_ref)``, ``ĝ`` the
    earth's vertical in body axes of each xyzw quaternion (n, 4) (body → earth)."""
    up = np.array([0.0, 0.0, 1.0])
    g_est = dp.quat_rotate(dp.quat_conj(q_est), up)
    g_ref = dp.quat_rotate(dp.quat_conj(q_ref), up)
    return np.degrees(dp.quat_rotate(q_ref, np.cross(g_est, g_ref)))


def band_rms(e: np.ndarray, mask: np.ndarray, rate: float) -> tuple[float, list[float]]:
    """RMS (over ``mask``) of the vectors ``e`` (n, 3) and of their parts in each band of :data:`EDGES`."""
    x = np.where(mask[:, None], e, 0.0)
    spec = np.fft.rfft(x, axis=0)
    f = np.fft.rfftfreq(len(x), 1.0 / rate)
    out = []
    for lo, hi in zip(EDGES[:-1], EDGES[1:], strict=True):
        part = np.fft.irfft(np.where(((f >= lo) & (f < hi))[:, None], spec, 0.0), n=len(x), axis=0)[mask]
        out.append(float(np.sqrt(np.mean(np.sum(part**2, axis=1)))))
    return float(np.sqrt(np.mean(np.sum(e[mask] ** 2, axis=1)))), out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trials", nargs="*", default=list(TRIALS), help="BROAD trial numbers (default: the twelve)")
    ap.add_argument("--markdown", type=Path, help="write the table into this file's marked block")
    args = ap.parse_args()
    import vqf

    files = {p.name[:2]: p for p in DATA.glob("*.mat")}
    missing = [k for k in args.trials if k not in files]
    if missing:
        print(f"no BROAD file for trial(s) {', '.join(missing)} in {DATA}", file=sys.stderr)
        return 1
    head = " | ".join(f"{lo:.2g}–{hi:.2g} Hz" if np.isfinite(hi) else f"> {lo:.2g} Hz" for lo, hi in
                      zip(EDGES[:-1], EDGES[1:], strict=True))  # fmt: skip
    lines = [f"| trial | method | inclination (°) | {head} |", "|---|---|---:|" + "---:|" * (len(EDGES) - 1)]
    for k in args.trials:
        t = load_broad(files[k])
        mask = t.movement & np.all(np.isfinite(t.quat), axis=1)
        q_ref = np.where(mask[:, None], t.quat, np.array([0.0, 0.0, 0.0, 1.0]))
        gyr, acc = np.ascontiguousarray(t.gyr), np.ascontiguousarray(t.acc)
        runs = {"dualpose 6D": estimate_orientation(t.gyr, t.acc, None, t.rate, use_mag=False,
                                                    n_rest=t.static_start).quat}  # fmt: skip
        for name, tau in (("VQF 6D", None), ("VQF 6D, τ_acc = 1.5 s", 1.5)):
            f = vqf.VQF(1.0 / t.rate) if tau is None else vqf.VQF(1.0 / t.rate, tauAcc=tau)
            runs[name] = f.updateBatch(gyr, acc)["quat6D"][:, [1, 2, 3, 0]]
        for name, q in runs.items():
            total, bands = band_rms(earth_tilt_error(q, q_ref), mask, t.rate)
            lines.append(f"| {k} | {name} | {total:.3f} | " + " | ".join(f"{b:.3f}" for b in bands) + " |")
    table = "\n".join(lines)
    print(table)
    if args.markdown is not None:
        write_marked_block(args.markdown, table, BEGIN, END)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
