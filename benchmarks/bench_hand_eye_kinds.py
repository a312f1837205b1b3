"""Hand–eye with time offset on simulated recordings of the held-out kinds (an arm with a perfect camera model, a
hand-held rig with an offset of an hour, sparse noisy motion capture at commensurate rates) and on ETH's two real
sets: dualpose against OpenCV's five closed forms, every method scored with the same loop residual on the same pairs.

Run: ``PYTHONPATH=src .venv/bin/python benchmarks/bench_hand_eye_kinds.py [--seeds 1,2,3] [--kinds arm,handheld,sparse]
[--camera-scale S] [--data DIR] [--markdown PATH]``.
OpenCV (``calibrateHandEye``, poses thinned to 200 as in ``bench_hand_eye.py``) is run at dualpose's ``τ`` and, on the
simulated sets, also at the true ``τ``; "best" is the smaller residual of the two.  "τ − scan min" is the distance
of dualpose's ``τ`` to the minimum of the loop residual scanned at 0.5 ms over ±10 ms (``X`` re-fitted at each
``τ``, :func:`dualpose.calibration.loop_residual`, with the result's weights).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from _common import emit
from bench_hand_eye import DATASETS, OPENCV, opencv_x, score
from dualpose.calibration import calibrate_hand_eye_streams, clean_pose_stream, loop_residual
from dualpose.io.pose_csv import read_pose_csv
from dualpose.sim import simulate_hand_eye

OFFSETS = {"arm": 0.02, "handheld": 3600.3, "sparse": 0.02}
DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "handeye"


def _scan_min(cam, body, r) -> float:
    i, j = r.pairs.T
    taus = r.time_offset + np.arange(-20, 21) * 5e-4
    costs = [loop_residual(cam, body, i, j, t, r.quat, r.translation, r.sigma_rotation, r.sigma_translation).cost
             for t in taus]  # fmt: skip
    return float(taus[int(np.argmin(costs))])


def run_set(label: str, cam, body, tau_true: float | None) -> str:
    t0 = time.perf_counter()
    r = calibrate_hand_eye_streams(cam, body)
    wall = time.perf_counter() - t0
    p = r.pairs
    rot, tr, n = score(cam, body, p, r.time_offset, r.quat, r.translation)
    cols, best_r, best_t = [], np.inf, np.inf
    for flag in OPENCV.values():
        vals = [score(cam, body, p, tau, *opencv_x(cam, body, p, tau, flag))[:2]
                for tau in ([r.time_offset] if tau_true is None else [r.time_offset, tau_true])]  # fmt: skip
        cr, ct = min(v[0] for v in vals), min(v[1] for v in vals)
        best_r, best_t = min(best_r, cr), min(best_t, ct)
        cols.append(f"{cr:.4f} / {ct:.3f}")
    dtau = "" if tau_true is None else f"{1e3 * (r.time_offset - tau_true):+.2f}"
    scan = 1e3 * abs(_scan_min(cam, body, r) - r.time_offset)
    return (f"| {label} | {dtau} | {scan:.1f} | {rot:.4f} / {tr:.3f} | " + " | ".join(cols)
            + f" | {rot / best_r:.3f} | {tr / best_t:.3f} | {r.start_method} | {n} | {wall:.1f} |")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="1,2,3", help="comma-separated seeds of the simulated sets")
    ap.add_argument("--markdown", metavar="PATH", help="also write the table as Markdown (never overwritten)")
    ap.add_argument("--data", default=str(DATA), help="directory of ETH's two real sets (skipped when missing)")
    ap.add_argument("--kinds", default=",".join(OFFSETS), help="simulated kinds (arm,handheld,sparse)")
    ap.add_argument(
        "--camera-scale",
        type=float,
        default=1.0,
        help="scale the simulated camera positions (a scale error of VIO or of the target, e.g. 1.1)",
    )
    args = ap.parse_args(argv)
    head = ("| set | τ − true [ms] | τ − scan min [ms] | dualpose rot [deg] / trans [mm] | "
            + " | ".join(f"OpenCV {m}" for m in OPENCV)
            + " | rot / best | trans / best | start | pairs | seconds |")  # fmt: skip
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    data = Path(args.data)
    for name, (cam_file, body_file) in DATASETS.items():
        if not data.is_dir():
            break
        cam, _ = clean_pose_stream(*read_pose_csv(data / cam_file), cam_file)
        body, _ = clean_pose_stream(*read_pose_csv(data / body_file), body_file)
        lines.append(run_set(name, cam, body, None))
        print(lines[-1], flush=True)
    for kind in args.kinds.split(","):
        for seed in (int(s) for s in args.seeds.split(",")):
            rec = simulate_hand_eye(kind, seed, OFFSETS[kind])
            pos = args.camera_scale * rec.camera_positions
            cam, _ = clean_pose_stream(rec.camera_stamps, pos, rec.camera_quats, "camera")
            body, _ = clean_pose_stream(rec.body_stamps, rec.body_positions, rec.body_quats, "body")
            lines.append(run_set(f"sim {kind} (seed {seed})", cam, body, OFFSETS[kind]))
            print(lines[-1], flush=True)
    return emit("\n".join(lines), args.markdown)


if __name__ == "__main__":
    sys.exit(main())
