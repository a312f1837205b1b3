"""Diagnostic: how well the data determine an alignment, and how credible a hand–eye match is (docs/refusals.md).

Run ``.venv/bin/python benchmarks/diag_degenerate.py [--data ../shared/data/handeye] [--kinds arm,handheld,sparse]``.
(1) Alignments of the kinds docs/refusals.md lists (seeded): a reference standing still with 0.1 mm jitter against
an estimate moving ~0.5 m, and 3 / 11 / 100 poses of a 10 m path bending by 1 cm with 2 cm noise, each with its
rotation standard deviation from :func:`dualpose.evaluation.align.alignment_conditioning` (``undetermined="warn"``
so the number is printed).  (2) Hand–eye matches of the two shared recordings, the two cross pairs of them (camera
of one, body of the other: different motions), and the simulated kinds of ``bench_hand_eye_kinds.py`` (seeds 1–3):
rotation loop residual, the residual the streams' own noise predicts, their ratio, the coarse rate correlation and
the verdict.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream
from dualpose.evaluation.align import align_positions
from dualpose.io.pose_csv import read_pose_csv
from dualpose.sim.hand_eye_recordings import simulate_hand_eye

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "handeye"
FILES = {
    "prime_sense_1": ("prime_sense_1_camera_in_target.csv", "prime_sense_1_marker_in_vicon.csv"),
    "robot_arm_real": ("robot_arm_real_camera_in_target.csv", "robot_arm_real_hand_in_base.csv"),
}
OFFSETS = {"arm": 0.02, "handheld": 3600.3, "sparse": 0.02}  # as bench_hand_eye_kinds.py


def alignment_rows() -> list[str]:
    rng = np.random.default_rng(0)
    n = 500
    still = np.array([1.0, 2.0, 3.0]) + rng.normal(0.0, 1e-4, (n, 3))
    s = np.linspace(0.0, 10.0, n)
    moving = 0.5 * np.column_stack([np.cos(s), np.sin(s), 0.1 * s]) + rng.normal(0.0, 0.02, (n, 3))
    cases = [("still reference (0.1 mm jitter), 500 poses", still, moving)]
    for k in (3, 11, 100):
        t = np.linspace(0.0, 10.0, k)
        truth = np.column_stack([t, 0.01 * np.sin(t), 0.0 * t])
        cases.append((f"{k} poses of a nearly straight path", truth, truth + rng.normal(0.0, 0.02, (k, 3))))
    rows = ["| case | se3 | sim3 | scale | posyaw |", "|---|---|---|---|---|"]
    for name, ref, est in cases:
        cells = []
        for method in ("se3", "sim3", "scale", "posyaw"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                c = align_positions(ref, est, method, undetermined="warn").conditioning
            verdict = "refused" if "not determined" in c.reason else ("warned" if c.reason else "kept")
            cells.append(f"{np.degrees(c.rotation_std_rad):.3g}° {verdict}")
        rows.append(f"| {name} | " + " | ".join(cells) + " |")
    return rows


def hand_eye_row(label: str, cam, body) -> str:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = calibrate_hand_eye_streams(cam, body)
    return (f"| {label} | {r.rotation_rmse_deg:.3f} | {r.expected_rotation_rmse_deg:.3f} | {r.residual_to_noise:.2f} | "
            f"{r.coarse_correlation:.2f} | {r.credibility.split(':')[0]} |")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DATA), help="directory of the shared hand-eye recordings")
    ap.add_argument("--kinds", default=",".join(OFFSETS), help="simulated kinds (arm,handheld,sparse)")
    args = ap.parse_args(argv)
    print("\n".join(alignment_rows()) + "\n", flush=True)
    print("| pair | residual [deg] | expected [deg] | ratio | rate correlation | verdict |\n|---|---|---|---|---|---|")
    data = Path(args.data)
    if data.is_dir():
        streams = {k: tuple(clean_pose_stream(*read_pose_csv(data / f), f)[0] for f in v) for k, v in FILES.items()}
        for a in streams:
            for b in streams:
                label = f"{a} (true pair)" if a == b else f"{a} camera + {b} body (different motions)"
                print(hand_eye_row(label, streams[a][0], streams[b][1]), flush=True)
    for kind in args.kinds.split(","):
        for seed in (1, 2, 3):
            rec = simulate_hand_eye(kind, seed, OFFSETS[kind])
            cam, _ = clean_pose_stream(rec.camera_stamps, rec.camera_positions, rec.camera_quats, "camera")
            body, _ = clean_pose_stream(rec.body_stamps, rec.body_positions, rec.body_quats, "body")
            print(hand_eye_row(f"simulated {kind} (seed {seed})", cam, body), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
