"""Error-state filter vs the offline RTS smoother on the simulated eight-shaped run.

Method and results: docs/fusion.md, "Offline smoothing (RTS)".

Run ``.venv/bin/python benchmarks/smoother_accuracy.py [--seeds 10] [--nees-runs 25] [--markdown PATH]``.

For each seed this is ``dualpose fuse --smooth --seed S`` (:func:`dualpose.pipelines.fuse.run_fuse`): the ESKF starts
without truth (static alignment + first-frame PnP), the smoother runs over its recorded nodes; metrics over the
whole 6.9 s run: ATE after SE(3) alignment, orientation RMSE after that alignment, and position / orientation RMSE
in the simulator's frame without alignment.  NEES: Monte-Carlo runs started from the prior around the truth, the
run-averaged 15-dim NEES of filter and smoother averaged over time, against the two-sided 95 % band.  Dropout: the
same start with a 2 s vision dropout (t ∈ [3, 5) s) and 10 % gross outlier correspondences, errors in the
simulator's frame over the 5.4 s eight (t ∈ [1.0, 6.4] s), as in ``benchmarks/fusion_accuracy.py``.
"""

from __future__ import annotations

import argparse

import numpy as np

import dualpose as dp
from _common import emit
from dualpose import sim
from dualpose.estimation import consistency, eskf, initialization, smoother
from dualpose.pipelines.fuse import run_fuse

ROWS = (
    ("ATE RMSE, SE(3) [mm]", "ate_rmse_m", 1e3),
    ("orientation RMSE, SE(3)-aligned [deg]", "orientation_rmse_deg", 1.0),
    ("position RMSE, unaligned [mm]", "position_rmse_unaligned_m", 1e3),
    ("orientation RMSE, unaligned [deg]", "orientation_rmse_unaligned_deg", 1.0),
    ("RPE RMSE, 0.5 m [mm]", "rpe_rmse_m", 1e3),
)


def nees_mc(n_runs: int) -> tuple[float, float, float, float]:
    """Time-averaged Monte-Carlo NEES of filter and smoother and the band (seeds as benchmarks/fusion_accuracy.py)."""
    traj = sim.eight_motion()
    tot_f = tot_s = 0.0
    for s in range(n_runs):
        run = sim.simulate(traj, seed=5000 + s)
        res = consistency.filter_from_prior(run, np.random.default_rng([s, 7])).run_recording(run, record_nodes=True)
        tot_f = tot_f + consistency.nees_against_truth(run.truth, res)
        tot_s = tot_s + consistency.nees_against_truth(run.truth, smoother.rts_smooth(res))
    lo, hi = consistency.nees_band(15, n_runs)
    return float((tot_f / n_runs).mean()), float((tot_s / n_runs).mean()), lo, hi


def dropout_errors(seed: int) -> np.ndarray:
    """(2, 3): position RMSE (m), orientation RMSE (deg), max position error (m) of filter and smoother over the
    eight with a 2 s vision dropout and 10 % outliers."""
    run = sim.simulate_eight(seed, outlier_fraction=0.1, dropouts=((3.0, 5.0),))
    x, P0 = initialization.initial_state_from_run(run)
    f = eskf.ErrorStateEKF.from_state(run, x, P0)
    res = f.run_recording(run, record_nodes=True)
    sm = smoother.rts_smooth(res)
    m = (run.t >= 1.0) & (run.t <= 6.4)
    out = []
    for est in (res, sm):
        e = np.linalg.norm(est.position - run.truth["position"], axis=1)[m]
        a = np.degrees(dp.quat_angle(est.quat, run.truth["quat"]))[m]
        out.append([np.sqrt(np.mean(e**2)), np.sqrt(np.mean(a**2)), e.max()])
    return np.array(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--nees-runs", type=int, default=25)
    ap.add_argument("--markdown")
    args = ap.parse_args()
    filt: dict[str, list[float]] = {key: [] for _, key, _ in ROWS}
    smooth: dict[str, list[float]] = {key: [] for _, key, _ in ROWS}
    wall = []
    for s in range(args.seeds):
        m = run_fuse("sim", "eskf", seed=s, smooth=True).metrics
        for _, key, _ in ROWS:
            filt[key].append(m[key])
            smooth[key].append(m["smoothed"][key])
        wall.append(m["smoothed"]["smoother_wall_time_s"])
    lines = [
        f"Eight-shaped run, {args.seeds} seeds (`dualpose fuse --smooth --seed S`), mean over seeds (worst seed in "
        "brackets):",
        "",
        "| metric | ESKF (filter) | ESKF + RTS smoother | smoother / filter |",
        "|---|---:|---:|---:|",
    ]
    for label, key, scale in ROWS:
        f, sm = scale * np.array(filt[key]), scale * np.array(smooth[key])
        lines.append(f"| {label} | {f.mean():.3f} ({f.max():.3f}) | {sm.mean():.3f} ({sm.max():.3f}) | "
                     f"{sm.mean() / f.mean():.2f} |")  # fmt: skip
    drop = np.array([dropout_errors(s) for s in range(args.seeds)])  # (seeds, 2, 3)
    lines += [
        "",
        f"2 s vision dropout + 10 % outliers, {args.seeds} seeds, over the 5.4 s eight, unaligned, mean (worst seed):",
        "",
        "| | position RMSE [mm] | orientation RMSE [deg] | max position error [mm] |",
        "|---|---:|---:|---:|",
    ]
    for k, name in enumerate(("ESKF (filter)", "ESKF + RTS smoother")):
        v = drop[:, k]
        lines.append(f"| {name} | {1e3 * v[:, 0].mean():.1f} ({1e3 * v[:, 0].max():.1f}) | {v[:, 1].mean():.3f} "
                     f"({v[:, 1].max():.3f}) | {1e3 * v[:, 2].mean():.1f} ({1e3 * v[:, 2].max():.1f}) |")  # fmt: skip
    nf, ns, lo, hi = nees_mc(args.nees_runs)
    lines += [
        "",
        f"NEES (15-dim, {args.nees_runs} runs, time-averaged): filter {nf:.2f}, smoother {ns:.2f}, 95 % band "
        f"[{lo:.2f}, {hi:.2f}].  Backward pass: median {1e3 * np.median(wall):.1f} ms per run (6.9 s of data).",
    ]
    text = "\n".join(lines)
    return emit(text, args.markdown)


if __name__ == "__main__":
    raise SystemExit(main())
