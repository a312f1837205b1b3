"""A simulated calibration-target recording with lens distortion (the simulator's eight, landmarks seen through a
radial-tangential camera), as :func:`dualpose.io.target.recording.read_target_recording` would return it."""

from __future__ import annotations

import math

import numpy as np

import dualpose as dp
from dualpose import sim
from dualpose.io.euroc import ImuData
from dualpose.io.target.recording import TargetRecording
from dualpose.pipelines.track_target import target_recording_lines
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
        pix, pts, corner, counts = [], [], [], []
        for k in range(len(f.t)):
            ids = f.landmark_ids[f.offsets[k] : f.offsets[k + 1]]
            pw = run.landmarks[ids]
            pc = camera_points(kin["quat"][k], kin["position"][k], q_bc, p_bc, pw)
            uv = CAMERA.project(pc) + pixel_sigma * rng.standard_normal((len(pw), 2))
            inside = (uv[:, 0] > 0) & (uv[:, 0] < CAMERA.width) & (uv[:, 1] > 0) & (uv[:, 1] < CAMERA.height)
            pix.append(uv[inside])
            pts.append(pw[inside])
            corner.append(ids[inside])  # the landmark's index: unique within the frame
            counts.append(int(inside.sum()))
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        fns = np.round(f.t * 1e9).astype(np.int64)
        m = int(offsets[-1])
        detections[name] = TargetDetections(fns, seconds_from_ns(fns), offsets, np.concatenate(pix),
                                            np.concatenate(pts), np.zeros(m, np.int64),
                                            np.concatenate(corner).astype(np.int64))  # fmt: skip
    rig = RigSensors(cameras={n: CAMERA for n in cams}, camera_rates={n: 20.0 for n in cams},
                     imu_noise=run.imu_noise, imu_rate=run.imu_noise.update_rate,
                     gravity_magnitude=float(np.linalg.norm(run.gravity)), camera_extrinsics={})  # fmt: skip
    cal = CameraImuCalibration("cam0", run.q_bc, run.p_bc, 0.0, pixel_sigma)
    truth = Trajectory(imu.stamps, run.truth["position"], run.truth["quat"], ns)
    M = np.eye(4)
    M[:3, :3] = dp.matrix_from_quat(run.q_bc)
    M[:3, 3] = p1
    return TargetRecording(imu=imu, detections=detections, rig=rig, path="sim"), cal, truth, {"cam1": M.ravel()}


def write_target_directory(directory, recording: TargetRecording) -> None:
    """Write ``recording`` in the imu_april layout: ``imu0.csv``, ``camN_aprilgrid.csv``, ``sensors.yaml``."""
    from pathlib import Path

    from dualpose.io.euroc import write_euroc_imu

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    write_euroc_imu(d / "imu0.csv", recording.imu)
    for name, det in recording.detections.items():
        rows = ["#timestamp [ns],u [px],v [px],X [m],Y [m],Z [m],tag_id,corner_idx"]
        for k in range(len(det)):
            a, b = det.offsets[k], det.offsets[k + 1]
            if a == b:
                rows.append(f"{det.stamps_ns[k]}")
            for i in range(a, b):
                nums = ",".join(map(repr, [*det.pixels[i].tolist(), *det.points[i].tolist()]))
                rows.append(f"{det.stamps_ns[k]},{nums},{det.tag_id[i]},{det.corner_id[i]}")
        (d / f"{name}_aprilgrid.csv").write_text("\n".join(rows) + "\n")
    n = recording.rig.imu_noise
    lines = [
        f"imu0: {{rate_hz: {float(recording.rig.imu_rate)!r}, gyroscope_noise_density: "
        f"{float(n.gyroscope_noise_density)!r}, gyroscope_random_walk: {float(n.gyroscope_random_walk)!r}, "
        f"accelerometer_noise_density: {float(n.accelerometer_noise_density)!r}, accelerometer_random_walk: "
        f"{float(n.accelerometer_random_walk)!r}, gravity_m_s2: {float(recording.rig.gravity_magnitude)!r}}}"
    ]
    for name, cam in recording.rig.cameras.items():
        lines += [
            f"{name}:",
            f"  resolution: [{cam.width}, {cam.height}]",
            "  rate_hz: 20.0",
            "  camera_model: pinhole",
            f"  intrinsics_fx_fy_cx_cy: [{cam.fx!r}, {cam.fy!r}, {cam.cx!r}, {cam.cy!r}]",
            "  distortion_model: radial-tangential",
            f"  distortion_k1_k2_p1_p2: [{cam.k1!r}, {cam.k2!r}, {cam.p1!r}, {cam.p2!r}]",
        ]
    (d / "sensors.yaml").write_text("\n".join(lines) + "\n")


def stream_lines(src: TargetRecording, cal, t_end: float = math.inf) -> list[str]:
    """The recording up to ``t_end`` (s) as stream lines (:func:`target_recording_lines`)."""
    imu, det = src.imu, src.detections[cal.camera]
    keep = imu.stamps < t_end
    cut = TargetRecording(type(imu)(imu.stamps_ns[keep], imu.stamps[keep], imu.gyro[keep], imu.accel[keep], imu.name),
                          {cal.camera: det.select(det.t < t_end)}, src.rig, src.path)  # fmt: skip
    return target_recording_lines(cut, cal.camera, cal.time_offset_s)
