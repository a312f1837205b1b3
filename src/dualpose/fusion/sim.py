"""Seeded camera-IMU simulator: exact ground truth, IMU and point-correspondence streams (Hol 2008 set-up).

Frames: earth/world ``w`` (z up by default; gravity ``g_w`` is a parameter), IMU body ``b``, camera ``c`` (z along
the optical axis, x right, y down).  Orientations are ``(..., 4)`` xyzw quaternions ``q_wb`` (body -> world, active).

Trajectories are trigonometric sums in a phase ``θ(t)``: position ``p(t) = p0 + Σ_k A_k (sin(n_k θ + ψ_k) − sin ψ_k)``
and orientation ``q(t) = q0 ⊗ Exp(φ(t))`` with ``φ`` of the same form.  They are C^∞ in θ, and θ(t) is either linear
(random generator) or a quintic smoothstep (Hol's eight: starts and stops at rest, C² at the junctions), so velocity,
acceleration and the body angular velocity ``ω_b = J_r(φ) φ̇`` are exact closed forms.

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

import numpy as np

import dualpose as dp

__all__ = [
    "ImuNoise",
    "PinholeModel",
    "PinholeCamera",
    "CameraIntrinsics",
    "Trajectory",
    "FrameCorrespondences",
    "CameraFrames",
    "observe_landmarks",
    "SimulatedRun",
    "eight_trajectory",
    "random_trajectory",
    "two_plane_landmarks",
    "look_at_quat",
    "default_extrinsic",
    "simulate",
    "simulate_eight",
]

STANDARD_GRAVITY = 9.81


@dataclass(frozen=True)
class ImuNoise:
    """IMU noise in Kalibr's ``imu.yaml`` terms (continuous-time densities); defaults resemble an Xsens MTx.

    Attributes
    ----------
    gyroscope_noise_density : float
        rad/s/√Hz (default 1.745e-3 = 0.1 °/s/√Hz).
    gyroscope_random_walk : float
        rad/s²/√Hz, bias random walk.
    accelerometer_noise_density : float
        m/s²/√Hz.
    accelerometer_random_walk : float
        m/s³/√Hz.
    gyroscope_initial_bias_sigma, accelerometer_initial_bias_sigma : float
        Standard deviation of the turn-on bias drawn per run (rad/s, m/s²).
    update_rate : float
        Hz.
    """

    gyroscope_noise_density: float = math.radians(0.1)
    gyroscope_random_walk: float = 4.0e-5
    accelerometer_noise_density: float = 2.0e-3
    accelerometer_random_walk: float = 4.0e-4
    gyroscope_initial_bias_sigma: float = math.radians(0.5)
    accelerometer_initial_bias_sigma: float = 0.05
    update_rate: float = 100.0

    def scaled(self, factor: float) -> ImuNoise:
        """All noise terms (not the rate) multiplied by ``factor`` (``0`` gives a noise-free IMU)."""
        return ImuNoise(
            self.gyroscope_noise_density * factor,
            self.gyroscope_random_walk * factor,
            self.accelerometer_noise_density * factor,
            self.accelerometer_random_walk * factor,
            self.gyroscope_initial_bias_sigma * factor,
            self.accelerometer_initial_bias_sigma * factor,
            self.update_rate,
        )


class PinholeModel:
    """Projection shared by the pinhole cameras; a subclass provides ``fx``, ``fy``, ``cx``, ``cy`` (pixels) and
    ``width``, ``height``.  Pixel ``u = fx X/Z + cx``, ``v = fy Y/Z + cy`` (camera frame, metres)."""

    @property
    def matrix(self) -> np.ndarray:
        """Intrinsic matrix ``K``, shape (3, 3), pixels."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def project(self, points_c: np.ndarray) -> np.ndarray:
        """Pixels ``(..., 2)`` of camera-frame points ``(..., 3)`` (metres; Z must be > 0)."""
        p = np.asarray(points_c, dtype=np.float64)
        if p.shape[-1:] != (3,):
            raise ValueError(f"points_c must have shape (..., 3); got {p.shape}")
        z = p[..., 2]
        return np.stack([self.fx * p[..., 0] / z + self.cx, self.fy * p[..., 1] / z + self.cy], axis=-1)


