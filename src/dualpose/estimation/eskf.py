"""Error-state extended Kalman filter for camera-IMU pose tracking (Solà 2017, "Quaternion kinematics for the
error-state Kalman filter", §5-7) — the recommended default filter of :mod:`dualpose.estimation`.

Nominal state (16,) = ``[p_wb (3) m, v_w (3) m/s, q_wb (4) xyzw, b_g (3) rad/s, b_a (3) m/s²]`` driven by the IMU
as input; error state (15,) = ``[δp, δv, δθ, δb_g, δb_a]`` with a 3-parameter local attitude error
``q = q̂ ⊗ Exp(δθ)``.  Updates use the Joseph form and are followed by injection and the reset Jacobian
``G = diag(I, I, I − [½δθ]×, I, I)``.  Camera updates use the reprojection model of :mod:`dualpose.estimation.models`,
one χ²-gated 2-D update per correspondence.  Predict/update kernels and the whole-run loop are the native
extension's ``eskf_*`` functions (``src/native/estimation``); :class:`EskfStream` runs the same compiled steps one
sample / frame at a time (streaming, docs/fusion.md "Streaming").
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import chi2

import dualpose as dp
from dualpose import _native
from dualpose.estimation import models
from dualpose.estimation._fusion_stream import BlockResult, FrameUpdate, FusionStream
from dualpose.estimation._stream import check_streams, vec3
from dualpose.estimation.interface import Estimator, UpdateResult
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE
from dualpose.types import CameraFrame, ImuNoise, PinholeCamera, SensorRun, _inputs

__all__ = [
    "BlockResult",
    "EskfStateAccessors",
    "ErrorStateEKF",
    "EskfStream",
    "FilterNodes",
    "FilterResult",
    "FrameUpdate",
    "InnovationReport",
    "initial_covariance",
]


def initial_covariance(
    position_sigma: float = 0.01,
    velocity_sigma: float = 0.01,
    attitude_sigma: float = math.radians(0.5),
    imu_noise: ImuNoise | None = None,
) -> np.ndarray:
    """Diagonal initial error covariance (15, 15); bias sigmas are the IMU's turn-on bias sigmas."""
    imu_noise = ImuNoise() if imu_noise is None else imu_noise
    sig = ESKF_ERROR.assemble(
        position=np.full(3, position_sigma),
        velocity=np.full(3, velocity_sigma),
        attitude=np.full(3, attitude_sigma),
        gyro_bias=np.full(3, max(imu_noise.gyroscope_initial_bias_sigma, 1e-6)),
        accel_bias=np.full(3, max(imu_noise.accelerometer_initial_bias_sigma, 1e-6)),
    )
    return np.diag(sig**2)


@dataclass
class InnovationReport:
    """Per-correspondence innovation statistics of a run (Hol §innovation monitoring).

    ``nis`` (M,) NIS of every correspondence at its turn (2 dof), ``accepted`` (M,) bool, ``bounds`` the two-sided
    95% χ²(2) interval, ``gate`` the rejection threshold.  ``fraction_inside`` is over accepted correspondences.
    """

    nis: np.ndarray
    accepted: np.ndarray
    dof: int
    bounds: tuple[float, float]
    gate: float

    @property
    def fraction_inside(self) -> float:
        v = self.nis[self.accepted]
        return float(np.mean((v >= self.bounds[0]) & (v <= self.bounds[1]))) if len(v) else float("nan")

    @property
    def mean_nis(self) -> float:
        v = self.nis[self.accepted]
        return float(v.mean()) if len(v) else float("nan")

    @property
    def n_rejected(self) -> int:
        return int(np.sum(~self.accepted))

    def summary(self) -> dict[str, float]:
        return {
            "n_correspondences": int(len(self.nis)),
            "n_rejected": self.n_rejected,
            "mean_nis": self.mean_nis,
            "nis_dof": self.dof,
            "nis_fraction_inside": self.fraction_inside,
            "nis_bounds_low": self.bounds[0],
            "nis_bounds_high": self.bounds[1],
        }


