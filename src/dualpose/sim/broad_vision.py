"""Pseudo-vision on real IMU data: a BROAD trial turned into a camera-IMU recording.

BROAD (Laidig, Caruso, Cereatti, Seel: "BROAD -- A Benchmark for Robust Inertial Orientation Estimation", Data
2021, 6(7), 72; CC BY 4.0) records a real IMU at 285.7 Hz together with an optical reference pose.  Here the real
IMU drives :class:`~dualpose.estimation.eskf.ErrorStateEKF` and the camera is virtual: a fixed field of landmarks is
projected through the optical reference pose (``opt_quat`` IMU→ENU, ``opt_pos`` m, interpolated to the frame
times: linear / slerp) at 12.5 Hz with 1 px noise into the simulator's camera (320 × 240, f = 213.3 px) mounted
with the simulator's default extrinsic.  Frames are only produced where the reference at both neighbouring samples
is finite (no frame while the optical system lost the markers).  The world frame is ENU, gravity
``[0, 0, −9.8128]`` m/s² (normal gravity at Berlin, 52.5° N).  The filter starts from the static start
(:attr:`~dualpose.io.broad.BroadTrial.static_start`: gyro bias, levelling) and a PnP of the first frame in it.

Noise model, the same rule for every trial: white-noise densities measured on the trial's static start (standard
deviation of first differences / √2 / √rate, RMS over the axes) times :data:`NOISE_INFLATION` (the allowance for
errors in motion that the white-noise model lacks, chosen by NIS consistency); bias random walks and the
accelerometer turn-on bias of the consumer-MEMS class (:data:`GYROSCOPE_RANDOM_WALK`,
:data:`ACCELEROMETER_RANDOM_WALK`, :data:`ACCELEROMETER_INITIAL_BIAS_SIGMA`).  Time: the IMU stamps lag the
reference by :data:`REFERENCE_TIME_OFFSET` (one value for the dataset), so the pseudo-camera carries that
``timeshift_cam_imu`` and the reference is compared on the IMU clock (:func:`reference_on_imu_clock`).

Not modelled: the lever arm between the IMU and the point the optical reference tracks (≈ 1 cm by a least-squares
fit on the trials) and any residual IMU/reference time offset; both appear as vision-inertial inconsistency.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dualpose.io.broad import BroadTrial
from dualpose.sim.camera_imu import observe_landmarks
from dualpose.sim.motion import default_extrinsic, extrinsic_arrays
from dualpose.types import FrameCorrespondences, ImuNoise, PinholeCamera, Recording, Trajectory
from dualpose.types.trajectory import interpolate_poses

__all__ = [
    "BERLIN_GRAVITY",
    "GYROSCOPE_RANDOM_WALK",
    "ACCELEROMETER_RANDOM_WALK",
    "ACCELEROMETER_INITIAL_BIAS_SIGMA",
    "NOISE_INFLATION",
    "REFERENCE_TIME_OFFSET",
    "imu_noise_from_rest",
    "landmark_shell",
    "dropout_windows",
    "pseudo_vision",
    "reference_on_imu_clock",
    "recording_from_broad",
]

#: m/s², WGS84 normal gravity at 52.5° N, 40 m (Berlin, where BROAD was recorded); ENU gravity is [0, 0, −g]
BERLIN_GRAVITY = 9.8128
#: rad/s²/√Hz, gyro bias random walk of the consumer-MEMS class (≈ 5× the ADIS16448's Kalibr value)
GYROSCOPE_RANDOM_WALK = 1.0e-4
#: m/s³/√Hz, accelerometer bias random walk of the consumer-MEMS class (the ADIS16448's Kalibr value)
ACCELEROMETER_RANDOM_WALK = 3.0e-3
#: factor on the white-noise densities measured at rest: allowance for what a MEMS IMU adds in motion and the
#: filter does not model (gyro scale factor and axis misalignment ≈ 0.5 % on BROAD, i.e. ~0.01–0.03 rad/s at
#: 2–5 rad/s; accelerometer scale/misalignment, g-sensitivity, impacts).  One value for all trials, chosen without
#: the reference: of the factors {1, 3, 10, 30, 100}, the one whose lowest camera-NIS coverage over the seven trials
#: is closest to the nominal 95 % (0.945; ×10 and ×100 give 0.934); the sweep is tabulated in docs/broad-pose.md
NOISE_INFLATION = 30.0
#: m/s², accelerometer turn-on bias σ (consumer MEMS: ~0.1 m/s²; BROAD's static ``|a|`` is 9.82–9.91 m/s²)
ACCELEROMETER_INITIAL_BIAS_SIGMA = 0.1
#: s, the IMU stamps lag the optical reference: the gyro stamped t measured the rotation the reference shows at
#: t − 4.1 ms (least-squares fit of the gyro to the reference's angular rate over 0.25 ms steps: 4.0–4.25 ms in all
#: seven trials); one value for the dataset, used as the pseudo-camera's ``timeshift_cam_imu``
REFERENCE_TIME_OFFSET = 4.1e-3
#: pseudo-vision: camera rate (Hz), pixel noise (px), correspondences per frame, landmarks, shell radii (m)
CAMERA_RATE = 12.5
PIXEL_SIGMA = 1.0
PER_FRAME = 20
N_LANDMARKS = 1500
SHELL_RADII = (2.0, 5.0)


def imu_noise_from_rest(gyr: np.ndarray, acc: np.ndarray, rate: float, inflation: float = NOISE_INFLATION) -> ImuNoise:
    """IMU noise for a BROAD trial: white-noise densities from samples at rest, the rest from the sensor class.

    The measured density is ``std(diff(x)) / √2 / √rate`` (first differences cancel a slowly varying bias and the
    orientation), RMS over the three axes; the filter gets it times ``inflation`` (:data:`NOISE_INFLATION`).

    Parameters
    ----------
    gyr, acc : (n, 3) rad/s, m/s², at rest.  rate : Hz.  inflation : float, > 0.
    """
    gyr = np.asarray(gyr, dtype=np.float64)
    acc = np.asarray(acc, dtype=np.float64)
    if gyr.ndim != 2 or gyr.shape[1] != 3 or acc.shape != gyr.shape or len(gyr) < 3:
        raise ValueError(f"gyr and acc must have the same shape (n >= 3, 3); got {gyr.shape} and {acc.shape}")

    if not inflation > 0:
        raise ValueError(f"inflation must be > 0; got {inflation}")

    def density(x: np.ndarray) -> float:
        return inflation * float(np.sqrt(np.mean(np.var(np.diff(x, axis=0), axis=0) / 2.0)) / math.sqrt(rate))

    return ImuNoise(
        gyroscope_noise_density=density(gyr),
        gyroscope_random_walk=GYROSCOPE_RANDOM_WALK,
        accelerometer_noise_density=density(acc),
        accelerometer_random_walk=ACCELEROMETER_RANDOM_WALK,
        gyroscope_initial_bias_sigma=ImuNoise().gyroscope_initial_bias_sigma,
        accelerometer_initial_bias_sigma=ACCELEROMETER_INITIAL_BIAS_SIGMA,
        update_rate=float(rate),
    )


def landmark_shell(
    rng: np.random.Generator, center: np.ndarray, n: int = N_LANDMARKS, radii: tuple[float, float] = SHELL_RADII
) -> NDArray[np.float64]:
    """``n`` landmarks (n, 3) uniformly distributed in the spherical shell ``radii`` (m) around ``center`` (3,):
    a virtual room that a camera pointing anywhere from inside sees (~9 % of them in the 74° × 59° view)."""
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r0, r1 = radii
    r = (r0**3 + rng.random(n) * (r1**3 - r0**3)) ** (1.0 / 3.0)  # uniform in volume
    return np.asarray(center, dtype=np.float64) + d * r[:, None]


def dropout_windows(
    t_start: float, t_end: float, length: float = 2.0, period: float = 10.0
) -> tuple[tuple[float, float], ...]:
    """Vision dropouts of ``length`` s every ``period`` s between ``t_start`` and ``t_end``: the windows
    ``[t_start + k·period + (period − length)/2, … + length)`` for k = 0, 1, … that end before ``t_end``."""
    if not (0 < length < period):
        raise ValueError(f"need 0 < length < period; got length={length}, period={period}")
    out = []
    a = t_start + 0.5 * (period - length)
    while a + length <= t_end:
        out.append((a, a + length))
        a += period
    return tuple(out)


def pseudo_vision(
    trial: BroadTrial,
    landmarks: np.ndarray,
    rng: np.random.Generator,
    camera: PinholeCamera | None = None,
    extrinsic: tuple[np.ndarray, np.ndarray] | None = None,
    rate: float = CAMERA_RATE,
    phase: float = 0.0137,
    pixel_sigma: float = PIXEL_SIGMA,
    per_frame: int = PER_FRAME,
    dropouts: tuple[tuple[float, float], ...] = (),
) -> FrameCorrespondences:
    """Camera frames of ``landmarks`` (L, 3) seen through the optical reference pose of ``trial``.

    Frames at ``phase + k / rate`` s (trial time, the IMU clock; no time offset) where the reference at both
    neighbouring samples is finite and the time is outside every ``dropouts`` interval ``[a, b)``; the reference
    pose is interpolated (linear position, slerp) and observed by :func:`dualpose.sim.observe_landmarks`.
    """
    camera = PinholeCamera() if camera is None else camera
    q_bc, p_bc = extrinsic_arrays(extrinsic)
    t = trial.time
    ok = _finite_reference(trial)
    tf = np.arange(phase, t[-1], 1.0 / rate)
    k = np.clip(np.searchsorted(t, tf, side="right"), 1, len(t) - 1)
    keep = ok[k - 1] & ok[k]
    for a, b in dropouts:
        keep &= ~((tf >= a) & (tf < b))
    tf = tf[keep]
    p, q = interpolate_poses(t[ok], trial.pos[ok], trial.quat[ok], tf)
    obs = observe_landmarks(q, p, landmarks, camera, q_bc, p_bc, rng, pixel_sigma, per_frame)
    return FrameCorrespondences(tf, obs["offsets"], obs["pixels"], obs["points"])


def _finite_reference(trial: BroadTrial) -> NDArray[np.bool_]:
    result: NDArray[np.bool_] = np.isfinite(trial.quat).all(axis=1) & np.isfinite(trial.pos).all(axis=1)
    return result


def reference_on_imu_clock(trial: BroadTrial, offset: float = REFERENCE_TIME_OFFSET) -> Trajectory:
    """The optical reference at the IMU sample times: ``ref(t_k − offset)`` interpolated (linear / slerp) between
    two finite reference samples; IMU times whose bracketing reference samples are not both finite are left out."""
    t = trial.time
    ok = _finite_reference(trial)
    tr = t - offset
    k = np.searchsorted(t, tr, side="right")
    inside = (k >= 1) & (k < len(t))
    k = np.clip(k, 1, len(t) - 1)
    keep = inside & ok[k - 1] & ok[k]
    p, q = interpolate_poses(t[ok], trial.pos[ok], trial.quat[ok], tr[keep])
    return Trajectory(t[keep], p, q, name=f"{trial.name} optical reference")


def recording_from_broad(
    trial: BroadTrial,
    seed: int = 0,
    dropout: tuple[float, float] | None = None,
    name: str | None = None,
    noise_inflation: float = NOISE_INFLATION,
    time_offset: float = REFERENCE_TIME_OFFSET,
) -> Recording:
    """The :class:`~dualpose.types.recording.Recording` of a BROAD trial with pseudo-vision (module docstring).

    Parameters
    ----------
    trial : BroadTrial
    seed : int
        Seeds the landmark field and the pixel noise.
    dropout : (length, period) in seconds, optional
        Drop the vision for ``length`` s every ``period`` s during the movement phase (:func:`dropout_windows`
        from the first movement sample to the end).
    name : str, optional
        Label; default the trial name.
    noise_inflation : float
        Factor on the white-noise densities measured on the static start (:func:`imu_noise_from_rest`).
    time_offset : float
        IMU-clock minus reference-clock time, s (:data:`REFERENCE_TIME_OFFSET`): the camera's
        ``timeshift_cam_imu`` and the shift of the reference used as ground truth (:func:`reference_on_imu_clock`).

    Returns
    -------
    Recording
        World ENU.  The IMU stream starts at the last sample before the first pseudo-vision frame (index
        ``info["first_sample"]`` of the trial); ``rest_seconds`` runs from there to the end of the static start;
        ``ground_truth`` is :func:`reference_on_imu_clock` from there on; ``info`` also holds ``movement`` (bool,
        per recording sample), ``dropouts`` and ``landmarks``.
    """
    if not isinstance(trial, BroadTrial):
        raise TypeError(f"trial must be a dualpose.io.BroadTrial; got {type(trial).__name__}")
    n_rest = trial.static_start
    if n_rest < 3:
        raise ValueError(f"{trial.name}: the static start has {n_rest} samples; at least 3 are needed")
    t = trial.time
    ok = _finite_reference(trial)
    rng = np.random.default_rng([seed, 6])
    landmarks = landmark_shell(rng, np.mean(trial.pos[ok], axis=0))
    windows = () if dropout is None else dropout_windows(t[n_rest], t[-1], *dropout)
    frames = pseudo_vision(trial, landmarks, rng, dropouts=windows)
    if len(frames) == 0:
        raise ValueError(f"{trial.name}: the optical reference is never finite; no pseudo-vision frames")
    # start at the last IMU sample before the first frame: the optical system may see the markers only some seconds
    # into the static start, and inertial dead reckoning until then would drift far out of the camera model's reach
    i0 = max(int(np.searchsorted(t, frames.t[0] + time_offset, side="right")) - 1, 0)
    if n_rest - i0 < 3:
        raise ValueError(f"{trial.name}: the first reference pose comes after the static start; cannot initialise")
    trial.require_finite(start=i0)  # named by the trial's own sample numbers
    q_bc, p_bc = default_extrinsic()
    truth = reference_on_imu_clock(trial, time_offset)
    truth = truth.take(np.flatnonzero(truth.stamps >= t[i0]))
    return Recording(
        t=t[i0:], gyro=trial.gyr[i0:], accel=trial.acc[i0:], frames=frames, camera=PinholeCamera(), q_bc=q_bc,
        p_bc=p_bc, pixel_sigma=PIXEL_SIGMA,
        imu_noise=imu_noise_from_rest(trial.gyr[i0:n_rest], trial.acc[i0:n_rest], trial.rate, noise_inflation),
        time_offset=time_offset, gravity=np.array([0.0, 0.0, -BERLIN_GRAVITY]),
        rest_seconds=(n_rest - i0) / trial.rate, ground_truth=truth, name=trial.name if name is None else name,
        info={"movement": trial.movement[i0:], "dropouts": windows, "landmarks": landmarks, "first_sample": i0},
    )  # fmt: skip