@dataclass(frozen=True)
class PinholeCamera(PinholeModel):
    """Pinhole camera without distortion.  Pixel ``u = fx X/Z + cx``, ``v = fy Y/Z + cy`` (camera frame, metres).

    Defaults: Hol's 320 × 240 camera with f = 3.2 mm and an assumed 15 µm pixel pitch (fx = fy = 213.3 px).
    """

    width: int = 320
    height: int = 240
    focal_length_m: float = 3.2e-3
    pixel_pitch_m: float = 15e-6

    @property
    def fx(self) -> float:
        return self.focal_length_m / self.pixel_pitch_m

    @property
    def fy(self) -> float:
        return self.focal_length_m / self.pixel_pitch_m

    @property
    def cx(self) -> float:
        return 0.5 * self.width

    @property
    def cy(self) -> float:
        return 0.5 * self.height


@dataclass(frozen=True)
class CameraIntrinsics(PinholeModel):
    """Pinhole camera given by its intrinsics in pixels (what a calibration file states), no distortion.

    Attributes
    ----------
    fx, fy : float
        Focal lengths, pixels (> 0).
    cx, cy : float
        Principal point, pixels.
    width, height : int
        Image size, pixels (> 0).
    """

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def __post_init__(self) -> None:
        for name in ("fx", "fy", "cx", "cy"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ValueError(f"{name} must be a finite number of pixels; got {v!r}")
        if not (self.fx > 0 and self.fy > 0):
            raise ValueError(f"fx and fy must be > 0 pixels; got {self.fx}, {self.fy}")
        for name in ("width", "height"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
                raise ValueError(f"{name} must be a positive whole number of pixels; got {v!r}")


def _smoothstep(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Quintic smoothstep ``S = 10τ³ − 15τ⁴ + 6τ⁵`` clipped to [0, 1] and its first two derivatives."""
    inside = (tau > 0.0) & (tau < 1.0)
    t = np.clip(tau, 0.0, 1.0)
    s = t**3 * (10.0 + t * (-15.0 + 6.0 * t))
    ds = np.where(inside, 30.0 * t**2 * (1.0 - t) ** 2, 0.0)
    dds = np.where(inside, 60.0 * t * (1.0 - t) * (1.0 - 2.0 * t), 0.0)
    return s, ds, dds


@dataclass(frozen=True)
class Trajectory:
    """Closed-form smooth 6-DoF body trajectory (see the module docstring for the form).

    Attributes
    ----------
    p0 : ndarray (3,)
        Body position at θ = 0, world frame, metres.
    q0 : ndarray (4,)
        Body orientation ``q_wb`` at θ = 0, xyzw.
    pos_amp, pos_phase : ndarray (K, 3); pos_harm : ndarray (K,)
        Position terms ``A_k``, ``ψ_k`` (per axis) and harmonic ``n_k``.
    rot_amp, rot_phase : ndarray (L, 3); rot_harm : ndarray (L,)
        Rotation-vector terms, radians.
    phase_kind : str
        ``"linear"`` (θ = Ω t) or ``"smoothstep"`` (θ = 2π S((t − t_start)/period), at rest outside).
    omega0 : float
        Ω for ``"linear"``, rad/s of phase.
    t_start, period : float
        Start and duration (s) of the smoothstep phase.
    duration : float
        Total length of the run, s.
    """

    p0: np.ndarray
    q0: np.ndarray
    pos_amp: np.ndarray
    pos_harm: np.ndarray
    pos_phase: np.ndarray
    rot_amp: np.ndarray
    rot_harm: np.ndarray
    rot_phase: np.ndarray
    phase_kind: str = "linear"
    omega0: float = 1.0
    t_start: float = 0.0
    period: float = 1.0
    duration: float = 1.0

    def phase(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """θ(t), θ'(t), θ''(t) for times ``t`` (s), each shaped like ``t``."""
        t = np.asarray(t, dtype=np.float64)
        if self.phase_kind == "linear":
            return self.omega0 * t, np.full_like(t, self.omega0), np.zeros_like(t)
        s, ds, dds = _smoothstep((t - self.t_start) / self.period)
        k = 2.0 * math.pi
        return k * s, k * ds / self.period, k * dds / self.period**2

    @staticmethod
    def _series(amp: np.ndarray, harm: np.ndarray, ph: np.ndarray, th: np.ndarray) -> tuple[np.ndarray, ...]:
        arg = harm[:, None] * th[..., None, None] + ph  # (..., K, 3)
        s, c = np.sin(arg), np.cos(arg)
        f = np.sum(amp * (s - np.sin(ph)), axis=-2)
        df = np.sum(amp * harm[:, None] * c, axis=-2)
        ddf = -np.sum(amp * harm[:, None] ** 2 * s, axis=-2)
        return f, df, ddf

    def kinematics(self, t: np.ndarray) -> dict[str, np.ndarray]:
        """Exact ground truth at times ``t`` (shape (N,)).

        Returns
        -------
        dict
            ``position`` (N, 3) m, ``velocity`` (N, 3) m/s, ``acceleration`` (N, 3) m/s² (world frame),
            ``quat`` (N, 4) ``q_wb`` xyzw, ``omega`` (N, 3) rad/s body-frame angular velocity.
        """
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        th, dth, ddth = self.phase(t)
        f, df, ddf = self._series(self.pos_amp, self.pos_harm, self.pos_phase, th)
        pos = self.p0 + f
        vel = df * dth[:, None]
        acc = ddf * dth[:, None] ** 2 + df * ddth[:, None]
        phi, dphi, _ = self._series(self.rot_amp, self.rot_harm, self.rot_phase, th)
        q = dp.quat_mul(self.q0, dp.quat_from_rotvec(phi))
        omega = np.einsum("nij,nj->ni", dp.so3_right_jacobian(phi), dphi * dth[:, None])
        return {"position": pos, "velocity": vel, "acceleration": acc, "quat": q, "omega": omega}


def look_at_quat(eye: np.ndarray, target: np.ndarray, up: np.ndarray = (0.0, 0.0, 1.0)) -> np.ndarray:
    """``q_wc`` (xyzw) of a camera at ``eye`` looking at ``target`` (z forward, x right, y down, world ``up``)."""
    z = np.asarray(target, float) - np.asarray(eye, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, float))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return dp.quat_from_matrix(np.stack([x, y, z], axis=1))


def default_extrinsic() -> tuple[np.ndarray, np.ndarray]:
    """Body→camera extrinsic ``(q_bc, p_bc)``: camera axes in the body frame (IMU x ≈ optical axis, z ≈ up,
    tilted by a few degrees) and the camera centre in the body frame (metres)."""
    r_nominal = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # columns: x_c, y_c, z_c in b
    q = dp.quat_mul(dp.quat_from_matrix(r_nominal), dp.quat_from_rotvec([0.03, -0.02, 0.04]))
    return q, np.array([0.03, -0.012, 0.021])


def _body_from_camera(q_wc: np.ndarray, c_w: np.ndarray, q_bc: np.ndarray, p_bc: np.ndarray):
    q_wb = dp.quat_mul(q_wc, dp.quat_conj(q_bc))
    return q_wb, c_w - dp.quat_rotate(q_wb, p_bc)


SCENE_TARGET = np.array([0.0, 0.35, 0.35])
CAMERA_HOME = np.array([0.0, 1.45, 0.85])


def eight_trajectory(
    path_length: float = 2.6,
    period: float = 5.4,
    static_before: float = 1.0,
    static_after: float = 0.5,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
) -> Trajectory:
    """Hol's eight-shaped run: a figure eight of ``path_length`` metres traversed once in ``period`` seconds.

    The eight lies in the plane facing the wall (x lateral, z vertical) with a depth oscillation in y; the camera
    looks at the two-plane scene throughout while roll, pitch and yaw oscillate.  The phase is a quintic smoothstep,
    so the body is at rest for ``static_before`` s (for static alignment), then moves with peak acceleration
    ≈ 3.9 m/s² and peak angular rate ≈ 1 rad/s (Hol: up to 4 m/s², 1 rad/s), then rests for ``static_after`` s.
    """
    q_bc, p_bc = default_extrinsic() if extrinsic is None else extrinsic
    q_wb0, p0 = _body_from_camera(look_at_quat(CAMERA_HOME, SCENE_TARGET), CAMERA_HOME, q_bc, p_bc)
    # shape: x = a sin θ, z = b sin 2θ, y = d (cos 2θ − 1); scaled to the requested path length
    shape = np.array([[1.0, 0.0, 0.0], [0.0, 0.12, 0.5]])
    harm = np.array([1.0, 2.0])
    phase = np.array([[0.0, 0.0, 0.0], [0.0, math.pi / 2, 0.0]])
    th = np.linspace(0.0, 2 * math.pi, 20001)
    arg = harm[:, None] * th[:, None, None] + phase
    d = np.sum(shape * harm[:, None] * np.cos(arg), axis=1)
    length = np.trapezoid(np.linalg.norm(d, axis=1), th)
    amp = shape * (path_length / length)
    rot_amp = np.array([[0.22, 0.0, 0.26], [0.0, 0.17, 0.0]])
    rot_phase = np.array([[0.3, 0.0, 1.1], [0.0, 0.7, 0.0]])
    return Trajectory(
        p0=p0,
        q0=q_wb0,
        pos_amp=amp,
        pos_harm=harm,
        pos_phase=phase,
        rot_amp=rot_amp,
        rot_harm=harm.copy(),
        rot_phase=rot_phase,
        phase_kind="smoothstep",
        t_start=static_before,
        period=period,
        duration=static_before + period + static_after,
    )


def random_trajectory(
    seed: int,
    duration: float = 10.0,
    n_terms: int = 4,
    position_amplitude: float = 0.15,
    rotation_amplitude: float = 0.08,
    max_frequency_hz: float = 0.6,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
) -> Trajectory:
    """Smooth (C^∞) random 6-DoF trajectory: ``n_terms`` random sinusoids per axis in position and rotation vector.

    Frequencies are uniform in (0.1, ``max_frequency_hz``) Hz; amplitudes are uniform up to ``position_amplitude``
    metres and ``rotation_amplitude`` radians per term; the camera stays near the default home pose, facing the scene.
    """
    rng = np.random.default_rng(seed)
    q_bc, p_bc = default_extrinsic() if extrinsic is None else extrinsic
    q_wb0, p0 = _body_from_camera(look_at_quat(CAMERA_HOME, SCENE_TARGET), CAMERA_HOME, q_bc, p_bc)
    omega0 = 2 * math.pi * 0.1
    harm_p = rng.uniform(1.0, max_frequency_hz / 0.1, n_terms)
    harm_r = rng.uniform(1.0, max_frequency_hz / 0.1, n_terms)
    return Trajectory(
        p0=p0,
        q0=q_wb0,
        pos_amp=rng.uniform(-position_amplitude, position_amplitude, (n_terms, 3)),
        pos_harm=harm_p,
        pos_phase=rng.uniform(0, 2 * math.pi, (n_terms, 3)),
        rot_amp=rng.uniform(-rotation_amplitude, rotation_amplitude, (n_terms, 3)),
        rot_harm=harm_r,
        rot_phase=rng.uniform(0, 2 * math.pi, (n_terms, 3)),
        phase_kind="linear",
        omega0=omega0,
        duration=duration,
    )


def two_plane_landmarks(rng: np.random.Generator, n: int = 300) -> np.ndarray:
    """``n`` landmarks (world frame, metres) on two orthogonal textured planes: the wall y = 0 (x ∈ [−1.2, 1.2],
    z ∈ [0, 1.6]) and the floor z = 0 (x ∈ [−1.2, 1.2], y ∈ [0, 1.0]); shape (n, 3)."""
    n_wall = n // 2
    wall = np.column_stack([rng.uniform(-1.2, 1.2, n_wall), np.zeros(n_wall), rng.uniform(0.0, 1.6, n_wall)])
    m = n - n_wall
    floor = np.column_stack([rng.uniform(-1.2, 1.2, m), rng.uniform(0.0, 1.0, m), np.zeros(m)])
    return np.vstack([wall, floor])


@dataclass
class FrameCorrespondences:
    """2-D–3-D point correspondences of all camera frames, flattened (what the filters consume).

    Frame ``k`` (camera-clock stamp ``t[k]``, s; ``t`` (F,)) owns rows ``offsets[k]:offsets[k+1]`` of ``pixels``
    (M, 2) and ``points`` (M, 3) world-frame landmark positions (metres); ``offsets`` (F + 1,) int64.
    """

    t: np.ndarray
    offsets: np.ndarray
    pixels: np.ndarray
    points: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def frame(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(pixels (m, 2), points (m, 3))`` of frame ``k``."""
        a, b = self.offsets[k], self.offsets[k + 1]
        return self.pixels[a:b], self.points[a:b]

    @property
    def counts(self) -> np.ndarray:
        """Number of correspondences per frame, shape (F,)."""
        return np.diff(self.offsets)


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
    trajectory: Trajectory
    magnetic_field: np.ndarray = field(default_factory=lambda: np.array([0.4, 0.0, -0.9]))

    def sensor_options(self) -> dict:
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
    trajectory: Trajectory,
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
    """Generate IMU samples and camera correspondences along ``trajectory`` (everything seeded by ``seed``).

    Parameters
    ----------
    trajectory : Trajectory
        Body (IMU) motion; its ``duration`` sets the run length.
    imu_noise : ImuNoise, optional
        Defaults to :class:`ImuNoise()` (Xsens-MTx-like); ``ImuNoise().scaled(0)`` is noise- and bias-free.
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
        Defaults to :func:`default_extrinsic`; must match the one used to build the trajectory's camera view.
    magnetometer_sigma : float, optional
        If given, a magnetometer ``m_b = R_wbᵀ m_w + noise`` (unit-norm-ish field) is simulated at the IMU rate.
    """
    if not 0.0 <= outlier_fraction < 1.0:
        raise ValueError(f"outlier_fraction must be in [0, 1); got {outlier_fraction}")
    imu_noise = ImuNoise() if imu_noise is None else imu_noise
    camera = PinholeCamera() if camera is None else camera
    q_bc, p_bc = default_extrinsic() if extrinsic is None else extrinsic
    q_bc = np.asarray(q_bc, float)
    p_bc = np.asarray(p_bc, float)
    rng = np.random.default_rng(seed)
    scene_rng = np.random.default_rng([seed, 1])
    landmarks = two_plane_landmarks(scene_rng, n_landmarks)

    ang = math.radians(gravity_misalignment_deg)
    gravity = STANDARD_GRAVITY * np.array([0.0, math.sin(ang), -math.cos(ang)])

    dt = 1.0 / imu_noise.update_rate
    n = int(math.floor(trajectory.duration * imu_noise.update_rate + 1e-9)) + 1
    t = np.arange(n) * dt
    truth = trajectory.kinematics(t)
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
        trajectory,
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
        trajectory=trajectory, magnetic_field=mag_field,
    )  # fmt: skip


def camera_points(q_wb: np.ndarray, p_wb: np.ndarray, q_bc: np.ndarray, p_bc: np.ndarray, pts_w: np.ndarray):
    """World points ``(M, 3)`` in the camera frame ``(M, 3)`` for body pose ``(q_wb, p_wb)`` and extrinsic."""
    pts_b = dp.quat_rotate(dp.quat_conj(q_wb), pts_w - p_wb)
    return dp.quat_rotate(dp.quat_conj(q_bc), pts_b - p_bc)


def _make_frames(
    traj, landmarks, camera, q_bc, p_bc, rng, rate, phase, sigma, per_frame, outlier_fraction, dropouts, offset
) -> CameraFrames:  # noqa: ANN001
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


def simulate_eight(seed: int = 0, **kwargs) -> SimulatedRun:  # noqa: ANN003
    """Hol's eight-shaped run (:func:`eight_trajectory`) with the default sensors; ``kwargs`` go to :func:`simulate`."""
    return simulate(eight_trajectory(), seed=seed, **kwargs)
