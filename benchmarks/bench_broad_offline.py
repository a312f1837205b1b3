"""dualpose's offline AHRS (RTS smoother) on the BROAD trials next to offline VQF, the forward filters and Madgwick.

Run ``.venv/bin/python benchmarks/bench_broad_offline.py [--markdown docs/broad.md]`` (needs the ``bench`` extra for
``vqf``).  Everything runs in one process on the trials in ``../shared/data/broad``; defaults fixed for every trial.

* dualpose offline 9D / 6D: :func:`dualpose.estimation.ahrs.smoother.smooth_orientation` with its defaults
  (magnetometer time offset estimated from the whole recording, no magnetometer self-calibration); "9D + mag
  calibration" adds the self-calibration decided by its reference-free rule (``mag_calibration="auto"``).
* dualpose forward 9D / 6D: :func:`dualpose.estimation.ahrs.estimate_orientation` with its defaults (the forward pass
  of the smoother without the self-calibration).
* offline VQF 9D / 6D: ``vqf.offlineVQF(gyr, acc, mag, Ts)`` (vqf 2.1.2, default parameters; Laidig & Seel 2023);
  VQF 9D / 6D: the real-time ``vqf.VQF(Ts).updateBatch``.  Both output wxyz, converted to xyzw.
* Madgwick: BROAD's published total RMSE at β = 0.12 (``bench_broad.MADGWICK_012``), not re-run.

Scoring as ``bench_broad.py``: BROAD's metric over the movement samples; 9D as is, 6D after one constant heading
offset per method.  µs/sample: best of 3 wall times of the estimator's kernel over the whole trial (dualpose: the
native forward + backward call ``_native.ahrs_smooth``, or ``ahrs_run`` for the forward filter, without the
once-per-recording time-offset estimate and self-calibration, which bench_broad.py times; VQF: the whole
``offlineVQF`` / ``updateBatch`` call).
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

from _common import write_marked_block
from bench_broad import MADGWICK_012, trial_subsets
from dualpose.estimation.ahrs import estimate_orientation
from dualpose.estimation.ahrs.smoother import smooth_orientation
from dualpose.evaluation.orientation_errors import orientation_rmse
from dualpose.io import load_broad

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"
BEGIN, END = "<!-- bench_broad_offline:begin -->", "<!-- bench_broad_offline:end -->"
WXYZ_TO_XYZW = [1, 2, 3, 0]
METHODS = ("dualpose offline 9D", "dualpose offline 9D + mag calibration", "dualpose offline 6D",
           "dualpose forward 9D", "dualpose forward 6D", "offline VQF 9D", "offline VQF 6D", "VQF 9D",
           "VQF 6D")  # fmt: skip
#: the smoother runs: name, use_mag, mag_calibration
OFFLINE_RUNS = (("dualpose offline 9D", True, None), ("dualpose offline 9D + mag calibration", True, "auto"),
                ("dualpose offline 6D", False, None))  # fmt: skip


def _best(fn, seconds):
    """The result of the fastest of 3 calls of fn() and its seconds (``seconds(result, wall)``)."""
    best, best_s = None, np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        r = fn()
        s = seconds(r, time.perf_counter() - t0)
        if s < best_s:
            best, best_s = r, s
    return best, best_s


def _vqf(trial) -> dict:
    import vqf

    gyr, acc, mag = (np.ascontiguousarray(a) for a in (trial.gyr, trial.acc, trial.mag))
    ts = 1.0 / trial.rate
    off, off_s = _best(lambda: vqf.offlineVQF(gyr, acc, mag, ts), lambda r, w: w)
    rt, rt_s = _best(lambda: vqf.VQF(ts).updateBatch(gyr, acc, mag), lambda r, w: w)
    out = {}
    for label, res, s in (("offline VQF", off, off_s), ("VQF", rt, rt_s)):
        for d in ("9D", "6D"):
            out[f"{label} {d}"] = (res[f"quat{d}"][:, WXYZ_TO_XYZW], s)
    return out


def _dualpose(trial) -> dict:
    args = (trial.gyr, trial.acc, trial.mag, trial.rate)
    kw = {"n_rest": trial.static_start}
    out = {}
    for name, use_mag, cal in OFFLINE_RUNS:
        kw_run = {**kw, "use_mag": use_mag, "mag_calibration": cal}
        r, s = _best(lambda kw_run=kw_run: smooth_orientation(*args, **kw_run), lambda r, w: r.seconds)
        out[name] = (r.quat, s)
    for name, use_mag in (("dualpose forward 9D", True), ("dualpose forward 6D", False)):
        r, s = _best(lambda use_mag=use_mag: estimate_orientation(*args, use_mag=use_mag, **kw), lambda r, w: r.seconds)
        out[name] = (r.quat, s)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--markdown", help="write the tables into this Markdown file between " + BEGIN + " and " + END)
    args = ap.parse_args()
    files = sorted(DATA.glob("*.mat"))
    if not files:
        print(f"no BROAD trials in {DATA}", file=sys.stderr)
        return 1
    rows = []
    for path in files:
        t = load_broad(path)
        runs = {**_dualpose(t), **_vqf(t)}
        n = t.gyr.shape[0]
        scores = {}
        for name in METHODS:
            q, seconds = runs[name]
            scores[name] = (orientation_rmse(q, t.quat, t.movement, fit_heading_offset=name.endswith("6D")),
                            1e6 * seconds / n)  # fmt: skip
        rows.append((t.name, t.name[:2], scores))
        print(t.name, "  ".join(f"{k}: {v[0].total_rmse_deg:.3f}" for k, v in scores.items()), flush=True)
    text = "\n".join(_markdown(rows))
    print(text)
    if args.markdown:
        write_marked_block(Path(args.markdown), text, BEGIN, END)
    return 0


def _markdown(rows: list) -> list[str]:
    out = ["| trial | method | total RMSE (°) | heading RMSE (°) | inclination RMSE (°) | µs/sample |",
           "|---|---|---:|---:|---:|---:|"]  # fmt: skip
    for name, key, scores in rows:
        for method, (s, us) in scores.items():
            out.append(f"| {name} | {method} | {s.total_rmse_deg:.3f} | {s.heading_rmse_deg:.3f} | "
                       f"{s.inclination_rmse_deg:.3f} | {us:.2f} |")  # fmt: skip
        out.append(f"| {name} | Madgwick β=0.12 (published) | {MADGWICK_012[key]:.3f} | – | – | – |")
    out += ["", "Mean over the trials:", "",
            "| method | mean total RMSE (°) | mean heading RMSE (°) | mean inclination RMSE (°) | mean µs/sample |",
            "|---|---:|---:|---:|---:|"]  # fmt: skip
    for method in METHODS:
        vals = np.array([[s.total_rmse_deg, s.heading_rmse_deg, s.inclination_rmse_deg, us]
                         for _, _, sc in rows for s, us in [sc[method]]])  # fmt: skip
        m = vals.mean(axis=0)
        out.append(f"| {method} | {m[0]:.3f} | {m[1]:.3f} | {m[2]:.3f} | {m[3]:.2f} |")
    out.append(f"| Madgwick β=0.12 (published) | {np.mean([MADGWICK_012[k] for _, k, _ in rows]):.3f} | – | – | – |")
    out += ["", "Against offline VQF (total RMSE, °; ratio = dualpose / offline VQF):", "",
            "| comparison | dualpose mean | offline VQF mean | ratio | trials where dualpose is lower |",
            "|---|---:|---:|---:|---:|"]  # fmt: skip
    for ours, theirs in (("dualpose offline 9D", "offline VQF 9D"), ("dualpose offline 6D", "offline VQF 6D")):
        a = np.array([sc[ours][0].total_rmse_deg for _, _, sc in rows])
        b = np.array([sc[theirs][0].total_rmse_deg for _, _, sc in rows])
        ai = np.array([sc[ours][0].inclination_rmse_deg for _, _, sc in rows])
        bi = np.array([sc[theirs][0].inclination_rmse_deg for _, _, sc in rows])
        out.append(f"| {ours} vs {theirs}, total | {a.mean():.3f} | {b.mean():.3f} | {a.mean() / b.mean():.3f} | "
                   f"{int((a < b).sum())} of {len(a)} |")  # fmt: skip
        out.append(f"| {ours} vs {theirs}, inclination | {ai.mean():.3f} | {bi.mean():.3f} | "
                   f"{ai.mean() / bi.mean():.3f} | {int((ai < bi).sum())} of {len(ai)} |")  # fmt: skip
    out += ["", "Offline 9D against offline VQF by subset (total RMSE, °; target: ratio ≤ 0.9 and dualpose lower on "
            "≥ 3/4 of the trials; 6D inclination for reference):", "",
            "| subset | trials | dualpose offline 9D | offline VQF 9D | ratio | dualpose lower | target | "
            "dualpose offline 6D inclination | offline VQF 6D inclination |",
            "|---|---:|---:|---:|---:|---:|---|---:|---:|"]  # fmt: skip
    for label, idx in trial_subsets([n for n, _, _ in rows]):
        a = np.array([rows[i][2]["dualpose offline 9D"][0].total_rmse_deg for i in idx])
        b = np.array([rows[i][2]["offline VQF 9D"][0].total_rmse_deg for i in idx])
        ai = np.mean([rows[i][2]["dualpose offline 6D"][0].inclination_rmse_deg for i in idx])
        bi = np.mean([rows[i][2]["offline VQF 6D"][0].inclination_rmse_deg for i in idx])
        wins = int((a < b).sum())
        ok = a.mean() <= 0.9 * b.mean() and wins >= 0.75 * len(idx)
        out.append(f"| {label} | {len(idx)} | {a.mean():.3f} | {b.mean():.3f} | {a.mean() / b.mean():.3f} | "
                   f"{wins} of {len(idx)} | {'PASS' if ok else 'FAIL'} | {ai:.3f} | {bi:.3f} |")
    from importlib.metadata import version

    out += ["", f"Machine: {platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}, "
            f"vqf {version('vqf')}."]  # fmt: skip
    return out


if __name__ == "__main__":
    sys.exit(main())
