"""Camera–IMU calibration on EuRoC imu_april (docs/euroc.md): each camera calibrated independently against the IMU,
compared with EuRoC's published Kalibr extrinsics (Burri et al. 2016, mav0/cam0|cam1/sensor.yaml ``T_BS``) and,
composed (``T_cam0_cam1 = T_b_c0⁻¹ T_b_c1``), with the stereo extrinsic of sensors.yaml.

Run ``nice .venv/bin/python benchmarks/calibrate_euroc.py [--imu-models scale_misalignment calibrated
scale_misalignment_size_effect] [--bias-models
random_walk constant] [--noise-scales 1 3 10] [--option noise_model=motion huber=3 ...] [--intrinsics fixed distortion
radial focal+distortion focal all] [--window START END] [--stereo-ba] [--pan-by-view] [--frame-consistency]
[--min-obliquity 0 10 15 20] [--min-rate 0.2 0.4] [--target-scale 0.99 1.01] [--target-bow X_MM Y_MM]
[--markdown PATH]`` (one full calibration per camera and model pair, ≈ 5–30 s each on 2 shared cores; 1–4 min with
refined camera parameters, which take the NumPy path). ``--intrinsics`` refines the named
camera parameters in the batch, the others held at sensors.yaml's values by ``intrinsics_prior_sigma``. The
composition table gives the formal σ of the composition from the two runs' covariances (taken as independent) and the
error's Mahalanobis distance. ``--option KEY=VALUE`` passes options to ``calibrate_camera_imu`` (the hypotheses of
docs/euroc.md); ``--stereo-ba`` adds the camera-only stereo bundle adjustment of the same corner files (intrinsics
fixed as in sensors.yaml): the stereo extrinsic that the detections themselves imply; ``--pan-by-view`` each camera's
per-frame PnP pan against it by view obliquity, target distance, rate and time (with each ``--intrinsics`` choice's
refined parameters); ``--frame-consistency`` the per-frame χ² and the time correlation of the per-frame pose
corrections.  Diagnostics, not methods: ``--min-obliquity DEG`` calibrates from the frames whose own PnP view is at
least DEG from frontal, ``--min-rate`` from the frames turning at least that fast; ``--target-scale``,
``--target-bow`` give the sensitivity to the target's scale and flatness.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

import dualpose as dp
from _common import emit
from dualpose.calibration.camera_imu import calibrate_camera_imu
from dualpose.evaluation import target_reference
from dualpose.evaluation.target_reference import camera_poses
from dualpose.io import read_rig_sensors, read_target_detections
from dualpose.io.recording import read_imu
from dualpose.io.target.recording import read_target_recording
from dualpose.pipelines.calibrate_camera_imu import (
    EUROC_KALIBR_T_BS,
    calibrate_camera_imu_files,
    calibration_summary,
    pose_matrix,
)
from dualpose.types.camera import FrameCorrespondences

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "euroc" / "imu_april"

def _angle_deg(R: np.ndarray) -> float:
    return math.degrees(float(np.linalg.norm(dp.so3_log(R))))


def _vec(v, scale: float = 1.0, fmt: str = "{:+.2f}") -> str:
    return " ".join(fmt.format(scale * x) for x in v)


def stereo_bundle_adjustment(window: tuple[float, float] | None = None, details: bool = False,
                             parameters: dict[str, np.ndarray] | None = None) -> tuple:  # fmt: skip
    """Camera-only stereo calibration of the corner files with the intrinsics of sensors.yaml held fixed: a pose per
    frame seen by both cameras (≥ 8 corners each; started from cam0's PnP) and one ``T_cam0_cam1``, Gauss–Newton on
    the reprojection errors of both cameras (Huber at 1.5 σ, corners beyond 5 σ dropped after 5, 10 and 15 steps),
    the frame poses eliminated by their Schur complement.  Returns ``T_cam0_cam1`` (4, 4), the frame count, the
    final pixel σ and, per camera, the mean and RMS rotation (camera frame, deg) of its own per-frame PnP (frames
    with RMS < 0.7 px) relative to the adjusted pose of that camera."""
    src = read_target_recording(DATA)
    cams = {c: src.rig.camera(c) for c in ("cam0", "cam1")}
    if parameters is not None:  # camera parameters other than sensors.yaml's (refined by a camera-IMU run)
        cams = {c: with_parameters(cam, parameters[c]) for c, cam in cams.items()}
    det = src.detections
    ps0 = camera_poses(det["cam0"], cams["cam0"], 8)
    ns1 = det["cam1"].stamps_ns
    f1 = np.clip(np.searchsorted(ns1, ps0.stamps_ns), 0, len(ns1) - 1)
    ok = (ns1[f1] == ps0.stamps_ns) & (det["cam1"].counts[f1] >= 8)
    if window is not None:
        rel = (ps0.stamps_ns - src.imu.stamps_ns[0]) * 1e-9
        ok &= (rel >= window[0]) & (rel <= window[1])
    R = dp.matrix_from_quat(ps0.q_wc[ok]).swapaxes(1, 2)  # target -> cam0
    t = -np.einsum("kij,kj->ki", R, ps0.c_w[ok])
    T10 = np.linalg.inv(src.rig.T_cam0_cam1)
    R10, t10 = T10[:3, :3].copy(), T10[:3, 3].copy()
    data = []
    for cam, frames in (("cam0", ps0.frame[ok]), ("cam1", f1[ok])):
        d = det[cam]
        c = d.counts[frames]
        rows = d.offsets[frames][:, None] + np.arange(int(c.max()))[None, :]
        valid = np.arange(int(c.max()))[None, :] < c[:, None]
        rows = np.where(valid, rows, d.offsets[frames][:, None])
        data.append([cam, d.pixels[rows], d.points[rows], valid, valid.copy()])
    n, sigma = int(ok.sum()), 0.4
    for it in range(30):
        A, B, C = np.zeros((n, 6, 6)), np.zeros((n, 6, 6)), np.zeros((6, 6))
        ga, gc = np.zeros((n, 6)), np.zeros(6)
        res = []
        for k, (cam, U, X, valid, inl) in enumerate(data):
            RX = np.einsum("kij,kmj->kmi", R, X)
            x0 = RX + t[:, None]
            Jl = np.concatenate([-dp.so3_hat(RX), np.broadcast_to(np.eye(3), RX.shape + (3,))], axis=-1)
            Jg = np.zeros(RX.shape + (6,))
            xc = x0
            if k:
                xc = np.einsum("ij,kmj->kmi", R10, x0) + t10
                Jl = np.einsum("ij,kmjl->kmil", R10, Jl)
                Jg = np.concatenate([-dp.so3_hat(xc - t10), np.broadcast_to(np.eye(3), xc.shape + (3,))], axis=-1)
            uv, Jp = cams[cam].project_jacobian(np.where(valid[..., None], xc, [0.0, 0.0, 1.0]))
            r = uv - U
            res.append(r)
            s_ = np.linalg.norm(r, axis=-1) / sigma
            sw = np.sqrt(np.where(s_ <= 1.5, 1.0, 1.5 / np.maximum(s_, 1e-12)) * inl)
            Jl, Jg, rw = (Jp @ Jl) * sw[..., None, None], (Jp @ Jg) * sw[..., None, None], r * sw[..., None]
            A += np.einsum("kmai,kmaj->kij", Jl, Jl)
            B += np.einsum("kmai,kmaj->kij", Jl, Jg)
            C += np.einsum("kmai,kmaj->ij", Jg, Jg)
            ga += np.einsum("kmai,kma->ki", Jl, rw)
            gc += np.einsum("kmai,kma->i", Jg, rw)
        Ai = np.linalg.inv(A)
        S = C - np.einsum("kji,kjl,klm->im", B, Ai, B)
        dg = -np.linalg.solve(S, gc - np.einsum("kji,kjl,kl->i", B, Ai, ga))
        dl = -np.einsum("kij,kj->ki", Ai, ga + np.einsum("kij,j->ki", B, dg))
        R, t = dp.so3_exp(dl[:, :3]) @ R, t + dl[:, 3:]
        R10, t10 = dp.so3_exp(dg[:3]) @ R10, t10 + dg[3:]
        if it in (5, 10, 15):
            inl_r = np.concatenate([r[e[4]] for r, e in zip(res, data, strict=True)])
            sigma = 1.4826 * float(np.median(np.abs(inl_r)))
            for r, e in zip(res, data, strict=True):
                e[4] = e[3] & (np.linalg.norm(r, axis=-1) < 5 * sigma)
        if it > 16 and np.abs(dg).max() < 1e-10:
            break
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R10, t10
    pnp = {}
    per_frame: dict[str, np.ndarray] = {"R_c0_target": R, "t_c0_target": t, "stamps_ns": ps0.stamps_ns[ok]}
    for cam, frames, R_ba in (("cam0", ps0.frame[ok], R), ("cam1", f1[ok], np.einsum("ij,kjl->kil", R10, R))):
        ps = ps0 if cam == "cam0" else camera_poses(det[cam], cams[cam], 8)
        j = np.clip(np.searchsorted(ps.frame, frames), 0, len(ps.frame) - 1)
        m = (ps.frame[j] == frames) & (ps.rms_px[j] < 0.7)
        e = np.degrees(dp.so3_log(dp.matrix_from_quat(ps.q_wc[j[m]]).swapaxes(1, 2) @ np.swapaxes(R_ba[m], 1, 2)))
        pnp[cam] = (e.mean(axis=0), np.sqrt(np.mean(e**2, axis=0)))
        err = np.full((n, 3), np.nan)
        err[m] = e
        per_frame[f"{cam}_pnp_error_deg"] = err
    if details:
        return np.linalg.inv(T), n, sigma, pnp, per_frame
    return np.linalg.inv(T), n, sigma, pnp


def stereo_table(window: tuple[float, float] | None) -> str:
    stereo = read_rig_sensors(DATA / "sensors.yaml").T_cam0_cam1
    T, n, sigma, pnp = stereo_bundle_adjustment(window)
    rv = np.degrees(dp.so3_log(T[:3, :3] @ stereo[:3, :3].T))
    d = 1e3 * (T[:3, 3] - stereo[:3, 3])
    return "\n".join([
        "| camera-only stereo bundle adjustment of the same corners vs sensors.yaml `T_cam0_cam1` | value |",
        "|---|---|",
        f"| frames (both cameras ≥ 8 corners), pixel σ | {n}, {sigma:.3f} px |",
        f"| rotation error [deg] (rotation vector in cam0: {_vec(rv, fmt='{:+.4f}')}) | {np.linalg.norm(rv):.4f} |",
        f"| translation error [mm] (x y z) | {_vec(d)} (‖·‖ {np.linalg.norm(d):.2f}) |",
        *(f"| {c}'s per-frame PnP relative to the adjusted pose: mean (RMS) rotation [deg], camera axes | "
          f"{_vec(mu, fmt='{:+.4f}')} ({_vec(rms, fmt='{:.3f}')}) |" for c, (mu, rms) in pnp.items()),
        ""])  # fmt: skip


def with_parameters(camera: Any, parameters: np.ndarray) -> Any:
    """``camera`` (a radial–tangential model) with its 8 ``parameters`` (fx fy cx cy k1 k2 p1 p2) replaced."""
    names = ("fx", "fy", "cx", "cy", *camera.DISTORTION_NAMES)
    return dataclasses.replace(camera, **{k: float(v) for k, v in zip(names, parameters, strict=True)})


def obliquity_deg(R_ct: np.ndarray) -> np.ndarray:
    """Angle (deg) between the optical axis and the target's normal for camera←target rotations ``R_ct`` (F, 3, 3):
    0 for a frontal view."""
    n = R_ct[:, :, 2]
    out: np.ndarray = np.degrees(np.arctan2(np.linalg.norm(n[:, :2], axis=1), np.abs(n[:, 2])))
    return out


def pan_by_view_table(parameters: dict[str, np.ndarray] | None = None, label: str = "sensors.yaml") -> str:
    """Each camera's per-frame PnP rotation about its y axis (pan) relative to the stereo bundle adjustment's pose of
    that camera, by quintiles of the view's obliquity, the target's distance, the body rate and the time; both with
    the camera ``parameters`` (default: sensors.yaml's) and the PnP outlier gate at 10 px (refined parameters leave
    a frame of cam1 with fewer than 6 corners within the 3 px gate)."""
    src = read_target_recording(DATA)
    gate = target_reference.OUTLIER_PX
    target_reference.OUTLIER_PX = 10.0
    try:
        T, n, sigma, _, pf = stereo_bundle_adjustment(None, details=True, parameters=parameters)
    finally:
        target_reference.OUTLIER_PX = gate
    stereo = read_rig_sensors(DATA / "sensors.yaml").T_cam0_cam1
    ba_err = np.linalg.norm(np.degrees(dp.so3_log(T[:3, :3] @ stereo[:3, :3].T)))
    ba_dt = 1e3 * np.linalg.norm(T[:3, 3] - stereo[:3, 3])
    T10 = np.linalg.inv(T)
    ts = pf["stamps_ns"] * 1e-9
    centre = src.detections["cam0"].points.mean(axis=0)
    out = [f"Camera parameters: {label}; stereo BA vs sensors.yaml: {ba_err:.4f}°, {ba_dt:.2f} mm, pixel σ "
           f"{sigma:.3f} px", "",
           "| camera | feature | quintile ranges: mean pan of the per-frame PnP vs the stereo BA [deg] |",
           "|---|---|---|"]  # fmt: skip
    for cam in ("cam0", "cam1"):
        R, t = pf["R_c0_target"], pf["t_c0_target"]
        if cam == "cam1":
            R, t = np.einsum("ij,kjl->kil", T10[:3, :3], R), np.einsum("ij,kj->ki", T10[:3, :3], t) + T10[:3, 3]
        rel = np.einsum("kji,kjl->kil", R[:-1], R[1:])
        rate = np.linalg.norm(dp.so3_log(rel), axis=1) / np.diff(ts)
        feats = {"obliquity [deg]": obliquity_deg(R), "distance [m]": (np.einsum("kij,j->ki", R, centre) + t)[:, 2],
                 "rate [rad/s]": np.concatenate([rate, rate[-1:]]), "time [s]": ts - ts[0]}  # fmt: skip
        pan = pf[f"{cam}_pnp_error_deg"][:, 1]
        ok = np.isfinite(pan)
        out.append(f"| {cam} | all ({int(ok.sum())} frames) | {np.mean(pan[ok]):+.3f} |")
        for name, f in feats.items():
            q = np.quantile(f[ok], np.linspace(0.0, 1.0, 6))
            cells = [f"{a:.2f}–{b:.2f}: {np.mean(pan[ok & (f >= a) & (f <= b)]):+.3f}"
                     for a, b in zip(q[:-1], q[1:], strict=True)]
            out.append(f"| {cam} | {name} | {' · '.join(cells)} |")
    return "\n".join(out) + "\n"


def calibrate_oblique_views(cam: str, min_obliquity: float, window: tuple[float, float] | None,
                            full: bool = False, target: tuple[float, float, float] = (1.0, 0.0, 0.0),
                            min_rate: float = 0.0, **options: object) -> Any:  # fmt: skip
    """A diagnostic, not a method: ``cam`` calibrated from the frames whose own PnP view is at least
    ``min_obliquity`` degrees from frontal and turning at least ``min_rate`` rad/s (the gyro's rate at the frame's
    stamp; the others left out, the IMU bridging them), with the target's points
    scaled by ``target[0]`` and bowed by ``target[1:]`` (m: the sag at the target's x and y edges, ``z += s_x ξ² +
    s_y η²`` with ξ, η ∈ [−1, 1] across the target); returns the summary of ``calibrate_camera_imu_files`` (with
    ``full``: the ``CameraImuCalibration`` itself)."""
    rig = read_rig_sensors(DATA / "sensors.yaml")
    imu = read_imu(str(DATA / "imu0.csv"))
    det = read_target_detections(str(DATA / f"{cam}_aprilgrid.csv"))
    ps = camera_poses(det, rig.camera(cam), 8)
    keep = np.zeros(len(det.stamps_ns), dtype=bool)
    keep[ps.frame[obliquity_deg(dp.matrix_from_quat(ps.q_wc).swapaxes(1, 2)) >= min_obliquity]] = True
    ns0 = int(imu.stamps_ns[0])
    imu_t = (imu.stamps_ns - ns0) * 1e-9
    ft = (det.stamps_ns - ns0) * 1e-9
    use_imu = np.ones(len(imu_t), dtype=bool)
    keep &= np.interp(ft, imu_t, np.linalg.norm(imu.gyro, axis=1)) >= min_rate
    if window is not None:
        keep &= (ft >= window[0]) & (ft <= window[1])
        use_imu = (imu_t >= window[0] - 0.5) & (imu_t <= window[1] + 0.5)
    sel = det.select(keep)
    lo, hi = det.points.min(axis=0), det.points.max(axis=0)
    xi = (sel.points[:, :2] - 0.5 * (lo + hi)[:2]) / np.maximum(0.5 * (hi - lo)[:2], 1e-9)
    points = sel.points * target[0]
    points[:, 2] += target[1] * xi[:, 0] ** 2 + target[2] * xi[:, 1] ** 2
    frames = FrameCorrespondences((sel.stamps_ns - ns0) * 1e-9, sel.offsets, sel.pixels, points)
    res = calibrate_camera_imu(imu_t[use_imu], imu.gyro[use_imu], imu.accel[use_imu], frames, rig.camera(cam),
                               rig.imu_noise, rig.gravity_magnitude, **options)  # type: ignore[arg-type]
    return res if full else calibration_summary(res, cam)


def frame_consistency_table(window: tuple[float, float] | None, options: dict | None) -> str:
    """Per-frame consistency of the corners with the IMU-tied trajectory (``frame_pose_correction``,
    ``frame_pose_chi2`` of the result): χ², the mean pan correction and the autocorrelation of the rotation
    corrections over frames (lags in frames, 20 Hz), with the effective number of independent frames
    ``N / (1 + 2 Σ ρ)`` (lags 1–40)."""
    out = ["| camera | per-frame χ² (6 dof) mean, median | mean rotation correction [deg] (camera x y z) | "
           "autocorrelation of the pan correction, lags 1 2 5 10 20 40 | effective independent frames (pan) |",
           "|---|---|---|---|---|"]  # fmt: skip
    for cam in ("cam0", "cam1"):
        res = calibrate_oblique_views(cam, 0.0, window, full=True, **(options or {}))
        c, chi2 = res.frame_pose_correction, res.frame_pose_chi2
        rot = np.degrees(c[:, :3])
        x = rot[:, 1] - rot[:, 1].mean()
        rho = np.array([np.dot(x[:-k], x[k:]) / np.dot(x, x) for k in range(1, 41)])
        n_eff = len(x) / (1.0 + 2.0 * float(np.sum(rho)))
        out.append(f"| {cam} | {np.mean(chi2):.1f}, {np.median(chi2):.1f} | {_vec(rot.mean(axis=0), fmt='{:+.4f}')} | "
                   f"{_vec(rho[[0, 1, 4, 9, 19, 39]], fmt='{:.2f}')} | {n_eff:.0f} of {len(x)} |")  # fmt: skip
    return "\n".join(out) + "\n"


#: camera-parameter refinements in the batch (``--intrinsics``): the σ of the prior on (fx, fy, cx, cy, k1, k2, p1,
#: p2) at the values of sensors.yaml (``inf``: free; 1e-3 px / 1e-6 holds a parameter)
INTRINSICS = {
    "fixed": None,
    "focal": [math.inf, math.inf, 1e-3, 1e-3, 1e-6, 1e-6, 1e-6, 1e-6],
    "distortion": [1e-3, 1e-3, 1e-3, 1e-3, math.inf, math.inf, math.inf, math.inf],
    "radial": [1e-3, 1e-3, 1e-3, 1e-3, math.inf, math.inf, 1e-6, 1e-6],
    "focal+distortion": [math.inf, math.inf, 1e-3, 1e-3, math.inf, math.inf, math.inf, math.inf],
    "all": [math.inf] * 8,
}


def composition_covariance(m0: dict, m1: dict) -> np.ndarray:
    """Covariance (6, 6) of the composition ``T_b_c0⁻¹ T_b_c1``'s error ``[rotation vector in cam0 (rad),
    translation (m)]`` from the two calibrations' ``covariance`` (``[ε, p_bc]`` blocks; ``R̂_bc = Exp(ε) R_bc``),
    first order, the two runs taken as independent (they share the IMU record, so this is not exact)."""
    R0 = pose_matrix(m0)[:3, :3]
    dp_ = np.asarray(m1["translation_m"]) - np.asarray(m0["translation_m"])
    J0, J1 = np.zeros((6, 6)), np.zeros((6, 6))
    J0[:3, :3], J0[3:, 0:3], J0[3:, 3:] = -R0.T, R0.T @ dp.so3_hat(dp_), -R0.T
    J1[:3, :3], J1[3:, 3:] = R0.T, R0.T
    S0, S1 = (np.asarray(m["covariance"])[:6, :6] for m in (m0, m1))
    out: np.ndarray = J0 @ S0 @ J0.T + J1 @ S1 @ J1.T
    return out


#: the camera parameters of the last ``tables`` run per ``--intrinsics`` choice (for ``--pan-by-view``)
REFINED: dict[str, dict[str, np.ndarray]] = {}


def tables(imu_model: str, bias_model: str, noise_scale: float = 1.0, window: tuple[float, float] | None = None,
           options: dict | None = None, intrinsics: str = "fixed", min_obliquity: float = 0.0,
           target: tuple[float, float, float] = (1.0, 0.0, 0.0), min_rate: float = 0.0) -> str:  # fmt: skip
    res = {}
    if INTRINSICS[intrinsics] is not None:
        options = {**(options or {}), "estimate_intrinsics": True, "intrinsics_prior_sigma": INTRINSICS[intrinsics]}
    for cam in ("cam0", "cam1"):
        if min_obliquity > 0 or min_rate > 0 or target != (1.0, 0.0, 0.0):
            res[cam] = calibrate_oblique_views(cam, min_obliquity, window, target=target, min_rate=min_rate,
                                               bias_model=bias_model, imu_model=imu_model,
                                               **(options or {}))  # fmt: skip
            continue
        res[cam] = calibrate_camera_imu_files(str(DATA / "imu0.csv"), str(DATA / f"{cam}_aprilgrid.csv"),
                                              str(DATA / "sensors.yaml"), cam, bias_model, imu_model=imu_model,
                                              imu_noise_scale=noise_scale, frame_window=window,
                                              **(options or {}))  # fmt: skip
    REFINED[intrinsics] = {cam: np.asarray(m["camera_parameters"], dtype=np.float64) for cam, m in res.items()}
    scale = "" if noise_scale == 1.0 else f", IMU noise × {noise_scale:g}"
    scale += "" if window is None else f", frames {window[0]:g}–{window[1]:g} s"
    scale += "".join(f", {k}={v}" for k, v in (options or {}).items() if k not in ("estimate_intrinsics",
                                                                                  "intrinsics_prior_sigma"))
    scale += "" if intrinsics == "fixed" else f", camera parameters refined: {intrinsics}"
    scale += f", only views ≥ {min_obliquity:g}° from frontal (diagnostic)" if min_obliquity > 0 else ""
    scale += f", only frames turning at ≥ {min_rate:g} rad/s (diagnostic)" if min_rate > 0 else ""
    scale += f", target scaled × {target[0]:g}" if target[0] != 1.0 else ""
    scale += (f", target bowed by {1e3 * target[1]:g} / {1e3 * target[2]:g} mm at its x / y edges"
              if target[1:] != (0.0, 0.0) else "")  # fmt: skip
    out = [f"#### IMU model `{imu_model}`, bias model `{bias_model}`{scale}", "",
           "| camera | rotation vs Kalibr [deg] | translation − Kalibr [mm] (x y z) | ‖·‖ [mm] | τ [ms] | "
           "reprojection RMS [px] | frames used | corners rejected | runtime [s] |",
           "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for cam, m in res.items():
        T, Tk = pose_matrix(m), EUROC_KALIBR_T_BS[cam]
        dt = 1e3 * (T[:3, 3] - Tk[:3, 3])
        out.append(
            f"| {cam} | {_angle_deg(Tk[:3, :3].T @ T[:3, :3]):.3f} | {_vec(dt)} | {np.linalg.norm(dt):.2f} | "
            f"{1e3 * m['time_offset_s']:+.4f} ± {1e3 * m['std']['time_offset_s']:.4f} | "
            f"{m['reprojection_rms_px']:.3f} | {m['frames_used']} / {m['outliers']['frames_total']} | "
            f"{m['outliers']['corners_rejected']} / {m['outliers']['corners_total']} | {m['runtime_s']:.1f} |"
        )
    stereo = read_rig_sensors(DATA / "sensors.yaml").T_cam0_cam1
    est = np.linalg.inv(pose_matrix(res["cam0"])) @ pose_matrix(res["cam1"])
    d = 1e3 * (est[:3, 3] - stereo[:3, 3])
    rv = np.degrees(dp.so3_log(est[:3, :3] @ stereo[:3, :3].T))
    out += ["", "| composition `T_b_c0⁻¹ T_b_c1` vs sensors.yaml `T_cam0_cam1` | value |", "|---|---|",
            f"| rotation error [deg] (rotation vector in cam0: {_vec(rv, fmt='{:+.4f}')}) | "
            f"{_angle_deg(stereo[:3, :3].T @ est[:3, :3]):.4f} |",
            f"| translation error [mm] (x y z) | {_vec(d)} (‖·‖ {np.linalg.norm(d):.2f}) |"]  # fmt: skip
    cov = composition_covariance(res["cam0"], res["cam1"])
    sr, st = np.degrees(np.sqrt(np.diag(cov)[:3])), 1e3 * np.sqrt(np.diag(cov)[3:])
    e = np.concatenate([np.radians(rv), d * 1e-3])
    out += [f"| formal σ of the composition (the two runs' covariances, taken as independent): rotation [deg] "
            f"(cam0 x y z), translation [mm] | {_vec(sr, fmt='{:.4f}')}, {_vec(st)} |",
            f"| error / σ per axis: rotation, translation | {_vec(e[:3] / np.sqrt(np.diag(cov)[:3]), fmt='{:+.1f}')}, "
            f"{_vec(e[3:] / np.sqrt(np.diag(cov)[3:]), fmt='{:+.1f}')} |",
            f"| Mahalanobis distance of the 6-dof error (χ²(6) 99 %: 4.1) | "
            f"{math.sqrt(float(e @ np.linalg.solve(cov, e))):.1f} |", ""]  # fmt: skip
    out += ["| camera | σ rotation [deg] (IMU x y z) | σ translation [mm] | gyro bias [rad/s] (σ) | "
            "accel bias [m/s²] (σ) | gravity in target [m/s²] (σ deg) | IMU χ²/dof |",
            "|---|---|---|---|---|---|---|"]  # fmt: skip
    for cam, m in res.items():
        s = m["std"]
        out.append(
            f"| {cam} | {_vec(s['rotation_deg'], fmt='{:.4f}')} | {_vec(s['translation_m'], 1e3, '{:.3f}')} | "
            f"{_vec(m['gyro_bias'], fmt='{:+.5f}')} ({_vec(s['gyro_bias'], fmt='{:.1e}')}) | "
            f"{_vec(m['accel_bias'], fmt='{:+.4f}')} ({_vec(s['accel_bias'], fmt='{:.1e}')}) | "
            f"{_vec(m['gravity_target'], fmt='{:+.4f}')} ({s['gravity_target_deg']:.4f}) | "
            f"{m['imu_chi2_per_dof']:.2f} |"
        )
    if intrinsics != "fixed":
        out += ["", "| camera | refined − sensors.yaml: fx fy cx cy [px], k1 k2 p1 p2 (σ) |", "|---|---|"]
        for cam, m in res.items():
            d = np.asarray(m["camera_parameters"]) - read_rig_sensors(DATA / "sensors.yaml").camera(cam).parameters
            sd = np.asarray(m["camera_parameters_std"])
            out.append(f"| {cam} | {_vec(d[:4], fmt='{:+.3f}')}, {_vec(d[4:], fmt='{:+.4f}')} "
                       f"({_vec(sd[:4], fmt='{:.3f}')}, {_vec(sd[4:], fmt='{:.4f}')}) |")
    out += ["", "| camera | axis matrices | gyro `M − I` [‰] (rows) | accelerometer `M − I` [‰] (rows) |",
            "|---|---|---|---|"]  # fmt: skip
    for cam, m in res.items():
        rows = [("post-hoc fit", m["gyro_misalignment"], m["accel_misalignment"])]
        if "gyro_axes_matrix" in m:
            eye = np.eye(3)
            rows.append((f"in the batch (σ ≤ {1e3 * max(m['imu_axes_std']):.2f} ‰)",
                         np.array(m["gyro_axes_matrix"]) - eye, np.array(m["accel_axes_matrix"]) - eye))  # fmt: skip
        for name, g, a in rows:
            gs = "; ".join(_vec(r, 1e3, "{:+.2f}") for r in g)
            acc = "; ".join(_vec(r, 1e3, "{:+.2f}") for r in a)
            out.append(f"| {cam} | {name} | {gs} | {acc} |")
    if all("accel_axis_positions_m" in m for m in res.values()):
        out += ["", "| camera | accelerometer y axis position r_y [mm] (σ) | z axis position r_z [mm] (σ) |",
                "|---|---|---|"]  # fmt: skip
        for cam, m in res.items():
            r, sr = np.asarray(m["accel_axis_positions_m"]), np.asarray(m["accel_axis_positions_std_m"])
            out.append(f"| {cam} | {_vec(r[1], 1e3)} ({_vec(sr[:3], 1e3)}) | {_vec(r[2], 1e3)} ({_vec(sr[3:], 1e3)}) |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--imu-models", nargs="+",
                    choices=("scale_misalignment", "calibrated", "scale_misalignment_size_effect"),
                    default=["scale_misalignment"])
    ap.add_argument("--bias-models", nargs="+", choices=("random_walk", "constant"), default=["random_walk"])
    ap.add_argument("--noise-scales", nargs="+", type=float, default=[1.0],
                    help="multiply the IMU noise of sensors.yaml (sensitivity study)")
    ap.add_argument("--option", nargs="+", default=[], metavar="KEY=VALUE",
                    help="options of calibrate_camera_imu, e.g. noise_model=motion huber=3 reject_sigmas=3")
    ap.add_argument("--intrinsics", nargs="+", choices=tuple(INTRINSICS), default=["fixed"],
                    help="camera parameters refined in the batch (the rest held at sensors.yaml's values)")
    ap.add_argument("--window", nargs=2, type=float, default=None, metavar=("START", "END"),
                    help="only the frames in [START, END] s from the first IMU sample")
    ap.add_argument("--stereo-ba", action="store_true", help="add the camera-only stereo bundle adjustment")
    ap.add_argument("--pan-by-view", action="store_true",
                    help="add the per-frame PnP pan against the stereo bundle adjustment by obliquity, distance, rate")
    ap.add_argument("--min-rate", nargs="+", type=float, default=[0.0], metavar="RAD_S",
                    help="diagnostic: leave out the frames taken while the gyro turned slower than this")
    ap.add_argument("--target-scale", nargs="+", type=float, default=[], metavar="FACTOR",
                    help="also calibrate with the target's points scaled (sensitivity)")
    ap.add_argument("--target-bow", nargs=2, type=float, action="append", default=[], metavar=("X_MM", "Y_MM"),
                    help="also calibrate with the target bowed by this sag at its x and y edges (sensitivity)")
    ap.add_argument("--frame-consistency", action="store_true",
                    help="add the per-frame χ² and the autocorrelation of the per-frame pose corrections")
    ap.add_argument("--min-obliquity", nargs="+", type=float, default=[0.0], metavar="DEG",
                    help="diagnostic: leave out the frames whose own PnP view is within DEG of frontal")
    ap.add_argument("--markdown", default=None, help="also write the tables to this file (never overwritten)")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"EuRoC imu_april data missing ({DATA})", file=sys.stderr)
        return 1
    options = {}
    for item in args.option:
        key, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--option expects KEY=VALUE; got {item!r}")
        try:
            options[key] = float(value)
        except ValueError:
            options[key] = value
    window = tuple(args.window) if args.window else None
    targets = [(1.0, 0.0, 0.0)] + [(k, 0.0, 0.0) for k in args.target_scale if k != 1.0]
    targets += [(1.0, 1e-3 * bx, 1e-3 * by) for bx, by in args.target_bow]
    text = "\n\n".join(tables(i, b, f, window, options, c, o, tg, mr) for i in args.imu_models
                        for b in args.bias_models for f in args.noise_scales for c in args.intrinsics
                        for o in args.min_obliquity for tg in targets for mr in args.min_rate)  # fmt: skip
    if args.stereo_ba:
        text += "\n\n" + stereo_table(window)
    if args.pan_by_view:
        for c in args.intrinsics:
            par = None if c == "fixed" else REFINED[c]
            label = "sensors.yaml" if par is None else f"refined ({c}) by the runs above"
            text += "\n\n" + pan_by_view_table(par, label)
    if args.frame_consistency:
        for c in args.intrinsics:
            extra = {} if INTRINSICS[c] is None else {"estimate_intrinsics": True,
                                                      "intrinsics_prior_sigma": INTRINSICS[c]}  # fmt: skip
            text += f"\n\nCamera parameters: {c}\n\n" + frame_consistency_table(window, {**options, **extra})
    return emit(text, args.markdown)


if __name__ == "__main__":
    raise SystemExit(main())