@dataclass
class FilterNodes:
    """What the filter stores for the offline smoother (:func:`dualpose.estimation.smoother.rts_smooth`).

    A node is the start ``t[0]`` and every time the filter predicts to: each IMU time and each camera time strictly
    between IMU times (K ≤ N + F nodes).  ``t`` (K,) s; ``prior_states`` / ``posterior_states`` (K, 16) nominal
    ``[p, v, q_wb xyzw, b_g, b_a]`` before / after the camera update at the node (equal at nodes without one);
    ``prior_covariance`` / ``posterior_covariance`` (K, 15, 15) error covariance in the chart of the matching
    nominal state (the posterior one after the reset Jacobian G); ``transition`` (K, 15, 15) the error-state
    transition ``F`` from node i to i + 1 (Solà eq. 269; identity for the last node); ``imu_node`` (N,) and
    ``frame_node`` (F,) the node index of each IMU sample and camera frame (−1: frame outside the IMU span).
    """

    t: np.ndarray
    prior_states: np.ndarray
    prior_covariance: np.ndarray
    posterior_states: np.ndarray
    posterior_covariance: np.ndarray
    transition: np.ndarray
    imu_node: np.ndarray
    frame_node: np.ndarray


@dataclass
class FilterResult:
    """Output of :meth:`ErrorStateEKF.run`: states at the IMU times.

    ``t`` (N,), ``position`` (N, 3), ``velocity`` (N, 3), ``quat`` (N, 4) ``q_wb`` xyzw, ``gyro_bias`` (N, 3),
    ``accel_bias`` (N, 3), ``covariance`` (N, 15, 15) error-state covariance; ``frame_states`` (F, 16) and
    ``frame_covariance`` (F, 15, 15) right after each camera update; ``innovation`` the NIS report; ``nodes`` the
    per-node record for the smoother (:class:`FilterNodes`, only with ``run(..., record_nodes=True)``).
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    quat: np.ndarray
    gyro_bias: np.ndarray
    accel_bias: np.ndarray
    covariance: np.ndarray
    frame_states: np.ndarray
    frame_covariance: np.ndarray
    innovation: InnovationReport
    wall_time: float = float("nan")
    nodes: FilterNodes | None = None


class _SensorSource(Protocol):
    """A recording, simulated run or sensor set-up (:class:`~dualpose.types.SensorSetup`): its IMU noise and the
    filter keyword arguments of its sensors."""

    @property
    def imu_noise(self) -> ImuNoise: ...
    def sensor_options(self) -> dict[str, Any]: ...


class EskfStateAccessors(Estimator):
    """The named blocks of an error-state IMU state (:data:`~dualpose.estimation.state.ESKF_STATE` in ``self.x``,
    the (15, 15) ``covariance`` over :data:`~dualpose.estimation.state.ESKF_ERROR`), the world-frame attitude
    covariance and the attitude-fix model, shared by :class:`ErrorStateEKF` and
    :class:`~dualpose.estimation.msckf.MsckfVio`."""

    @property
    def position(self) -> np.ndarray:
        """Body position in the world frame (3,), m."""
        return self.block("position")

    @property
    def velocity(self) -> np.ndarray:
        """Velocity in the world frame (3,), m/s."""
        return self.block("velocity")

    @property
    def quat(self) -> np.ndarray:
        """Orientation ``q_wb`` (4,) xyzw."""
        return self.block("quat")

    @property
    def gyro_bias(self) -> np.ndarray:
        """Gyroscope bias (3,), rad/s."""
        return self.block("gyro_bias")

    @property
    def accel_bias(self) -> np.ndarray:
        """Accelerometer bias (3,), m/s²."""
        return self.block("accel_bias")

    def attitude_covariance(self) -> np.ndarray:
        """World-frame attitude error covariance (3, 3): ``R̂ P_θθ R̂ᵀ`` (the local error rotated to the world)."""
        R = dp.matrix_from_quat(self.quat)
        out: NDArray[np.float64] = R @ ESKF_ERROR.cov(self.covariance, "attitude") @ R.T
        return out

    def _attitude_model(self, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # ρ(δθ) = Log(q_m ⊗ (q̂ Exp(δθ))*) ≈ r − J_r⁻¹(r) R̂ δθ with r = Log(q_m ⊗ q̂*)
        r = dp.rotvec_from_quat(dp.quat_mul(quat, dp.quat_conj(self.quat)))
        H = np.zeros((3, ESKF_ERROR.dim))
        H[:, ESKF_ERROR.slice("attitude")] = dp.so3_right_jacobian_inv(r) @ dp.matrix_from_quat(self.quat)
        return r, H


class ErrorStateEKF(EskfStateAccessors, Estimator):
    """Camera-IMU error-state EKF (Solà 2017); an :class:`~dualpose.estimation.interface.Estimator`.

    State :data:`~dualpose.estimation.state.ESKF_STATE` (16,), covariance over
    :data:`~dualpose.estimation.state.ESKF_ERROR` (15,) with the local attitude error ``q = q̂ ⊗ Exp(δθ)``.

    Parameters
    ----------
    position, velocity : (3,) initial p_wb (m), v_w (m/s), world frame.
    quat : (4,) initial q_wb, xyzw.
    covariance : (15, 15) initial error covariance (see :func:`initial_covariance`).
    imu_noise : ImuNoise
        Kalibr densities used for the process noise (``Q`` blocks ``σ² Δt``, Solà eq. 262), plus the scale-factor
        terms ``ε² |ω|² · 1 s`` (attitude) and ``ε_a² |f|² · 1 s`` (velocity) of its ``*_scale_sigma``.
    gravity : (3,) world gravity the filter assumes, m/s² (default ``[0, 0, −9.81]``).
    camera : PinholeCamera.  q_bc, p_bc : camera→body rotation (xyzw) and camera centre in the body frame.
    pixel_sigma : float, px.  gate_probability : float, χ²(2) gate (default 0.999 → 13.8).
    camera_time_offset : float
        Known ``t_imu = t_cam + offset`` (s); camera stamps are shifted by it before use.
    gyro_bias, accel_bias : (3,) initial bias estimates.
    """

    def __init__(
        self,
        position: np.ndarray,
        velocity: np.ndarray,
        quat: np.ndarray,
        covariance: np.ndarray,
        imu_noise: ImuNoise | None = None,
        gravity: ArrayLike = (0.0, 0.0, -9.81),
        camera: PinholeCamera | None = None,
        q_bc: ArrayLike = (0.0, 0.0, 0.0, 1.0),
        p_bc: ArrayLike = (0.0, 0.0, 0.0),
        pixel_sigma: float = 1.0,
        gate_probability: float = 0.999,
        camera_time_offset: float = 0.0,
        gyro_bias: ArrayLike = (0.0, 0.0, 0.0),
        accel_bias: ArrayLike = (0.0, 0.0, 0.0),
    ) -> None:
        # the filter-parameter checks every path shares (dualpose.types._inputs, docs/refusals.md)
        self.x = ESKF_STATE.assemble(
            position=_inputs.finite_vector(position, "position", 3, _inputs.MAX_POSITION_M, "m"),
            velocity=_inputs.finite_vector(velocity, "velocity", 3, _inputs.MAX_VELOCITY_M_S, "m/s"),
            quat=_inputs.unit_quaternion(quat, "quat"),
            gyro_bias=_inputs.finite_vector(gyro_bias, "gyro_bias", 3, _inputs.IMU_LIMITS["gyro"], "rad/s"),
            accel_bias=_inputs.finite_vector(accel_bias, "accel_bias", 3, _inputs.IMU_LIMITS["accel"], "m/s²"),
        )  # fmt: skip
        self.P = _inputs.covariance_matrix(covariance, "covariance", ESKF_ERROR.dim)
        self.imu_noise = ImuNoise() if imu_noise is None else imu_noise
        _inputs.check_imu_noise(self.imu_noise)
        nz = self.imu_noise
        self.noise = np.array(
            [
                nz.gyroscope_noise_density**2,
                nz.accelerometer_noise_density**2,
                nz.gyroscope_random_walk**2,
                nz.accelerometer_random_walk**2,
                nz.gyroscope_scale_sigma**2,
                nz.accelerometer_scale_sigma**2,
            ]
        )
        self.gravity = _inputs.gravity_vector(gravity)
        self.camera = PinholeCamera() if camera is None else camera
        _inputs.check_camera(self.camera)
        c = self.camera
        self.intrinsics = np.array([c.fx, c.fy, c.cx, c.cy])
        self.q_bc = _inputs.unit_quaternion(q_bc, "q_bc")
        self.p_bc = _inputs.finite_vector(p_bc, "p_bc", 3, _inputs.MAX_POSITION_M, "m")
        self.pixel_sigma = _inputs.positive(pixel_sigma, "pixel_sigma", 1e4, "px")
        self.gate = float(chi2.ppf(_inputs.probability(gate_probability, "gate_probability"), 2))
        camera_time_offset = _inputs.time_offset(camera_time_offset, "camera_time_offset")
        self.camera_time_offset = float(camera_time_offset)
        self.time: float | None = None
        self._u = np.zeros(6)  # IMU measurement held at the current filter time [gyro, accel]
        self._nis: list[np.ndarray] = []
        self._acc: list[np.ndarray] = []

    # ------------------------------------------------------------------ construction helpers
    @classmethod
    def for_run(
        cls,
        run: _SensorSource,
        position: np.ndarray,
        velocity: np.ndarray,
        quat: np.ndarray,
        covariance: np.ndarray | None = None,
        **kwargs: Any,
    ) -> ErrorStateEKF:
        """A filter configured with a simulated run's sensor set-up (noise, camera, extrinsic, pixel sigma, offset).

        The gravity the filter assumes stays the nominal ``[0, 0, −9.81]`` unless given in ``kwargs``.
        """
        cov = initial_covariance(imu_noise=run.imu_noise) if covariance is None else covariance
        opts = run.sensor_options()
        opts.update(kwargs)
        return cls(position, velocity, quat, cov, **opts)

    @classmethod
    def from_state(cls, run: _SensorSource, x: np.ndarray, covariance: np.ndarray, **kwargs: Any) -> ErrorStateEKF:
        """:meth:`for_run` from a whole nominal state ``x`` (16,) (:data:`~dualpose.estimation.state.ESKF_STATE`)."""
        blocks = {name: ESKF_STATE.get(x, name) for name in ESKF_STATE.names}
        position, velocity, quat = blocks.pop("position"), blocks.pop("velocity"), blocks.pop("quat")
        return cls.for_run(run, position, velocity, quat, covariance, **{**blocks, **kwargs})

    # ------------------------------------------------------------------ the estimator interface
    state_layout = ESKF_STATE
    covariance_layout = ESKF_ERROR

    @property
    def state(self) -> np.ndarray:
        """Nominal state (16,) (:data:`~dualpose.estimation.state.ESKF_STATE`), a copy."""
        return np.copy(self.x, order="C")

    @property
    def covariance(self) -> np.ndarray:
        """Error-state covariance (15, 15) (:data:`~dualpose.estimation.state.ESKF_ERROR`), a copy."""
        return np.copy(self.P, order="C")

    def _update_linear(self, residual: np.ndarray, jacobian: np.ndarray, covariance: np.ndarray) -> UpdateResult:
        self._check_linear(residual, jacobian, covariance)
        return UpdateResult(self._update(residual, jacobian, covariance), len(residual), True)

    def _update_camera(self, frame: CameraFrame) -> UpdateResult:
        accepted = self.update_camera(frame.t, frame.pixels, frame.points)
        return UpdateResult(self._nis[-1], 2, accepted)

    # ------------------------------------------------------------------ online API
    def predict(self, gyro: np.ndarray, accel: np.ndarray, dt: float) -> None:
        """Propagate by ``dt`` seconds with the IMU measurement held constant (gyro rad/s, accel m/s², body)."""
        if dt < 0:
            raise ValueError(f"dt must be >= 0; got {dt}")
        g, a = vec3(gyro, "gyro"), vec3(accel, "accel")
        _native.eskf_predict(self.x, self.P, g, a, float(dt), self.gravity, self.noise)

    def propagate(self, t: float, gyro: ArrayLike, accel: ArrayLike, mag: ArrayLike | None = None) -> None:
        """Feed the IMU sample taken at time ``t``: integrates from the filter time to ``t`` with the mean of the
        held and the new measurement (exact for a linear signal up to second order), then holds the new one.
        ``mag`` is not used by this filter (magnetometer updates go through :meth:`update_magnetometer`)."""
        u = np.concatenate([np.asarray(gyro, float), np.asarray(accel, float)])
        dt = self._elapsed(t, f"IMU sample at t={t}")
        if dt > 0:
            mid = 0.5 * (self._u + u)
            _native.eskf_predict(self.x, self.P, mid[:3].copy(), mid[3:].copy(), dt, self.gravity, self.noise)
        self.time = float(t)
        self._u = u

    def update_camera(self, t_cam: float, pixels: np.ndarray, points: np.ndarray) -> np.ndarray:
        """Update with the point correspondences of a frame stamped ``t_cam`` (camera clock).

        The state is first propagated exactly to ``t_cam + camera_time_offset`` with the last IMU sample held
        (the batch :meth:`run` interpolates between the bracketing samples instead).  Returns a bool (M,) array of
        the accepted correspondences.
        """
        t = self._frame_time(t_cam, self.camera_time_offset)
        if self.time is not None and t > self.time:  # (_frame_time set the time)
            _native.eskf_predict(self.x, self.P, self._u[:3].copy(), self._u[3:].copy(), t - self.time, self.gravity,
                                 self.noise)  # fmt: skip
            self.time = t
        pixels = np.ascontiguousarray(pixels, dtype=np.float64).reshape(-1, 2)
        points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        if len(pixels) != len(points):
            raise ValueError(f"pixels (M, 2) and points (M, 3) differ in M: {len(pixels)} vs {len(points)}")
        nis = np.empty(len(pixels))
        acc = np.zeros(len(pixels), np.int64)
        _native.eskf_update_points(self.x, self.P, self.intrinsics, self.q_bc, self.p_bc, pixels, points,
                                   self.pixel_sigma, self.gate, nis, acc)  # fmt: skip
        self._nis.append(nis)
        self._acc.append(acc.astype(bool))
        return acc.astype(bool)

    def _update(self, r: np.ndarray, H: np.ndarray, cov: ArrayLike) -> float:
        c = np.asarray(cov, dtype=np.float64)
        if c.ndim == 0:
            c = np.eye(len(r)) * c
        if c.shape != (len(r), len(r)):
            raise ValueError(f"covariance must have shape ({len(r)}, {len(r)}) or be a scalar; got {c.shape}")
        return float(_native.eskf_update_dense(self.x, self.P, np.ascontiguousarray(r, dtype=np.float64),
                                               np.ascontiguousarray(H, dtype=np.float64), np.ascontiguousarray(c)))

    def update_position(self, position: np.ndarray, covariance: np.ndarray | float) -> float:
        """Position fix (3,) m with covariance (3, 3) or a scalar variance; returns the NIS (3 dof)."""
        return self._update(*models.position_model(self.x, position), covariance)

    def update_pose(self, position: np.ndarray, quat: np.ndarray, covariance: np.ndarray | float) -> float:
        """Full pose fix ``(p_wb, q_wb)`` with covariance (6, 6) over ``[δp, δθ]``; returns the NIS (6 dof)."""
        return self._update(*models.pose_model(self.x, position, quat), covariance)

    def update_magnetometer(
        self, measurement: np.ndarray, field_w: np.ndarray, covariance: np.ndarray | float
    ) -> float:
        """Magnetometer (3,) body frame, known world field ``field_w`` (3,); returns the NIS (3 dof)."""
        return self._update(*models.magnetometer_model(self.x, measurement, field_w), covariance)

    def innovation_report(self) -> InnovationReport:
        """NIS report of the camera updates made through :meth:`update_camera`."""
        nis = np.concatenate(self._nis) if self._nis else np.zeros(0)
        acc = np.concatenate(self._acc) if self._acc else np.zeros(0, bool)
        return _report(nis, acc, self.gate)

    def kernel_config(self) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
        NDArray[np.float64], NDArray[np.float64], float, float,
    ]:
        """The constants of the compiled filter (``eskf_run``, ``eskf_stream_new``): ``gravity`` (3,), ``noise``
        (6,) ``[σ_g², σ_a², σ_bg², σ_ba², ε_g², ε_a²]`` (ε: ``ImuNoise``'s scale-factor uncertainties), ``intr``
        (4,) ``[fx, fy, cx, cy]``, ``q_bc`` (4,), ``p_bc`` (3,), ``pixel_sigma``, ``gate``; float64, C-contiguous."""
        f64 = np.float64
        return (np.ascontiguousarray(self.gravity, dtype=f64), np.ascontiguousarray(self.noise, dtype=f64),
                np.ascontiguousarray(self.intrinsics, dtype=f64), np.ascontiguousarray(self.q_bc, dtype=f64),
                np.ascontiguousarray(self.p_bc, dtype=f64), self.pixel_sigma, self.gate)  # fmt: skip

    # ------------------------------------------------------------------ batch
    def run(
        self,
        t: np.ndarray,
        gyro: np.ndarray,
        accel: np.ndarray,
        frame_t: np.ndarray,
        offsets: np.ndarray,
        pixels: np.ndarray,
        points: np.ndarray,
        record_nodes: bool = False,
    ) -> FilterResult:
        """Filter a whole recording from the current state (taken to be at ``t[0]``).

        Parameters
        ----------
        t : (N,) IMU times, s.  gyro, accel : (N, 3).  frame_t : (F,) camera stamps (camera clock).
        offsets : (F + 1,) int, frame k owns rows ``offsets[k]:offsets[k+1]`` of ``pixels`` (M, 2) and ``points``
        (M, 3).  The IMU signal is taken as linear between samples and each step is split exactly at the camera
        times ``frame_t + camera_time_offset``.
        record_nodes : bool
            Also store the prior/posterior states and covariances and the transition matrices of every filter node
            (``FilterResult.nodes``, about 3 × 1.8 kB per node) for :func:`dualpose.estimation.smoother.rts_smooth`.
        """
        t, gyro, accel, cam_t, offsets, pixels, points = check_streams(
            t, gyro, accel, frame_t, offsets, pixels, points, self.camera_time_offset, strictly_increasing=True
        )
        n = len(t)
        nf = len(cam_t)
        nx, ne = ESKF_STATE.dim, ESKF_ERROR.dim
        X = np.empty((n, nx))
        Ps = np.empty((n, ne, ne))
        XF = np.full((nf, nx), np.nan)
        PF = np.full((nf, ne, ne), np.nan)
        nis = np.full(len(pixels), np.nan)
        acc = np.zeros(len(pixels), np.int64)
        t0 = time.perf_counter()
        args = (t, gyro, accel, cam_t, offsets, pixels, points, self.x, self.P, *self.kernel_config(),
                X, Ps, XF, PF, nis, acc)  # fmt: skip
        nodes = None
        if record_nodes:
            nodes = _record_run(args, n, nf)
        else:
            _native.eskf_run(*args)
        wall = time.perf_counter() - t0
        self.time = float(t[-1])
        self._u = np.concatenate([gyro[-1], accel[-1]])
        used = np.isfinite(nis)
        rep = _report(nis[used], acc[used].astype(bool), self.gate)
        blocks = {name: ESKF_STATE.get(X, name) for name in ESKF_STATE.names}
        return FilterResult(
            t=t, **blocks, covariance=Ps, frame_states=XF, frame_covariance=PF, innovation=rep, wall_time=wall,
            nodes=nodes,
        )  # fmt: skip

    def run_recording(self, run: SensorRun, record_nodes: bool = False) -> FilterResult:
        """:meth:`run` on a recording or simulated run (anything with the :class:`~dualpose.types.SensorRun` fields)."""
        f = run.frames
        return self.run(run.t, run.gyro, run.accel, f.t, f.offsets, f.pixels, f.points, record_nodes=record_nodes)


def _record_run(args: tuple[object, ...], n: int, nf: int) -> FilterNodes:
    """Run the ``run_recorded`` kernel with ``args`` (those of ``run``) and return the trimmed node record."""
    cap = n + nf
    nx, ne = ESKF_STATE.dim, ESKF_ERROR.dim
    XA, XB = np.empty((cap, nx)), np.empty((cap, nx))
    PA, PB, FS = np.empty((cap, ne, ne)), np.empty((cap, ne, ne)), np.empty((cap, ne, ne))
    TN = np.empty(cap)
    imu_node, frame_node = np.empty(n, np.int64), np.empty(nf, np.int64)
    k = _native.eskf_run_recorded(*args, XA, PA, XB, PB, FS, TN, imu_node, frame_node)
    return FilterNodes(
        t=TN[:k], prior_states=XA[:k], prior_covariance=PA[:k], posterior_states=XB[:k], posterior_covariance=PB[:k],
        transition=FS[:k], imu_node=imu_node, frame_node=frame_node,
    )  # fmt: skip


def _report(nis: np.ndarray, accepted: np.ndarray, gate: float) -> InnovationReport:
    """The :class:`InnovationReport` of camera updates (2 dof, two-sided 95 % band); also used by
    :mod:`dualpose.estimation.hol22`."""
    return InnovationReport(
        nis=nis, accepted=accepted, dof=2, bounds=(float(chi2.ppf(0.025, 2)), float(chi2.ppf(0.975, 2))), gate=gate
    )


class EskfStream(FusionStream):
    """:class:`ErrorStateEKF` one sample / frame at a time, bit for bit its :meth:`~ErrorStateEKF.run`
    (docs/fusion.md "Streaming"; the queue, blocks and saved state: ``dualpose.estimation._fusion_stream``).

    Parameters
    ----------
    filter : ErrorStateEKF
        The filter to continue: its current state and covariance (taken to be before the first sample), IMU noise,
        gravity, camera, extrinsic, pixel σ, gate and camera time offset.  The filter itself is not changed.

    Examples
    --------
    >>> import numpy as np
    >>> from dualpose.estimation.eskf import EskfStream, ErrorStateEKF, initial_covariance
    >>> s = EskfStream(ErrorStateEKF(np.zeros(3), np.zeros(3), [0, 0, 0, 1.0], initial_covariance()))
    >>> s.update_imu(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 9.81]).shape
    (16,)
    """

    _kind = "eskf"
    _filter_type = ErrorStateEKF
    #: the layout of :attr:`state`
    state_layout = ESKF_STATE
    #: the size of the square :attr:`covariance` (the error state's dimension)
    covariance_dim = 15
    #: version of the saved state's byte layout (``STREAM_VERSION`` in ``src/native/estimation/eskf_run.hpp``)
    LAYOUT_VERSION = _native.ESKF_STREAM_VERSION

    def _frame_between(self, f: FrameUpdate, t1: float, g1: np.ndarray, a1: np.ndarray) -> None:
        _native.eskf_stream_frame(self._buf, f.t, t1, g1, a1, f.pixels, f.points, f.nis, f.accepted_flags)
        f.status = "done"

    def _first_sample(self, t: float, g: np.ndarray, a: np.ndarray, at_t: list[FrameUpdate]) -> np.ndarray:
        x = self._imu(self._buf, t, g, a)
        for f in at_t:  # as the batch filter: frames at the first sample's time update the start
            _native.eskf_stream_update(self._buf, f.pixels, f.points, f.nis, f.accepted_flags)
            f.status = "done"
        return self.state if at_t else x
