"""Diagnostic: where in a BROAD trial does dualpose's 6D inclination lose to VQF's?  (Uses the optical reference: a
diagnostic, not a method; docs/broad.md, "Twelve trials", (e).)

Run ``.venv/bin/python benchmarks/diag_broad_blocks.py [TRIAL ...] [--block S] [--config KEY=VALUE ...]`` (default:
trials 33 and 15, 2 s blocks; needs the ``bench`` extra for ``vqf``).  Per trial: the real-time 6D filter
(:func:`dualpose.estimation.ahrs.estimate_orientation` with ``use_mag=False``, its defaults unless ``--config``
overrides an :class:`~dualpose.estimation.ahrs.AhrsConfig` field, e.g. ``acc_adapt_matrix=False``) and VQF 2.x's
6D output (``vqf.VQF(Ts).updateBatch``, defaults), the inclination error per movement sample against the reference
(``bench_broad.py``'s metric), and per block of movement samples: its RMS for both, the block's contribution to
the difference of the two mean squares over the trial, MS(dualpose) − MS(VQF) in deg² (positive: dualpose loses
there; the contributions add up to the difference), the mean rate ``|ω − b̂|`` and the mean ``| |a| − g |``.  Last
line: the difference and the contribution of the first 6 s of movement.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation
from dualpose.evaluation.orientation_errors import earth_error_quat, heading_inclination_errors
from dualpose.io import load_broad

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"


def _inclination_deg(q: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return np.degrees(heading_inclination_errors(earth_error_quat(q, ref))[2])


def _config(items: list[str]) -> AhrsConfig:
    kw: dict[str, object] = {}
    for item in items:
        key, value = item.split("=", 1)
        kw[key] = {"true": True, "false": False}.get(value.lower(), None)
        if kw[key] is None:
            kw[key] = float(value)
    return AhrsConfig(**kw)  # type: ignore[arg-type]


def main() -> int:
    import vqf

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trials", nargs="*", default=["33", "15"], help="trial numbers (file name prefixes)")
    ap.add_argument("--block", type=float, default=2.0, help="block length, s of movement samples")
    ap.add_argument("--config", nargs="*", default=[], help="AhrsConfig overrides, KEY=VALUE")
    args = ap.parse_args()
    config = _config(args.config)
    for key in args.trials:
        path = next(iter(sorted(DATA.glob(f"{key}*.mat"))), None)
        if path is None:
            print(f"no BROAD trial {key} in {DATA}")
            continue
        t = load_broad(path)
        r = estimate_orientation(t.gyr, t.acc, None, t.rate, use_mag=False, n_rest=t.static_start, config=config)
        v6 = vqf.VQF(1.0 / t.rate).updateBatch(*(np.ascontiguousarray(a) for a in (t.gyr, t.acc, t.mag)))["quat6D"]
        ok = t.movement & np.all(np.isfinite(t.quat), axis=1)
        idx = np.flatnonzero(ok)
        d, v = _inclination_deg(r.quat[ok], t.quat[ok]), _inclination_deg(v6[ok][:, [1, 2, 3, 0]], t.quat[ok])
        rate = np.degrees(np.linalg.norm(t.gyr - r.gyroscope_bias, axis=1))
        dev = np.abs(np.linalg.norm(t.acc, axis=1) - np.median(np.linalg.norm(t.acc[: t.static_start], axis=1)))
        rms_d, rms_v = np.sqrt(np.mean(d**2)), np.sqrt(np.mean(v**2))
        print(f"\n{t.name}: inclination RMSE dualpose {rms_d:.3f}°, VQF {rms_v:.3f}°\n")
        print("| t (s) | dualpose (°) | VQF (°) | contribution (deg²) | mean abs(ω) (°/s) | mean abs(abs(a) − g) "
              "(m/s²) |")  # fmt: skip
        print("|---:|---:|---:|---:|---:|---:|")
        n = max(1, int(round(args.block * t.rate)))
        for s in range(0, len(idx), n):
            sl = slice(s, s + n)
            rows = idx[sl]
            part = (np.sum(d[sl] ** 2) - np.sum(v[sl] ** 2)) / len(idx)
            print(f"| {rows[0] / t.rate:.1f} | {np.sqrt(np.mean(d[sl] ** 2)):.2f} | "
                  f"{np.sqrt(np.mean(v[sl] ** 2)):.2f} | {part:+.4f} | {rate[rows].mean():.0f} | "
                  f"{dev[rows].mean():.2f} |")  # fmt: skip
        first = idx < idx[0] + int(6.0 * t.rate)
        part = (np.sum(d[first] ** 2) - np.sum(v[first] ** 2)) / len(idx)
        print(f"\nMS(dualpose) − MS(VQF) {rms_d**2 - rms_v**2:+.4f} deg², of which the first 6 s of movement "
              f"{part:+.4f}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
