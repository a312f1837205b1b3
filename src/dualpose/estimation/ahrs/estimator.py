"""The orientation filter of :mod:`dualpose.estimation.ahrs` one sample at a time, behind the estimator interface.

State :data:`~dualpose.estimation.state.AHRS_STATE` = ``[q_wb (4) xyzw, b_g (3) rad/s]``; covariance over
:data:`~dualpose.estimation.state.AHRS_ERROR` = ``[δθ (3), δb_g (3)]`` with the **global** attitude error
``q = Exp(δθ) ⊗ q̂`` (earth frame), so that :meth:`AhrsFilter.attitude_covariance` is the attitude block itself.

:meth:`AhrsFilter.propagate` is the batch filter's predict (the same compiled function,
``dualpose._native.ahrs_predict``): ``q ← q ⊗ Exp((ω − b) Δt)``, ``P ← F P Fᵀ + Q`` with the rate-proportional
scale-factor noise (Solà 2017 §5 with the global error).  Attitude information enters through
:meth:`~dualpose.estimation.interface.Estimator.update` (an :class:`~dualpose.estimation.interface.AttitudeFix` or a
:class:`~dualpose.estimation.interface.LinearMeasurement`), applied with the batch filter's Joseph update and
injection/reset.  The earth-frame averaged accelerometer and magnetometer updates of
:func:`~dualpose.estimation.ahrs.estimate_orientation` run in its compiled whole-recording loop (docs/broad.md).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp
from dualpose import _native
from dualpose.estimation.ahrs.config import MEMS_GYRO_BIAS_RANDOM_WALK, AhrsNoise
from dualpose.estimation.interface import Estimator, UpdateResult
from dualpose.estimation.state import AHRS_ERROR, AHRS_STATE

__all__ = ["AhrsFilter"]


class AhrsFilter(Estimator):
    """Orientation + gyroscope-bias error-state filter (module docstring).

    Parameters
    ----------
    quat : (4,) initial ``q_wb`` xyzw (body -> earth).
    gyro_bias : (3,) initial gyroscope bias, rad/s.
    covariance : (6, 6) initial covariance over :data:`~dualpose.estimation.state.AHRS_ERROR`.
    noise : AhrsNoise, optional
        Gyroscope white-noise density (rad/s/√Hz) and bias random walk (rad/s²/√Hz); defaults
        ``AhrsNoise()`` with the MEMS bias random walk.
    gyro_scale_sigma : float
        Relative gyroscope scale-factor / misalignment uncertainty ε; adds ``ε² |ω|² · 1 s`` to the attitude
        process-noise density (as :func:`~dualpose.estimation.ahrs.estimate_orientation`).
    """

    state_layout = AHRS_STATE
    covariance_layout = AHRS_ERROR

    def __init__(
        self,
        quat: ArrayLike,
        gyro_bias: ArrayLike = (0.0, 0.0, 0.0),
        covariance: ArrayLike | None = None,
        noise: AhrsNoise | None = None,
        gyro_scale_sigma: float = 0.005,
    ) -> None:
        x = AHRS_STATE.assemble(quat=quat, gyro_bias=gyro_bias)
        q = AHRS_STATE.get(x, "quat")
        nq = float(np.linalg.norm(q))
        if not (math.isfinite(nq) and nq > 0.0) or not np.isfinite(x).all():
            raise ValueError("quat must be a finite nonzero quaternion and gyro_bias finite")
        self._q = np.ascontiguousarray(q / nq)
        self._b = np.ascontiguousarray(AHRS_STATE.get(x, "gyro_bias"))
        n = AHRS_ERROR.dim
        P = np.eye(n) * 1e-4 if covariance is None else np.array(covariance, dtype=np.float64)
        if P.shape != (n, n) or not np.isfinite(P).all():
            raise ValueError(f"covariance must be a finite ({n}, {n}) matrix; got shape {P.shape}")
        self._P = np.ascontiguousarray(0.5 * (P + P.T))
        self.noise = AhrsNoise(gyroscope_random_walk=MEMS_GYRO_BIAS_RANDOM_WALK) if noise is None else noise
        if not (math.isfinite(gyro_scale_sigma) and gyro_scale_sigma >= 0.0):
            raise ValueError(f"gyro_scale_sigma must be a finite number >= 0; got {gyro_scale_sigma}")
        self.gyro_scale_sigma = float(gyro_scale_sigma)
        self.time: float | None = None

    # ------------------------------------------------------------------ the estimator interface
    @property
    def state(self) -> np.ndarray:
        """``[q_wb, b_g]`` (7,), a copy."""
        return AHRS_STATE.assemble(quat=self._q, gyro_bias=self._b)

    @property
    def covariance(self) -> np.ndarray:
        """Covariance (6, 6) over ``[δθ, δb_g]`` (global attitude error), a copy."""
        return np.copy(self._P, order="C")

    @property
    def quat(self) -> np.ndarray:
        """Orientation ``q_wb`` (4,) xyzw."""
        return np.copy(self._q, order="C")

    @property
    def gyro_bias(self) -> np.ndarray:
        """Gyroscope bias (3,), rad/s."""
        return np.copy(self._b, order="C")

    def attitude_covariance(self) -> np.ndarray:
        """World-frame attitude error covariance (3, 3): the attitude block (the error is global)."""
        return np.copy(AHRS_ERROR.cov(self._P, "attitude"), order="C")

    def propagate(
        self, t: float, gyro: ArrayLike, accel: ArrayLike | None = None, mag: ArrayLike | None = None
    ) -> None:
        """Predict from the filter time to ``t`` (s) with the gyroscope sample ``gyro`` (3,) rad/s taken at ``t``
        (the batch filter's convention: the sample at ``t`` drives the step that ends there).  The first sample
        only sets the time.  ``accel`` and ``mag`` are not used by the predict."""
        g = np.asarray(gyro, dtype=np.float64)
        if g.shape != (3,) or not np.isfinite(g).all():
            raise ValueError(f"gyro must be a finite array of shape (3,) in rad/s; got {g!r}")
        if not math.isfinite(t):
            raise ValueError(f"t must be a finite time in seconds; got {t!r}")
        dt = self._elapsed(t, f"IMU sample at t={t}")
        if dt > 0.0:
            n = self.noise
            _native.ahrs_predict(self._q, self._b, self._P, g[0], g[1], g[2], dt, n.gyroscope_noise_density**2,
                                 n.gyroscope_random_walk**2, self.gyro_scale_sigma**2)  # fmt: skip
        self.time = float(t)

    def _attitude_model(self, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # ρ(δθ) = Log(q_m ⊗ (Exp(δθ) q̂)*) = Log(Exp(r) Exp(−δθ)) ≈ r − J_r⁻¹(r) δθ,  r = Log(q_m ⊗ q̂*)
        r = dp.rotvec_from_quat(dp.quat_mul(quat, dp.quat_conj(self._q)))
        H = np.zeros((3, AHRS_ERROR.dim))
        H[:, AHRS_ERROR.slice("attitude")] = dp.so3_right_jacobian_inv(r)
        return r, H

    def _update_linear(self, residual: np.ndarray, jacobian: np.ndarray, covariance: np.ndarray) -> UpdateResult:
        self._check_linear(residual, jacobian, covariance)
        S = jacobian @ self._P @ jacobian.T + covariance
        K = np.ascontiguousarray(np.linalg.solve(S, jacobian @ self._P).T)
        dx = np.ascontiguousarray(K @ residual)
        # Joseph form with a general noise covariance: P ← A P Aᵀ + K R Kᵀ, A = I − K H
        A = np.eye(AHRS_ERROR.dim) - K @ jacobian
        P = A @ self._P @ A.T + K @ covariance @ K.T
        self._P[:] = 0.5 * (P + P.T)
        _native.ahrs_inject_and_reset(self._q, self._b, self._P, dx)
        return UpdateResult(float(residual @ np.linalg.solve(S, residual)), len(residual), True)
