"""Accuracy of the camera-IMU filters on the simulated eight-shaped run (Hol 2008), with the baselines Hol compared.

Run ``.venv/bin/python benchmarks/fusion_accuracy.py [--seeds 10] [--markdown PATH]``.

Errors are plain RMSE against the simulator's ground truth in the simulator's own earth frame (no alignment is
needed or applied), over the 5.4 s eight (t ∈ [1.0, 6.4] s; the run rests 1 s before and 0.5 s after).  Filters
start WITHOUT truth: static accelerometer alignment over the first 0.9 s (gyro bias) + PnP of the first frame (pose),
zero velocity.  Rows:

* ESKF / Hol22: the two filters, default noise (1 px, Xsens-MTx-like IMU, 20 correspondences per frame).
* vision-only PnP: DLT + Gauss–Newton per frame (Hol's vision-only comparison), errors at the frame times.
* IMU-only: the ESKF with no camera, from the same start — the drift.
* ESKF dropout+outliers: a 2 s vision dropout (t ∈ [3, 5) s) and 10 % gross outlier correspondences.
* ESKF 1° gravity: the scene's vertical misaligned by 1° (the filter assumes the nominal gravity).
* NEES: 25 Monte-Carlo runs, start drawn from the prior around the truth, average 15-dim NEES vs its 95 % band.
"""

from __future__ import annotations

import argparse

import numpy as np

import dualpose as dp
from _common import emit
from dualpose import sim
from dualpose.estimation import consistency, eskf, hol22, initialization
from dualpose.registration import pnp

MOVING = (1.0, 6.4)


def errors(t: np.ndarray, pos: np.ndarray, quat: np.ndarray, truth_pos: np.ndarray, truth_q: np.ndarray):
    m = (t >= MOVING[0]) & (t <= MOVING[1])
    e = np.linalg.norm(pos - truth_pos, axis=1)[m]
    a = np.degrees(dp.quat_angle(quat, truth_q))[m]
    return float(np.sqrt(np.mean(e**2))), float(np.sqrt(np.mean(a**2))), float(e.max())


def eskf_errors(run: sim.SimulatedRun, frames: bool = True):
    x, P0 = initialization.initial_state_from_run(run)
    f = eskf.ErrorStateEKF.from_state(run, x, P0)
    if frames:
        res = f.run_recording(run)
    else:
        res = f.run(run.t, run.gyro, run.accel, np.zeros(0), np.zeros(1, np.int64), np.zeros((0, 2)), np.zeros((0, 3)))
    return errors(run.t, res.position, res.quat, run.truth["position"], run.truth["quat"]), res


def hol_errors(run: sim.SimulatedRun):
    x, P0 = initialization.initial_state_from_run(run)
    res = hol22.Hol22EKF.from_eskf_state(x, P0, run).run_recording(run)
    return errors(run.t, res.position, res.quat, run.truth["position"], run.truth["quat"])


def pnp_errors(run: sim.SimulatedRun):
    f = run.frames
    P, Q = [], []
    for k in range(len(f)):
        pix, pts = f.frame(k)
        p_wb, q_wb, _ = initialization.body_pose_from_camera(
            pnp.solve_pnp(pix, pts, run.camera.matrix), run.q_bc, run.p_bc
        )
        P.append(p_wb)
        Q.append(q_wb)
    kin = run.motion.kinematics(f.t_true)
    return errors(f.t_true, np.array(P), np.array(Q), kin["position"], kin["quat"])


def nees_mc(n_runs: int = 25) -> tuple[float, float, float, float]:
    traj = sim.eight_motion()
    total = 0.0
    for s in range(n_runs):
        run = sim.simulate(traj, seed=5000 + s)
        res = consistency.filter_from_prior(run, np.random.default_rng([s, 7])).run_recording(run)
        total = total + consistency.nees_against_truth(run.truth, res)
    avg = total / n_runs
    lo, hi = consistency.nees_band(15, n_runs)
    return float(avg.mean()), lo, hi, float(np.mean((avg >= lo) & (avg <= hi)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--markdown")
    args = ap.parse_args()
    seeds = range(args.seeds)
    names = ("ESKF", "Hol22", "vision-only PnP", "IMU-only (ESKF, no camera)", "ESKF 2 s dropout + 10 % outliers",
             "ESKF 1° gravity misalignment")  # fmt: skip
    table: dict[str, list] = {k: [] for k in names}
    rtf = []
    for s in seeds:
        run = sim.simulate_eight(s)
        err, res = eskf_errors(run)
        table["ESKF"].append(err)
        rtf.append((run.t[-1] - run.t[0]) / res.wall_time)
        table["Hol22"].append(hol_errors(run))
        table["vision-only PnP"].append(pnp_errors(run))
        table["IMU-only (ESKF, no camera)"].append(eskf_errors(run, frames=False)[0])
        table["ESKF 2 s dropout + 10 % outliers"].append(
            eskf_errors(sim.simulate_eight(s, outlier_fraction=0.1, dropouts=((3.0, 5.0),)))[0]
        )
        table["ESKF 1° gravity misalignment"].append(
            eskf_errors(sim.simulate_eight(s, gravity_misalignment_deg=1.0))[0]
        )
    lines = [
        f"Eight-shaped run, {args.seeds} seeds, RMSE over the 5.4 s eight (mean over seeds; worst seed in brackets).",
        "",
        "| method | position RMSE [mm] | orientation RMSE [deg] | max position error [mm] |",
        "|---|---:|---:|---:|",
    ]
    for name, vals in table.items():
        v = np.array(vals)
        lines.append(
            f"| {name} | {1e3 * v[:, 0].mean():.1f} ({1e3 * v[:, 0].max():.1f}) | {v[:, 1].mean():.3f} "
            f"({v[:, 1].max():.3f}) | {1e3 * v[:, 2].mean():.1f} ({1e3 * v[:, 2].max():.1f}) |"
        )
    mean_nees, lo, hi, inside = nees_mc()
    lines += [
        "",
        f"ESKF real-time factor (batch run, this machine): median {np.median(rtf):.0f}x.",
        f"NEES (15-dim error state, 25 runs): time-average {mean_nees:.2f}, 95 % band [{lo:.2f}, {hi:.2f}], "
        f"fraction of time steps inside {inside:.3f}.",
    ]
    text = "\n".join(lines)
    return emit(text, args.markdown)


if __name__ == "__main__":
    raise SystemExit(main())
