"""What the rotation error inside a camera outage is made of: EuRoC imu_april, cam0 + IMU (docs/fusion.md, "Outages").

The issue's score of a 1 s outage is the largest rotation error, against cam1's per-frame PnP through EuRoC's
published cam1 extrinsic, over the reference frames inside the window (``track_target.score_run``).  This script
splits it:

1. **Per window** — the score of the smoothed ``fuse --data --outage`` output (max and RMS), with the run's constant
   rotation offset removed; the same for the run without outages and for cam0's own PnP (no outage); the
   reference's own per-frame scatter, seen as the disagreement of the two cameras' PnP through the *stereo*
   extrinsic of ``sensors.yaml`` (camera-only: no IMU, no camera–IMU extrinsic), centred, and divided by √2 for one
   camera's share ("one camera's floor"); and what the missing second itself costs (smoothed runs with and without
   the outage compared at every IMU sample of the window, no reference).
2. **Who is wrong over 0.2–1 s** — the relative rotation over an interval measured three ways (cam0 PnP, cam1 PnP,
   the gyro integrated with the calibration's axis matrix and bias), split by the three-cornered hat into each
   source's error (``evaluation.target_reference.three_cornered_hat``; what the two cameras share is given to the
   gyro).
3. **Which gyro model explains the gyro's part** — the mean of the two cameras minus the gyro over 0.2 s / 0.5 s
   intervals fitted, on the first half of the recording, by a constant scale/misalignment matrix ``E`` (the error
   ``E ω``, 9 numbers: what gyro scale states in the filter would estimate), a g-sensitivity ``G f`` (9), a
   per-axis quadratic scale ``ω|ω|`` (3 × 3) and a gyro–camera time shift ``δ`` (1), and scored on the second half.
   Then the time shift per 8 s segment, and ``E`` learned on cam0 over the 8 s before each window and used inside it.
4. **Re-run** — the outage and no-outage runs again with the best constant ``E`` fitted to cam0 over the *whole* run
   (outage windows included: more than gyro scale states could learn, an upper bound on what they bring); and a
   plain gyro bridge of every window (integration from the outage run's attitude before the window, the mismatch at
   its end spread linearly).

The gyro is integrated with the mean rate of consecutive samples over each step (the midpoint rule of the ESKF and
of the preintegration); holding each sample over the step after it would show a spurious 2.5 ms gyro lag.

Run ``nice .venv/bin/python benchmarks/diag_outage_euroc.py --calibration CALIB.json [--markdown PATH]``
(``CALIB.json`` from ``dualpose calibrate camera-imu imu0.csv cam0_aprilgrid.csv --sensors sensors.yaml
--camera cam0 --json``).  About 15 s of CPU.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

import dualpose as dp
from _common import emit
from dualpose.evaluation.target_reference import body_trajectory, three_cornered_hat
from dualpose.io.target.recording import read_camera_imu_calibration, read_target_recording
from dualpose.pipelines.track_target import EUROC_T_BS, extrinsic_from_matrix, prepare_track, run_track
from track_euroc import DATA, OUTAGES, _rotation_errors

DEG = float(np.degrees(1.0))
#: interval lengths of the relative-rotation comparisons, in 50 ms frame steps
HAT_STEPS = (4, 10, 20)


def _prefix_products(steps: np.ndarray) -> np.ndarray:
    """``out[k] = steps[0] @ ... @ steps[k-1]`` (``out[0] = I``) for (N, 3, 3) steps, by log-depth doubling."""
    p = steps.copy()
    shift = 1
    while shift < len(p):
        p[shift:] = p[:-shift] @ p[shift:]
        shift *= 2
    return np.concatenate([np.eye(3)[None], p])


def _mid(x: np.ndarray) -> np.ndarray:
    """The mean of consecutive samples (N-1, ...): the rate over each IMU step, as the ESKF and the preintegration
    use it (a sample held over the step after it would lag by half a step, 2.5 ms at 200 Hz)."""
    return 0.5 * (x[:-1] + x[1:])


class GyroPath:
    """The gyro's attitude and path integrals (body rates, IMU clock), midpoint rule."""

    def __init__(self, t: np.ndarray, gyro: np.ndarray, accel: np.ndarray) -> None:
        self.t, self.gyro = t, gyro
        dt = np.diff(t)
        steps = dp.so3_exp(_mid(gyro) * dt[:, None])
        self.R = _prefix_products(steps)  # R(t_k) = R(t_0)⁻¹ R(t_k): integration
        # each step's integrand at its mid-point: R(t_k) Exp(½ ω̄ dt) feature(mid)
        r_mid = self.R[:-1] @ dp.so3_exp(0.5 * _mid(gyro) * dt[:, None])
        feats = {"E": gyro, "G": accel, "Q": gyro * np.abs(gyro)}
        w = r_mid[:, :, :, None] * dt[:, None, None, None]
        self.integrals = {k: np.concatenate([np.zeros((1, 3, 3, 3)), np.cumsum(w * _mid(f)[:, None, None, :], axis=0)])
                          for k, f in feats.items()}  # fmt: skip

    def at(self, ts: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(self.t, ts, side="right") - 1, 0, len(self.t) - 2)
        h = ts - self.t[i]
        frac = (h / (self.t[i + 1] - self.t[i]))[:, None]
        w = self.gyro[i] + 0.5 * frac * (self.gyro[i + 1] - self.gyro[i])  # the mean rate over [t_i, ts]
        return self.R[i] @ dp.so3_exp(w * h[:, None])

    def rate(self, ts: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(ts, self.t, self.gyro[:, i]) for i in range(3)])


