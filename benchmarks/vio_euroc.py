"""Visual–inertial odometry on EuRoC V1_01 (30 s, GTSAM's replay CSV): dualpose's MSCKF beside GTSAM's equivariant
filter (``gtsam_unstable.eqvio.EqVIOFilter``, gtsam >= 4.3, the ``bench`` extra), scored against the ground truth
(GPL-3.0, read from ``../shared/data/euroc/v101_30s``; never copied into the project).

Run: ``python benchmarks/vio_euroc.py`` (prints a Markdown table: docs/vio.md).  The MSCKF is the whole
``dualpose fuse`` job (:func:`dualpose.pipelines.vio.run_vio`).  EqVIO is replayed with the settings of the file's
``meta`` rows through the Python binding, which exposes position and velocity only: its row has the 4-DoF and
SE(3) ATE and the final drift, no orientation error.  The published EqVIO numbers of this segment (GTSAM's C++
``EqVIOFilterExample``: ATE 2.88 cm (4-DoF), 2.59 cm (SE(3)), orientation 1.16°, final error 0.53 % of 8.2 m) are
printed beside, since a replay through the binding need not match the C++ example bit for bit.
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

import numpy as np

from dualpose.io import read_euroc_groundtruth
from dualpose.io.feature_tracks import read_eqvio_csv
from dualpose.pipelines.vio import run_vio, vio_metrics
from dualpose.types import Trajectory

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "euroc" / "v101_30s"
PUBLISHED = {"ate_rmse_4dof_m": 0.0288, "ate_rmse_se3_m": 0.0259, "orientation_rmse_4dof_deg": 1.16,
             "final_drift_percent": 0.53}  # fmt: skip


def eqvio_replay(csv: Path) -> tuple[Trajectory, float] | None:
    """GTSAM's EqVIO over the file as GTSAM's C++ ``EqVIOFilterExample`` replays it: the filter built from the
    meta settings (state with the camera extrinsic ``T_ci``, initial covariance, process and input noise),
    initialised from the first IMU sample, the IMU samples up to each frame, then one update with the frame's
    normalised features (unit camera, noise = the normalised measurement variance); the position after every
    frame.  None when gtsam is not installed."""
    try:
        import gtsam
        from gtsam_unstable import eqvio
    except ImportError:
        return None
    rec = read_eqvio_csv(csv)
    m = {}
    for k, v in rec.meta.items():
        try:
            m[k] = float(v)
        except ValueError:
            continue
    p = eqvio.EqVIOFilterParams()
    names = {"initialPointDepth": ["eqf.initial_point_depth"], "initialPointVariance": ["eqf.initial_point_variance"],
             "outlierThresholdAbs": ["eqf.outlier_threshold_abs", "eqf.outlier_threshold_abs_norm"],
             "featureRetention": ["eqf.feature_retention"], "biasOmegaProcessVariance": ["eqf.process_var_bias_omega"],
             "biasAccelProcessVariance": ["eqf.process_var_bias_accel"],
             "attitudeProcessVariance": ["eqf.process_var_attitude"],
             "positionProcessVariance": ["eqf.process_var_position"],
             "velocityProcessVariance": ["eqf.process_var_velocity"],
             "cameraAttitudeProcessVariance": ["eqf.process_var_cam_attitude"],
             "cameraPositionProcessVariance": ["eqf.process_var_cam_position"],
             "pointProcessVariance": ["eqf.process_var_point"]}  # fmt: skip
    for attr, keys in names.items():  # later keys override earlier ones, as the C++ example's setParam
        for key in keys:
            if key in m:
                setattr(p, attr, m[key])
    if hasattr(p, "measurementNoiseVariance"):
        p.measurementNoiseVariance = m["eqf.measurement_noise_variance_norm"]
    Q = np.zeros((12, 12))
    for i, key in enumerate(("eqf.input_var_gyr", "eqf.input_var_acc", "eqf.input_var_gyr_bias_walk",
                             "eqf.input_var_acc_bias_walk")):  # fmt: skip
        Q[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = np.eye(3) * m[key]
    p.inputNoise = Q
    q = [m[f"T_ci_q{c}"] for c in "wxyz"]
    xi0 = eqvio.State()
    xi0.cameraOffset = gtsam.Pose3(gtsam.Rot3.Quaternion(*q), gtsam.Point3(m["T_ci_tx"], m["T_ci_ty"], m["T_ci_tz"]))
    sigma0 = np.eye(xi0.dim())
    for i, key in enumerate(("eqf.initial_var_bias_omega", "eqf.initial_var_bias_accel", "eqf.initial_var_attitude",
                             "eqf.initial_var_position", "eqf.initial_var_velocity", "eqf.initial_var_cam_attitude",
                             "eqf.initial_var_cam_position")):  # fmt: skip
        sigma0[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] *= m[key]
    f = eqvio.EqVIOFilter(xi0, sigma0, [], p)
    cam = gtsam.PinholeCameraCal3_S2(gtsam.Pose3(), gtsam.Cal3_S2(1.0, 1.0, 0.0, 0.0, 0.0))
    var = m["eqf.measurement_noise_variance_norm"]
    tr = rec.tracks
    t0 = time.perf_counter()
    out_t, out_p = [], []
    imu = []
    for k in range(len(rec.t)):
        u = eqvio.IMUInput()
        u.stamp, u.gyr, u.acc = float(rec.t[k]), rec.gyro[k], rec.accel[k]
        imu.append(u)
    f.initializeFromIMU(imu[0])
    now, k = float(rec.t[0]), 0
    for j in range(len(tr)):  # the IMU samples up to the frame, each held until the next (or the frame), then update
        tf = float(tr.t[j])
        while k < len(imu) and rec.t[k] < tf:
            end = min(float(rec.t[k + 1]) if k + 1 < len(imu) else tf, tf)
            if end > now:
                f.predict(imu[k], end - max(now, float(rec.t[k])))
                now = end
            if k + 1 < len(imu) and rec.t[k + 1] <= tf:
                k += 1
            else:
                break
        fr = tr.frame(j)
        meas = {int(i): np.asarray(v) for i, v in zip(fr.track_id, fr.uv, strict=True)}
        f.update(meas, cam, np.eye(2 * len(meas)) * var)
        out_t.append(tf + rec.t0)
        out_p.append(np.asarray(f.position()).reshape(3))
    wall = time.perf_counter() - t0
    quats = np.tile([0.0, 0.0, 0.0, 1.0], (len(out_t), 1))
    return Trajectory(np.asarray(out_t), np.asarray(out_p), quats, name="eqvio"), wall


def main() -> int:
    csv, gt_path = DATA / "eqvio_processed_30s.csv", DATA / "groundtruth.csv"
    if not csv.is_file() or not gt_path.is_file():
        print(f"data missing: {DATA}", file=sys.stderr)
        return 1
    t0 = time.perf_counter()
    run = run_vio(csv, truth=gt_path)
    total = time.perf_counter() - t0
    ours = run.metrics
    rows = [("dualpose MSCKF", ours["ate_rmse_4dof_m"], ours["ate_rmse_se3_m"], ours["orientation_rmse_4dof_deg"],
             ours["final_drift_percent"],
             f"filter {ours['filter_s']:.2f} s wall ({ours['realtime_factor']:.0f}× real time), "
             f"{ours['filter_cpu_s']:.2f} s CPU ({ours['realtime_factor_cpu']:.0f}×); job {total:.2f} s")]  # fmt: skip
    rep = eqvio_replay(csv)
    if rep is None:
        rows.append(("GTSAM EqVIO (binding)", math.nan, math.nan, math.nan, math.nan, "gtsam not installed"))
    else:
        traj, wall = rep
        gt = read_euroc_groundtruth(gt_path)
        after = traj.stamps >= run.estimate.stamps[0]
        est = Trajectory(traj.stamps[after], traj.positions[after], traj.quats[after])
        try:
            e = vio_metrics(gt, est)
            if not e["ate_rmse_4dof_m"] < 1.0:
                raise ValueError(f"diverged (ATE {e['ate_rmse_4dof_m']:.3g} m): this replay does not reproduce "
                                 "the C++ example")  # fmt: skip
            rows.append(("GTSAM EqVIO (binding replay)", e["ate_rmse_4dof_m"], e["ate_rmse_se3_m"], math.nan,
                         e["final_drift_percent"], f"{wall:.2f} s"))  # fmt: skip
        except ValueError as exc:
            rows.append(("GTSAM EqVIO (binding replay)", math.nan, math.nan, math.nan, math.nan, f"failed: {exc}"))
    rows.append(("GTSAM EqVIO (published, C++ example)", PUBLISHED["ate_rmse_4dof_m"], PUBLISHED["ate_rmse_se3_m"],
                 PUBLISHED["orientation_rmse_4dof_deg"], PUBLISHED["final_drift_percent"], "7–8 s"))  # fmt: skip
    print("| estimator | ATE 4-DoF [cm] | ATE SE(3) [cm] | orientation 4-DoF [°] | final drift [% of path] | time |")
    print("|---|---|---|---|---|---|")
    for name, a, b, c, d, w in rows:
        def fmt(v: float, s: float = 1.0, f: str = ".2f") -> str:
            return "n/a" if math.isnan(v) else format(v * s, f)

        print(f"| {name} | {fmt(a, 100)} | {fmt(b, 100)} | {fmt(c)} | {fmt(d)} | {w} |")
    print(f"\npath length {ours['path_length_m']:.2f} m, {ours['n_matched']} matched poses after the rest "
          f"({ours['rest_s']:.2f} s); load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
