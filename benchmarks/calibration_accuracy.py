"""Accuracy of the camera–IMU calibrations (docs/fusion.md, "Calibration") on the simulator, against its known truth.

Run ``.venv/bin/python benchmarks/calibration_accuracy.py [--runs 200] [--markdown PATH]``.

* Extrinsic rotation (Hol's static-pose method): 6 static poses of 0.5 s each in front of the two-plane scene
  (floor = level pattern), bias-free accelerometer (calibrated), one fixed geometry per extrinsic, ``--runs`` noise
  seeds: empirical per-axis std of the error vs the predicted σ (mean of the first-order covariances), the NEES
  (3 dof) and the fraction of runs within 3σ on every axis.  Also with an uncalibrated turn-on accelerometer bias
  (σ 0.05 m/s²), declared through ``accel_bias_covariance``.
* Scene gravity alignment: the eight's first 0.9 s at rest (12 frames), scene vertical misaligned by 1° and 5°;
  angular error of the gravity direction vs the predicted σ, and the ESKF position RMSE over the eight with the
  nominal vs the estimated gravity.
* Time offset: the eight with injected offsets ±5, ±15, ±30 ms; stage 1 (rate matching: without the extrinsic =
  registration mode; with it, unweighted (the default; σ from the PnP + gyro covariances) and weighted by those
  covariances) and stage 2 (filter NIS search from the default stage 1).
* Full chain: ``dualpose calibrate`` (each stage on the previous stages' estimates, uncalibrated accelerometer
  bias), 5° scene tilt, −20 ms offset.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

import dualpose as dp
from dualpose import calibration as cal
from dualpose import sim
from dualpose.estimation import eskf, initialization
from dualpose.pipelines.calibrate import calibrate_run_time_offset
from dualpose.sim.calibration_scenarios import random_extrinsic, simulate_static_poses
from dualpose.types import ImuNoise

MOVING = (1.0, 6.4)
BIAS_FREE = ImuNoise(accelerometer_initial_bias_sigma=0.0, accelerometer_random_walk=0.0)


def extrinsic_rows(runs: int) -> list[str]:
    rows = []
    cases = [
        ("default", sim.default_extrinsic(), BIAS_FREE, False),
        ("random (seed 5)", random_extrinsic(5), BIAS_FREE, False),
        ("default, accel bias 0.05 m/s²", sim.default_extrinsic(), ImuNoise(), True),
    ]
    for name, ext, noise, with_bias in cases:
        t0 = time.perf_counter()
        errs, covs = [], []
        bias_cov = np.eye(3) * noise.accelerometer_initial_bias_sigma**2 if with_bias else None
        for seed in range(runs):
            poses = simulate_static_poses(6, seed, extrinsic=ext, duration=0.5, pose_seed=0, imu_noise=noise)
            st = cal.stack_static_periods([cal.static_period_from_run(r) for r in poses])
            res = cal.camera_imu_rotation(**st, accel_bias_covariance=bias_cov)
            errs.append(dp.rotvec_from_quat(dp.quat_mul(res.q_bc, dp.quat_conj(ext[0]))))
            covs.append(res.covariance)
        errs, covs = np.array(errs), np.array(covs)
        emp = np.degrees(errs.std(axis=0, ddof=1))
        pred = np.degrees(np.sqrt(np.diag(covs.mean(axis=0))))
        nees = float(np.einsum("ni,nij,nj->n", errs, np.linalg.inv(covs), errs).mean())
        inside = float(np.mean(np.all(np.abs(errs) <= 3 * np.sqrt(np.diagonal(covs, axis1=1, axis2=2)), axis=1)))
        rms = math.degrees(math.sqrt(np.mean(np.sum(errs**2, axis=1))))
        per_run = (time.perf_counter() - t0) / runs * 1e3
        fmt = "/".join(f"{v:.3f}" for v in emp)
        fmp = "/".join(f"{v:.3f}" for v in pred)
        ratio = "/".join(f"{v:.2f}" for v in emp / pred)
        rows.append(f"| {name} | {fmt} | {fmp} | {ratio} | {rms:.3f} | {nees:.2f} | {inside:.0%} | {per_run:.0f} |")
    return rows


def _eskf_position_rmse(run: sim.SimulatedRun, gravity: np.ndarray) -> float:
    x, P = initialization.initial_state_from_run(run)
    f = eskf.ErrorStateEKF.from_state(run, x, P, gravity=gravity)
    res = f.run_recording(run)
    m = (run.t >= MOVING[0]) & (run.t <= MOVING[1])
    return float(np.sqrt(np.mean(np.sum((res.position - run.truth["position"])[m] ** 2, axis=1))))


def gravity_rows(runs: int) -> list[str]:
    rows = []
    for mis in (1.0, 5.0):
        for label, noise in (("calibrated (bias-free)", BIAS_FREE), ("turn-on bias σ 0.05 m/s²", ImuNoise())):
            errs, sig, tilt, rm_nom, rm_est = [], [], [], [], []
            bias_cov = np.eye(3) * noise.accelerometer_initial_bias_sigma**2
            for seed in range(runs):
                run = sim.simulate_eight(seed=seed, gravity_misalignment_deg=mis, imu_noise=noise)
                rest = cal.static_period_from_run(run, 0.0, 0.9)
                g = cal.scene_gravity(
                    rest.specific_force, rest.q_wc, run.q_bc, rest.specific_force_covariance,
                    rest.attitude_covariance, accel_bias_covariance=bias_cov, magnitude=9.81,
                )  # fmt: skip
                true_dir = run.gravity / np.linalg.norm(run.gravity)
                err = math.degrees(math.atan2(np.linalg.norm(np.cross(g.direction, true_dir)), g.direction @ true_dir))
                errs.append(err)
                sig.append(g.sigma_deg)
                tilt.append(g.tilt_deg)
                if seed < 10:
                    rm_nom.append(_eskf_position_rmse(run, np.array([0.0, 0.0, -9.81])))
                    rm_est.append(_eskf_position_rmse(run, g.gravity))
            errs = np.array(errs)
            rows.append(
                f"| {mis:.0f}° | {label} | {np.mean(tilt):.3f} | {math.sqrt(np.mean(errs**2)):.3f} | "
                f"{errs.max():.3f} | {np.mean(sig):.3f} | {np.mean(errs <= 3 * np.array(sig)):.0%} | "
                f"{1e3 * np.mean(rm_nom):.1f} → {1e3 * np.mean(rm_est):.1f} |"
            )
    return rows


def time_offset_rows(runs_per_offset: int) -> list[str]:
    rows = []
    all_first, all_second = [], []
    for j, off in enumerate((-0.030, -0.015, -0.005, 0.005, 0.015, 0.030)):
        e1, s1, e0, eu, e2, wall = [], [], [], [], [], []
        for i in range(runs_per_offset):
            run = sim.simulate_eight(seed=100 + 10 * j + i, time_offset=off)
            t0 = time.perf_counter()
            first, second = calibrate_run_time_offset(run, run.q_bc)
            wall.append(time.perf_counter() - t0)
            blind, _ = calibrate_run_time_offset(run, None, refine=False)
            weighted, _ = calibrate_run_time_offset(run, run.q_bc, refine=False, weighted=True)
            e1.append(first.offset - off)
            s1.append(first.sigma)
            e0.append(blind.offset - off)
            eu.append(weighted.offset - off)
            e2.append(second.offset - off)
        e1, e0, eu, e2 = (1e3 * np.array(v) for v in (e1, e0, eu, e2))
        all_first.extend(e1)
        all_second.extend(e2)
        rows.append(
            f"| {1e3 * off:+.0f} | {np.sqrt(np.mean(e0**2)):.2f} | {np.sqrt(np.mean(e1**2)):.2f} "
            f"({np.abs(e1).max():.2f}) | {1e3 * np.mean(s1):.2f} | {np.sqrt(np.mean(eu**2)):.2f} | "
            f"{np.mean(e2):+.2f} | {np.sqrt(np.mean(e2**2)):.2f} ({np.abs(e2).max():.2f}) | {np.mean(wall):.2f} |"
        )
    a1, a2 = np.array(all_first), np.array(all_second)
    rows.append(
        f"| all | | {np.sqrt(np.mean(a1**2)):.2f} ({np.abs(a1).max():.2f}) | | | {np.mean(a2):+.2f} | "
        f"{np.sqrt(np.mean(a2**2)):.2f} ({np.abs(a2).max():.2f}) | |"
    )
    return rows


def chain_rows(seeds: int) -> list[str]:
    from dualpose.pipelines.calibrate import calibrate_simulated_session

    ms = [calibrate_simulated_session(seed=s, gravity_misalignment_deg=5.0, time_offset_ms=-20.0) for s in range(seeds)]

    def rms(key: str) -> float:
        return math.sqrt(np.mean([m[key] ** 2 for m in ms]))

    def mean(key: str) -> float:
        return float(np.mean([m[key] for m in ms]))

    return [
        f"| camera-IMU rotation error [deg] | {rms('extrinsic_error_deg'):.3f} | "
        f"{max(m['extrinsic_error_deg'] for m in ms):.3f} | {mean('extrinsic_sigma_deg'):.3f} |",
        f"| gravity direction error [deg] | {rms('gravity_error_deg'):.3f} | "
        f"{max(m['gravity_error_deg'] for m in ms):.3f} | {mean('gravity_sigma_deg'):.3f} |",
        f"| time offset after the filter [ms] | {rms('time_offset_error_ms'):.2f} | "
        f"{max(abs(m['time_offset_error_ms']) for m in ms):.2f} | |",
    ]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=200, help="Monte-Carlo runs for the extrinsic rotation")
    ap.add_argument("--gravity-runs", type=int, default=30)
    ap.add_argument("--offset-runs", type=int, default=5, help="runs per injected time offset")
    ap.add_argument("--chain-runs", type=int, default=10, help="seeds of the full dualpose-calibrate chain")
    ap.add_argument("--markdown", help="also write the tables to this file (refuses to overwrite without --force)")
    ap.add_argument("--force", action="store_true")
    args = ap.parse_args(argv)
    out = [
        "### Camera–IMU rotation (6 static poses × 0.5 s, one geometry, "
        f"{args.runs} noise seeds)",
        "",
        "| case | empirical std x/y/z [deg] | predicted σ x/y/z [deg] | ratio | RMS error [deg] | NEES (3) | "
        "within 3σ | ms/run |",
        "|---|---|---|---|---:|---:|---:|---:|",
        *extrinsic_rows(args.runs),
        "",
        f"### Scene gravity alignment (eight's 0.9 s rest, {args.gravity_runs} seeds)",
        "",
        "| misalignment | accelerometer | estimated tilt (mean) [deg] | RMS error [deg] | max [deg] | predicted σ "
        "[deg] | within 3σ | ESKF position RMSE nominal → estimated g [mm] |",
        "|---|---|---:|---:|---:|---:|---:|---|",
        *gravity_rows(args.gravity_runs),
        "",
        f"### Time offset (eight, {args.offset_runs} seeds per offset; errors in ms)",
        "",
        "| injected [ms] | stage 1 without extrinsic RMS | stage 1 RMS (max) | stage 1 predicted σ | "
        "stage 1 weighted RMS | filter mean error | filter RMS (max) | s/run |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
        *time_offset_rows(args.offset_runs),
        "",
        "### Full chain (`dualpose calibrate --gravity-misalignment 5 --time-offset -20`, "
        f"seeds 0–{args.chain_runs - 1})",
        "",
        "| quantity | RMS error | max | mean predicted σ |",
        "|---|---:|---:|---:|",
        *chain_rows(args.chain_runs),
    ]
    text = "\n".join(out)
    print(text)
    if args.markdown:
        if os.path.exists(args.markdown) and not args.force:
            print(f"error: {args.markdown} exists (use --force)", file=sys.stderr)
            return 1
        with open(args.markdown, "w", encoding="utf-8") as fh:
            fh.write(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
