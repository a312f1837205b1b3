"""Seeded camera-IMU simulator: exact ground truth, IMU and point-correspondence streams (Hol 2008 set-up).

Frames: earth/world ``w`` (z up by default; gravity ``g_w`` is a parameter), IMU body ``b``, camera ``c`` (z along
the optical axis, x right, y down).  Orientations are ``(..., 4)`` xyzw quaternions ``q_wb`` (body -> world, active).

The body follows a closed-form :class:`~dualpose.sim.motion.SmoothMotion`, so the truth is exact.

IMU model (Kalibr conventions, continuous-time densities)::

    gyro  = ω_b + b_g + n_g,   n_g ~ N(0, σ_g² / Δt),  ḃ_g = σ_bg w
    accel = R_wbᵀ (a_w − g_w) + b_a + n_a,   n_a ~ N(0, σ_a² / Δt),  ḃ_a = σ_ba w

(Hol eq. 1, 2: ``y_a = b̈^b − g^b + δ_a + e_a``).  Camera: pinhole, 320 × 240, f = 3.2 mm, pixel pitch 15 µm
(a 4.8 × 3.6 mm 1/3" sensor read out at 320 × 240), i.e. ``f = 213.3 px``.  A camera frame taken at IMU time
``t`` carries the camera-clock stamp ``t − time_offset`` (Kalibr ``timeshift_cam_imu``: ``t_imu = t_cam + shift``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

import dualpose as dp
from dualpose.sim.motion import SmoothMotion, eight_motion, extrinsic_arrays
from dualpose.types.camera import FrameCorrespondences, PinholeCamera, PinholeModel
from dualpose.types.imu import STANDARD_GRAVITY, ImuNoise
from dualpose.types.recording import Recording
from dualpose.types.trajectory import Trajectory

__all__ = [
    "CameraFrames",
    "SimulatedRun",
    "camera_points",
    "observe_landmarks",
    "two_plane_landmarks",
    "simulate",
    "simulate_eight",
    "recording_from_simulation",
]

def two_plane_landmarks(rng: np.random.Generator, n: int = 300) -> NDArray[np.float64]:
    """``n`` landmarks (world frame, metres) on two orthogonal textured planes: the wall y = 0 (x ∈ [−1.2, 1.2],
    z ∈ [0, 1.6]) and the floor z = 0 (x ∈ [−1.2, 1.2], y ∈ [0, 1.0]); shape (n, 3)."""
    n_wall = n // 2
    wall = np.column_stack([rng.uniform(-1.2, 1.2, n_wall), np.zeros(n_wall), rng.uniform(0.0, 1.6, n_wall)])
    m = n - n_wall
    floor = np.column_stack([rng.uniform(-1.2, 1.2, m), rng.uniform(0.0, 1.0, m), np.zeros(m)])
    return np.vstack([wall, floor])


@dataclass
class CameraFrames(FrameCorrespondences):
    """Simulated frames: :class:`FrameCorrespondences` plus what only a simulator knows.

    ``t_true`` (F,) the IMU-clock capture times, ``landmark_ids`` (M,) and ``outlier`` (M,) (True where the pixel
    was replaced by a gross outlier).
    """

    t_true: np.ndarray = field(kw_only=True)
    landmark_ids: np.ndarray = field(kw_only=True)
    outlier: np.ndarray = field(kw_only=True)


@dataclass
class SimulatedRun:
    """A simulated run: IMU samples, camera frames, exact truth at the IMU times and the set-up that made them.

    Attributes
    ----------
    t : (N,) IMU sample times, s.  ``gyro`` (N, 3) rad/s, ``accel`` (N, 3) m/s² (specific force), ``mag`` (N, 3)
    (unit-field units) or None.  ``truth`` holds ``position``, ``velocity``, ``acceleration``, ``quat`` (``q_wb``),
    ``omega``, ``gyro_bias``, ``accel_bias`` at ``t``.  ``frames``: :class:`CameraFrames`.  ``q_bc``, ``p_bc``:
    extrinsic (camera axes and centre in the body frame).  ``gravity``: true ``g_w`` (3,) m/s².
    """

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    mag: np.ndarray | None
    truth: dict[str, np.ndarray]
    frames: CameraFrames
    camera: PinholeCamera
    q_bc: np.ndarray
    p_bc: np.ndarray
    landmarks: np.ndarray
    gravity: np.ndarray
    imu_noise: ImuNoise
    pixel_sigma: float
    time_offset: float
    motion: SmoothMotion
    magnetic_field: np.ndarray = field(default_factory=lambda: np.array([0.4, 0.0, -0.9]))

    def sensor_options(self) -> dict[str, Any]:
        """Keyword arguments giving a filter this run's sensor set-up (IMU noise, camera, extrinsic, pixel σ, offset).

        Shared by ``ErrorStateEKF.from_simulation`` and ``Hol22EKF.from_simulation``.
        """
        return {
            "imu_noise": self.imu_noise,
            "camera": self.camera,
            "q_bc": self.q_bc,
            "p_bc": self.p_bc,
            "pixel_sigma": max(self.pixel_sigma, 1e-3),
            "camera_time_offset": self.time_offset,
        }


def simulate(
    motion: SmoothMotion,
    seed: int = 0,
    imu_noise: ImuNoise | None = None,
    camera: PinholeCamera | None = None,
    camera_rate: float = 12.5,
    camera_phase: float = 0.0137,
    pixel_sigma: float = 1.0,
    landmarks_per_frame: int = 20,
    n_landmarks: int = 300,
    outlier_fraction: float = 0.0,
    dropouts: tuple[tuple[float, float], ...] = (),
    time_offset: float = 0.0,
    gravity_misalignment_deg: float = 0.0,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
    magnetometer_sigma: float | None = None,
) -> SimulatedRun:
    """Generate IMU samples and camera correspondences along ``motion`` (everything seeded by ``seed``).

    Parameters
    ----------
    motion : SmoothMotion
        Body (IMU) motion; its ``duration`` sets the run length.
    imu_noise : ImuNoise, optional
        Defaults to ``ImuNoise()`` (:class:`~dualpose.types.imu.ImuNoise`, Xsens-MTx-like);
        ``ImuNoise().scaled(0)`` is noise- and bias-free.
    camera_rate, camera_phase : float
        Frames are captured at IMU-clock times ``camera_phase + k / camera_rate`` (Hz, s); the phase need not align
        with the IMU samples.
    pixel_sigma : float
        Standard deviation of the pixel noise, px.
    landmarks_per_frame : int
        At most this many visible landmarks are reported per frame (random subset).
    outlier_fraction : float
        Fraction of correspondences whose pixel is replaced by a uniform random position in the image.
    dropouts : sequence of (t0, t1)
        IMU-clock intervals without frames (motion blur, occlusion).
    time_offset : float
        ``t_imu = t_cam + time_offset`` (s): stamps in ``frames.t`` are ``t_true − time_offset``.
    gravity_misalignment_deg : float
        The true gravity ``g_w`` is ``[0, 0, −9.81]`` rotated by this angle about the world x axis (the scene
        model's vertical is then off by that angle).
    extrinsic : (q_bc, p_bc), optional
        Defaults to :func:`~dualpose.sim.motion.default_extrinsic`; must match the one used to build the
        trajectory's camera view.
    magnetometer_sigma : float, optional
        If given, a magnetometer ``m_b = R_wbᵀ m_w + noise`` (unit-norm-ish field) is simulated at the IMU rate.
    """
    if not 0.0 <= outlier_fraction < 1.0:
        raise ValueError(f"outlier_fraction must be in [0, 1); got {outlier_fraction}")
    imu_noise = ImuNoise() if imu_noise is None else imu_noise
    camera = PinholeCamera() if camera is None else camera
    q_bc, p_bc = extrinsic_arrays(extrinsic)
    rng = np.random.default_rng(seed)
    scene_rng = np.random.default_rng([seed, 1])
    landmarks = two_plane_landmarks(scene_rng, n_landmarks)

    ang = math.radians(gravity_misalignment_deg)
    gravity = STANDARD_GRAVITY * np.array([0.0, math.sin(ang), -math.cos(ang)])

    dt = 1.0 / imu_noise.update_rate
    n = int(math.floor(motion.duration * imu_noise.update_rate + 1e-9)) + 1
    t = np.arange(n) * dt
    truth = motion.kinematics(t)
    q_wb = truth["quat"]

    sg_c, sa_c = imu_noise.gyroscope_noise_density, imu_noise.accelerometer_noise_density
    bg0 = rng.normal(0.0, imu_noise.gyroscope_initial_bias_sigma, 3)
    ba0 = rng.normal(0.0, imu_noise.accelerometer_initial_bias_sigma, 3)
    steps_g = rng.normal(0.0, imu_noise.gyroscope_random_walk * math.sqrt(dt), (n, 3))
    steps_a = rng.normal(0.0, imu_noise.accelerometer_random_walk * math.sqrt(dt), (n, 3))
    steps_g[0] = 0.0
    steps_a[0] = 0.0
    bg = bg0 + np.cumsum(steps_g, axis=0)
    ba = ba0 + np.cumsum(steps_a, axis=0)
    gyro = truth["omega"] + bg + rng.normal(0.0, sg_c / math.sqrt(dt), (n, 3))
    specific = dp.quat_rotate(dp.quat_conj(q_wb), truth["acceleration"] - gravity)
    accel = specific + ba + rng.normal(0.0, sa_c / math.sqrt(dt), (n, 3))
    truth["gyro_bias"] = bg
    truth["accel_bias"] = ba

    mag_field = np.array([0.4, 0.0, -0.9])
    mag = None
    if magnetometer_sigma is not None:
        mag = dp.quat_rotate(dp.quat_conj(q_wb), mag_field) + rng.normal(0.0, magnetometer_sigma, (n, 3))

    frames = _make_frames(
        motion,
        landmarks,
        camera,
        q_bc,
        p_bc,
        rng,
        camera_rate,
        camera_phase,
        pixel_sigma,
        landmarks_per_frame,
        outlier_fraction,
        dropouts,
        time_offset,
    )
    return SimulatedRun(
        t=t, gyro=gyro, accel=accel, mag=mag, truth=truth, frames=frames, camera=camera, q_bc=q_bc, p_bc=p_bc,
        landmarks=landmarks, gravity=gravity, imu_noise=imu_noise, pixel_sigma=pixel_sigma, time_offset=time_offset,
        motion=motion, magnetic_field=mag_field,
    )  # fmt: skip


def camera_points(
    q_wb: NDArray[np.float64], p_wb: NDArray[np.float64], q_bc: NDArray[np.float64], p_bc: NDArray[np.float64],
    pts_w: NDArray[np.float64],
) -> NDArray[np.float64]:
    """World points ``(M, 3)`` in the camera frame ``(M, 3)`` for body pose ``(q_wb, p_wb)`` and extrinsic."""
    pts_b = dp.quat_rotate(dp.quat_conj(q_wb), pts_w - p_wb)
    return dp.quat_rotate(dp.quat_conj(q_bc), pts_b - p_bc)


def _make_frames(
    traj: SmoothMotion, landmarks: NDArray[np.float64], camera: PinholeModel, q_bc: NDArray[np.float64],
    p_bc: NDArray[np.float64], rng: np.random.Generator, rate: float, phase: float, sigma: float, per_frame: int,
    outlier_fraction: float, dropouts: tuple[tuple[float, float], ...], offset: float,
) -> CameraFrames:
    t_true = np.arange(phase, traj.duration + 1e-12, 1.0 / rate)
    keep = np.ones(len(t_true), bool)
    for a, b in dropouts:
        keep &= ~((t_true >= a) & (t_true < b))
    t_true = t_true[keep]
    kin = traj.kinematics(t_true)
    obs = observe_landmarks(
        kin["quat"], kin["position"], landmarks, camera, q_bc, p_bc, rng, sigma, per_frame, outlier_fraction
    )
    return CameraFrames(t=t_true - offset, t_true=t_true, **obs)


def observe_landmarks(
    q_wb: np.ndarray,
    p_wb: np.ndarray,
    landmarks: np.ndarray,
    camera: PinholeModel,
    q_bc: np.ndarray,
    p_bc: np.ndarray,
    rng: np.random.Generator,
    pixel_sigma: float = 1.0,
    per_frame: int = 20,
    outlier_fraction: float = 0.0,
) -> dict[str, np.ndarray]:
    """Noisy pixel observations of the visible landmarks from F body poses (the simulator's camera model).

    For each pose a landmark is visible when it lies more than 5 cm in front of the camera and projects inside the
    image; at most ``per_frame`` of them are kept (random subset), their pixels get N(0, ``pixel_sigma``²) noise and
    a fraction ``outlier_fraction`` is replaced by a uniform random pixel.  Random draws per frame, in frame order:
    subset, noise, outlier flags, outlier pixels.

    Parameters
    ----------
    q_wb : (F, 4) xyzw body→world.  p_wb : (F, 3) m.  landmarks : (L, 3) world frame, m.
    camera : PinholeModel.  q_bc, p_bc : extrinsic (camera axes and centre in the body frame).

    Returns
    -------
    dict
        ``offsets`` (F + 1,) int64, ``pixels`` (M, 2), ``points`` (M, 3), ``landmark_ids`` (M,) int64,
        ``outlier`` (M,) bool -- the fields of :class:`CameraFrames` other than the times.
    """
    offsets = [0]
    pix_all, pts_all, ids_all, out_all = [], [], [], []
    for k in range(len(q_wb)):
        pc = camera_points(q_wb[k], p_wb[k], q_bc, p_bc, landmarks)
        front = pc[:, 2] > 0.05
        uv = np.full((len(pc), 2), -1.0)
        uv[front] = camera.project(pc[front])
        vis = front & (uv[:, 0] >= 0) & (uv[:, 0] < camera.width) & (uv[:, 1] >= 0) & (uv[:, 1] < camera.height)
        ids = np.flatnonzero(vis)
        if len(ids) > per_frame:
            ids = np.sort(rng.choice(ids, per_frame, replace=False))
        pix = uv[ids] + rng.normal(0.0, pixel_sigma, (len(ids), 2))
        out = rng.random(len(ids)) < outlier_fraction
        pix[out] = rng.uniform([0.0, 0.0], [camera.width, camera.height], (int(out.sum()), 2))
        pix_all.append(pix)
        pts_all.append(landmarks[ids])
        ids_all.append(ids)
        out_all.append(out)
        offsets.append(offsets[-1] + len(ids))
    return {
        "offsets": np.asarray(offsets, np.int64),
        "pixels": np.concatenate(pix_all) if pix_all else np.zeros((0, 2)),
        "points": np.concatenate(pts_all) if pts_all else np.zeros((0, 3)),
        "landmark_ids": np.concatenate(ids_all).astype(np.int64) if ids_all else np.zeros(0, np.int64),
        "outlier": np.concatenate(out_all) if out_all else np.zeros(0, bool),
    }


def simulate_eight(seed: int = 0, **kwargs: Any) -> SimulatedRun:
    """Hol's eight-shaped run (:func:`eight_motion`) with the default sensors; ``kwargs`` go to :func:`simulate`."""
    return simulate(eight_motion(), seed=seed, **kwargs)


def recording_from_simulation(run: SimulatedRun, rest_seconds: float | None = 0.9, name: str = "sim") -> Recording:
    """The :class:`Recording` of a simulated run: its sensors as the filter sees them, truth at the IMU times.

    The gravity the filter assumes is the nominal ``[0, 0, −9.81]`` (a simulated misalignment of ``run.gravity``
    stays unknown to it); ``pixel_sigma`` is floored at 1e-3 px like :meth:`SimulatedRun.sensor_options`.  The
    ground truth carries the true velocity and biases as ``extra`` columns (``velocity``, ``gyro_bias``,
    ``accel_bias``, each (N, 3)), which :func:`dualpose.io.write_recording` writes to the EuRoC ground truth.
    """
    opts = run.sensor_options()
    extra = {k: run.truth[k] for k in ("velocity", "gyro_bias", "accel_bias")}
    truth = Trajectory(run.t, run.truth["position"], run.truth["quat"], name="truth", extra=extra)
    return Recording(
        t=run.t, gyro=run.gyro, accel=run.accel, frames=run.frames, camera=opts["camera"], q_bc=opts["q_bc"],
        p_bc=opts["p_bc"], pixel_sigma=opts["pixel_sigma"], imu_noise=opts["imu_noise"],
        time_offset=opts["camera_time_offset"], rest_seconds=rest_seconds, ground_truth=truth, name=name,
    )  # fmt: skip
