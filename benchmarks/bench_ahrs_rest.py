"""The AHRS's rest detector and gyroscope-bias update on slow rotations with three 10 s breaks, next to VQF.

Run ``.venv/bin/python benchmarks/bench_ahrs_rest.py`` (docs/broad.md, "Rest detector and bias update").

Data: :func:`dualpose.sim.rest_breaks.rest_break_recording` (100 Hz, 5 s rest, four 25 s segments of slow rotation
up to ~17 °/s separated by three 10 s breaks; per-sample noise 0.003 rad/s, 0.03 m/s², 0.4 µT; a gyroscope bias
that drifts by 0.3 °/s over the recording plus a random walk of 1e-4 rad/s²/√Hz), seeds 0–9.  Per seed and mode
(9D, 6D): dualpose with the rest detector (default) and without (``AhrsConfig(rest_window=0)``), and VQF 2.x
real-time (``vqf.VQF(1/rate).updateBatch``, defaults) on the same samples, scored over every sample after the
initial rest (segments and breaks; 6D after one fitted heading offset, as in ``bench_broad.py``).

Bias: per-axis RMS over seeds and axes of the bias error at the last sample of each break, against the posterior
standard deviation the samples allow: a bias random walk of density σ_w measured through white noise of density
σ_d = σ_g/√rate for T seconds of quiet samples has the Kalman–Bucy posterior variance σ_w σ_d coth(T σ_w / σ_d)
(from an uninformative prior), which is σ_d²/T = σ_g²/N (N samples) when σ_w → 0.  The second table repeats the
recording without the random walk and without the drift (constant bias: the σ_g/√N case); the third one with the
random walk, no drift and breaks that are not perfectly still (``creep`` = 0.02 °/s about a random axis per break, the
level measured in BROAD's breaks); the fourth adds a bias that differs by 0.03 °/s between motion and rest
(``motion_bias``).  "rest_bias_sigma=0" is the rest update without the spell-common offset (before).
"""

from __future__ import annotations

import math

import numpy as np
import vqf

from dualpose.estimation.ahrs import AhrsConfig, estimate_orientation
from dualpose.evaluation.orientation_errors import orientation_rmse
from dualpose.sim.rest_breaks import rest_break_recording

SEEDS = range(10)
ON, WHITE, OFF = AhrsConfig(), AhrsConfig(rest_bias_sigma=0.0), AhrsConfig(rest_window=0.0)


def _score(quat: np.ndarray, rec, use_mag: bool) -> tuple[float, float, float]:
    s = orientation_rmse(quat, rec.quat, rec.scored, fit_heading_offset=not use_mag)
    return s.total_rmse_deg, s.heading_rmse_deg, s.inclination_rmse_deg


def _bias_errors(bias: np.ndarray, rec) -> np.ndarray:
    """(n_breaks, 3) bias error at each break's last sample, °/s."""
    ends = rec.breaks[:, 1] - 1
    return np.degrees(bias[ends] - rec.bias[ends])


def _posterior_sigma(rec, walk: float, seconds: float) -> float:
    """°/s per axis: σ_w σ_d coth(T σ_w/σ_d), or σ_d²/T without the walk (module docstring)."""
    sd = rec.gyr_sigma / math.sqrt(rec.rate)
    var = sd * sd / seconds if walk == 0.0 else walk * sd / math.tanh(seconds * walk / sd)
    return math.degrees(math.sqrt(var))


def run(walk: float, drift: float, creep: float = 0.0, motion_bias: float = 0.0) -> dict:
    rows: dict[str, list] = {}
    bias: dict[str, list] = {}
    rest_samples = []
    for seed in SEEDS:
        rec = rest_break_recording(seed, bias_walk=walk, drift=drift, creep=creep, motion_bias=motion_bias)
        for use_mag in (True, False):
            mode = "9D" if use_mag else "6D"
            for name, cfg in (("with rest update", ON), ("rest update, rest_bias_sigma=0", WHITE), ("without", OFF)):
                r = estimate_orientation(rec.gyr, rec.acc, rec.mag if use_mag else None, rec.rate, use_mag=use_mag,
                                         n_rest=rec.n_rest, config=cfg)  # fmt: skip
                rows.setdefault(f"dualpose {mode}, {name}", []).append(_score(r.quat, rec, use_mag))
                bias.setdefault(f"dualpose {mode}, {name}", []).append(_bias_errors(r.gyroscope_bias, rec))
                if use_mag and cfg is ON:
                    rest_samples.append(r.rest_samples)
        out = vqf.VQF(1.0 / rec.rate).updateBatch(rec.gyr, rec.acc, rec.mag)
        for mode, key in (("9D", "quat9D"), ("6D", "quat6D")):
            rows.setdefault(f"VQF {mode}", []).append(_score(out[key][:, [1, 2, 3, 0]], rec, mode == "9D"))
        bias.setdefault("VQF", []).append(_bias_errors(out["bias"], rec))
    pause = (rec.breaks[0, 1] - rec.breaks[0, 0]) / rec.rate
    return dict(rows=rows, bias=bias, rest_samples=rest_samples, rec=rec, pause=pause, walk=walk)


def print_orientation(res: dict, title: str) -> None:
    print(f"{title}: orientation RMSE (°), mean over seeds 0–9, every sample after the initial rest (6D: one fitted "
          "heading offset):\n")  # fmt: skip
    print("| method | total | heading | inclination |")
    print("|---|---:|---:|---:|")
    for name, v in res["rows"].items():
        m = np.mean(np.array(v), axis=0)
        print(f"| {name} | {m[0]:.3f} | {m[1]:.3f} | {m[2]:.3f} |")
    rs = res["rest_samples"]
    print(f"\nSamples flagged at rest (9D, per recording): {min(rs)}–{max(rs)} of 3 × {int(res['pause'] * 100)} break "
          "samples.\n")  # fmt: skip


def print_bias(res: dict, title: str) -> None:
    rec, pause = res["rec"], res["pause"]
    sigma = _posterior_sigma(rec, res["walk"], pause)
    print(f"{title}: per-axis RMS over seeds and axes of the bias error at the end of each break (°/s); the level the "
          f"noise allows for {pause:.0f} s of quiet samples: {sigma:.4f} °/s\n")  # fmt: skip
    print("| method | break 1 | break 2 | break 3 |")
    print("|---|---:|---:|---:|")
    for name, v in res["bias"].items():
        if "without" in name and "6D" in name:
            continue
        e = np.array(v)  # (seeds, breaks, 3)
        rms = np.sqrt(np.mean(e**2, axis=(0, 2)))
        print(f"| {name} | " + " | ".join(f"{x:.4f}" for x in rms) + " |")
    print()


def main() -> int:
    res = run(walk=1.0e-4, drift=math.radians(0.3))
    title = "Bias drifting (0.3 °/s drift + random walk 1e-4 rad/s²/√Hz)"
    print_orientation(res, title)
    print_bias(res, title)
    res = run(walk=0.0, drift=0.0)
    print_orientation(res, "Bias constant")
    print_bias(res, "Bias constant")
    res = run(walk=1.0e-4, drift=0.0, creep=math.radians(0.02))
    title = "Breaks creeping at 0.02 °/s (random walk 1e-4 rad/s²/√Hz, no drift)"
    print_orientation(res, title)
    print_bias(res, title)
    res = run(walk=1.0e-4, drift=0.0, creep=math.radians(0.02), motion_bias=math.radians(0.03))
    title = "Breaks creeping at 0.02 °/s and a bias 0.03 °/s different in motion (random walk, no drift)"
    print_orientation(res, title)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
