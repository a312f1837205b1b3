"""Hol's 22-state multi-rate EKF (Hol 2008 / Hol et al. 2007: state eq. 8, process eq. 9, measurements eq. 11a–c).

State (22,) = ``[b^e (3) m, ḃ^e (3) m/s, b̈^e (3) m/s², q^{be} (4) xyzw, ω^b_{eb} (3) rad/s, δ^b_ω (3) rad/s,
δ^b_a (3) m/s²]``; ``q^{be}`` rotates earth vectors into the body frame (``R^{be} = R_wbᵀ``).  Process (eq. 9):
constant acceleration and angular velocity driven by white noise, biases random walks,
``q_{t+1} = exp(−T/2 ω) ⊙ q_t``.  Accelerometer (eq. 11a) and gyroscope (eq. 11b) are *measurements* processed at
every IMU sample; camera frames (eq. 11c, the implicit ``[−f I₂, zⁱ] z^c = 0`` form, noise covariance
``(Z σ_px)² I₂`` with the predicted depth Z) whenever a frame arrives, after a time update to the frame time.  The
quaternion is renormalized after each update and its covariance block projected accordingly.  The step methods
are plain numpy (the readable reference); :meth:`Hol22EKF.run` is the same algorithm compiled
(:mod:`dualpose.estimation._hol22_kernels`).  The error-state filter (:mod:`dualpose.estimation.eskf`) is the faster,
recommended default.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

import dualpose as dp
from dualpose.estimation import models
from dualpose.estimation.eskf import InnovationReport
from dualpose.types import ImuNoise, PinholeCamera, SensorRun

__all__ = ["Hol22EKF", "Hol22Result", "HolProcessNoise", "process_model"]


@dataclass(frozen=True)
class HolProcessNoise:
    """Continuous-time spectral densities of the process noise (Hol Table 2.1's tuning knobs).

    ``acceleration`` ((m/s³)²/Hz) drives b̈ (eq. 9c), ``angular_velocity`` ((rad/s²)²/Hz) drives ω (eq. 9e);
    the bias random walks (eq. 9f, 9g) come from the IMU's Kalibr random walks.
    """

    acceleration: float = 400.0
    angular_velocity: float = 40.0


def _exp_half(omega: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """``exp(−T/2 ω)`` (xyzw, Hol eq. 10b) and its Jacobian w.r.t. ω (4, 3)."""
    r = float(np.linalg.norm(omega))
    th = 0.5 * T * r
    s = 0.5 * T * (math.sin(th) / th if th > 1e-8 else 1.0 - th * th / 6.0)  # sin(θ)/|ω|
    c2 = -((0.5 * T) ** 3) / 3.0 if th < 1e-4 else (0.5 * T * math.cos(th) - s) / (r * r)
    dq = np.array([-s * omega[0], -s * omega[1], -s * omega[2], math.cos(th)])
    J = np.empty((4, 3))
    J[0:3] = -(s * np.eye(3) + c2 * np.outer(omega, omega))
    J[3] = -0.5 * T * s * omega
    return dq, J


def process_model(x: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Hol eq. 9 without noise: the next 22-state (22,) and its Jacobian ``F = ∂f/∂x`` (22, 22)."""
    x = np.asarray(x, dtype=np.float64)
    if x.shape != (22,):
        raise ValueError(f"x must have shape (22,); got {x.shape}")
    F = np.eye(22)
    I3 = np.eye(3)
    F[0:3, 3:6] = T * I3
    F[0:3, 6:9] = 0.5 * T * T * I3
    F[3:6, 6:9] = T * I3
    dq, Jw = _exp_half(x[13:16], T)
    q = x[9:13]
    F[9:13, 9:13] = dp.quat_left_matrix(dq)  # ∂(dq ⊙ q)/∂q
    F[9:13, 13:16] = dp.quat_right_matrix(q) @ Jw  # ∂(dq ⊙ q)/∂ω
    out = x.copy()
    out[0:3] += T * x[3:6] + 0.5 * T * T * x[6:9]
    out[3:6] += T * x[6:9]
    out[9:13] = dp.quat_mul(dq, q)
    return out, F


@dataclass
class Hol22Result:
    """States at the IMU times: ``position`` (N, 3), ``velocity`` (N, 3), ``acceleration`` (N, 3),
    ``quat`` (N, 4) ``q_wb`` xyzw (the conjugate of Hol's q^{be}), ``omega`` (N, 3), ``gyro_bias`` (N, 3),
    ``accel_bias`` (N, 3), ``covariance`` (N, 22, 22); ``innovation`` the camera NIS report (2 dof)."""

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    quat: np.ndarray
    omega: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    covariance: np.ndarray
    innovation: InnovationReport
    wall_time: float


class Hol22EKF:
    """Hol's 22-state EKF.

    Parameters
    ----------
    x0 : (22,) initial state (eq. 8 layout).  P0 : (22, 22) initial covariance.
    imu_noise : ImuNoise (measurement noise of eq. 11a/11b and bias random walks).
    process_noise : HolProcessNoise.
    gravity, camera, q_bc, p_bc, pixel_sigma, gate_probability, camera_time_offset : as for
    :class:`~dualpose.estimation.eskf.ErrorStateEKF`.
    """

    def __init__(
        self,
        x0: np.ndarray,
        P0: np.ndarray,
        imu_noise: ImuNoise | None = None,
        process_noise: HolProcessNoise | None = None,
        gravity: np.ndarray = (0.0, 0.0, -9.81),
        camera: PinholeCamera | None = None,
        q_bc: np.ndarray = (0.0, 0.0, 0.0, 1.0),
        p_bc: np.ndarray = (0.0, 0.0, 0.0),
        pixel_sigma: float = 1.0,
        gate_probability: float = 0.999,
        camera_time_offset: float = 0.0,
    ) -> None:
        x0 = np.array(x0, dtype=np.float64)
        if x0.shape != (22,):
            raise ValueError(f"x0 must have shape (22,); got {x0.shape}")
        P0 = np.array(P0, dtype=np.float64)
        if P0.shape != (22, 22):
            raise ValueError(f"P0 must have shape (22, 22); got {P0.shape}")
        self.x = x0
        self.x[9:13] /= np.linalg.norm(self.x[9:13])
        self.P = 0.5 * (P0 + P0.T)
        self.imu_noise = ImuNoise() if imu_noise is None else imu_noise
        self.process_noise = HolProcessNoise() if process_noise is None else process_noise
        self.gravity = np.asarray(gravity, dtype=np.float64)
        self.camera = PinholeCamera() if camera is None else camera
        c = self.camera
        self.intrinsics = (c.fx, c.fy, c.cx, c.cy)
        self.q_bc = np.asarray(q_bc, dtype=np.float64)
        self.p_bc = np.asarray(p_bc, dtype=np.float64)
        self.pixel_sigma = float(pixel_sigma)
        self.gate = float(chi2.ppf(gate_probability, 2))
        self.camera_time_offset = float(camera_time_offset)
        n = self.imu_noise
        rate = n.update_rate
        self.R_imu = np.diag(
            np.r_[np.full(3, n.accelerometer_noise_density**2 * rate), np.full(3, n.gyroscope_noise_density**2 * rate)]
        )
        self._nis: list[np.ndarray] = []
        self._acc: list[np.ndarray] = []

    @classmethod
    def from_eskf_state(
        cls, x16: np.ndarray, P15: np.ndarray, run: SensorRun, omega: np.ndarray | None = None, **kwargs
    ) -> Hol22EKF:
        """Start from an error-state filter's state/covariance (position, velocity, q_wb, biases) for ``run``'s
        sensors: b̈ = 0 and ω = 0 (or ``omega``) with wide priors, q^{be} = conj(q_wb)."""
        x = np.zeros(22)
        x[0:6] = x16[0:6]
        q_be = dp.quat_conj(x16[6:10])
        x[9:13] = q_be
        x[13:16] = 0.0 if omega is None else omega
        x[16:19] = x16[10:13]
        x[19:22] = x16[13:16]
        # [δp, δv, δθ, δbg, δba] → 22-state: q^{be} = Exp(−δθ) ⊙ q^{be}  ⇒  ∂q/∂δθ = −½ W(q^{be})[:, :3]
        J = np.zeros((22, 15))
        J[0:6, 0:6] = np.eye(6)
        J[9:13, 6:9] = -0.5 * dp.quat_right_matrix(q_be)[:, :3]
        J[16:22, 9:15] = np.eye(6)
        P = J @ P15 @ J.T
        P[6:9, 6:9] += np.eye(3) * 0.5**2
        P[13:16, 13:16] += np.eye(3) * 0.1**2
        P[9:13, 9:13] += np.eye(4) * 1e-12
        opts = run.sensor_options()
        opts.update(kwargs)
        return cls(x, P, **opts)

    # ------------------------------------------------------------------ eq. 9
    def time_update(self, T: float) -> None:
        """Propagate by ``T`` seconds through the process model eq. 9 (``P ← F P Fᵀ + Q``)."""
        if T <= 0.0:
            return
        self.x, F = process_model(self.x, T)
        self.P = F @ self.P @ F.T + np.diag(self.process_noise_diagonal() * T)

    def process_noise_diagonal(self) -> np.ndarray:
        """Spectral densities (22,) on the diagonal of ``Q = diag(·) T``: b̈ (eq. 9c), ω (eq. 9e) and the bias
        random walks (eq. 9f, 9g); zero elsewhere."""
        pn, n = self.process_noise, self.imu_noise
        q = np.zeros(22)
        q[6:9] = pn.acceleration
        q[13:16] = pn.angular_velocity
        q[16:19] = n.gyroscope_random_walk**2
        q[19:22] = n.accelerometer_random_walk**2
        return q

    def _normalize(self) -> None:
        q = self.x[9:13]
        nq = np.linalg.norm(q)
        u = q / nq
        J = np.eye(22)
        J[9:13, 9:13] = (np.eye(4) - np.outer(u, u)) / nq
        self.x[9:13] = u
        self.P = J @ self.P @ J.T

    def _joseph(self, K: np.ndarray, H: np.ndarray, R: np.ndarray) -> None:
        A = np.eye(22) - K @ H
        P = A @ self.P @ A.T + K @ R @ K.T
        self.P = 0.5 * (P + P.T)

    # ------------------------------------------------------------------ eq. 11a, 11b
    def imu_update(self, accel: np.ndarray, gyro: np.ndarray) -> float:
        """Accelerometer + gyroscope measurement update (eq. 11a, 11b); returns the NIS (6 dof)."""
        ha, Ha = models.hol_accelerometer(self.x, self.gravity)
        hw, Hw = models.hol_gyroscope(self.x)
        H = np.vstack([Ha, Hw])
        nu = np.concatenate([np.asarray(accel, float) - ha, np.asarray(gyro, float) - hw])
        S = H @ self.P @ H.T + self.R_imu
        K = np.linalg.solve(S, H @ self.P).T
        self.x = self.x + K @ nu
        self._joseph(K, H, self.R_imu)
        self._normalize()
        return float(nu @ np.linalg.solve(S, nu))

    # ------------------------------------------------------------------ eq. 11c
    def camera_update(self, pixels: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Sequential χ²-gated update with the correspondences of one frame (eq. 11c, measured value 0).

        All correspondences are linearised at the predicted state and taken in order of their prior NIS (as in the
        error-state filter).  Returns the accepted mask (M,).
        """
        h, H, depth = models.hol_camera_implicit(self.x, pixels, points, self.intrinsics, self.q_bc, self.p_bc)
        m = len(h)
        Rs = (np.maximum(depth, 1e-3) * self.pixel_sigma) ** 2
        P = self.P
        prior = np.full(m, np.inf)
        for i in range(m):
            if depth[i] > 1e-6:
                S = H[i] @ P @ H[i].T + Rs[i] * np.eye(2)
                prior[i] = h[i] @ np.linalg.solve(S, h[i])
        dx = np.zeros(22)
        nis = np.full(m, np.inf)
        acc = np.zeros(m, bool)
        for i in np.argsort(prior):
            if depth[i] <= 1e-6:
                continue
            Hi = H[i]
            nu = -h[i] - Hi @ dx
            R = Rs[i] * np.eye(2)
            PHt = self.P @ Hi.T
            S = Hi @ PHt + R
            nis[i] = nu @ np.linalg.solve(S, nu)
            if nis[i] > self.gate:
                continue
            K = np.linalg.solve(S, PHt.T).T
            dx += K @ nu
            self._joseph(K, Hi, R)
            acc[i] = True
        self.x = self.x + dx
        self._normalize()
        self._nis.append(nis)
        self._acc.append(acc)
        return acc

    # ------------------------------------------------------------------ Algorithm 1
    def run(
        self,
        t: np.ndarray,
        gyro: np.ndarray,
        accel: np.ndarray,
        frame_t: np.ndarray,
        offsets: np.ndarray,
        pixels: np.ndarray,
        points: np.ndarray,
    ) -> Hol22Result:
        """Hol's Algorithm 1 over a recording (layouts as :meth:`ErrorStateEKF.run`); the current state is at
        ``t[0]``.  Camera frames are processed at their own times (time update to the frame time first).

        Runs as one compiled loop (:mod:`dualpose.estimation._hol22_kernels`) with the same equations as
        :meth:`time_update`, :meth:`camera_update` and :meth:`imu_update` called in that order.
        """
        from dualpose._validation import lazy_kernels

        kernel = lazy_kernels("dualpose.estimation._hol22_kernels")("run")
        from dualpose.estimation._stream import check_streams

        t, gyro, accel, cam_t, offsets, pixels, points = check_streams(
            t, gyro, accel, frame_t, offsets, pixels, points, self.camera_time_offset, strictly_increasing=False
        )
        n = len(t)
        X = np.empty((n, 22))
        Ps = np.empty((n, 22, 22))
        nis = np.full(len(pixels), np.nan)
        acc = np.zeros(len(pixels), np.int64)
        Rcb = dp.matrix_from_quat(dp.quat_conj(self.q_bc))
        self.x = np.ascontiguousarray(self.x)
        self.P = np.ascontiguousarray(self.P)
        t0 = _time.perf_counter()
        kernel(t, gyro, accel, cam_t, offsets, pixels, points, self.x, self.P, self.process_noise_diagonal(),
               self.gravity, self.R_imu, np.array(self.intrinsics, dtype=np.float64), self.p_bc, Rcb,
               self.pixel_sigma, self.gate, X, Ps, nis, acc)  # fmt: skip
        wall = _time.perf_counter() - t0
        used = ~np.isnan(nis)
        self._nis.append(nis[used])
        self._acc.append(acc[used].astype(bool))
        rep = InnovationReport(
            nis[used], acc[used].astype(bool), 2, (float(chi2.ppf(0.025, 2)), float(chi2.ppf(0.975, 2))), self.gate
        )
        return Hol22Result(
            t=t, position=X[:, 0:3], velocity=X[:, 3:6], acceleration=X[:, 6:9], quat=dp.quat_conj(X[:, 9:13]),
            omega=X[:, 13:16], gyro_bias=X[:, 16:19], accel_bias=X[:, 19:22], covariance=Ps, innovation=rep,
            wall_time=wall,
        )  # fmt: skip

    def run_recording(self, run: SensorRun) -> Hol22Result:
        """:meth:`run` on a recording or simulated run (anything with the :class:`~dualpose.types.SensorRun` fields)."""
        f = run.frames
        return self.run(run.t, run.gyro, run.accel, f.t, f.offsets, f.pixels, f.points)