def _rel(R: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.swapaxes(R[a], 1, 2) @ R[b]


def _log_diff(r_ref: np.ndarray, r: np.ndarray) -> np.ndarray:
    return dp.so3_log(np.swapaxes(r_ref, 1, 2) @ r)


def _pairs(tc: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    a = np.arange(len(tc) - n)
    b = a + n
    ok = np.abs(tc[b] - tc[a] - 0.05 * n) < 0.02
    return a[ok], b[ok]


def _norm_deg(v: np.ndarray) -> np.ndarray:
    return DEG * np.linalg.norm(v, axis=-1)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def _window_rows(errs: dict, t0: float) -> dict:
    """Per window, per track: (max, RMS, max offset removed, RMS offset removed) of the rotation error, degrees."""
    out = {}
    for name, (st, _, ev) in errs.items():
        c = ev.mean(axis=0)
        rows = []
        for a, b in OUTAGES:
            m = (st - t0 >= a) & (st - t0 < b)
            e, e0 = _norm_deg(ev[m]), _norm_deg(ev[m] - c)
            rows.append((e.max(), _rms(e), e0.max(), _rms(e0)))
        out[name] = np.array(rows)
    return out


def _hat_lines(tc, B0, B1, G, wv) -> tuple[list[str], float]:
    lines = ["| interval | pairs | cam0 σ (x y z) [deg] | cam1 σ (x y z) [deg] | gyro + what the cameras share σ "
             "(x y z) [deg] | RMS cam0−cam1 / cam0−gyro / cam1−gyro [deg] |", "|---|---:|---|---|---|---|"]  # fmt: skip
    sig = lambda v: " ".join(f"{DEG * np.sqrt(max(x, 0.0)):.3f}" for x in v)  # noqa: E731
    for n in HAT_STEPS:
        a, b = _pairs(tc, n)
        r0, r1, rg = _rel(B0, a, b), _rel(B1, a, b), _rel(G, a, b)
        d01, d0g, d1g = _log_diff(r1, r0), _log_diff(rg, r0), _log_diff(rg, r1)
        v0, v1, vg = three_cornered_hat(d01, d0g, d1g)
        pair_rms = " / ".join(f"{_rms(_norm_deg(d)):.3f}" for d in (d01, d0g, d1g))
        lines.append(f"| {0.05 * n:.1f} s | {len(a)} | {sig(v0)} | {sig(v1)} | {sig(vg)} | {pair_rms} |")
    # the time shift over 0.2 s intervals, both cameras
    a, b = _pairs(tc, 4)
    rg = _rel(G, a, b)
    X = wv[b] - np.einsum("nji,nj->ni", rg, wv[a])
    m = 0.5 * (_log_diff(rg, _rel(B0, a, b)) + _log_diff(rg, _rel(B1, a, b)))
    return lines, float(np.sum(X * m) / np.sum(X * X))


def _model_blocks(path: GyroPath, tc, G, wv, a, b) -> dict[str, np.ndarray]:
    """Regressors of the camera−gyro relative-rotation error (body frame at b) of each gyro error model."""
    blocks = {}
    for k, integral in path.integrals.items():
        i = np.clip(np.searchsorted(path.t, tc), 0, len(path.t) - 1)
        W = integral[i]
        blocks[k] = np.einsum("nki,nkjl->nijl", G[b], W[b] - W[a]).reshape(len(a), 3, 9)
    blocks["dt"] = (wv[b] - np.einsum("nji,nj->ni", _rel(G, a, b), wv[a]))[:, :, None]
    return blocks


def _explained(y: np.ndarray, X: np.ndarray, train: np.ndarray) -> tuple[float, float, np.ndarray]:
    A = X.reshape(len(X), 3, -1)
    c, *_ = np.linalg.lstsq(A[train].reshape(-1, A.shape[2]), y[train].ravel(), rcond=None)
    out = []
    for s in (train, ~train):
        r = y[s].ravel() - A[s].reshape(-1, A.shape[2]) @ c
        out.append(1.0 - float(r @ r) / float(y[s].ravel() @ y[s].ravel()))
    return out[0], out[1], c


def _bridge(qf: np.ndarray, tf: np.ndarray, gyro: np.ndarray, ref_R: np.ndarray, tref: np.ndarray,
            offset: np.ndarray) -> np.ndarray:  # fmt: skip
    """Plain gyro bridge of each window from the track's attitude at the samples just outside it (the mismatch at
    the end spread linearly in time); per window (max, RMS) of the error with the offset removed, degrees."""
    RF = dp.matrix_from_quat(qf)
    rows = []
    for a, b in OUTAGES:
        ia, ib = np.searchsorted(tf, a) - 1, np.searchsorted(tf, b)
        steps = dp.so3_exp(_mid(gyro[ia:ib + 1]) * np.diff(tf[ia:ib + 1])[:, None])
        Rf = RF[ia] @ _prefix_products(steps)
        mis = dp.so3_log(Rf[-1].T @ RF[ib])
        s = (tf[ia:ib + 1] - tf[ia]) / (tf[ib] - tf[ia])
        Rb = Rf @ dp.so3_exp(s[:, None] * mis[None, :])
        w = (tref >= a) & (tref < b)
        e = _norm_deg(_log_diff(ref_R[w], Rb[np.searchsorted(tf, tref[w]) - ia]) - offset)
        rows.append((e.max(), _rms(e)))
    return np.array(rows)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(DATA), help="imu_april directory")
    ap.add_argument("--calibration", required=True, help="camera-IMU calibration JSON of cam0")
    ap.add_argument("--markdown", help="also write the tables to this file (never overwritten)")
    args = ap.parse_args()
    if not Path(args.data, "cam0_aprilgrid.csv").is_file():
        print(f"imu_april data missing ({args.data})", file=sys.stderr)
        return 1
    src = read_target_recording(args.data)
    cal = read_camera_imu_calibration(args.calibration)
    imu = src.imu
    t0 = float(imu.stamps[0])

    def runs(source, calib):
        full_setup = prepare_track(source, calib, "cam0")
        out_setup = prepare_track(source, calib, "cam0", OUTAGES)
        full = run_track(full_setup, "eskf", outages=OUTAGES, output="smoothed")
        out = run_track(out_setup, "eskf", outages=OUTAGES, output="smoothed")
        return full_setup, full, out

    setup, full, out = runs(src, cal)
    ref, kept = setup.cache["reference", "cam1"]
    own = setup.cache["own"]
    pnp = body_trajectory(own, cal.rotation_xyzw, cal.translation_m, cal.time_offset_s)
    errs = {"out": _rotation_errors(ref, out.estimate), "full": _rotation_errors(ref, full.estimate),
            "pnp": _rotation_errors(ref, pnp)}  # fmt: skip
    rows = _window_rows(errs, t0)
    # the two cameras' PnP through the stereo extrinsic (camera-only), in the body frame
    q1, _ = extrinsic_from_matrix(EUROC_T_BS["cam1"])
    R_bc1 = dp.matrix_from_quat(q1)
    T01 = src.rig.camera_extrinsics.get(("cam0", "cam1"))
    T01 = np.linalg.inv(src.rig.camera_extrinsics[("cam1", "cam0")]) if T01 is None else T01
    common, i0, i1 = np.intersect1d(own.stamps_ns, kept.stamps_ns, return_indices=True)
    Rc0, Rc1 = dp.matrix_from_quat(own.q_wc[i0]), dp.matrix_from_quat(kept.q_wc[i1])
    d_st = np.einsum("ij,nj->ni", R_bc1, _log_diff(Rc1, Rc0 @ T01[:3, :3]))
    d_st -= d_st.mean(axis=0)
    t_st = (common - imu.stamps_ns[0]) * 1e-9
    # the cost of the outage itself, no reference
    fe, oe = full.estimate, out.estimate
    dr = DEG * dp.quat_angle(oe.quats, fe.quats)
    gyro_norm = np.linalg.norm(imu.gyro, axis=1)
    rel = imu.stamps - t0
    mf, mp = full.metrics, full.metrics["camera_pnp"]
    lines = [
        f"calibration {args.calibration}; reference cam1 PnP ({mf['reference']['frames_scored']} frames); runs without "
        f"outages: smoothed {1e3 * mf['position_rmse_m']:.2f} mm / {mf['rotation_rmse_deg']:.3f}°, cam0 PnP "
        f"{1e3 * mp['position_rmse_m']:.2f} mm / {mp['rotation_rmse_deg']:.3f}°; constant rotation offset (mean error "
        f"vector, body x y z) of the smoothed run {np.round(DEG * errs['full'][2].mean(axis=0), 3).tolist()}°, of "
        f"cam0 PnP {np.round(DEG * errs['pnp'][2].mean(axis=0), 3).tolist()}°",
        "",
        "Per window, rotation error against the reference [deg], max / RMS over the reference frames inside "
        "(\"−c\": the run's constant offset removed); stereo: cam0 PnP vs cam1 PnP through sensors.yaml's stereo "
        "extrinsic, centred, max / RMS of |d| and of |d|/√2 (one camera's share); cost: smoothed with vs without the "
        "outage at the IMU samples inside:",
        "",
        "| outage [s] | max rate [rad/s] | frames | **outage run** max / RMS | outage run −c max / RMS | no outage max "
        "/ RMS | no outage −c max / RMS | cam0 PnP max / RMS | cam0 PnP −c max / RMS | stereo \\|d\\| max / RMS | "
        "one camera's floor max / RMS | cost of the outage max [deg] |",
        "|---|---:|---:|---|---|---|---|---|---|---|---|---:|",
    ]  # fmt: skip
    f2 = lambda r: f"{r[0]:.3f} / {r[1]:.3f}"  # noqa: E731
    for i, (a, b) in enumerate(OUTAGES):
        w_st = (t_st >= a) & (t_st < b)
        ds = _norm_deg(d_st[w_st])
        w_imu = (oe.stamps - t0 >= a) & (oe.stamps - t0 < b)
        nf = int(((errs["out"][0] - t0 >= a) & (errs["out"][0] - t0 < b)).sum())
        o, f, p = rows["out"][i], rows["full"][i], rows["pnp"][i]
        lines.append(
            f"| {a:g}–{b:g} | {gyro_norm[(rel >= a) & (rel < b)].max():.2f} | {nf} | **{f2(o)}** | {f2(o[2:])} | "
            f"{f2(f)} | {f2(f[2:])} | {f2(p)} | {f2(p[2:])} | {ds.max():.3f} / {_rms(ds):.3f} | "
            f"{ds.max() / np.sqrt(2):.3f} / {_rms(ds) / np.sqrt(2):.3f} | {dr[w_imu].max():.3f} |")  # fmt: skip
    lines.append("| mean of the 7 | | | " + " | ".join(
        f2(rows[k].mean(axis=0)[j:j + 2]) for k in ("out", "full", "pnp") for j in (0, 2)) + " | | | |")  # fmt: skip
    n_ok = {k: int((rows[k][:, 0] <= 0.5).sum()) for k in rows}
    lines.append(f"\nwindows with max ≤ 0.5°: outage run {n_ok['out']}/7, no outage {n_ok['full']}/7, cam0 PnP "
                 f"{n_ok['pnp']}/7; per-camera PnP scatter (stereo |d|/√2, whole run): RMS "
                 f"{_rms(_norm_deg(d_st)) / np.sqrt(2):.3f}°, σ per body axis "
                 f"{np.round(DEG * d_st.std(axis=0) / np.sqrt(2), 3).tolist()}°")  # fmt: skip

    # --- sources of relative rotation over 0.2-1 s
    gyro_c, accel_c = cal.corrected_imu(imu.gyro, imu.accel)
    bg = np.asarray(cal.gyro_bias if cal.gyro_bias is not None else setup.start.alignment.gyro_bias)
    ba = np.asarray(cal.accel_bias if cal.accel_bias is not None else setup.start.alignment.accel_bias)
    path = GyroPath(imu.stamps, gyro_c - bg, accel_c - ba)
    q0, _ = cal.rotation_xyzw, cal.translation_m
    B0 = Rc0 @ dp.matrix_from_quat(np.asarray(q0)).T
    B1 = Rc1 @ R_bc1.T
    tc = common * 1e-9 + cal.time_offset_s
    G = path.at(tc)
    wv = path.rate(tc)
    hat, shift = _hat_lines(tc, B0, B1, G, wv)
    lines += ["", "Relative rotation over an interval: cam0 PnP, cam1 PnP, gyro (calibration's axis matrix and bias), "
              "three-cornered hat (body axes):", ""] + hat  # fmt: skip
    after = imu.stamps - t0 >= 10.0
    z_cam = dp.matrix_from_quat(np.asarray(q0))[:, 2]
    lines += ["", f"RMS body rate per axis (x y z) after the first 10 s: "
              f"{np.round(np.sqrt(np.mean(imu.gyro[after] ** 2, axis=0)), 2).tolist()} rad/s; cam0's optical axis "
              f"in the body frame {np.round(z_cam, 3).tolist()}"]  # fmt: skip

    # --- gyro error models, fitted on the first half, scored on the second
    lines += ["", "Mean of the two cameras minus the gyro, explained fraction by each gyro error model (fitted on the "
              "first half of the recording / scored on the second):", "",
              "| interval | E ω (scale, misalignment) | G f (g-sensitivity) | ω\\|ω\\| (quadratic) | time shift δ | "
              "E + G + δ |", "|---|---|---|---|---|---|"]  # fmt: skip
    for n in (4, 10, 20):
        a, b = _pairs(tc, n)
        blocks = _model_blocks(path, tc, G, wv, a, b)
        m = 0.5 * (_log_diff(_rel(G, a, b), _rel(B0, a, b)) + _log_diff(_rel(G, a, b), _rel(B1, a, b)))
        train = tc[a] < np.median(tc[a])
        cells = []
        for combo in (["E"], ["G"], ["Q"], ["dt"], ["E", "G", "dt"]):
            tr, te, _ = _explained(m, np.concatenate([blocks[k] for k in combo], axis=2), train)
            cells.append(f"{tr:.2f} / {te:+.2f}")
        lines.append(f"| {0.05 * n:.1f} s | " + " | ".join(cells) + " |")
    a, b = _pairs(tc, 4)
    seg = []
    for s0 in range(0, 72, 8):
        s = (tc[a] - t0 >= s0) & (tc[a] - t0 < s0 + 8)
        if s.sum() < 20:
            continue
        rg = _rel(G, a[s], b[s])
        X = wv[b[s]] - np.einsum("nji,nj->ni", rg, wv[a[s]])
        ds_ = [float(np.sum(X * _log_diff(rg, _rel(B, a[s], b[s]))) / np.sum(X * X)) for B in (B0, B1)]
        seg.append(f"{s0}–{s0 + 8} s: {1e3 * ds_[0]:+.2f} / {1e3 * ds_[1]:+.2f}")
    lines += ["", f"gyro–camera time shift δ (the cameras' attitude is the gyro's δ later; 0.2 s intervals, both "
              f"cameras): {1e3 * shift:+.2f} ms; per 8 s segment, cam0 / cam1 [ms]: " + "; ".join(seg)]  # fmt: skip

    # --- what online gyro states could learn: fitted on cam0 over the 8 s before each window, scored inside it
    lines += ["", "Learned before the window, used inside it (what gyro states in the filter could do at best): E "
              "fitted to cam0 − gyro on the 0.2 s / 0.5 s intervals of the 8 s before the window, scored on "
              "cam1 − gyro over the intervals inside the window (explained fraction; RMS |cam1 − gyro| before → after "
              "[deg]):", "", "| interval | model | " + " | ".join(f"{a:g}–{b:g}" for a, b in OUTAGES) + " |",
              "|---|---|" + "---|" * len(OUTAGES)]  # fmt: skip
    for n in (4, 10):
        a, b = _pairs(tc, n)
        blocks = _model_blocks(path, tc, G, wv, a, b)
        rg = _rel(G, a, b)
        y0, y1 = _log_diff(rg, _rel(B0, a, b)), _log_diff(rg, _rel(B1, a, b))
        for combo in (["E"],):
            X = np.concatenate([blocks[k] for k in combo], axis=2)
            cells = []
            for wa, wb in OUTAGES:
                before = (tc[a] - t0 >= wa - 8.0) & (tc[b] - t0 < wa)
                inside = (tc[a] - t0 >= wa) & (tc[b] - t0 <= wb + 0.01)
                c, *_ = np.linalg.lstsq(X[before].reshape(-1, X.shape[2]), y0[before].ravel(), rcond=None)
                r = y1[inside].ravel() - X[inside].reshape(-1, X.shape[2]) @ c
                y = y1[inside].ravel()
                cells.append(f"{1 - float(r @ r) / float(y @ y):+.2f} ({_rms(_norm_deg(y1[inside])):.2f} → "
                             f"{_rms(_norm_deg(r.reshape(-1, 3))):.2f})")  # fmt: skip
            lines.append(f"| {0.05 * n:.1f} s | {' + '.join(combo)} | " + " | ".join(cells) + " |")

    # --- re-run with the best constant E (cam0, whole run), and a plain gyro bridge
    a, b = _pairs(tc, 10)
    S = _model_blocks(path, tc, G, wv, a, b)["E"]
    E, *_ = np.linalg.lstsq(S.reshape(-1, 9), _log_diff(_rel(G, a, b), _rel(B0, a, b)).ravel(), rcond=None)
    E = E.reshape(3, 3)
    Mg = np.eye(3) if cal.gyro_axes_matrix is None else np.asarray(cal.gyro_axes_matrix)
    cal_e = replace(cal, gyro_axes_matrix=Mg @ np.linalg.inv(np.eye(3) + E),
                    accel_axes_matrix=cal.accel_axes_matrix if cal.accel_axes_matrix is not None else np.eye(3))
    lines += ["", "Re-run (smoothed output), per window max / RMS [deg] against the reference, with the gyro axis "
              f"matrix M_g (I + E)⁻¹, E fitted to cam0 over the whole run (‰: {np.round(1e3 * E, 2).tolist()}); and a "
              "plain gyro bridge from the outage run's attitude at the window ends (offset removed):", "",
              "| run | " + " | ".join(f"{a:g}–{b:g}" for a, b in OUTAGES) + " | windows ≤ 0.5° | no-outage RMSE "
              "[mm / deg] |", "|---|" + "---|" * (len(OUTAGES) + 2)]  # fmt: skip
    rmse = lambda m: f"{1e3 * m['position_rmse_m']:.2f} / {m['rotation_rmse_deg']:.3f}"  # noqa: E731
    lines.append("| as `fuse --outage` | " + " | ".join(f2(r) for r in rows["out"]) + f" | {n_ok['out']}/7 | "
                 f"{rmse(mf)} |")  # fmt: skip
    _, f_, o_ = runs(src, cal_e)
    r = _window_rows({"o": _rotation_errors(ref, o_.estimate)}, t0)["o"]
    lines.append("| best constant E | " + " | ".join(f2(x) for x in r) + f" | {int((r[:, 0] <= 0.5).sum())}/7 | "
                 f"{rmse(f_.metrics)} |")  # fmt: skip
    tf = oe.stamps - t0
    k0 = setup.start.imu_index
    if len(tf) != len(imu.stamps) - k0:
        raise RuntimeError("the smoothed output must hold every IMU sample from the start")
    offset = errs["out"][2].mean(axis=0)
    lines.append("| outage run, −c | " + " | ".join(f2(r[2:]) for r in rows["out"]) + " | | |")
    r = _bridge(oe.quats, tf, (gyro_c - bg)[k0:], dp.matrix_from_quat(ref.quats), ref.stamps - t0, offset)
    lines.append("| plain gyro bridge, −c | " + " | ".join(f2(x) for x in r) + " | | |")
    return emit("\n".join(lines), args.markdown)


if __name__ == "__main__":
    sys.exit(main())
