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
    """GTSAM's EqVIO over the file: IMU predictions, one update per frame with the features in pixels (camera =
    T_ci with the meta intrinsics, noise = the meta pixel variance).  None when gtsam is not installed."""
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
    names = {"attitudeProcessVariance": "eqf.process_var_attitude",
             "positionProcessVariance": "eqf.process_var_position",
             "velocityProcessVariance": "eqf.process_var_velocity", "pointProcessVariance": "eqf.process_var_point",
             "cameraAttitudeProcessVariance": "eqf.process_var_cam_attitude",
             "cameraPositionProcessVariance": "eqf.process_var_cam_position",
             "biasOmegaProcessVariance": "eqf.process_var_bias_omega",
             "biasAccelProcessVariance": "eqf.process_var_bias_accel", "initialPointDepth": "eqf.initial_point_depth",
             "initialPointVariance": "eqf.initial_point_variance", "featureRetention": "eqf.feature_retention",
             "outlierThresholdAbs": "eqf.outlier_threshold_abs"}  # fmt: skip
    for attr, key in names.items():
        if key in m:
            setattr(p, attr, m[key])
    Q = np.zeros((12, 12))
    for i, key in enumerate(("eqf.input_var_gyr", "eqf.input_var_acc", "eqf.input_var_gyr_bias_walk",
                             "eqf.input_var_acc_bias_walk")):  # fmt: skip
        Q[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = np.eye(3) * m[key]
    p.inputNoise = Q
    f = eqvio.EqVIOFilter(p)
    q = [m[f"T_ci_q{c}"] for c in "wxyz"]
    T_ci = gtsam.Pose3(gtsam.Rot3.Quaternion(*q), gtsam.Point3(m["T_ci_tx"], m["T_ci_ty"], m["T_ci_tz"]))
    K = np.array([m["camera_fx"], m["camera_fy"], m["camera_cx"], m["camera_cy"]])
    cam = gtsam.PinholeCameraCal3_S2(T_ci, gtsam.Cal3_S2(K[0], K[1], 0.0, K[2], K[3]))
    var = m["eqf.measurement_noise_variance_px"]
    tr = rec.tracks
    t0 = time.perf_counter()
    out_t, out_p = [], []
    j = 0
    for k in range(len(rec.t)):
        u = eqvio.IMUInput()
        u.stamp, u.gyr, u.acc = float(rec.t[k]), rec.gyro[k], rec.accel[k]
        if not f.isInitialized():
            f.initializeFromIMU(u)
        if k > 0:
            f.predict(u, float(rec.t[k] - rec.t[k - 1]))
        while j < len(tr) and tr.t[j] <= rec.t[k] + 1e-9:
            fr = tr.frame(j)
            px = fr.uv * K[:2] + K[2:]
            meas = {int(i): np.asarray(v) for i, v in zip(fr.track_id, px, strict=True)}
            f.update(meas, cam, np.eye(2 * len(meas)) * var)
            j += 1
        out_t.append(rec.t[k] + rec.t0)
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
             ours["final_drift_percent"], f"{ours['filter_s']:.2f} s filter, {total:.2f} s job")]  # fmt: skip
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
          f"({ours['rest_s']:.2f} s)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
