"""Tracking a camera–IMU rig against a calibration target: ``dualpose fuse --data DIR --camera cam0
--calibration CALIB.json`` on a target recording (EuRoC ``imu_april`` layout, :mod:`dualpose.io.target.recording`);
docs/fusion.md, "Tracking on EuRoC imu_april".

The world frame is the **target frame**; the output is the IMU's pose in it.  Nothing about the motion is assumed
and no ground truth is used:

* **Measurements.** The measured (distorted) corners of the chosen camera are converted to the pixels of the same
  rays in the undistorted pinhole camera with the same ``fx, fy, cx, cy`` (``camera.ideal_pixels``), so the
  pinhole-model filters (ESKF, Hol22) apply unchanged.  Their noise σ (one number per run, as the filters take) is
  the calibration's reprojection RMS (measured pixels) times the RMS over the image of the undistortion's pixel
  scale (:func:`ideal_pixel_sigma`): undistortion stretches the image edges, and the noise with it.
* **Sensors.** Extrinsic and clock offset from the calibration file; the IMU samples corrected with the calibration's
  IMU axis models when it states them (``ω = M_g⁻¹ ω̃``, ``f = M_a⁻¹ f̃``,
  :meth:`~dualpose.types.calibration.CameraImuCalibration.corrected_imu`: in the batch and the stream alike, before
  the start-up and the filter); IMU noise from the rig's ``sensors.yaml`` as stated (not tuned), optionally with
  scale-factor uncertainties (``scale_sigmas``, :func:`track_imu_noise`; both filters model them);
  initial biases from the calibration file where it states them, otherwise estimated at start-up.
* **Start-up** (:func:`startup`, Hol's gravity alignment for a moving sensor): the camera's PnP poses over the first
  :data:`STARTUP_SECONDS` of frames and the IMU between them give the gyro bias, the direction of gravity in the
  target frame, the velocities and the accelerometer bias by linear least squares
  (:func:`dualpose.estimation.initialization.align_with_camera_poses`); the filter starts at the first frame of the
  window with its PnP pose (and covariance), the aligned velocity and the biases.  Gravity is *estimated*, never
  taken from the calibration file (its ``gravity_target`` is only compared:
  ``startup.gravity_angle_to_calibration_deg``).
* **Reference and scoring** (when the directory has another camera's detections, :func:`score_run`): the other
  camera's per-frame PnP (refined through its lens model) on frames with reprojection RMS < 0.7 px and >= 30 corners,
  mapped to the IMU with a *given* extrinsic of that camera (EuRoC's published one for cam1 by default,
  :data:`EUROC_T_BS`): independent of the tracked camera's measurements and of the filter.  Scored: position and
  rotation RMSE in the target frame (no alignment), the tracked camera's own per-frame PnP measured the same way, and
  the error inside camera outages (``outages``: the tracked camera's detections deleted over given windows).
* **Output** (:func:`run_track`): offline, the ESKF run smoothed by the RTS smoother segment by segment, never across
  a re-lock (:func:`smooth_segments`), with the causal filter's track beside it; or the causal filter, which is what
  :class:`TrackStream` gives.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

import dualpose as dp
from dualpose.estimation import initialization
from dualpose.estimation._fusion_stream import BlockResult, FrameUpdate
from dualpose.estimation._stream import GapWatch
from dualpose.estimation.eskf import ErrorStateEKF, EskfStream, InnovationReport
from dualpose.estimation.hol22 import Hol22Stream
from dualpose.estimation.smoother import rts_smooth
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE, StateLayout
from dualpose.evaluation.target_reference import (
    CameraPoses,
    body_trajectory,
    camera_poses,
    errors_against,
    reference_trajectory,
)
from dualpose.io.recording import RecordingError
from dualpose.io.target.recording import TargetRecording, read_camera_imu_calibration, read_target_recording
from dualpose.pipelines._checks import check_before_fuse, warned
from dualpose.pipelines._lines import StreamTimes, format_numbers
from dualpose.pipelines.calibrate_camera_imu import EUROC_KALIBR_T_BS
from dualpose.pipelines.fuse import FILTERS, FuseResult
from dualpose.pipelines.fuse_stream import FrameUse, parse_fusion_line
from dualpose.registration.pnp import PnPResult, solve_pnp_ransac
from dualpose.types import FilterStart, ImuNoise, Recording, SensorSetup, Trajectory
from dualpose.types._inputs import Doubt, gyro_rotation_doubt
from dualpose.types.calibration import CameraImuCalibration
from dualpose.types.camera_models import DistortedCamera
from dualpose.types.target import RigSensors, TargetDetections

__all__ = [
    "EUROC_T_BS",
    "MEMS_SCALE_SIGMAS",
    "RELOCK_MIN_ACCEPTED",
    "RELOCK_MIN_CORNERS",
    "RELOCK_VELOCITY_SIGMA",
    "STARTUP_SECONDS",
    "StartUp",
    "TrackSetup",
    "TrackStream",
    "SmoothedTrack",
    "TrackedRun",
    "extrinsic_from_matrix",
    "ideal_pixel_sigma",
    "imu_only",
    "lost_frame",
    "prepare_track",
    "relock_start",
    "run_relocking",
    "run_track",
    "score_run",
    "smooth_segments",
    "startup",
    "stream_track_lines",
    "target_recording_lines",
    "track_imu_noise",
]

#: length of the start-up window (s of camera frames from the first usable one): long enough for the hand-held
#: rotation to separate gravity from the accelerometer bias, short against the run
STARTUP_SECONDS = 10.0
#: frames used in the start-up alignment need this many corners
STARTUP_MIN_CORNERS = 10

#: EuRoC's published camera poses in the IMU frame (Burri et al. 2016, mav0/camN/sensor.yaml ``T_BS``, Kalibr),
#: row-major 4 x 4: ``x_imu = T x_cam`` -- the extrinsic the *reference* camera is mapped with
EUROC_T_BS = EUROC_KALIBR_T_BS


#: relative scale-factor + axis-alignment uncertainties ``(ε_g, ε_a)`` of a calibrated MEMS IMU (the class value of the
#: AHRS's ``gyro_scale_sigma`` / ``acc_scale_sigma``; datasheets of the class state ~1 % sensitivity tolerance and
#: ~0.05-0.5° axis misalignment before calibration): what ``scale_sigmas="mems"``, the tracking default, gives.  A
#: Kalibr-style ``sensors.yaml`` states white noise and random walks only; these terms stand for the scale and axis
#: errors it leaves out (docs/fusion.md, "Tracking on EuRoC imu_april")
MEMS_SCALE_SIGMAS = (0.005, 0.005)


def track_imu_noise(rig: RigSensors, scale_sigmas: tuple[float, float] | str = "mems") -> ImuNoise:
    """The IMU noise the tracking filters use: the rig's densities and random walks as stated (``sensors.yaml``), its
    rate, and the scale-factor uncertainties ``scale_sigmas = (ε_g, ε_a)`` (``ImuNoise.gyroscope_scale_sigma``,
    ``accelerometer_scale_sigma``; ``"mems"``, the default, for :data:`MEMS_SCALE_SIGMAS`; ``(0, 0)`` for Kalibr's
    noise model alone)."""
    bad = f"scale_sigmas must be two finite numbers >= 0 (or 'mems'); got {scale_sigmas!r}"
    if isinstance(scale_sigmas, str) and scale_sigmas != "mems":
        raise ValueError(bad)
    eg, ea = MEMS_SCALE_SIGMAS if isinstance(scale_sigmas, str) else scale_sigmas
    if not (math.isfinite(eg) and math.isfinite(ea) and eg >= 0 and ea >= 0):
        raise ValueError(bad)
    n = rig.imu_noise
    if n is None:
        raise ValueError(f"{rig.path}: no IMU noise densities (imu0) in the sensor file")
    rate = rig.imu_rate if math.isfinite(rig.imu_rate) else n.update_rate
    return replace(n, update_rate=rate, gyroscope_scale_sigma=float(eg), accelerometer_scale_sigma=float(ea))


def extrinsic_from_matrix(T: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """``(q_bc (4,) xyzw, p_bc (3,) m)`` of a row-major 4 x 4 pose of the camera in the body frame."""
    M = np.asarray(T, dtype=np.float64).reshape(4, 4)
    return dp.quat_from_matrix(M[:3, :3]), np.copy(M[:3, 3], order="C")


def ideal_pixel_sigma(camera: DistortedCamera, sigma_px: float, grid: tuple[int, int] = (32, 20)) -> float:
    """The noise σ of ideal (undistorted pinhole) pixels for measured-pixel noise ``sigma_px``.

    The ideal pixel of a measured pixel ``m`` is ``K · undistort(K⁻¹ m)``; its Jacobian is
    ``J = diag(fx, fy) · (∂distort/∂xy)⁻¹ · diag(1/fx, 1/fy)`` and isotropic noise σ becomes ``σ J Jᵀ``.  One σ per run
    (the filters take one): ``sigma_px`` times the RMS over a ``grid`` of pixels covering the image of
    ``sqrt(‖J‖_F² / 2)`` (1 for a pinhole; about 1.3 for EuRoC's cameras, 1.0 at the centre, 1.7 in the corners).
    Depends on the camera model only, so a stream can compute it before its first frame.
    """
    u = (np.arange(grid[0]) + 0.5) * camera.width / grid[0]
    v = (np.arange(grid[1]) + 0.5) * camera.height / grid[1]
    pix = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    xy, ok = camera.unproject(pix, return_valid=True)
    Jd = camera.distort_jacobian(xy[ok])
    f = np.array([camera.fx, camera.fy])
    J = np.linalg.inv(Jd) * f[:, None] / f[None, :]
    scale2 = np.einsum("nij,nij->n", J, J) / 2.0
    return float(sigma_px * np.sqrt(scale2.mean()))


@dataclass
class StartUp:
    """Where the filter starts (:func:`startup`).

    ``x`` (16,) :data:`~dualpose.estimation.state.ESKF_STATE` and ``P`` (15, 15) over ``ESKF_ERROR`` at IMU sample
    ``imu_index``; ``alignment`` the :class:`~dualpose.estimation.initialization.CameraImuAlignment`; ``frames``
    (K,) the detection frames used; ``gyro_bias_from`` / ``accel_bias_from`` "calibration" or "start-up".
    """

    x: np.ndarray
    P: np.ndarray
    imu_index: int
    alignment: initialization.CameraImuAlignment
    frames: np.ndarray
    gyro_bias_from: str
    accel_bias_from: str
    #: (gyroscope, camera) rotation between the window's camera poses, rad, summed over the intervals
    rotation_check: tuple[float, float] = (0.0, 0.0)

    def startup_doubts(self, where: str) -> list[Doubt]:
        """What the start-up doubts, each warned: a gyroscope that turns much farther than the camera
        (``gyro_rotation_doubt`` of ``dualpose.types._inputs``: deg/s; the check of a rest period does not fit a rig
        that moves from its first sample), and a gravity direction the start-up window determines poorly (the
        alignment's ``"gravity_sigma"`` doubt, ``gravity_sigma_doubt``)."""
        return warned(gyro_rotation_doubt(*self.rotation_check, where), self.alignment.doubt)

    def summary(self, calibration: CameraImuCalibration) -> dict[str, Any]:
        """JSON-ready start-up report (gravity, its σ and magnitude check, biases, angle to the calibration's)."""
        a = self.alignment
        out = {
            "frames": int(len(self.frames)),
            "gravity_target": a.gravity.tolist(),
            "gravity_sigma_deg": a.gravity_sigma_deg,
            "gravity_estimated_magnitude": float(np.linalg.norm(a.gravity_estimated)),
            "gyro_bias": a.gyro_bias.tolist(),
            "gyro_bias_from": self.gyro_bias_from,
            "accel_bias": a.accel_bias.tolist(),
            "accel_bias_from": self.accel_bias_from,
            "alignment_residual_rms": a.residual_rms,
            "gravity_angle_to_calibration_deg": None,
        }
        g = calibration.gravity_target
        if g is not None and np.linalg.norm(g) > 0:
            c = float(np.linalg.norm(np.cross(a.gravity, g)))
            out["gravity_angle_to_calibration_deg"] = math.degrees(math.atan2(c, float(a.gravity @ g)))
        return out


@dataclass
class TrackSetup:
    """Everything :func:`run_track` runs on: the filter's ``recording`` (ideal pixels, gravity from the start-up,
    IMU from the start sample), its ``start``, the ``source`` recording as read, the ``calibration``, the tracked
    ``camera`` name and the detections it was given (``detections``, after any outage deletion); ``doubts``: what
    the set-up checks of ``dualpose fuse --data`` doubted about the IMU (``check_before_fuse`` of
    ``dualpose.pipelines._checks``: gaps, a stated rate the stamps contradict), each already warned, and the
    gyroscope check of :meth:`StartUp.startup_doubts`."""

    recording: Recording
    start: StartUp
    source: TargetRecording
    calibration: CameraImuCalibration
    camera: str
    detections: TargetDetections
    doubts: list[Doubt] = field(default_factory=list)
    cache: dict[str | tuple[str, str], Any] = field(default_factory=dict, repr=False)


def _mean_sigma(cov: np.ndarray) -> np.ndarray:
    sigma: NDArray[np.float64] = np.sqrt(np.trace(cov, axis1=-2, axis2=-1) / 3.0)
    return sigma


def startup(
    t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, det: TargetDetections, camera: DistortedCamera,
    calibration: CameraImuCalibration,
    imu_noise: ImuNoise, gravity_magnitude: float,
) -> StartUp:
    """The filter start from the first :data:`STARTUP_SECONDS` of frames (module docstring).

    Parameters
    ----------
    t, gyro, accel : the IMU (s on the IMU clock, rad/s, m/s², body frame), at least up to the end of the window.
    det : the tracked camera's detections (raw pixels); camera : its lens model.
    calibration : extrinsic, clock offset, optional biases.
    imu_noise : ImuNoise.  gravity_magnitude : m/s².

    Raises
    ------
    ValueError
        Fewer than 3 usable frames in the window, or an alignment that is not determined.
    """
    tau = calibration.time_offset_s
    t_frames = det.t + tau
    usable = (det.counts >= STARTUP_MIN_CORNERS) & (t_frames >= t[0]) & (t_frames <= t[-1])
    if not usable.any():
        raise ValueError(f"no frame with >= {STARTUP_MIN_CORNERS} corners within the IMU's time span")
    t0 = t_frames[np.argmax(usable)]
    window = usable & (t_frames <= t0 + STARTUP_SECONDS)
    poses = camera_poses(det.select(window), camera, STARTUP_MIN_CORNERS)
    good = poses.rms_px <= 3.0 * np.median(poses.rms_px)  # blurred frames: a robust cut of the start-up poses
    if good.sum() < 3:
        raise ValueError(f"only {int(good.sum())} usable frames in the start-up window of {STARTUP_SECONDS:g} s")
    q_bc, p_bc = calibration.rotation_xyzw, calibration.translation_m
    body = body_trajectory(poses, q_bc, p_bc, tau, mask=good)
    cov_body = np.array([initialization.body_pose_from_camera(
        PnPResult(poses.q_wc[i], poses.c_w[i], poses.covariance[i], float(poses.rms_px[i]), 0), q_bc, p_bc)[2]
        for i in np.flatnonzero(good)])  # fmt: skip
    n = imu_noise
    al = initialization.align_with_camera_poses(
        t, gyro, accel, body.stamps, body.positions, body.quats, gravity_magnitude,
        position_sigma=float(np.median(_mean_sigma(cov_body[:, :3, :3]))),
        attitude_sigma=float(np.median(_mean_sigma(cov_body[:, 3:, 3:]))),
        accelerometer_noise_density=n.accelerometer_noise_density,
        gyro_bias=calibration.gyro_bias, accel_bias=calibration.accel_bias,
    )  # fmt: skip
    k0 = int(np.searchsorted(t, body.stamps[0] - 1e-6))
    x = ESKF_STATE.assemble(position=body.positions[0], velocity=al.velocity[0], quat=body.quats[0],
                            gyro_bias=al.gyro_bias, accel_bias=al.accel_bias)  # fmt: skip
    E = ESKF_ERROR
    P = np.zeros((E.dim, E.dim))
    pose = [E.slice("position"), E.slice("attitude")]
    for i, a in enumerate(pose):
        for j, b in enumerate(pose):
            P[a, b] = cov_body[0][3 * i : 3 * i + 3, 3 * j : 3 * j + 3]
    E.cov(P, "velocity")[:] = np.eye(3) * max(al.velocity_sigma, 1e-3) ** 2
    span = float(body.stamps[-1] - body.stamps[0])
    att = float(np.median(_mean_sigma(cov_body[:, 3:, 3:])))
    bg_sigma = math.sqrt(2.0) * att / span if calibration.gyro_bias is None else n.gyroscope_initial_bias_sigma
    ba_sigma = al.accel_bias_sigma if calibration.accel_bias is None else n.accelerometer_initial_bias_sigma
    E.cov(P, "gyro_bias")[:] = np.eye(3) * max(bg_sigma, 1e-5) ** 2
    E.cov(P, "accel_bias")[:] = np.eye(3) * max(ba_sigma, 1e-3) ** 2
    return StartUp(
        x=x, P=P, imu_index=k0, alignment=al, frames=np.flatnonzero(window)[poses.frame[good]],
        gyro_bias_from="start-up" if calibration.gyro_bias is None else "calibration",
        accel_bias_from="start-up" if calibration.accel_bias is None else "calibration",
        rotation_check=_rotation_check(t, gyro, body.stamps, body.quats),
    )  # fmt: skip


def _rotation_check(t: NDArray[np.float64], gyro: NDArray[np.float64], stamps: NDArray[np.float64],
                    q_wb: NDArray[np.float64]) -> tuple[float, float]:
    """``(gyro, camera)``: the rotations (rad) of the rates ``gyro`` (N, 3) rad/s at ``t`` (N,) s integrated between
    consecutive poses ``q_wb`` (K, 4) at ``stamps`` (K,) s (small-angle vector per interval), and of the poses
    themselves, each summed over the K - 1 intervals."""
    w = np.concatenate([np.zeros((1, 3)), np.cumsum(gyro[:-1] * np.diff(t)[:, None], axis=0)])
    at = np.column_stack([np.interp(stamps, t, w[:, k]) for k in range(3)])
    turned = float(np.linalg.norm(np.diff(at, axis=0), axis=1).sum())
    return turned, float(np.sum(dp.quat_angle(q_wb[:-1], q_wb[1:])))


def _frames_outside(det: TargetDetections, outages: Sequence[tuple[float, float]], t_first: float) -> np.ndarray:
    """Mask (F,) of the frames outside every outage window (s from ``t_first``, start inclusive, end exclusive); a
    ``ValueError`` for a window that holds no frame (it would delete nothing)."""
    keep = np.ones(len(det), bool)
    rel = det.t - t_first
    for a, b in outages:
        if not (math.isfinite(a) and math.isfinite(b) and b > a):
            raise ValueError(f"outage windows must be (start, end) seconds with end > start; got {(a, b)!r}")
        inside = (rel >= a) & (rel < b)
        if not inside.any():
            span = f"{rel[0]:.2f} to {rel[-1]:.2f} s" if len(rel) else "none"
            raise ValueError(f"outage {a:g}:{b:g} s holds no frame of the camera (its frames: {span} from the first "
                             "IMU sample)")  # fmt: skip
        keep &= ~inside
    return keep


def prepare_track(
    data: str | os.PathLike[str] | TargetRecording,
    calibration: str | os.PathLike[str] | CameraImuCalibration,
    camera: str = "cam0",
    outages: Sequence[tuple[float, float]] = (),
    scale_sigmas: tuple[float, float] | str = "mems",
) -> TrackSetup:
    """Read a target recording and a calibration and set the filter up (module docstring).

    Parameters
    ----------
    data : target-recording directory or a :class:`~dualpose.io.target.recording.TargetRecording`.
    calibration : calibration JSON or a :class:`~dualpose.types.calibration.CameraImuCalibration`.
    camera : the tracked camera (must be in ``sensors.yaml`` and have its detections in the directory).
    outages : (start, end) windows, seconds from the first IMU sample, whose frames of ``camera`` are deleted.
    scale_sigmas : the IMU scale-factor uncertainties ``(ε_g, ε_a)`` or ``"mems"`` (:func:`track_imu_noise`).

    Raises
    ------
    RecordingError
        Unreadable or inconsistent inputs (file and line, the available cameras, a calibration of another camera).
    """
    src = data if isinstance(data, TargetRecording) else read_target_recording(data)
    cal = calibration if isinstance(calibration, CameraImuCalibration) else read_camera_imu_calibration(calibration)
    if camera not in src.detections:
        raise RecordingError(f"{src.path}: no detections of camera {camera!r}; available: {', '.join(src.detections)}")
    if cal.camera != camera:
        raise RecordingError(f"the calibration is of camera {cal.camera!r}, but --camera is {camera!r}")
    rig = src.rig
    if rig.imu_noise is None:
        raise RecordingError(f"{rig.path}: no IMU noise densities (imu0) in the sensor file")
    model = rig.camera(camera)
    imu = src.imu
    det = src.detections[camera]
    det = det.select(_frames_outside(det, outages, float(imu.stamps[0])))
    g_mag = rig.gravity_magnitude if math.isfinite(rig.gravity_magnitude) else 9.81
    noise = track_imu_noise(rig, scale_sigmas)
    gyro, accel = cal.corrected_imu(imu.gyro, imu.accel)  # the calibration's IMU axis models, if any
    try:
        st = startup(imu.stamps, gyro, accel, det, model, cal, noise, g_mag)
    except ValueError as exc:
        raise RecordingError(f"{src.path}: cannot start the filter: {exc}") from None
    k0 = st.imu_index
    frames = det.correspondences(model)
    keep = frames.t + cal.time_offset_s > imu.stamps[k0]  # the start frame's corners gave the start pose
    sub = det.select(keep)
    frames = sub.correspondences(model)
    rec = Recording(
        t=imu.stamps[k0:], gyro=gyro[k0:], accel=accel[k0:], frames=frames, camera=model.pinhole(),
        q_bc=cal.rotation_xyzw, p_bc=cal.translation_m,
        pixel_sigma=ideal_pixel_sigma(model, cal.reprojection_rms_px), imu_noise=noise,
        time_offset=cal.time_offset_s, gravity=st.alignment.gravity, stamps_ns=imu.stamps_ns[k0:],
        name=f"{src.path} ({camera})",
    )  # fmt: skip
    doubts = check_before_fuse(rec, at_rest=False)  # too short, in g: RecordingError; doubts: RecordingWarning
    doubts += st.startup_doubts(rec.name or "recording")
    return TrackSetup(recording=rec, start=st, source=src, calibration=cal, camera=camera, detections=det,
                      doubts=doubts)


#: a frame with at least this many correspondences of which the χ² gate accepted fewer than half means the filter
#: has lost the target (after a long outage its prediction is outside the gate): it is re-locked on that frame
RELOCK_MIN_CORNERS = 20
RELOCK_MIN_ACCEPTED = 0.5
#: velocity 1σ after a re-lock (m/s): what the filter carried through the outage is not trusted
RELOCK_VELOCITY_SIGMA = 1.0


def relock_start(
    state: dict[str, Any], gyro: np.ndarray, dt: float, pixels: np.ndarray, points: np.ndarray,
    rec: Recording | SensorSetup,
) -> tuple[np.ndarray, np.ndarray] | None:
    """The error-state start ``(x (16,), P (15, 15))`` that re-locks a filter on a frame it rejected.

    ``state``: the filter's ``position``, ``velocity``, ``quat`` (q_wb), ``gyro_bias``, ``accel_bias`` and their
    bias covariances ``gyro_bias_cov``, ``accel_bias_cov`` (3, 3) at the IMU sample the frame was filtered at, ``dt``
    (s) after the frame.  Pose: the frame's PnP (seeded RANSAC + Gauss–Newton on its ideal pixels, covariance for the
    recording's pixel σ) mapped to the body, its attitude carried over ``dt`` with the bias-corrected ``gyro`` (3,);
    velocity and biases: the filter's, the velocity with 1σ :data:`RELOCK_VELOCITY_SIGMA`; no cross-covariances.
    None when the PnP fails.
    """
    try:
        pnp, inliers = solve_pnp_ransac(pixels, points, rec.camera.matrix, pixel_sigma=rec.pixel_sigma)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if inliers.sum() < RELOCK_MIN_CORNERS:
        return None
    p, q, cov = initialization.body_pose_from_camera(pnp, rec.q_bc, rec.p_bc)
    q = dp.quat_mul(q, dp.quat_from_rotvec((np.asarray(gyro) - state["gyro_bias"]) * dt))
    x = ESKF_STATE.assemble(position=p, velocity=state["velocity"], quat=q, gyro_bias=state["gyro_bias"],
                            accel_bias=state["accel_bias"])  # fmt: skip
    E = ESKF_ERROR
    P = np.zeros((E.dim, E.dim))
    pose = [E.slice("position"), E.slice("attitude")]
    for i, a in enumerate(pose):
        for j, b in enumerate(pose):
            P[a, b] = cov[3 * i : 3 * i + 3, 3 * j : 3 * j + 3]
    E.cov(P, "velocity")[:] = np.eye(3) * RELOCK_VELOCITY_SIGMA**2
    E.cov(P, "gyro_bias")[:] = state["gyro_bias_cov"]
    E.cov(P, "accel_bias")[:] = state["accel_bias_cov"]
    return x, P


def lost_frame(counts: np.ndarray, accepted: np.ndarray) -> np.ndarray:
    """Mask of the frames (counts (F,) correspondences, ``accepted`` the per-correspondence flags in frame order)
    on which the filter has lost the target (:data:`RELOCK_MIN_CORNERS`, :data:`RELOCK_MIN_ACCEPTED`)."""
    offsets = np.concatenate([[0], np.cumsum(counts)])
    n_acc = np.add.reduceat(np.r_[accepted.astype(np.int64), 0], offsets[:-1]) if len(counts) else np.zeros(0)
    n_acc = np.where(counts > 0, n_acc, 0)
    return (counts >= RELOCK_MIN_CORNERS) & (n_acc < RELOCK_MIN_ACCEPTED * counts)


@dataclass
class TrackedRun:
    """The filtered run with its re-locks: states at the IMU times (``t`` (N,), ``position``, ``velocity`` (N, 3),
    ``quat`` (N, 4) q_wb, ``position_cov`` (N, 3, 3), ``attitude_sigma_deg`` (N,) or None), the per-correspondence
    ``nis`` / ``accepted`` in processing order, ``relocks`` (the IMU times of the re-locks), ``wall_time`` (s, all
    filter runs)."""

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    quat: np.ndarray
    position_cov: np.ndarray
    attitude_sigma_deg: np.ndarray | None
    nis: np.ndarray
    accepted: np.ndarray
    bounds: tuple[float, float]
    gate: float
    relocks: list[float]
    wall_time: float
    #: ``(imu_index, x (16,), P (15, 15))`` of every filter the run started: the start (index 0) and each re-lock
    #: (the IMU sample it re-initialised at, its error-state start); each segment runs to the next one's index
    segments: list[tuple[int, NDArray[np.float64], NDArray[np.float64]]] = field(default_factory=list)


def _new_stream(
    filter: str, sensors: Recording | SensorSetup, x: np.ndarray, P: np.ndarray
) -> EskfStream | Hol22Stream:
    """The streaming filter (:class:`~dualpose.estimation.eskf.EskfStream` / ``Hol22Stream``) of ``filter`` for
    ``sensors`` (a Recording or SensorSetup) started from the error-state ``(x, P)``."""
    f = FILTERS[filter](sensors, x, P)
    return EskfStream(f) if filter == "eskf" else Hol22Stream(f)


def _filter_state(layout: StateLayout, x: np.ndarray, C: np.ndarray) -> dict[str, Any]:
    """A stream's state ``x`` and covariance ``C`` (its ``state_layout``) in the error-state filter's terms (for
    :func:`relock_start`)."""
    hol = "quat_be" in layout.names
    cl = layout if hol else ESKF_ERROR  # Hol22: covariance over its state; ESKF: over its error state
    q = dp.quat_conj(layout.get(x, "quat_be")) if hol else layout.get(x, "quat")
    return {"position": layout.get(x, "position"), "velocity": layout.get(x, "velocity"), "quat": q,
            "gyro_bias": layout.get(x, "gyro_bias"), "accel_bias": layout.get(x, "accel_bias"),
            "gyro_bias_cov": cl.cov(C, "gyro_bias").copy(),
            "accel_bias_cov": cl.cov(C, "accel_bias").copy()}  # fmt: skip


def _relocked(
    state: Callable[[], dict[str, Any]], done: list[FrameUpdate], t: float, gyro: ArrayLike, accel: ArrayLike,
    sensors: Recording | SensorSetup, filter: str,
) -> tuple[EskfStream | Hol22Stream, NDArray[np.float64], NDArray[np.float64]] | None:
    """After the IMU sample ``(t, gyro, accel)`` with the filter in ``state`` (a callable giving
    :func:`_filter_state`'s dict): the first of the frames ``done`` (FrameUpdates filtered at that sample, in order)
    that the filter lost and that re-locks gives a new stream, started from :func:`relock_start` and fed that sample
    as its first, returned with that start ``(stream, x (16,), P (15, 15))``; None when no frame does.  The batch run
    and :class:`TrackStream` both call this."""
    for fu in done:
        n = len(fu.pixels)
        if fu.status != "done" or not n or not lost_frame(np.array([n]), fu.accepted)[0]:
            continue
        new = relock_start(state(), np.asarray(gyro, dtype=np.float64), t - fu.t, fu.pixels, fu.points, sensors)
        if new is None:
            continue
        fresh = _new_stream(filter, sensors, *new)
        fresh.update_imu(t, gyro, accel)
        return fresh, new[0], new[1]
    return None


#: frame-filtering IMU samples per compiled block of :func:`run_relocking`
BLOCK_GROUPS = 64


def run_relocking(rec: Recording, x: np.ndarray, P: np.ndarray, filter: str = "eskf") -> TrackedRun:
    """Run ``filter`` from ``(x, P)`` over ``rec`` and re-lock it on every frame it loses (:func:`lost_frame`,
    :func:`relock_start`): the streaming filter fed in compiled blocks
    (:meth:`~dualpose.estimation.eskf.EskfStream.update_batch`, the covariance after every sample); the frames of a
    block are checked sample by sample in order, and at the first re-lock the rest of the block is dropped and a new
    filter continues from that sample -- exactly what :class:`TrackStream` does line by line (the streams equal the
    batch filters bit for bit, docs/fusion.md "Streaming")."""
    f = rec.frames
    t, gyro, accel = rec.t, rec.gyro, rec.accel
    n = len(t)
    k_of = np.searchsorted(t, f.t + rec.time_offset, side="left")  # the IMU sample each frame is filtered at
    stream = _new_stream(filter, rec, x, P)
    L = stream.state_layout
    hol = "quat_be" in L.names
    cov_layout = L if hol else ESKF_ERROR
    starts = np.flatnonzero(np.diff(np.r_[-1, k_of]) != 0)  # first frame of each run of equal k_of
    starts = starts[k_of[starts] < n]  # frames after the last sample are never filtered
    ends = np.r_[starts[1:], np.searchsorted(k_of, n)] if len(starts) else starts
    Xs: list[np.ndarray] = []
    Cs: list[np.ndarray] = []
    nis: list[np.ndarray] = []
    acc: list[np.ndarray] = []
    relocks: list[float] = []
    segments: list[tuple[int, NDArray[np.float64], NDArray[np.float64]]] = [(0, np.array(x, dtype=np.float64),
                                                                           np.array(P, dtype=np.float64))]
    i, g, wall = 0, 0, 0.0
    o = f.offsets
    while g < len(starts):
        h = min(g + BLOCK_GROUPS, len(starts))
        k_last = int(k_of[starts[h - 1]])
        f0, f1 = starts[g], ends[h - 1]
        t0 = time.perf_counter()
        blk = stream.update_batch(t[i : k_last + 1], gyro[i : k_last + 1], accel[i : k_last + 1], f.t[f0:f1],
                                  o[f0 : f1 + 1] - o[f0], f.pixels[o[f0] : o[f1]], f.points[o[f0] : o[f1]],
                                  covariance=True)  # fmt: skip
        cov = blk.covariance
        assert cov is not None  # covariance=True
        keep_rows, keep_frames = len(blk.states), f1 - f0
        for q in range(g, h):
            k = int(k_of[starts[q]])
            row = k - i
            done = blk.frames[starts[q] - f0 : ends[q] - f0]

            def state_at(b: BlockResult = blk, c: np.ndarray = cov, r: int = row) -> dict[str, Any]:
                return _filter_state(L, b.states[r], c[r])

            relock = _relocked(state_at, done, float(t[k]), gyro[k], accel[k], rec, filter)
            if relock is not None:
                fresh = relock[0]
                segments.append((k, relock[1], relock[2]))
                keep_rows, keep_frames = row + 1, ends[q] - f0
                blk.states[row] = fresh.state
                cov[row] = fresh.covariance
                relocks.append(float(t[k]))
                stream, h = fresh, q + 1
                break
        wall += time.perf_counter() - t0
        Xs.append(blk.states[:keep_rows])
        Cs.append(cov[:keep_rows])
        for fu in blk.frames[:keep_frames]:
            nis.append(fu.nis)
            acc.append(fu.accepted)
        i, g = i + keep_rows, h
    if i < n:
        t0 = time.perf_counter()
        blk = stream.update_batch(t[i:], gyro[i:], accel[i:], covariance=True)
        wall += time.perf_counter() - t0
        assert blk.covariance is not None  # covariance=True
        Xs.append(blk.states)
        Cs.append(blk.covariance)
    X, C = np.concatenate(Xs), np.concatenate(Cs)
    quat = dp.quat_conj(L.get(X, "quat_be")) if hol else L.get(X, "quat")
    att = None if hol else np.degrees(np.sqrt(np.trace(cov_layout.cov(C, "attitude"), axis1=1, axis2=2)))
    return TrackedRun(
        t=t.copy(), position=L.get(X, "position"), velocity=L.get(X, "velocity"), quat=quat,
        position_cov=cov_layout.cov(C, "position"), attitude_sigma_deg=att,
        nis=np.concatenate(nis) if nis else np.zeros(0), accepted=np.concatenate(acc) if acc else np.zeros(0, bool),
        bounds=(float(chi2.ppf(0.025, 2)), float(chi2.ppf(0.975, 2))), gate=float(chi2.ppf(0.999, 2)),
        relocks=relocks, wall_time=wall, segments=segments,
    )  # fmt: skip


@dataclass
class SmoothedTrack:
    """The RTS-smoothed run of :func:`smooth_segments`: states at the IMU times (``t`` (N,) s, ``position``,
    ``velocity`` (N, 3) target frame, ``quat`` (N, 4) q_wb xyzw, ``position_cov`` (N, 3, 3) m², ``attitude_sigma_deg``
    (N,) the square root of the trace of the smoothed attitude-error covariance), ``segments`` (S,) the IMU index each
    smoothed segment starts at, ``wall_time`` (s: the segments' filter runs with their node records and the backward
    passes)."""

    t: NDArray[np.float64]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    quat: NDArray[np.float64]
    position_cov: NDArray[np.float64]
    attitude_sigma_deg: NDArray[np.float64]
    segments: NDArray[np.int64]
    wall_time: float


def smooth_segments(rec: Recording, run: TrackedRun) -> SmoothedTrack:
    """The error-state RTS smoother (:func:`dualpose.estimation.smoother.rts_smooth`) over an ESKF
    :func:`run_relocking` run, one segment per filter it started, so that no smoothing crosses a re-lock.

    Segment s runs from its start sample ``k_s`` (:attr:`TrackedRun.segments`, with its start ``(x, P)``) to the sample
    before the next start ``k_{s+1}``, over the frames filtered after ``k_s`` up to ``k_{s+1} − 1``: the batch filter
    (bit for bit the stream's states of the segment, docs/fusion.md "Streaming") is re-run with its node record and
    smoothed backwards from the segment's last sample, where smoother and filter agree.  The frames of the re-locking
    sample itself (the lost frame and any with it) belong to neither side: the old filter rejected them, the new one
    starts from them.  A one-sample segment keeps the filter's state.

    Raises
    ------
    ValueError
        ``run`` has no segment record, or it is not of the error-state filter (only its node record is smoothed).
    """
    if not run.segments or run.segments[0][0] != 0:
        raise ValueError("run must be a run_relocking result with its segments (the first starting at sample 0)")
    if run.attitude_sigma_deg is None:
        raise ValueError("smooth_segments needs an ESKF run (filter='eskf'): the RTS smoother runs over the "
                         "error-state filter's nodes")  # fmt: skip
    f = rec.frames
    t, n = rec.t, len(rec.t)
    tf = f.t + rec.time_offset
    o = f.offsets
    bounds = [k for k, _, _ in run.segments] + [n]
    position, velocity, quat = run.position.copy(), run.velocity.copy(), run.quat.copy()
    pos_cov, att = run.position_cov.copy(), run.attitude_sigma_deg.copy()
    wall = 0.0
    for (k0, x, P), k1 in zip(run.segments, bounds[1:], strict=True):
        if k1 - k0 < 2:
            continue
        j0, j1 = (int(v) for v in np.searchsorted(tf, [t[k0], t[k1 - 1]], side="right"))
        t0 = time.perf_counter()
        fr = ErrorStateEKF.from_state(rec, x, P).run(
            t[k0:k1], rec.gyro[k0:k1], rec.accel[k0:k1], f.t[j0:j1], o[j0 : j1 + 1] - o[j0], f.pixels[o[j0] : o[j1]],
            f.points[o[j0] : o[j1]], record_nodes=True,
        )  # fmt: skip
        sm = rts_smooth(fr)
        wall += time.perf_counter() - t0
        position[k0:k1], velocity[k0:k1], quat[k0:k1] = sm.position, sm.velocity, sm.quat
        pos_cov[k0:k1] = ESKF_ERROR.cov(sm.covariance, "position")
        att[k0:k1] = np.degrees(np.sqrt(np.trace(ESKF_ERROR.cov(sm.covariance, "attitude"), axis1=1, axis2=2)))
    return SmoothedTrack(t=t.copy(), position=position, velocity=velocity, quat=quat, position_cov=pos_cov,
                         attitude_sigma_deg=att, segments=np.array(bounds[:-1], dtype=np.int64),
                         wall_time=wall)  # fmt: skip


def run_track(
    setup: TrackSetup,
    filter: str = "eskf",
    reference_camera: str | None = None,
    outages: Sequence[tuple[float, float]] = (),
    progress: Callable[[int, int, str], None] | None = None,
    reference_extrinsics: Mapping[str, ArrayLike] = EUROC_T_BS,
    output: str | None = None,
) -> FuseResult:
    """Run ``filter`` on a :func:`prepare_track` set-up and score it against the other camera's reference.

    Parameters
    ----------
    setup : TrackSetup (its detections already without the ``outages`` frames).
    filter : {"eskf", "hol22"}.
    reference_camera : the camera whose PnP is the reference (default: the first other camera with detections and an
        extrinsic in ``reference_extrinsics``); no reference when there is none.
    outages : the windows deleted in :func:`prepare_track`, to report the errors inside them.
    progress : called as ``progress(done, total, stage)``.
    reference_extrinsics : camera name -> row-major 4 x 4 pose of that camera in the IMU frame, for the reference
        (default EuRoC's published ones, :data:`EUROC_T_BS`); never the tracked camera's calibration.
    output : {"smoothed", "filter"} or None
        The trajectory returned as ``estimate`` (and scored at the top level of ``metrics``): the offline RTS
        smoother over the run's segments (:func:`smooth_segments`; ESKF only) or the causal filter.  None: "smoothed"
        for the ESKF, "filter" for Hol22 (no smoother).

    Returns
    -------
    FuseResult
        ``estimate`` the ``output`` trajectory, ``truth`` the reference (at the frames the estimate covers), errors
        against it, and ``metrics`` with the start-up, the NIS, the real-time factors (filter and smoother; wall time:
        ``realtime_factor``, CPU time: ``realtime_factor_cpu``) and :func:`score_run`'s scores (``reference``: None
        without one); ``metrics["output"]`` names the output.  With
        ``output="smoothed"``: ``filtered`` is the causal filter's trajectory, ``metrics["causal_filter"]`` its scores
        (``position_rmse_m``, ``rotation_rmse_deg``, ``nees_position``, ``outages``) and ``metrics["smoother"]`` the
        number of segments, their IMU start indices and the smoother's time.

    Raises
    ------
    ValueError
        Unknown ``filter`` or ``output``, or ``output="smoothed"`` with a filter other than "eskf".
    """
    if filter not in FILTERS:
        raise ValueError(f"filter must be one of {tuple(FILTERS)}; got {filter!r}")
    out = output if output is not None else ("smoothed" if filter == "eskf" else "filter")
    if out not in ("smoothed", "filter"):
        raise ValueError(f"output must be 'smoothed', 'filter' or None; got {output!r}")
    if out == "smoothed" and filter != "eskf":
        raise ValueError(f"output='smoothed' needs filter 'eskf' (got {filter!r}): the RTS smoother runs over the "
                         "error-state filter's nodes")  # fmt: skip
    stages = ("filter", "smooth", "score")

    def step(k: int) -> None:
        if progress is not None:
            progress(k + 1, len(stages), stages[k])

    rec, st = setup.recording, setup.start
    no_frames = (np.zeros(0), np.zeros(1, np.int64), np.zeros((0, 2)), np.zeros((0, 3)))
    FILTERS[filter](rec, st.x, st.P).run(rec.t[:2], rec.gyro[:2], rec.accel[:2], *no_frames)  # load the kernel
    cpu = time.process_time()
    tr = run_relocking(rec, st.x, st.P, filter)
    step(0)
    filtered = Trajectory(tr.t, tr.position, tr.quat, rec.stamps_ns, name=f"dualpose fuse --filter {filter}")
    estimate, pos_cov, ori_sigma, sm = filtered, tr.position_cov, tr.attitude_sigma_deg, None
    if out == "smoothed":
        sm = smooth_segments(rec, tr)
        estimate = Trajectory(sm.t, sm.position, sm.quat, rec.stamps_ns,
                              name=f"dualpose fuse --filter {filter} (RTS-smoothed)")  # fmt: skip
        pos_cov, ori_sigma = sm.position_cov, sm.attitude_sigma_deg
    cpu = time.process_time() - cpu
    step(1)
    wall = tr.wall_time + (0.0 if sm is None else sm.wall_time)
    rep = InnovationReport(tr.nis, tr.accepted, 2, tr.bounds, tr.gate)
    metrics = {
        "data": setup.source.path,
        "camera": setup.camera,
        "filter": filter,
        "output": out,
        "duration_s": rec.duration,
        "imu_samples": int(len(rec.t)),
        "camera_frames": int(len(rec.frames)),
        "pixel_sigma_ideal_px": rec.pixel_sigma,
        "filter_wall_time_s": tr.wall_time,
        "realtime_factor": rec.duration / wall,
        "cpu_time_s": cpu,
        "realtime_factor_cpu": rec.duration / cpu if cpu > 0 else math.inf,
        **rep.summary(),
        "relocks": len(tr.relocks),
        "relock_times_s": [t - float(rec.t[0]) for t in tr.relocks],
        "startup": st.summary(setup.calibration),
        "input_doubts": [d.as_dict() for d in setup.doubts + _camera_doubts(rec, rep.summary())],
    }
    scores = score_run(setup, estimate, pos_cov, reference_camera, outages, reference_extrinsics)
    metrics.update(scores.pop("metrics"))
    if sm is not None:
        fs = score_run(setup, filtered, tr.position_cov, reference_camera, outages, reference_extrinsics)["metrics"]
        metrics["causal_filter"] = {k: fs[k] for k in ("position_rmse_m", "rotation_rmse_deg", "nees_position",
                                                       "outages")}  # fmt: skip
        metrics["smoother"] = {"segments": int(len(sm.segments)), "segment_start_samples": sm.segments.tolist(),
                               "wall_time_s": sm.wall_time}  # fmt: skip
    step(2)
    return FuseResult(
        estimate=estimate, metrics=metrics,
        position_sigma=np.sqrt(np.maximum(np.diagonal(pos_cov, axis1=1, axis2=2), 0)),
        orientation_sigma_deg=ori_sigma, nis=np.asarray(rep.nis), nis_accepted=np.asarray(rep.accepted, dtype=bool),
        nis_bounds=(float(rep.bounds[0]), float(rep.bounds[1])), filtered=None if sm is None else filtered, **scores,
    )  # fmt: skip


def _camera_doubts(rec: Recording, nis: Mapping[str, Any]) -> list[Doubt]:
    """The camera doubts of ``fuse --stream`` (:class:`~dualpose.pipelines.fuse_stream.FrameUse`) for a batch run:
    frames outside the IMU samples on the IMU clock, correspondences mostly rejected (``nis``:
    :meth:`InnovationReport.summary`); each warned."""
    use = FrameUse(rec.name or "recording")
    t = rec.frames.t + rec.time_offset
    use.given = len(t)
    use.used = int(np.count_nonzero((t >= rec.t[0]) & (t <= rec.t[-1])))
    use.points, use.accepted = int(nis["n_correspondences"]), int(nis["n_correspondences"] - nis["n_rejected"])
    d = use.finish()
    return [] if d is None else [d]


def _reference_camera(setup: TrackSetup, name: str | None, extrinsics: Mapping[str, ArrayLike]) -> str | None:
    if name is not None:
        if name not in setup.source.detections:
            raise RecordingError(f"{setup.source.path}: no detections of reference camera {name!r}; available: "
                                 f"{', '.join(setup.source.detections)}")  # fmt: skip
        if name not in extrinsics:
            raise RecordingError(f"no extrinsic for reference camera {name!r} (known: {', '.join(extrinsics)})")
        return name
    others = [c for c in setup.source.detections if c != setup.camera and c in extrinsics]
    return others[0] if others else None


def score_run(
    setup: TrackSetup,
    estimate: Trajectory,
    position_covariance: np.ndarray | None = None,
    reference_camera: str | None = None,
    outages: Sequence[tuple[float, float]] = (),
    reference_extrinsics: Mapping[str, ArrayLike] = EUROC_T_BS,
) -> dict[str, Any]:
    """Scores of ``estimate`` (body poses in the target frame at the IMU times) against the reference camera.

    Returns ``{"metrics": {...}, "truth": ..., "position_error": ..., "orientation_error_deg": ...,
    "error_index": ...}`` (the :class:`~dualpose.pipelines.fuse.FuseResult` fields; None without a reference).
    ``metrics``: ``reference`` (camera, frames, its median reprojection RMS), ``position_rmse_m``,
    ``rotation_rmse_deg``, ``camera_pnp`` (the tracked camera's per-frame PnP through the calibration's extrinsic,
    scored at the same reference frames), ``nees_position`` (mean of ``eᵀ (P_filter + P_reference)⁻¹ e`` over the
    reference frames, 3 dof), ``outages`` (per window: frames, position RMSE and maximum, rotation RMSE and maximum).
    """
    none = {"truth": None, "position_error": None, "orientation_error_deg": None, "error_index": None}
    ref_cam = _reference_camera(setup, reference_camera, reference_extrinsics)
    keys = ("reference", "position_rmse_m", "rotation_rmse_deg", "camera_pnp", "nees_position", "outages")
    if ref_cam is None:
        return {"metrics": dict.fromkeys(keys), **none}
    src = setup.source
    q1, p1 = extrinsic_from_matrix(reference_extrinsics[ref_cam])
    if ("reference", ref_cam) not in setup.cache:  # the per-frame PnP of both cameras, once per set-up
        ref_det, ref_model = src.detections[ref_cam], src.rig.camera(ref_cam)
        setup.cache["reference", ref_cam] = reference_trajectory(ref_det, ref_model, q1, p1)
        setup.cache["own"] = camera_poses(src.detections[setup.camera], src.rig.camera(setup.camera))
    ref, kept = setup.cache["reference", ref_cam]
    own = setup.cache["own"]
    err = errors_against(ref, estimate)
    cal = setup.calibration
    # the tracked camera's own frames, at the reference frames' times (interpolated across its clock offset, never
    # across a missing frame)
    pnp = errors_against(ref, body_trajectory(own, cal.rotation_xyzw, cal.translation_m, cal.time_offset_s))
    t0 = float(src.imu.stamps[0])
    # NEES of the position against the reference, with the reference's own covariance (camera centre + lever arm)
    row = np.clip(np.searchsorted(estimate.stamps, err.estimate.stamps - 1e-6), 0, len(estimate) - 1)
    nees = None
    if position_covariance is not None and len(err.index):
        _, _, cref = _reference_position_covariance(kept, q1, p1)
        S = position_covariance[row] + cref[err.index]
        e = err.position
        nees = float(np.mean(np.einsum("ni,ni->n", e, np.linalg.solve(S, e[..., None])[..., 0])))
    windows = []
    for a, b in outages:
        rel = err.estimate.stamps - t0
        w = err.within((rel >= a) & (rel < b))
        dist = np.linalg.norm(w.position, axis=1)
        windows.append({
            "start_s": float(a), "end_s": float(b), "frames": int(len(w.index)),
            "position_rmse_m": w.position_rmse_m if len(dist) else None,
            "position_max_m": float(dist.max()) if len(dist) else None,
            "rotation_rmse_deg": w.rotation_rmse_deg if len(dist) else None,
            "rotation_max_deg": float(w.rotation_deg.max()) if len(w.index) else None,
        })  # fmt: skip
    metrics = {
        "reference": {"camera": ref_cam, "frames": int(len(ref)), "frames_scored": int(len(err.index)),
                      "median_rms_px": float(np.median(kept.rms_px))},
        "position_rmse_m": err.position_rmse_m,
        "rotation_rmse_deg": err.rotation_rmse_deg,
        "camera_pnp": {"frames": int(len(pnp.index)), "position_rmse_m": pnp.position_rmse_m,
                       "rotation_rmse_deg": pnp.rotation_rmse_deg},
        "nees_position": nees,
        "outages": windows,
    }  # fmt: skip
    return {
        "metrics": metrics, "truth": ref.take(err.index), "position_error": err.position,
        "orientation_error_deg": err.rotation_deg, "error_index": row,
    }  # fmt: skip


def _reference_position_covariance(
    poses: CameraPoses, q_bc: np.ndarray, p_bc: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body position covariance (P, 3, 3) of reference poses: ``δp = δc + R_wb [p_bc]× R_bc δθ_c``."""
    R_bc = dp.matrix_from_quat(q_bc)
    q_wb = dp.quat_mul(poses.q_wc, dp.quat_conj(q_bc))
    R_wb = dp.matrix_from_quat(q_wb)
    J = np.zeros((len(poses.t), 3, 6))
    J[:, :, 0:3] = R_wb @ dp.so3_hat(p_bc) @ R_bc
    J[:, :, 3:6] = np.eye(3)
    return q_wb, R_wb, J @ poses.covariance @ J.swapaxes(1, 2)


def imu_only(setup: TrackSetup, seconds: Sequence[float] = (1.0, 5.0),
             reference_extrinsics: Mapping[str, ArrayLike] = EUROC_T_BS) -> dict[str, Any]:
    """The filter's start propagated with the IMU alone (no frame): position and rotation RMSE against the reference
    over the first ``seconds`` after the start, for comparison with the tracked run."""
    rec = setup.recording
    blind = replace(rec, frames=setup.detections.select(np.zeros(len(setup.detections), bool)).correspondences())
    res = FILTERS["eskf"](blind, setup.start.x, setup.start.P).run_recording(blind)
    est = Trajectory(res.t, res.position, res.quat, rec.stamps_ns)
    sc = score_run(setup, est, reference_extrinsics=reference_extrinsics)
    out: dict[str, Any] = {}
    if sc["truth"] is None:
        return dict.fromkeys(f"{s:g}s" for s in seconds)
    rel = sc["truth"].stamps - rec.t[0]
    for s in seconds:
        m = rel <= s
        e, r = sc["position_error"][m], sc["orientation_error_deg"][m]
        out[f"{s:g}s"] = {"position_rmse_m": float(np.sqrt(np.mean(np.sum(e**2, axis=1)))) if m.any() else None,
                          "rotation_rmse_deg": float(np.sqrt(np.mean(r**2))) if m.any() else None}  # fmt: skip
    return out


class TrackStream:
    """:func:`run_track`'s filter on a stream of lines (``dualpose fuse --stream --sensors sensors.yaml --camera cam0
    --calibration CALIB.json``): the same start-up, filter and re-locks, so the pose lines are the batch run's states
    bit for bit.

    Input lines as :func:`dualpose.pipelines.fuse_stream.parse_fusion_line` (``imu, t, gx, gy, gz, ax, ay, az`` and
    ``cam, t, n, u1, v1, X1, Y1, Z1, ...``) with the camera's **measured (distorted) pixels** and the corners in the
    target frame; the stream converts them with the camera model (a camera front end pipes its detections as they
    are).  The first :data:`STARTUP_SECONDS` of frames are buffered for the start-up alignment (:func:`startup`): the
    first pose line -- for the IMU sample at the first frame of the window -- is written when the IMU passes the end of
    the window (or at the end of the input), then one line per IMU line as it arrives.

    Parameters
    ----------
    rig : RigSensors.  camera : the tracked camera's name.  calibration : CameraImuCalibration.
    filter : {"eskf", "hol22"}.  scale_sigmas : as :func:`prepare_track`.
    """

    def __init__(self, rig: RigSensors, camera: str, calibration: CameraImuCalibration, filter: str = "eskf",
                 scale_sigmas: tuple[float, float] | str = "mems") -> None:
        if filter not in FILTERS:
            raise ValueError(f"filter must be one of {tuple(FILTERS)}; got {filter!r}")
        if rig.imu_noise is None:
            raise ValueError(f"{rig.path}: no IMU noise densities (imu0) in the sensor file")
        if calibration.camera != camera:
            raise ValueError(f"the calibration is of camera {calibration.camera!r}, but --camera is {camera!r}")
        self.model = rig.camera(camera)
        self.calibration = calibration
        self.filter = filter
        self.noise = track_imu_noise(rig, scale_sigmas)
        self.gravity_magnitude = rig.gravity_magnitude if math.isfinite(rig.gravity_magnitude) else 9.81
        self.pixel_sigma = ideal_pixel_sigma(self.model, calibration.reprojection_rms_px)
        self._imu: list[tuple[float, list[float], list[float]]] = []
        self._cams: list[tuple[float, np.ndarray, np.ndarray]] = []
        self._t_first: float | None = None  # IMU time of the first usable frame
        self._stream: EskfStream | Hol22Stream | None = None
        self._setup: SensorSetup | None = None
        self._frames: list[tuple[FrameUpdate, float]] = []  # (FrameUpdate, camera stamp) queued in the current stream
        self.relocks: list[float] = []  # IMU times of the re-locks
        self.start: StartUp | None = None
        #: what the set-up checks doubted (a gyroscope in deg/s at the start, a camera effectively unused at the
        #: end), each also warned (:class:`~dualpose.types.recording.RecordingWarning`)
        self.doubts: list[Doubt] = []
        self._frame_use = FrameUse("the stream's camera lines")
        #: the IMU gaps (longer than five sample periods of the rig's ``update_rate``), of the start-up window and of
        #: every filter after it (they share it): warned about and counted
        self.gap_watch = GapWatch(1.0 / self.noise.update_rate)

    def _running(self) -> EskfStream | Hol22Stream:
        assert self._stream is not None  # started by _begin
        return self._stream

    def _sensor_setup(self) -> SensorSetup:
        assert self.start is not None  # the start-up ran
        cal = self.calibration
        return SensorSetup(camera=self.model.pinhole(), q_bc=cal.rotation_xyzw, p_bc=cal.translation_m,
                           pixel_sigma=self.pixel_sigma, imu_noise=self.noise, start=FilterStart(np.zeros(3),
                           np.array([0.0, 0.0, 0.0, 1.0])), time_offset=cal.time_offset_s,
                           gravity=self.start.alignment.gravity)  # fmt: skip

    def _pose(self, t: float, x: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        L = self._running().state_layout
        if "quat_be" in L.names:
            return t, L.get(x, "position"), dp.quat_conj(L.get(x, "quat_be"))
        return t, L.get(x, "position"), L.get(x, "quat")

    def _camera(self, t: float, raw: np.ndarray, points: np.ndarray) -> None:
        ideal = self.model.ideal_pixels(raw) if len(raw) else np.zeros((0, 2))
        self._frame_use.given += 1
        self._frames.append((self._running().update_camera(t, ideal, points), t))

    def _imu_step(self, t: float, g: ArrayLike, a: ArrayLike) -> tuple[float, np.ndarray, np.ndarray]:
        st = self._running()
        x = st.update_imu(t, g, a)
        done = [fu for fu, _ in self._frames if fu.status != "pending"]
        pending = [(fu, tc) for fu, tc in self._frames if fu.status == "pending"]
        self._frames = pending
        for fu in done:
            self._frame_use.settled(fu)
        assert self._setup is not None  # made with the stream
        relock = _relocked(lambda: _filter_state(st.state_layout, st.state, st.covariance), done, t,
                           np.asarray(g, dtype=np.float64), np.asarray(a, dtype=np.float64), self._setup,
                           self.filter)  # fmt: skip
        if relock is not None:
            fresh = relock[0]
            fresh.gap_watch = self.gap_watch
            self._stream = fresh
            x = fresh.state
            self._frames = [(fresh.update_camera(tc, fu.pixels, fu.points), tc) for fu, tc in pending]
            self.relocks.append(t)
        return self._pose(t, x)

    def _begin(self) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """Run the start-up on the buffered inputs and filter them; the poses from the start sample on."""
        from dualpose.types.target import TargetDetections

        t = np.array([r[0] for r in self._imu])
        g = np.array([r[1] for r in self._imu], dtype=np.float64).reshape(-1, 3)
        a = np.array([r[2] for r in self._imu], dtype=np.float64).reshape(-1, 3)
        ft = np.array([c[0] for c in self._cams])
        counts = np.array([len(c[1]) for c in self._cams], dtype=np.int64)
        offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        pix = np.concatenate([c[1] for c in self._cams]) if counts.sum() else np.zeros((0, 2))
        pts = np.concatenate([c[2] for c in self._cams]) if counts.sum() else np.zeros((0, 3))
        m = len(pix)
        det = TargetDetections(np.round(ft * 1e9).astype(np.int64), ft, offsets, pix, pts, np.zeros(m, np.int64),
                               np.zeros(m, np.int64))  # fmt: skip
        self.start = startup(t, g, a, det, self.model, self.calibration, self.noise, self.gravity_magnitude)
        self._setup = self._sensor_setup()
        self._stream = _new_stream(self.filter, self._setup, self.start.x, self.start.P)
        self._stream.gap_watch = GapWatch(None, watch_rate=False)  # the buffered samples were watched as they came
        k0 = self.start.imu_index
        self.doubts += self.start.startup_doubts("the stream's IMU lines")
        tau = self.calibration.time_offset_s
        items = [(float(t[k]), 1, ("imu", k)) for k in range(k0, len(t))]
        items += [(float(ft[j] + tau), 0, ("cam", j)) for j in range(len(ft)) if ft[j] + tau > t[k0]]
        items.sort(key=lambda it: it[:2])
        out = []
        for _, _, (kind, i) in items:
            if kind == "imu":
                out.append(self._imu_step(float(t[i]), self._imu[i][1], self._imu[i][2]))
            else:
                self._camera(float(ft[i]), self._cams[i][1], self._cams[i][2])
        self._imu, self._cams = [], []
        self._running().gap_watch = self.gap_watch
        return out

    def update(self, kind: str, t: float, a: ArrayLike, b: ArrayLike) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """One input (``"imu", t, gyro, accel`` or ``"cam", t, raw pixels (n, 2), points (n, 3)``); returns the
        ``(t, position (3,), q_wb (4,))`` poses it completes (none while the start-up window is read).  IMU samples
        go through the calibration's axis models first
        (:meth:`~dualpose.types.calibration.CameraImuCalibration.corrected_imu`)."""
        if kind != "cam":
            self.gap_watch.see(t)  # before any filter: the stamps of the start-up window are watched too
            a, b = self.calibration.corrected_imu(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
        if self._stream is not None:
            if kind == "cam":
                self._camera(t, np.asarray(a, dtype=np.float64).reshape(-1, 2), np.asarray(b, dtype=np.float64))
                return []
            return [self._imu_step(t, a, b)]
        buffered = self._cams if kind == "cam" else self._imu  # the filter checks the order once it runs
        if buffered and not t > buffered[-1][0]:
            raise ValueError(f"t must be finite and increase strictly: got {t!r} after {buffered[-1][0]!r}")
        if kind == "cam":
            raw = np.asarray(a, dtype=np.float64).reshape(-1, 2)
            self._cams.append((t, raw, np.asarray(b, dtype=np.float64).reshape(-1, 3)))
            if self._t_first is None and len(raw) >= STARTUP_MIN_CORNERS and self._imu and \
                    t + self.calibration.time_offset_s >= self._imu[0][0]:
                self._t_first = t + self.calibration.time_offset_s
            return []
        self._imu.append((t, np.asarray(a, dtype=np.float64).tolist(), np.asarray(b, dtype=np.float64).tolist()))
        if self._t_first is not None and t > self._t_first + STARTUP_SECONDS:
            return self._begin()
        return []

    def finish(self) -> list[tuple[float, np.ndarray, np.ndarray]]:
        """At the end of the input: the start-up on what was read if it has not run yet (and its poses); then the
        doubt about the camera, if any (:class:`~dualpose.pipelines.fuse_stream.FrameUse`)."""
        out = self._begin() if self._stream is None and self._imu else []
        d = self._frame_use.finish()
        self.doubts += [] if d is None else [d]
        return out


def target_recording_lines(recording: TargetRecording, camera: str = "cam0", time_offset: float = 0.0) -> list[str]:
    """A target recording as :class:`TrackStream` input lines: one ``imu`` line per sample and one ``cam`` line per
    frame of ``camera`` (its measured pixels and target-frame corners; ``cam, t, 0`` for a frame without detections),
    in time order on the IMU clock (``t_cam + time_offset``; a frame before the IMU sample at its time), every number
    as its exact ``repr``.  The inverse of what the stream reads, for piping a recording through
    ``dualpose fuse --stream --sensors``."""
    imu = recording.imu
    det = recording.detections[camera]
    rows = np.column_stack([imu.stamps, imu.gyro, imu.accel]).tolist()
    items = [(row[0], 1, "imu, " + format_numbers(row)) for row in rows]
    for j in range(len(det)):
        pix, pts = det.frame(j)
        tail = ", " + format_numbers(np.hstack([pix, pts]).ravel()) if len(pix) else "\n"
        items.append((float(det.t[j] + time_offset), 0, f"cam, {float(det.t[j])!r}, {len(pix)}{tail}"))
    items.sort(key=lambda it: it[:2])
    return [it[2] for it in items]


def stream_track_lines(lines: Iterable[str], stream: TrackStream, source: str = "stdin") -> Iterator[str]:
    """:func:`dualpose.pipelines.fuse_stream.stream_fusion_lines` for a :class:`TrackStream`: yields one
    ``t, px, py, pz, qx, qy, qz, qw`` line per IMU line from the start sample on (module docstring of
    :class:`TrackStream`); ``ValueError("{source} line N: ...")`` for a malformed line.  IMU gaps and stamps that
    contradict the rig's ``update_rate`` are warned about as in ``fuse --stream``
    (``StreamTimes`` of ``dualpose.pipelines._lines``)."""
    times = StreamTimes(1.0 / stream.noise.update_rate, source, "imu0 update_rate", stream.gap_watch)
    for lineno, line in enumerate(lines, start=1):
        try:
            item = parse_fusion_line(line)
            if item is None:
                continue
            if item[0] == "imu":
                times.check(item[1], lineno)
            poses = stream.update(*item)
        except ValueError as exc:
            raise ValueError(f"{source} line {lineno}: {exc}") from None
        for t, p, q in poses:
            yield format_numbers([t, *p.tolist(), *q.tolist()])
    for t, p, q in stream.finish():
        yield format_numbers([t, *p.tolist(), *q.tolist()])
