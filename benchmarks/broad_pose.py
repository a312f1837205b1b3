"""Full pose on real IMU data: the seven BROAD trials fused with pseudo-vision by the error-state filter.

Run ``.venv/bin/python benchmarks/broad_pose.py [--data ../shared/data/broad] [--markdown docs/broad-pose.md]``.

For every trial: :func:`dualpose.pipelines.broad_pose.run_broad_pose` with continuous vision and with 2 s vision
dropouts every 10 s of the movement phase; then the sweep of the noise inflation (and the run without the
IMU/reference time offset) that documents the choice of :data:`~dualpose.pipelines.broad_pose.NOISE_INFLATION`.
Prints a markdown document (the table of ``docs/broad-pose.md``) and writes it with ``--markdown PATH``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from dualpose.io import load_broad
from dualpose.pipelines import broad_pose as bp

DEFAULT_DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "broad"
DROPOUT = (2.0, 10.0)
SWEEP = (1.0, 3.0, 10.0, 30.0, 100.0)
#: a run "tracks" when its position RMSE over the movement phase stays below this (m)
TRACKED_M = 0.1


def cm(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DEFAULT_DATA), help="directory of the BROAD .mat trials")
    ap.add_argument("--markdown", metavar="PATH", help="write the markdown document to PATH (replaces it)")
    ap.add_argument("--no-sweep", action="store_true", help="skip the noise-inflation sweep")
    args = ap.parse_args(argv)
    files = sorted(Path(args.data).glob("*.mat"))
    if not files:
        print(f"no BROAD .mat files in {args.data}", file=sys.stderr)
        return 2
    trials = [load_broad(f) for f in files]

    main_rows, drop_rows = [], []
    for tr in trials:
        t0 = time.perf_counter()
        a = bp.run_broad_pose(tr).metrics
        b = bp.run_broad_pose(tr, dropout=DROPOUT).metrics
        print(f"{tr.name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr)
        main_rows.append(
            f"| {tr.name} | {a['duration_s']:.0f} | {a['camera_frames']} | {cm(a['ate_rmse_m'])} | "
            f"{cm(a['position_rmse_m'])} | {a['orientation_rmse_deg']:.3f} | {cm(a['position_max_m'])} | "
            f"{a['nis_fraction_inside']:.3f} | {a['n_rejected']} / {a['n_correspondences']} | "
            f"{a['realtime_factor']:.0f}× |"
        )
        drop_rows.append(
            f"| {tr.name} | {b['n_dropouts']} | {cm(b['ate_rmse_m'])} | {cm(b['position_rmse_m'])} | "
            f"{b['orientation_rmse_deg']:.3f} | {cm(b['position_rmse_in_dropouts_m'])} | {cm(b['position_max_m'])} | "
            f"{b['nis_fraction_inside']:.3f} |"
        )

    sweep_rows = []
    if not args.no_sweep:
        settings = [(f, bp.REFERENCE_TIME_OFFSET) for f in SWEEP] + [(bp.NOISE_INFLATION, 0.0)]
        for infl, off in settings:
            cells = []
            for dropout in (None, DROPOUT):
                ms = [
                    bp.run_broad_pose(tr, dropout=dropout, noise_inflation=infl, time_offset=off).metrics
                    for tr in trials
                ]
                pos = np.array([m["position_rmse_m"] for m in ms])
                ori = np.array([m["orientation_rmse_deg"] for m in ms])
                nis = np.array([m["nis_fraction_inside"] for m in ms])
                ok = pos < TRACKED_M
                med_pos = cm(float(np.median(pos[ok]))) if ok.any() else "–"
                med_ori = f"{np.median(ori[ok]):.3f}" if ok.any() else "–"
                cells.append(f"{int(ok.sum())} / {len(ms)} | {med_pos} | {med_ori} | {nis.min():.3f}")
            print(f"sweep inflation {infl:g}, offset {1e3 * off:g} ms done", file=sys.stderr)
            sweep_rows.append(f"| ×{infl:g} | {1e3 * off:g} | " + " | ".join(cells) + " |")

    doc = render(main_rows, drop_rows, sweep_rows, trials)
    print(doc)
    if args.markdown:
        Path(args.markdown).write_text(doc)
        print(f"written to {args.markdown}", file=sys.stderr)
    return 0


def render(main_rows: list[str], drop_rows: list[str], sweep_rows: list[str], trials: list) -> str:
    n = trials[0] if trials else None
    rate = f"{n.rate:.1f}" if n is not None else "285.7"
    lines = [
        "# Full pose on real IMU data: BROAD with pseudo-vision",
        "",
        "Data: BROAD — Laidig, Caruso, Cereatti, Seel, *BROAD — A Benchmark for Robust Inertial Orientation "
        "Estimation*, Data 2021, 6(7), 72 (CC BY 4.0); the seven trials in `../shared/data/broad/`.  The real IMU "
        f"({rate} Hz) drives the error-state filter (`dualpose.estimation.eskf.ErrorStateEKF`); the camera is virtual: "
        f"{bp.N_LANDMARKS} landmarks in a spherical shell of radii {bp.SHELL_RADII[0]:g}–{bp.SHELL_RADII[1]:g} m "
        "around the trial's mean position are projected through the optical reference pose (`opt_quat`, `opt_pos`, "
        f"interpolated) at {bp.CAMERA_RATE:g} Hz with {bp.PIXEL_SIGMA:g} px noise into the simulator's 320 × 240 "
        f"camera (f = 213.3 px, default extrinsic), {bp.PER_FRAME} correspondences per frame; no frame while the "
        "reference is NaN.",
        "",
        "Library: `dualpose.pipelines.broad_pose.run_broad_pose(trial, dropout=None | (length_s, period_s))`; CLI: "
        "`dualpose fuse --data ../shared/data/broad/01_undisturbed_slow_rotation_A.mat` (the job's summary; its "
        "orientation RMSE is after the SE(3) alignment, see below).",
        "",
        "Set-up, the same for every trial (`dualpose/sim/broad_vision.py`, run by `dualpose/pipelines/broad_pose.py`):",
        "",
        "* World ENU, gravity [0, 0, −9.8128] m/s² (normal gravity at Berlin).",
        "* Start: the IMU stream begins at the last sample before the first pseudo-vision frame; static alignment "
        "(gyro bias, levelling) over the rest of the static start (`BroadTrial.static_start`), pose from a RANSAC "
        "PnP of the first frame, zero velocity.",
        "* Noise: white-noise densities measured on the static start (std of first differences / √2 / √rate) times "
        f"{bp.NOISE_INFLATION:g} (chosen by NIS consistency, sweep below); bias random walks "
        f"{bp.GYROSCOPE_RANDOM_WALK:g} rad/s²/√Hz, {bp.ACCELEROMETER_RANDOM_WALK:g} m/s³/√Hz and accelerometer "
        f"turn-on σ {bp.ACCELEROMETER_INITIAL_BIAS_SIGMA:g} m/s² (consumer-MEMS class).",
        f"* Time: BROAD's IMU stamps lag the optical reference by {1e3 * bp.REFERENCE_TIME_OFFSET:g} ms (gyro vs the "
        "reference's angular rate, 4.0–4.25 ms in all seven trials); the pseudo-camera carries that "
        "`timeshift_cam_imu` and the reference is compared on the IMU clock.",
        "* Errors against the optical reference: ATE = RMSE after SE(3) Umeyama alignment over all reference "
        "samples; position and orientation RMSE without alignment (both are in ENU) over the `movement` samples "
        "with a finite reference (BROAD's scoring set).  The SE(3)-aligned orientation error is not used: on the "
        "rotation trials the positions span only 0.2–0.5 m, so the alignment's rotation is poorly determined.",
        "",
        "## Continuous vision",
        "",
        "| trial | duration [s] | frames | ATE SE(3) [cm] | position RMSE [cm] | orientation RMSE [°] | "
        "max position error [cm] | NIS inside 95 % band | rejected | real-time factor |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        *main_rows,
        "",
        f"## Vision dropped for {DROPOUT[0]:g} s every {DROPOUT[1]:g} s of the movement phase",
        "",
        "| trial | dropouts | ATE SE(3) [cm] | position RMSE [cm] | orientation RMSE [°] | "
        "position RMSE in dropouts [cm] | max position error [cm] | NIS inside 95 % band |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
        *drop_rows,
    ]
    if sweep_rows:
        lines += [
            "",
            "## Choice of the noise inflation (and of the time offset)",
            "",
            "The white-noise densities measured at rest leave out what a MEMS IMU adds in motion (scale factor and "
            "axis misalignment ≈ 0.5 % on BROAD's gyro, accelerometer scale/misalignment, tapping impacts), so the "
            "filter becomes over-confident, gates the camera out and diverges.  The inflation factor is one value "
            "for all trials, chosen without the reference: the factor whose lowest NIS coverage over the trials "
            "is closest to the nominal 0.95 (it was chosen on these same seven trials).  Without the 4.1 ms time "
            "offset (last row) the NIS coverage drops too.  Columns per vision mode: trials tracked "
            "(position RMSE < "
            f"{100 * TRACKED_M:g} cm), median position RMSE [cm] and orientation RMSE [°] over the tracked trials, "
            "lowest NIS coverage.",
            "",
            "| inflation | time offset [ms] | tracked | median pos. [cm] | median ori. [°] | min NIS | "
            "tracked (dropouts) | median pos. [cm] | median ori. [°] | min NIS |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
            *sweep_rows,
        ]
    lines += [
        "",
        "Not modelled: the lever arm between the IMU and the point the reference tracks (≈ 1 cm, least squares on "
        "the trials) and residual timing; they limit the position RMSE to ~1 cm with 1 px pseudo-vision.",
        "",
        "Produced by `.venv/bin/python benchmarks/broad_pose.py --markdown docs/broad-pose.md`.",
        "",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
