"""What the rotation/translation weighting, the robust scales, the χ² gate and the pair selection of the hand–eye
calibration do to the reported loop residuals, on simulated recordings (``dualpose.sim.simulate_hand_eye``).

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/hand_eye_weighting.py [--seeds 1,2]``.  Table 1: on dualpose's pairs
at its ``τ``, ``X`` fitted (:func:`dualpose.calibration.fit_hand_eye`) with the weights ``σ_r, σ_t`` of each row,
residuals as ratios to the best of OpenCV's five closed forms on the same pairs (at dualpose's and the true ``τ``);
"truth" is the true ``X`` at the true ``τ`` (the noise floor).  Table 2: the whole calibration with other pair
selections and without the χ² gate, each against OpenCV's best on its own pairs.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from bench_hand_eye import OPENCV, opencv_x, score
from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream, fit_hand_eye, pair_motions
from dualpose.calibration.hand_eye_residual import squared_pair_residuals
from dualpose.sim import simulate_hand_eye

OFFSETS = {"arm": 0.02, "handheld": 3600.3, "sparse": 0.02}
CHI2_3_MEDIAN = 2.365974


def best_opencv(cam, body, pairs, taus):
    rows = [score(cam, body, pairs, tau, *opencv_x(cam, body, pairs, tau, flag))[:2] for tau in taus
            for flag in OPENCV.values()]  # fmt: skip
    return min(r[0] for r in rows), min(r[1] for r in rows)


def weighting_rows(kind: str, seed: int) -> list[str]:
    rec = simulate_hand_eye(kind, seed, OFFSETS[kind])
    cam, _ = clean_pose_stream(rec.camera_stamps, rec.camera_positions, rec.camera_quats, "camera")
    body, _ = clean_pose_stream(rec.body_stamps, rec.body_positions, rec.body_quats, "body")
    r = calibrate_hand_eye_streams(cam, body)
    tau, p = r.time_offset, r.pairs
    ref = best_opencv(cam, body, p, [tau, rec.time_offset])
    qa, ta, qb, tb, _ = pair_motions(cam, body, p[:, 0], p[:, 1], tau)
    th2, t2 = squared_pair_residuals(qa, ta, qb, tb, r.quat, r.translation)
    med = (np.sqrt(np.median(th2) / CHI2_3_MEDIAN), np.sqrt(np.median(t2) / CHI2_3_MEDIAN))
    rms = (r.sigma_rotation, r.sigma_translation)  # fmt: skip
    fits = {
        "median-based σ (before)": med,
        "RMS-based σ of the best closed form (now)": rms,
        "translation weight ×100": (rms[0], rms[1] / 10),
        "translation weight ×0.01": (rms[0], rms[1] * 10),
        "rotation only (translation weight ~0)": (rms[0], 1e3),
    }
    out = []
    for label, (sr, st) in fits.items():
        q, t = fit_hand_eye(qa, ta, qb, tb, r.quat, r.translation, sr, st)
        rot, tr, _ = score(cam, body, p, tau, q, t)
        out.append(f"| {kind} {seed} | {label} | {rot:.4f} / {tr:.3f} | {rot / ref[0]:.3f} | {tr / ref[1]:.3f} |")
    for label, tt, q, t in (
        ("dualpose result", tau, r.quat, r.translation),
        ("truth (noise floor)", rec.time_offset, rec.quat, rec.translation),
    ):
        rot, tr, _ = score(cam, body, p, tt, q, t)
        out.append(f"| {kind} {seed} | {label} | {rot:.4f} / {tr:.3f} | {rot / ref[0]:.3f} | {tr / ref[1]:.3f} |")
    return out


def selection_rows(kind: str, seed: int) -> list[str]:
    rec = simulate_hand_eye(kind, seed, OFFSETS[kind])
    cam, _ = clean_pose_stream(rec.camera_stamps, rec.camera_positions, rec.camera_quats, "camera")
    body, _ = clean_pose_stream(rec.body_stamps, rec.body_positions, rec.body_quats, "body")
    out = []
    for label, kw in (
        ("default (10°, 2 s, χ² gate)", {}),
        ("min pair angle 5°", {"min_pair_angle": np.deg2rad(5)}),
        ("min pair angle 20°", {"min_pair_angle": np.deg2rad(20)}),
        ("no χ² gate", {"gate": np.inf}),
    ):
        r = calibrate_hand_eye_streams(cam, body, **kw)
        ref = best_opencv(cam, body, r.pairs, [r.time_offset, rec.time_offset])
        rot, tr, n = score(cam, body, r.pairs, r.time_offset, r.quat, r.translation)
        out.append(f"| {kind} {seed} | {label} | {n} | {rot:.4f} / {tr:.3f} | {rot / ref[0]:.3f} | {tr / ref[1]:.3f} |")
    return out  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1,2")
    ap.add_argument("--kinds", default="arm,handheld,sparse")
    args = ap.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    kinds = args.kinds.split(",")
    print("| set | X fitted with | rot [deg] / trans [mm] | rot / best OpenCV | trans / best OpenCV |")
    print("|---|---|---|---|---|")
    for kind in kinds:
        for seed in seeds:
            print("\n".join(weighting_rows(kind, seed)), flush=True)
    print("\n| set | pairs | used | rot [deg] / trans [mm] | rot / best OpenCV | trans / best OpenCV |")
    print("|---|---|---|---|---|---|")
    for kind in kinds:
        for seed in seeds:
            print("\n".join(selection_rows(kind, seed)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
