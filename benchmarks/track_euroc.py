"""Tracking a hand-held camera–IMU rig against a calibration target: EuRoC imu_april (docs/fusion.md, "Tracking on
EuRoC imu_april").

cam0 + IMU tracked with the ESKF and Hol22 (``dualpose fuse --data DIR --camera cam0 --calibration CALIB.json``),
scored against the independent reference: cam1's per-frame PnP mapped to the IMU with EuRoC's published cam1
extrinsic.  Rows: the fused runs, cam0-only per-frame PnP measured the same way, IMU-only from the start, camera
outages (cam0's detections deleted over 1 s windows across the run, several during fast rotation), NIS, a
position NEES against the reference, and the real-time factor (filter time, best of ``--repeat``).

Without ``--calibration`` the calibration is EuRoC's published Kalibr cam0 extrinsic with no time shift, no biases and
0.35 px reprojection RMS, built here (a fixture, not an estimate); with ``--calibration`` the file given (e.g. the
output of ``dualpose calibrate camera-imu ... --json``).

Run ``nice .venv/bin/python benchmarks/track_euroc.py [--calibration CALIB.json] [--axes-from CALIB.json]
[--scale-sigmas none|mems] [--structure] [--markdown PATH] [--figure PNG]``.  The ESKF rows are what ``fuse --data``
writes: the RTS-smoothed run (``--output smoothed``, the offline default: ``pipelines.track_target.smooth_segments``,
one segment per filter start or re-lock) and the causal filter (``--output filter``, what ``fuse --stream`` writes);
the real-time factors count the filter and, for the smoothed row, the smoother (best of ``--repeat``).
``--structure`` adds the error-structure diagnosis of docs/fusion.md: each camera's frame-to-frame PnP error with the
motion taken out by the IMU over one frame interval (white-noise σ and the correlation between the cameras), and
the split of each method's error against the reference into its mean, a slow part (9-frame running mean) and the rest.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter1d

import dualpose as dp
from _common import emit
from dualpose.calibration._preintegration import preintegrate
from dualpose.evaluation.target_reference import body_trajectory, errors_against
from dualpose.io.target.recording import (
    read_camera_imu_calibration,
    read_target_recording,
    write_camera_imu_calibration,
)
from dualpose.pipelines.track_target import (
    EUROC_T_BS,
    extrinsic_from_matrix,
    imu_only,
    prepare_track,
    run_relocking,
    run_track,
    smooth_segments,
)
from dualpose.types import Trajectory
from dualpose.types.calibration import CameraImuCalibration

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "euroc" / "imu_april"

#: 1 s camera outages (s from the first IMU sample): every 8 s after the 10 s start-up window, avoiding the recording's
#: own 1.2 s loss of the target near 56 s
OUTAGES = ((12.0, 13.0), (20.0, 21.0), (28.0, 29.0), (36.0, 37.0), (44.0, 45.0), (50.0, 51.0), (62.0, 63.0))


def _published_calibration(directory: Path) -> Path:
    q, p = extrinsic_from_matrix(EUROC_T_BS["cam0"])
    path = directory / "published_cam0.json"
    write_camera_imu_calibration(path, CameraImuCalibration("cam0", q, p, 0.0, 0.35))
    return path


def _mm(v) -> str:
    return "n/a" if v is None or not math.isfinite(v) else f"{1e3 * v:.2f}"


def _deg(v, digits: int = 3) -> str:
    return "n/a" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DATA), help="imu_april directory")
    ap.add_argument("--calibration", help="camera-IMU calibration JSON (default: EuRoC's published cam0 extrinsic)")
    ap.add_argument("--repeat", type=int, default=3, help="filter runs timed per filter (best of)")
    ap.add_argument("--scale-sigmas", default="mems", choices=("none", "mems"),
                    help="IMU scale-factor uncertainties of the filters: the MEMS class values (default, as fuse) or "
                    "none (Kalibr's model)")
    ap.add_argument("--axes-from", help="take the IMU axis matrices from this calibration JSON (with the extrinsic "
                    "of --calibration / the fixture)")
    ap.add_argument("--structure", action="store_true", help="add the error-structure diagnosis (docs/fusion.md)")
    ap.add_argument("--markdown", help="also write the tables to this file (never overwritten)")
    ap.add_argument("--figure", help="write the trajectory figure (PNG) here")
    args = ap.parse_args()
    if not Path(args.data, "cam0_aprilgrid.csv").is_file():
        print(f"imu_april data missing ({args.data})", file=sys.stderr)
        return 1
    tmp = tempfile.TemporaryDirectory()
    calib = Path(args.calibration) if args.calibration else _published_calibration(Path(tmp.name))
    if args.axes_from:
        axes = read_camera_imu_calibration(args.axes_from)
        calib = replace(read_camera_imu_calibration(calib), gyro_axes_matrix=axes.gyro_axes_matrix,
                        accel_axes_matrix=axes.accel_axes_matrix)  # fmt: skip
    scale = (0.0, 0.0) if args.scale_sigmas == "none" else "mems"
    src = read_target_recording(args.data)
    t0 = time.perf_counter()
    setup = prepare_track(src, calib, "cam0", scale_sigmas=scale)
    prep_s = time.perf_counter() - t0
    # the outage windows scored on the runs without outages too: what the reference's own noise allows there
    runs = {name: run_track(setup, name, outages=OUTAGES, output="filter") for name in ("eskf", "hol22")}
    smoothed_run = run_track(setup, "eskf", outages=OUTAGES, output="smoothed")
    timing = {}
    for name in (*runs, "smoothed"):
        best = math.inf
        for _ in range(args.repeat):
            tr = run_relocking(setup.recording, setup.start.x, setup.start.P, "eskf" if name == "smoothed" else name)
            best = min(best, tr.wall_time + (smooth_segments(setup.recording, tr).wall_time
                                             if name == "smoothed" else 0.0))  # fmt: skip
        timing[name] = best
    m = runs["eskf"].metrics
    dur = setup.recording.duration
    su = m["startup"]
    label = "EuRoC published cam0 extrinsic (fixture)" if not args.calibration else str(args.calibration)
    axes_m = setup.calibration.gyro_axes_matrix
    label += "; IMU axis matrices " + ("none" if axes_m is None else f"from {args.axes_from or args.calibration}")
    label += f"; ESKF scale-factor σ {setup.recording.imu_noise.gyroscope_scale_sigma:g} (gyro), " \
             f"{setup.recording.imu_noise.accelerometer_scale_sigma:g} (accel)"
    lines = [
        f"calibration: {label}; reference: cam1 per-frame PnP ({m['reference']['frames_scored']} frames, "
        f"RMS < 0.7 px, >= 30 corners, median RMS {m['reference']['median_rms_px']:.3f} px) through EuRoC's "
        "published cam1 extrinsic; "
        f"no alignment; {dur:.1f} s, {m['imu_samples']} IMU samples, {m['camera_frames']} cam0 frames",
        "",
        f"start-up ({su['frames']} frames, first 10 s): gravity {np.round(su['gravity_target'], 4).tolist()} m/s² "
        f"(σ {su['gravity_sigma_deg']:.3f}°, unconstrained |g| {su['gravity_estimated_magnitude']:.3f} m/s²"
        + ("" if su["gravity_angle_to_calibration_deg"] is None
           else f", {su['gravity_angle_to_calibration_deg']:.3f}° from the calibration's") + "); "
        f"gyro bias {np.round(su['gyro_bias'], 4).tolist()} rad/s ({su['gyro_bias_from']}), accel bias "
        f"{np.round(su['accel_bias'], 3).tolist()} m/s² ({su['accel_bias_from']}); ideal-pixel σ "
        f"{m['pixel_sigma_ideal_px']:.3f} px; set-up {prep_s:.2f} s",
        "",
        "| method | position RMSE [mm] | rotation RMSE [deg] | NIS inside 95 % | mean NIS (2) | position NEES (3) "
        "| rejected | re-locks | real-time factor |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]  # fmt: skip
    labels = {"smoothed": "ESKF + RTS, segmented (`fuse --data` default output)",
              "eskf": "ESKF causal filter (`--output filter`, `--stream`)", "hol22": "Hol22 causal filter"}
    for name, r in {"smoothed": smoothed_run, **runs}.items():
        mm = r.metrics
        lines.append(
            f"| {labels[name]} | {_mm(mm['position_rmse_m'])} | "
            f"{_deg(mm['rotation_rmse_deg'])} | {mm['nis_fraction_inside']:.3f} | {mm['mean_nis']:.2f} | "
            f"{mm['nees_position']:.1f} | {mm['n_rejected']} of {mm['n_correspondences']} | {mm['relocks']} | "
            f"{dur / timing[name]:.0f}× |"
        )
    pnp = m["camera_pnp"]
    lines.append(f"| cam0-only per-frame PnP | {_mm(pnp['position_rmse_m'])} | {_deg(pnp['rotation_rmse_deg'])} | "
                 "| | | | | |")  # fmt: skip
    smoothed = smoothed_run.estimate
    io = imu_only(setup, (0.5, 1.0, 2.0))
    for k, v in io.items():
        lines.append(f"| IMU only, first {k} after the start | {_mm(v['position_rmse_m'])} | "
                     f"{_deg(v['rotation_rmse_deg'])} | | | | | | |")  # fmt: skip
    # outages
    out_setup = prepare_track(src, calib, "cam0", OUTAGES, scale_sigmas=scale)
    gyro_norm = np.linalg.norm(src.imu.gyro, axis=1)
    rel = src.imu.stamps - src.imu.stamps[0]
    lines += ["", "| outage [s] | max rate [rad/s] | frames scored | ESKF + RTS max / RMS position [mm] | ESKF + RTS "
              "max / RMS rotation [deg] | ESKF filter max / RMS position [mm] | ESKF filter max rotation "
              "[deg] | Hol22 max / RMS position [mm] | Hol22 max rotation [deg] | no outage: ESKF + RTS / cam0 PnP max "
              "rotation [deg] |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    ref, _ = setup.cache["reference", "cam1"]
    cal = setup.calibration
    pnp_err = errors_against(ref, body_trajectory(setup.cache["own"], cal.rotation_xyzw, cal.translation_m,
                                                  cal.time_offset_s))  # fmt: skip
    pnp_rel = pnp_err.estimate.stamps - src.imu.stamps[0]
    out_runs = {name: run_track(out_setup, name, outages=OUTAGES, output="filter") for name in ("eskf", "hol22")}
    out_runs["smoothed"] = run_track(out_setup, "eskf", outages=OUTAGES, output="smoothed")
    for i, (a, b) in enumerate(OUTAGES):
        ws, we, wh = (out_runs[k].metrics["outages"][i] for k in ("smoothed", "eskf", "hol22"))
        w_max = float(gyro_norm[(rel >= a) & (rel < b)].max())
        lines.append(
            f"| {a:g}–{b:g} | {w_max:.2f} | {we['frames']} | {_mm(ws['position_max_m'])} / {_mm(ws['position_rmse_m'])}"
            f" | {_deg(ws['rotation_max_deg'])} / {_deg(ws['rotation_rmse_deg'])} | {_mm(we['position_max_m'])} / "
            f"{_mm(we['position_rmse_m'])}"
            f" | {_deg(we['rotation_max_deg'])} | {_mm(wh['position_max_m'])} / {_mm(wh['position_rmse_m'])} | "
            f"{_deg(wh['rotation_max_deg'])} | {_deg(smoothed_run.metrics['outages'][i]['rotation_max_deg'], 2)} / "
            f"{_deg(float(pnp_err.rotation_deg[(pnp_rel >= a) & (pnp_rel < b)].max()), 2)} |"
        )
    worst = {name: (max(w["position_max_m"] for w in r.metrics["outages"]),
                    max(w["rotation_max_deg"] for w in r.metrics["outages"]))
             for name, r in out_runs.items()}  # fmt: skip
    lines.append("")
    lines.append("worst outage error: " + "; ".join(f"{n}: {1e3 * p:.1f} mm, {r:.3f}°" for n, (p, r) in worst.items())
                 + " (runs with the outages, overall: " + "; ".join(
                     f"{n} {1e3 * r.metrics['position_rmse_m']:.2f} mm / {r.metrics['rotation_rmse_deg']:.3f}°"
                     for n, r in out_runs.items()) + ")")  # fmt: skip
    if args.structure:
        lines += [""] + _structure(setup, {"ESKF": runs["eskf"].estimate, "ESKF + RTS smoother": smoothed})
        lines += [""] + _outage_offsets(setup, out_runs["eskf"].estimate, out_runs["smoothed"].estimate, smoothed)
    if args.figure:
        _figure(smoothed_run, setup, args.figure)
        lines.append(f"figure: {args.figure}")
    return emit("\n".join(lines), args.markdown)


def _split(e: np.ndarray, scale: float) -> str:
    """Mean, slow part (9-frame running mean of the rest) and fast part (the remainder) of errors (K, 3), RMS per
    axis."""
    c = e - e.mean(axis=0)
    slow = uniform_filter1d(c, 9, axis=0)
    rms = lambda x: " ".join(f"{scale * v:.2f}" for v in np.sqrt(np.mean(x**2, axis=0)))  # noqa: E731
    return f"{' '.join(f'{scale * v:+.2f}' for v in e.mean(axis=0))} | {rms(slow)} | {rms(c - slow)}"


def _structure(setup, tracks: dict) -> list[str]:
    """Error structure of the per-frame PnP poses of both cameras and of the tracks against the reference."""
    src = setup.source
    imu = src.imu
    t_imu = (imu.stamps_ns - imu.stamps_ns[0]) * 1e-9
    ref, kept = setup.cache["reference", "cam1"]
    cal = setup.calibration
    poses = {"cam0": setup.cache["own"], "cam1": kept}
    ext = {"cam0": (cal.rotation_xyzw, cal.translation_m), "cam1": extrinsic_from_matrix(EUROC_T_BS["cam1"])}
    common = np.intersect1d(poses["cam0"].stamps_ns, poses["cam1"].stamps_ns)
    body = {}
    for c, ps in poses.items():
        i = np.searchsorted(ps.stamps_ns, common)
        tr = body_trajectory(ps, *ext[c])
        body[c] = (dp.matrix_from_quat(tr.quats[i]), tr.positions[i])
    # frame triples 50 ms apart: the IMU carries the pose from frame k-1 (and k) to k (k+1)
    s = (common - imu.stamps_ns[0]) * 1e-9 + cal.time_offset_s
    step = np.abs(np.diff(common) - 50_000_000) < 1_000_000
    k = np.flatnonzero(step[:-1] & step[1:]) + 1
    al = setup.start.alignment
    bg = np.asarray(cal.gyro_bias if cal.gyro_bias is not None else al.gyro_bias, dtype=np.float64)
    ba = np.asarray(cal.accel_bias if cal.accel_bias is not None else al.accel_bias, dtype=np.float64)
    gyro, accel = imu.gyro, imu.accel
    if cal.gyro_axes_matrix is not None:
        gyro = gyro @ np.linalg.inv(np.asarray(cal.gyro_axes_matrix)).T
        accel = accel @ np.linalg.inv(np.asarray(cal.accel_axes_matrix)).T
    pre = preintegrate(t_imu, gyro, accel, s, np.broadcast_to(bg, (len(s) - 1, 3)),
                       np.broadcast_to(ba, (len(s) - 1, 3)), 0.0, 0.0)  # fmt: skip
    g = np.asarray(setup.start.alignment.gravity)
    white = {}
    for c, (R, p) in body.items():
        eR = dp.so3_log(np.swapaxes(pre.dR[k - 1], 1, 2) @ np.swapaxes(R[k - 1], 1, 2) @ R[k])
        T1, T2 = pre.dt[k - 1][:, None], pre.dt[k][:, None]
        v0 = (p[k] - p[k - 1] - 0.5 * g * T1**2 - np.einsum("kij,kj->ki", R[k - 1], pre.dp[k - 1])) / T1
        v1 = v0 + g * T1 + np.einsum("kij,kj->ki", R[k - 1], pre.dv[k - 1])
        ep = p[k + 1] - (p[k] + v1 * T2 + 0.5 * g * T2**2 + np.einsum("kij,kj->ki", R[k], pre.dp[k]))
        white[c] = (eR, ep)
    out = [f"Per-frame PnP error with the motion removed by the IMU ({len(k)} frame triples 50 ms apart; rotation: "
           "relative rotation over one interval, σ = RMS/√2; position: second difference, σ = RMS/√6; body axes):",
           "", "| quantity | cam0 σ (x y z) | cam1 σ (x y z) | correlation cam0–cam1 (x y z) |",
           "|---|---|---|---|"]  # fmt: skip
    for name, j, scale, div in (("rotation [deg]", 0, np.degrees(1.0), np.sqrt(2)), ("position [mm]", 1, 1e3,
                                                                                          np.sqrt(6))):  # fmt: skip
        a, b = white["cam0"][j], white["cam1"][j]
        corr = [np.corrcoef(a[:, i], b[:, i])[0, 1] for i in range(3)]
        out.append(f"| {name} | {' '.join(f'{scale * v / div:.3f}' for v in a.std(axis=0))} | "
                   f"{' '.join(f'{scale * v / div:.3f}' for v in b.std(axis=0))} | "
                   f"{' '.join(f'{v:+.2f}' for v in corr)} |")  # fmt: skip
    out += ["", "Errors against the reference (cam1 PnP), split: mean, slow part (9-frame running mean), fast part "
            "(rest); RMS per axis (target frame for positions, body frame for rotations):", "",
            "| track | position mean [mm] | slow [mm] | fast [mm] | rotation mean [deg] | slow [deg] | fast [deg] | "
            "implied lag rotation / position [ms] |",
            "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    items = dict(tracks)
    items["cam0-only per-frame PnP"] = body_trajectory(poses["cam0"], *ext["cam0"], cal.time_offset_s)
    for name, tr in items.items():
        e = errors_against(ref, tr)
        rq = dp.matrix_from_quat(ref.quats[e.index])
        ev = dp.so3_log(np.swapaxes(rq, 1, 2) @ dp.matrix_from_quat(e.estimate.quats))
        # a track late by δ has errors ≈ −ω δ (body) and −v δ: the least-squares δ of each
        tt = ref.stamps[e.index]
        w = np.column_stack([np.interp(tt, imu.stamps, imu.gyro[:, i]) for i in range(3)])
        v = np.gradient(ref.positions[e.index], tt, axis=0)
        lag_r = -float(np.sum((ev - ev.mean(axis=0)) * w) / np.sum(w * w))
        lag_p = -float(np.sum((e.position - e.position.mean(axis=0)) * v) / np.sum(v * v))
        out.append(f"| {name} | {_split(e.position, 1e3)} | {_split(ev, np.degrees(1.0))} | "
                   f"{1e3 * lag_r:+.2f} / {1e3 * lag_p:+.2f} |")  # fmt: skip
    return out


def _rotation_errors(ref: Trajectory, track: Trajectory):
    """Errors of ``track`` at the reference frames: stamps (K,), position (K, 3) m, rotation vectors (K, 3) rad
    (body frame)."""
    e = errors_against(ref, track)
    rq = dp.matrix_from_quat(ref.quats[e.index])
    return e.estimate.stamps, e.position, dp.so3_log(np.swapaxes(rq, 1, 2) @ dp.matrix_from_quat(e.estimate.quats))


def _outage_offsets(setup, eskf_out: Trajectory, smoothed_out: Trajectory, smoothed_full: Trajectory) -> list[str]:
    """Inside each outage window: the largest errors of the ESKF and of the RTS-smoothed ESKF of the run with the
    outages, the rotation also with the run's constant rotation offset (its mean error vector) removed, and cam0's
    PnP the same way (no outage); and, needing no reference, the largest difference between the smoothed runs with and
    without the outages at the IMU samples inside the window (what the outage itself costs)."""
    ref, _ = setup.cache["reference", "cam1"]
    t0 = float(setup.source.imu.stamps[0])
    cal = setup.calibration
    tracks = {"ESKF": eskf_out, "RTS": smoothed_out,
              "PnP": body_trajectory(setup.cache["own"], cal.rotation_xyzw, cal.translation_m, cal.time_offset_s)}
    errs = {k: _rotation_errors(ref, tr) for k, tr in tracks.items()}
    out = ["Outage windows (cam0 deleted; PnP: no outage) — largest errors inside, and the largest rotation error with "
           "the run's constant rotation offset (mean error vector over all reference frames) removed:", "",
           "| outage [s] | ESKF position [mm] / rotation [deg] / offset removed | RTS-smoothed: position / rotation / "
           "offset removed | cam0 PnP rotation / offset removed [deg] | RTS with vs without the outage: position [mm] "
           "/ rotation [deg] |", "|---|---|---|---|---|"]  # fmt: skip
    t_imu = smoothed_full.stamps
    if not np.array_equal(t_imu, smoothed_out.stamps):
        raise RuntimeError("the runs with and without outages must share their IMU samples")
    dp_imu = np.linalg.norm(smoothed_out.positions - smoothed_full.positions, axis=1)
    dr_imu = np.degrees(dp.quat_angle(smoothed_out.quats, smoothed_full.quats))
    for a, b in OUTAGES:
        cells = []
        for k in ("ESKF", "RTS", "PnP"):
            st, pe, ev = errs[k]
            m = (st - t0 >= a) & (st - t0 < b)
            rot = np.degrees(np.linalg.norm(ev[m], axis=1).max())
            rot0 = np.degrees(np.linalg.norm(ev[m] - ev.mean(axis=0), axis=1).max())
            pos = 1e3 * np.linalg.norm(pe[m], axis=1).max()
            cells.append(f"{rot:.3f} / {rot0:.3f}" if k == "PnP" else f"{pos:.1f} / {rot:.3f} / {rot0:.3f}")
        w = (t_imu - t0 >= a) & (t_imu - t0 < b)
        cells.append(f"{1e3 * dp_imu[w].max():.1f} / {dr_imu[w].max():.3f}")
        out.append(f"| {a:g}–{b:g} | " + " | ".join(cells) + " |")
    return out


def _figure(result, setup, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ref = result.truth
    est = result.estimate
    t0 = setup.source.imu.stamps[0]
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(10, 3.8), gridspec_kw={"width_ratios": [1, 1.6]})
    a0.plot(est.positions[:, 0], est.positions[:, 1], "r-", lw=0.6, label="ESKF + RTS (cam0 + IMU)")
    a0.plot(ref.positions[:, 0], ref.positions[:, 1], "k.", ms=1.2, label="reference (cam1 PnP)")
    a0.set(xlabel="x [m] (target frame)", ylabel="y [m]", aspect="equal", title="IMU position over the target")
    a0.legend(fontsize=7, loc="best")
    tt = ref.stamps - t0
    a1.plot(tt, 1e3 * np.linalg.norm(result.position_error, axis=1), "r-", lw=0.6, label="ESKF + RTS position error")
    a1.set(xlabel="time [s]", ylabel="position error [mm]", ylim=(0, 40),
           title="error against the reference (no alignment)")  # fmt: skip
    a2 = a1.twinx()
    a2.plot(tt, result.orientation_error_deg, "b-", lw=0.4, alpha=0.6, label="rotation error")
    a2.set(ylabel="rotation error [deg]", ylim=(0, 2))
    a1.legend(loc="upper left", fontsize=7)
    a2.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
