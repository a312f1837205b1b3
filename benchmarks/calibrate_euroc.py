"""Camera–IMU calibration on EuRoC imu_april (docs/euroc.md): each camera calibrated independently against the IMU,
compared with EuRoC's published Kalibr extrinsics (Burri et al. 2016, mav0/cam0|cam1/sensor.yaml ``T_BS``) and,
composed (``T_cam0_cam1 = T_b_c0⁻¹ T_b_c1``), with the stereo extrinsic of sensors.yaml.

Run ``nice .venv/bin/python benchmarks/calibrate_euroc.py [--imu-models scale_misalignment calibrated]
[--bias-models random_walk constant] [--noise-scales 1 3 10] [--markdown PATH]`` (one full calibration per camera
and model pair, ≈ 20–90 s each on 2 shared cores).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

import dualpose as dp
from _common import emit
from dualpose.io import read_rig_sensors
from dualpose.pipelines.calibrate_camera_imu import EUROC_KALIBR_T_BS, calibrate_camera_imu_files, pose_matrix

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "euroc" / "imu_april"

def _angle_deg(R: np.ndarray) -> float:
    return math.degrees(float(np.linalg.norm(dp.so3_log(R))))


def _vec(v, scale: float = 1.0, fmt: str = "{:+.2f}") -> str:
    return " ".join(fmt.format(scale * x) for x in v)


def tables(imu_model: str, bias_model: str, noise_scale: float = 1.0) -> str:
    res = {}
    for cam in ("cam0", "cam1"):
        res[cam] = calibrate_camera_imu_files(str(DATA / "imu0.csv"), str(DATA / f"{cam}_aprilgrid.csv"),
                                              str(DATA / "sensors.yaml"), cam, bias_model, imu_model=imu_model,
                                              imu_noise_scale=noise_scale)  # fmt: skip
    scale = "" if noise_scale == 1.0 else f", IMU noise × {noise_scale:g}"
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
            f"| translation error [mm] (x y z) | {_vec(d)} (‖·‖ {np.linalg.norm(d):.2f}) |", ""]  # fmt: skip
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
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--imu-models", nargs="+", choices=("scale_misalignment", "calibrated"),
                    default=["scale_misalignment"])
    ap.add_argument("--bias-models", nargs="+", choices=("random_walk", "constant"), default=["random_walk"])
    ap.add_argument("--noise-scales", nargs="+", type=float, default=[1.0],
                    help="multiply the IMU noise of sensors.yaml (sensitivity study)")
    ap.add_argument("--markdown", default=None, help="also write the tables to this file (never overwritten)")
    args = ap.parse_args(argv)
    if not DATA.is_dir():
        print(f"EuRoC imu_april data missing ({DATA})", file=sys.stderr)
        return 1
    text = "\n\n".join(tables(i, b, f) for i in args.imu_models for b in args.bias_models for f in args.noise_scales)
    return emit(text, args.markdown)


if __name__ == "__main__":
    raise SystemExit(main())
