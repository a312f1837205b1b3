"""Hol's 22-state multi-rate EKF (Hol 2008 / Hol et al. 2007: state eq. 8, process eq. 9, measurements eq. 11a–c).

State (22,) = ``[b^e (3) m, ḃ^e (3) m/s, b̈^e (3) m/s², q^{be} (4) xyzw, ω^b_{eb} (3) rad/s, δ^b_ω (3) rad/s,
δ^b_a (3) m/s²]``; ``q^{be}`` rotates earth vectors into the body frame (``R^{be} = R_wbᵀ``).  Process (eq. 9):
constant acceleration and angular velocity driven by white noise, biases random walks,
``q_{t+1} = exp(−T/2 ω) ⊙ q_t``.  Accelerometer (eq. 11a) and gyroscope (eq. 11b) are *measurements* processed at
every IMU sample; camera frames (eq. 11c, the implicit ``[−f I₂, zⁱ] z^c = 0`` form, noise covariance
``(Z σ_px)² I₂`` with the predicted depth Z) whenever a frame arrives, after a time update to the frame time.  The
quaternion is renormalized after each update and its covariance block projected accordingly.  The step methods
are plain numpy (the readable reference); :meth:`Hol22EKF.run` is the same algorithm compiled
(``dualpose._native.hol22_run``, src/native/estimation/hol22_*), and :class:`Hol22Stream` runs its steps one
sample / frame at a time (streaming).  The error-state filter
(:mod:`dualpose.estimation.eskf`) is the faster, recommended default.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

import dualpose as dp
from dualpose import _native
from dualpose.estimation import models
from dualpose.estimation._fusion_stream import FrameUpdate, FusionStream
from dualpose.estimation._stream import check_streams
from dualpose.estimation.eskf import InnovationReport, _report
from dualpose.estimation.interface import Estimator, UpdateResult
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE, HOL22_STATE
from dualpose.types import CameraFrame, ImuNoise, PinholeCamera, SensorRun, _inputs

__all__ = ["Hol22EKF", "Hol22Result", "Hol22Stream", "HolProcessNoise", "process_model"]


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
    n = HOL22_STATE.dim
    if x.shape != (n,):
        raise ValueError(f"x must have shape ({n},); got {x.shape}")
    p, v, a = (HOL22_STATE.slice(k) for k in ("position", "velocity", "acceleration"))
    qs, ws = HOL22_STATE.slice("quat_be"), HOL22_STATE.slice("angular_velocity")
    F = np.eye(n)
    I3 = np.eye(3)
    F[p, v] = T * I3
    F[p, a] = 0.5 * T * T * I3
    F[v, a] = T * I3
    dq, Jw = _exp_half(x[ws], T)
    q = x[qs]
    F[qs, qs] = dp.quat_left_matrix(dq)  # ∂(dq ⊙ q)/∂q
    F[qs, ws] = dp.quat_right_matrix(q) @ Jw  # ∂(dq ⊙ q)/∂ω
    out = x.copy()
    out[p] += T * x[v] + 0.5 * T * T * x[a]
    out[v] += T * x[a]
    out[qs] = dp.quat_mul(dq, q)
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


class _SensorOptions(Protocol):
    """A recording, simulated run or sensor set-up: what :meth:`Hol22EKF.from_eskf_state` reads of it."""

    def sensor_options(self) -> dict[str, Any]: ...


class Hol22EKF(Estimator):
    """Hol's 22-state EKF; an :class:`~dualpose.estimation.interface.Estimator` whose state and covariance both
    follow :data:`~dualpose.estimation.state.HOL22_STATE` (the quaternion ``q^{be}`` as four numbers).

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
        gravity: ArrayLike = (0.0, 0.0, -9.81),
        camera: PinholeCamera | None = None,
        q_bc: ArrayLike = (0.0, 0.0, 0.0, 1.0),
        p_bc: ArrayLike = (0.0, 0.0, 0.0),
        pixel_sigma: float = 1.0,
        gate_probability: float = 0.999,
        camera_time_offset: float = 0.0,
    ) -> None:
        # the filter-parameter checks every path shares (dualpose.types._inputs, docs/refusals.md)
        x0 = _inputs.finite_vector(x0, "x0", HOL22_STATE.dim)
        self.x = x0
        q = HOL22_STATE.get(self.x, "quat_be")
        q[:] = _inputs.unit_quaternion(q, "x0[quat_be]")
        self.time: float | None = None
        self.P = _inputs.covariance_matrix(P0, "P0", HOL22_STATE.dim)
        self.imu_noise = ImuNoise() if imu_noise is None else imu_noise
        _inputs.check_imu_noise(self.imu_noise)
        self.process_noise = HolProcessNoise() if process_noise is None else process_noise
        self.gravity = _inputs.gravity_vector(gravity)
        self.camera = PinholeCamera() if camera is None else camera
        _inputs.check_camera(self.camera)
        c = self.camera
        self.intrinsics = (c.fx, c.fy, c.cx, c.cy)
        self.q_bc = _inputs.unit_quaternion(q_bc, "q_bc")
        self.p_bc = _inputs.finite_vector(p_bc, "p_bc", 3, _inputs.MAX_POSITION_M, "m")
        self.pixel_sigma = _inputs.positive(pixel_sigma, "pixel_sigma", 1e4, "px")
        self.gate = float(chi2.ppf(_inputs.probability(gate_probability, "gate_probability"), 2))
        camera_time_offset = _inputs.time_offset(camera_time_offset, "camera_time_offset")
        self.camera_time_offset = float(camera_time_offset)
        nz = self.imu_noise
        rate = nz.update_rate
        self.R_imu = np.diag(np.r_[np.full(3, nz.accelerometer_noise_density**2 * rate),
                                   np.full(3, nz.gyroscope_noise_density**2 * rate)])  # fmt: skip
        # scale-factor noise (ImuNoise ``*_scale_sigma``): ε² |z|² · 1 s as a density, times the rate per sample
        self.scale2 = np.array([nz.gyroscope_scale_sigma**2 * rate, nz.accelerometer_scale_sigma**2 * rate])
        self._nis: list[np.ndarray] = []
        self._acc: list[np.ndarray] = []

    @classmethod
    def from_eskf_state(
        cls, x16: np.ndarray, P15: np.ndarray, run: _SensorOptions, omega: np.ndarray | None = None, **kwargs: Any
    ) -> Hol22EKF:
        """Start from an error-state filter's state/covariance (position, velocity, q_wb, biases) for ``run``'s
        sensors: b̈ = 0 and ω = 0 (or ``omega``) with wide priors, q^{be} = conj(q_wb)."""
        S, E, L = ESKF_STATE, ESKF_ERROR, HOL22_STATE
        q_be = dp.quat_conj(S.get(x16, "quat"))
        x = L.assemble(
            position=S.get(x16, "position"), velocity=S.get(x16, "velocity"), acceleration=np.zeros(3), quat_be=q_be,
            angular_velocity=np.zeros(3) if omega is None else omega, gyro_bias=S.get(x16, "gyro_bias"),
            accel_bias=S.get(x16, "accel_bias"),
        )  # fmt: skip
        # [δp, δv, δθ, δbg, δba] → 22-state: q^{be} = Exp(−δθ) ⊙ q^{be}  ⇒  ∂q/∂δθ = −½ W(q^{be})[:, :3]
        J = np.zeros((L.dim, E.dim))
        for block in ("position", "velocity", "gyro_bias", "accel_bias"):
            J[L.slice(block), E.slice(block)] = np.eye(3)
        J[L.slice("quat_be"), E.slice("attitude")] = -0.5 * dp.quat_right_matrix(q_be)[:, :3]
        P = J @ P15 @ J.T
        L.cov(P, "acceleration")[:] += np.eye(3) * 0.5**2
        L.cov(P, "angular_velocity")[:] += np.eye(3) * 0.1**2
        L.cov(P, "quat_be")[:] += np.eye(4) * 1e-12
        opts = run.sensor_options()
        opts.update(kwargs)
        return cls(x, P, **opts)

    # ------------------------------------------------------------------ the estimator interface
    state_layout = HOL22_STATE
    covariance_layout = HOL22_STATE

    @property
    def state(self) -> np.ndarray:
        """State (22,) (:data:`~dualpose.estimation.state.HOL22_STATE`), a copy."""
        return np.copy(self.x, order="C")

    @property
    def covariance(self) -> np.ndarray:
        """Covariance (22, 22) in the state's own layout, a copy."""
        return np.copy(self.P, order="C")

    @property
    def quat(self) -> np.ndarray:
        """Orientation ``q_wb`` (4,) xyzw, the conjugate of Hol's ``q^{be}``."""
        return dp.quat_conj(HOL22_STATE.get(self.x, "quat_be"))

    def _attitude_jacobian(self) -> np.ndarray:
        """``∂e/∂q^{be}`` (3, 4) of the world-frame attitude error: ``q^{be}_true = q̂^{be} ⊗ Exp(−e)`` gives
        ``e ≈ −2 [q̂^{be}* ⊗ δq]_xyz``."""
        J: NDArray[np.float64] = -2.0 * dp.quat_left_matrix(dp.quat_conj(HOL22_STATE.get(self.x, "quat_be")))[:3, :]
        return J

    def attitude_covariance(self) -> np.ndarray:
        """World-frame attitude error covariance (3, 3), projected from the (4, 4) block of ``q^{be}``."""
        J = self._attitude_jacobian()
        out: NDArray[np.float64] = J @ HOL22_STATE.cov(self.P, "quat_be") @ J.T
        return out

    def tangent_covariance(self) -> np.ndarray:
        """Covariance (21, 21) with the quaternion block replaced by the world-frame attitude error (3,): ``T P Tᵀ``
        with ``T`` the identity on every other block and ``_attitude_jacobian`` on ``q^{be}`` (the 22-state
        covariance is singular along the unit quaternion after each renormalisation)."""
        L = HOL22_STATE
        rows = []
        for name in L.names:
            block = np.zeros((3 if name == "quat_be" else L.size(name), L.dim))
            block[:, L.slice(name)] = self._attitude_jacobian() if name == "quat_be" else np.eye(L.size(name))
            rows.append(block)
        T = np.vstack(rows)
        out: NDArray[np.float64] = T @ self.P @ T.T
        return out

    def _attitude_model(self, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # ρ = Log(q_m ⊗ q^{be}) ≈ r + J_r⁻¹(r) (−∂e/∂q) δq  ⇒  H = J_r⁻¹(r) ∂e/∂q (innovation r − H δq)
        r = dp.rotvec_from_quat(dp.quat_mul(quat, HOL22_STATE.get(self.x, "quat_be")))
        H = np.zeros((3, HOL22_STATE.dim))
        H[:, HOL22_STATE.slice("quat_be")] = dp.so3_right_jacobian_inv(r) @ self._attitude_jacobian()
        return r, H

    def _update_linear(self, residual: np.ndarray, jacobian: np.ndarray, covariance: np.ndarray) -> UpdateResult:
        self._check_linear(residual, jacobian, covariance)
        S = jacobian @ self.P @ jacobian.T + covariance
        K = np.linalg.solve(S, jacobian @ self.P).T
        self.x = self.x + K @ residual
        self._joseph(K, jacobian, covariance)
        self._normalize()
        return UpdateResult(float(residual @ np.linalg.solve(S, residual)), len(residual), True)

    def propagate(self, t: float, gyro: ArrayLike, accel: ArrayLike, mag: ArrayLike | None = None) -> None:
        """Algorithm 1 for one IMU sample taken at ``t``: time update from the filter time (eq. 9), then the
        accelerometer and gyroscope measurement update (eq. 11a, 11b).  ``mag`` is not used."""
        self.time_update(self._elapsed(t, f"IMU sample at t={t}"))
        self.time = float(t)
        self.imu_update(accel, gyro)

    def _update_camera(self, frame: CameraFrame) -> UpdateResult:
        t = self._frame_time(frame.t, self.camera_time_offset)
        assert self.time is not None  # (_frame_time set the time)
        self.time_update(t - self.time)
        self.time = t
        accepted = self.camera_update(frame.pixels, frame.points)
        return UpdateResult(self._nis[-1], 2, accepted)

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
        z = np.zeros(3)
        return HOL22_STATE.assemble(
            position=z, velocity=z, acceleration=np.full(3, pn.acceleration), quat_be=np.zeros(4),
            angular_velocity=np.full(3, pn.angular_velocity), gyro_bias=np.full(3, n.gyroscope_random_walk**2),
            accel_bias=np.full(3, n.accelerometer_random_walk**2),
        )  # fmt: skip

    def _normalize(self) -> None:
        qs = HOL22_STATE.slice("quat_be")
        q = self.x[qs]
        nq = np.linalg.norm(q)
        u = q / nq
        J = np.eye(HOL22_STATE.dim)
        J[qs, qs] = (np.eye(4) - np.outer(u, u)) / nq
        self.x[qs] = u
        self.P = J @ self.P @ J.T

    def _joseph(self, K: np.ndarray, H: np.ndarray, R: np.ndarray) -> None:
        A = np.eye(HOL22_STATE.dim) - K @ H
        P = A @ self.P @ A.T + K @ R @ K.T
        self.P = 0.5 * (P + P.T)

    # ------------------------------------------------------------------ eq. 11a, 11b
    def imu_update(self, accel: ArrayLike, gyro: ArrayLike) -> float:
        """Accelerometer + gyroscope measurement update (eq. 11a, 11b); returns the NIS (6 dof)."""
        ha, Ha = models.hol_accelerometer(self.x, self.gravity)
        hw, Hw = models.hol_gyroscope(self.x)
        H = np.vstack([Ha, Hw])
        nu = np.concatenate([np.asarray(accel, float) - ha, np.asarray(gyro, float) - hw])
        a, w = np.asarray(accel, float), np.asarray(gyro, float)
        R = self.R_imu + np.diag(np.r_[np.full(3, self.scale2[1] * (a @ a)), np.full(3, self.scale2[0] * (w @ w))])
        S = H @ self.P @ H.T + R
        K = np.linalg.solve(S, H @ self.P).T
        self.x = self.x + K @ nu
        self._joseph(K, H, R)
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
        dx = np.zeros(HOL22_STATE.dim)
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

    def kernel_config(self) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float, float,
    ]:
        """The constants of the compiled filter (``hol22_run``, ``hol22_stream_new``): ``qdiag`` (22,) (
        :meth:`process_noise_diagonal`), ``gravity`` (3,), ``R_imu`` (6, 6), ``scale2`` (2,) ``[ε_g², ε_a²] · rate``
        (added to the gyro / accelerometer diagonal of ``R_imu`` times the squared measured norm), ``intr`` (4,)
        ``[fx, fy, cx, cy]``,
        ``p_bc`` (3,), ``R^{cb}`` (3, 3), ``pixel_sigma``, ``gate``; float64, C-contiguous."""
        f64 = np.float64
        Rcb = np.ascontiguousarray(dp.matrix_from_quat(dp.quat_conj(self.q_bc)), dtype=f64)
        return (self.process_noise_diagonal(), np.ascontiguousarray(self.gravity, dtype=f64),
                np.ascontiguousarray(self.R_imu, dtype=f64), np.ascontiguousarray(self.scale2, dtype=f64),
                np.array(self.intrinsics, dtype=f64),
                np.ascontiguousarray(self.p_bc, dtype=f64), Rcb, self.pixel_sigma, self.gate)  # fmt: skip

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

        Runs as one compiled loop (``dualpose._native.hol22_run``) with the same equations as
        :meth:`time_update`, :meth:`camera_update` and :meth:`imu_update` called in that order.
        """
        t, gyro, accel, cam_t, offsets, pixels, points = check_streams(
            t, gyro, accel, frame_t, offsets, pixels, points, self.camera_time_offset, strictly_increasing=False
        )
        n, nx = len(t), HOL22_STATE.dim
        X = np.empty((n, nx))
        Ps = np.empty((n, nx, nx))
        nis = np.full(len(pixels), np.nan)
        acc = np.zeros(len(pixels), np.int64)
        self.x = np.ascontiguousarray(self.x)
        self.P = np.ascontiguousarray(self.P)
        t0 = _time.perf_counter()
        _native.hol22_run(t, gyro, accel, cam_t, offsets, pixels, points, self.x, self.P, *self.kernel_config(), X,
                          Ps, nis, acc)  # fmt: skip
        wall = _time.perf_counter() - t0
        used = ~np.isnan(nis)
        self._nis.append(nis[used])
        self._acc.append(acc[used].astype(bool))
        rep = _report(nis[used], acc[used].astype(bool), self.gate)
        self.time = float(t[-1])
        L = HOL22_STATE
        return Hol22Result(
            t=t, position=L.get(X, "position"), velocity=L.get(X, "velocity"), acceleration=L.get(X, "acceleration"),
            quat=dp.quat_conj(L.get(X, "quat_be")), omega=L.get(X, "angular_velocity"), gyro_bias=L.get(X, "gyro_bias"),
            accel_bias=L.get(X, "accel_bias"), covariance=Ps, innovation=rep, wall_time=wall,
        )  # fmt: skip

    def run_recording(self, run: SensorRun) -> Hol22Result:
        """:meth:`run` on a recording or simulated run (anything with the :class:`~dualpose.types.SensorRun` fields)."""
        f = run.frames
        return self.run(run.t, run.gyro, run.accel, f.t, f.offsets, f.pixels, f.points)


class Hol22Stream(FusionStream):
    """:class:`Hol22EKF` one sample / frame at a time, bit for bit its :meth:`~Hol22EKF.run` (docs/fusion.md
    "Streaming"; the queue, blocks and saved state: ``dualpose.estimation._fusion_stream``).

    Parameters
    ----------
    filter : Hol22EKF
        The filter to continue (state, covariance, noise, camera, extrinsic, gate, camera time offset); not changed.
    """

    _kind = "hol22"
    _filter_type = Hol22EKF
    #: the layout of :attr:`state`
    state_layout = HOL22_STATE
    #: the size of the square :attr:`covariance`
    covariance_dim = 22
    #: version of the saved state's byte layout (``STREAM_VERSION`` in ``src/native/estimation/hol22_run.hpp``)
    LAYOUT_VERSION = _native.HOL22_STREAM_VERSION

    def _frame_between(self, f: FrameUpdate, t1: float, g1: np.ndarray, a1: np.ndarray) -> None:
        _native.hol22_stream_frame(self._buf, f.t, f.pixels, f.points, f.nis, f.accepted_flags)
        f.status = "done"

    def _first_sample(self, t: float, g: np.ndarray, a: np.ndarray, at_t: list[FrameUpdate]) -> np.ndarray:
        for f in at_t:  # as the batch filter: frames at the first sample's time come before its update
            self._frame_between(f, t, g, a)
        return self._imu(self._buf, t, g, a)
