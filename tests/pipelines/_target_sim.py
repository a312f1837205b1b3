"""A simulated calibration-target recording with lens distortion (the simulator's eight, landmarks seen through a
radial-tangential camera), as :func:`dualpose.io.target_recording.read_target_recording` would return it."""

from __future__ import annotations

import numpy as np

import dualpose as dp
from dualpose import sim
from dualpose.io.euroc import ImuData
from dualpose.io.target_recording import TargetRecording
from dualpose.sim.camera_imu import camera_points
from dualpose.types import RadTanCamera, Trajectory
from dualpose.types.calibration import CameraImuCalibration
from dualpose.types.target import RigSensors, TargetDetections
from dualpose.types.trajectory import seconds_from_ns

#: the simulator's 320 x 240 camera (f = 213.3 px) with EuRoC-like barrel distortion
CAMERA = RadTanCamera(fx=640 / 3, fy=640 / 3, cx=160.0, cy=120.0, k1=-0.2, k2=0.05, p1=2e-4, p2=-1e-4, width=320,
                      height=240)  # fmt: skip
#: the reference camera "cam1": beside cam0 (11 cm along its x axis), same orientation
BASELINE_M = 0.11


def simulated_target_recording(seed: int = 0, pixel_sigma: float = 0.3, reference: bool = True):
    """``(TargetRecording, CameraImuCalibration of cam0, truth Trajectory at the IMU times, {"cam1": T_BS})``.

    The truth is only returned for the test to score against; nothing the pipeline reads carries it.
    """
    run = sim.simulate_eight(seed, landmarks_per_frame=40, camera_rate=20.0)
    rng = np.random.default_rng(seed + 100)
    ns = np.round(run.t * 1e9).astype(np.int64)
    imu = ImuData(ns, seconds_from_ns(ns), run.gyro, run.accel, "sim")
    f = run.frames
    kin = run.motion.kinematics(f.t_true)
    p1 = run.p_bc + dp.quat_rotate(run.q_bc, [BASELINE_M, 0.0, 0.0])
    cams = {"cam0": (run.q_bc, run.p_bc)}
    if reference:
        cams["cam1"] = (run.q_bc, p1)
    detections = {}
    for name, (q_bc, p_bc) in cams.items():
        pix, pts, counts = [], [], []
        for k in range(len(f.t)):
            ids = f.landmark_ids[f.offsets[k] : f.offsets[k + 1]]
            pw = run.landmarks[ids]
            pc = camera_points(kin["quat"][k], kin["position"][k], q_bc, p_bc, pw)
            uv = CAMERA.project(pc) + pixel_sigma * rng.standard_normal((len(pw), 2))
            inside = (uv[:, 0] > 0) & (uv[:, 0] < CAMERA.width) & (uv[:, 1] > 0) & (uv[:, 1] < CAMERA.height)
            pix.append(uv[inside])
            pts.append(pw[inside])
            counts.append(int(inside.sum()))
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        fns = np.round(f.t * 1e9).astype(np.int64)
        m = int(offsets[-1])
        ids = np.zeros(m, np.int64)
        detections[name] = TargetDetections(fns, seconds_from_ns(fns), offsets, np.concatenate(pix),
                                            np.concatenate(pts), ids, ids.copy())  # fmt: skip
    rig = RigSensors(cameras={n: CAMERA for n in cams}, camera_rates={n: 20.0 for n in cams},
                     imu_noise=run.imu_noise, imu_rate=run.imu_noise.update_rate,
                     gravity_magnitude=float(np.linalg.norm(run.gravity)), camera_extrinsics={})  # fmt: skip
    cal = CameraImuCalibration("cam0", run.q_bc, run.p_bc, 0.0, pixel_sigma)
    truth = Trajectory(imu.stamps, run.truth["position"], run.truth["quat"], ns)
    M = np.eye(4)
    M[:3, :3] = dp.matrix_from_quat(run.q_bc)
    M[:3, 3] = p1
    return TargetRecording(imu=imu, detections=detections, rig=rig, path="sim"), cal, truth, {"cam1": M.ravel()}
