"""The one interface of dualpose's recursive estimators, and the measurements they take.

Every estimator -- :class:`~dualpose.estimation.eskf.ErrorStateEKF`, :class:`~dualpose.estimation.hol22.Hol22EKF`,
:class:`~dualpose.estimation.ahrs.estimator.AhrsFilter` -- is an :class:`Estimator`:

* :meth:`Estimator.propagate` ``(t, gyro, accel, mag=None)`` feeds the IMU sample taken at time ``t`` (s);
* :meth:`Estimator.update` ``(measurement)`` fuses a measurement and returns an :class:`UpdateResult` (NIS, degrees
  of freedom, acceptance);
* :attr:`Estimator.state` and :attr:`Estimator.covariance` are the current state vector and covariance, laid out by
  :attr:`Estimator.state_layout` and :attr:`Estimator.covariance_layout` (named blocks,
  :mod:`dualpose.estimation.state`); :meth:`Estimator.block` reads one block by name;
* :attr:`Estimator.quat` and :meth:`Estimator.attitude_covariance` give the orientation ``q_wb`` (xyzw, body ->
  world) and the covariance (3, 3) of its world-frame error ``e = Log(q_true ⊗ q̂*)``, whatever the estimator's own
  attitude parametrisation, so that attitude errors of different estimators compare directly.

Measurements every estimator accepts: :class:`LinearMeasurement` (residual, Jacobian in the estimator's covariance
layout, noise covariance -- the general linearised update) and :class:`AttitudeFix` (a measured orientation with a
world-frame error covariance).  Camera frames (:class:`~dualpose.types.camera.CameraFrame`) are accepted by the
camera-IMU filters; an estimator refuses a measurement it has no model for with a ``TypeError``.  The shared laws
(symmetric positive-definite covariance, NEES/NIS consistency on the simulator, a zero-information update changes
nothing) are tested over all estimators in ``tests/estimation/test_estimator_laws.py``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike

import dualpose as dp
from dualpose.estimation.state import StateLayout
from dualpose.types.camera import CameraFrame

__all__ = ["AttitudeFix", "Estimator", "LinearMeasurement", "UpdateResult", "world_attitude_error"]


@dataclass(frozen=True)
class LinearMeasurement:
    """A linearised measurement ``r = H δx + e``, ``e ~ N(0, R)``, in the estimator's covariance layout.

    Attributes
    ----------
    residual : ndarray (m,)
        Measured minus predicted value.
    jacobian : ndarray (m, n)
        ``H``, with ``n`` the estimator's ``covariance_layout.dim``.
    covariance : ndarray (m, m)
        Noise covariance ``R`` (symmetric positive definite).
    """

    residual: np.ndarray
    jacobian: np.ndarray
    covariance: np.ndarray

    def __post_init__(self) -> None:
        r = np.atleast_1d(np.asarray(self.residual, dtype=np.float64))
        H = np.atleast_2d(np.asarray(self.jacobian, dtype=np.float64))
        R = np.atleast_2d(np.asarray(self.covariance, dtype=np.float64))
        m = r.shape[0]
        if r.ndim != 1 or H.shape[0] != m or R.shape != (m, m):
            raise ValueError(f"residual (m,), jacobian (m, n) and covariance (m, m) disagree: {r.shape}, {H.shape}, "
                             f"{R.shape}")  # fmt: skip
        for name, a in (("residual", r), ("jacobian", H), ("covariance", R)):
            if not np.isfinite(a).all():
                raise ValueError(f"{name} must be finite")
        object.__setattr__(self, "residual", r)
        object.__setattr__(self, "jacobian", H)
        object.__setattr__(self, "covariance", 0.5 * (R + R.T))


@dataclass(frozen=True)
class AttitudeFix:
    """A measured orientation ``q_wb`` (4,) xyzw with the covariance (3, 3) of its world-frame error:
    ``q_measured = Exp(n) ⊗ q_true``, ``n ~ N(0, covariance)`` (radians)."""

    quat: np.ndarray
    covariance: np.ndarray

    def __post_init__(self) -> None:
        q = np.asarray(self.quat, dtype=np.float64)
        C = np.asarray(self.covariance, dtype=np.float64)
        if q.shape != (4,) or not np.isfinite(q).all() or not np.any(q):
            raise ValueError(f"quat must be a finite nonzero quaternion of shape (4,) (xyzw); got {q!r}")
        if C.ndim == 0:
            C = np.eye(3) * float(C)
        if C.shape != (3, 3) or not np.isfinite(C).all():
            raise ValueError(f"covariance must be a finite (3, 3) matrix or a scalar variance; got shape {C.shape}")
        object.__setattr__(self, "quat", dp.quat_normalize(q))
        object.__setattr__(self, "covariance", 0.5 * (C + C.T))


@dataclass(frozen=True)
class UpdateResult:
    """Outcome of :meth:`Estimator.update`: ``nis`` (float, or (M,) per correspondence of a camera frame),
    ``dof`` of each NIS, ``accepted`` (bool, or (M,) bool)."""

    nis: float | np.ndarray
    dof: int
    accepted: bool | np.ndarray


class Estimator(ABC):
    """Interface of the recursive estimators (module docstring)."""

    #: layout of :attr:`state`
    state_layout: ClassVar[StateLayout]
    #: layout of the rows and columns of :attr:`covariance`
    covariance_layout: ClassVar[StateLayout]
    #: time of the current estimate, s (None before the first sample)
    time: float | None

    @property
    @abstractmethod
    def state(self) -> np.ndarray:
        """A copy of the state vector, shape ``(state_layout.dim,)``."""

    @property
    @abstractmethod
    def covariance(self) -> np.ndarray:
        """A copy of the covariance, shape ``(covariance_layout.dim, covariance_layout.dim)``."""

    @property
    @abstractmethod
    def quat(self) -> np.ndarray:
        """Orientation ``q_wb`` (4,) xyzw (body -> world)."""

    @abstractmethod
    def attitude_covariance(self) -> np.ndarray:
        """Covariance (3, 3) of the world-frame attitude error ``Log(q_true ⊗ q̂*)``, rad²."""

    def tangent_covariance(self) -> np.ndarray:
        """The covariance in minimal (tangent) coordinates: :attr:`covariance` for error-state estimators, whose
        covariance already is over a 3-parameter attitude error; estimators with an over-parametrised state (a
        quaternion as four numbers, whose covariance is singular along the quaternion) override it."""
        return self.covariance

    def block(self, name: str) -> np.ndarray:
        """One named block of :attr:`state` (a copy)."""
        return np.copy(self.state_layout.get(self.state, name), order="C")

    def covariance_block(self, name: str, other: str | None = None) -> np.ndarray:
        """The ``(name, other)`` block of :attr:`covariance` (a copy)."""
        return np.copy(self.covariance_layout.cov(self.covariance, name, other), order="C")

    @abstractmethod
    def propagate(self, t: float, gyro: ArrayLike, accel: ArrayLike, mag: ArrayLike | None = None) -> None:
        """Feed the IMU sample taken at time ``t`` (s): gyro (3,) rad/s, accel (3,) m/s² (specific force), body
        frame; ``mag`` (3,) for estimators that use a magnetometer (ignored by the others)."""

    def update(self, measurement: LinearMeasurement | AttitudeFix | CameraFrame) -> UpdateResult:
        """Fuse ``measurement`` at the current time (a camera frame first propagates to its own time)."""
        if isinstance(measurement, LinearMeasurement):
            return self._update_linear(measurement.residual, measurement.jacobian, measurement.covariance)
        if isinstance(measurement, AttitudeFix):
            r, H = self._attitude_model(measurement.quat)
            return self._update_linear(r, H, measurement.covariance)
        if isinstance(measurement, CameraFrame):
            return self._update_camera(measurement)
        raise TypeError(f"{type(self).__name__} has no model for a {type(measurement).__name__} measurement")

    @abstractmethod
    def _update_linear(self, residual: np.ndarray, jacobian: np.ndarray, covariance: np.ndarray) -> UpdateResult:
        """The linearised update (shapes checked here, in the covariance layout)."""

    @abstractmethod
    def _attitude_model(self, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residual (3,) and Jacobian (3, n) of a world-frame attitude measurement ``quat`` (unit, xyzw)."""

    def _update_camera(self, frame: CameraFrame) -> UpdateResult:
        raise TypeError(f"{type(self).__name__} has no camera model")

    def _elapsed(self, t: float, what: str) -> float:
        """Seconds from the filter time to ``t`` (0 before the first sample); the filters take their inputs in time
        order, so ``what`` (e.g. ``"IMU sample at t=…"``) older than the filter time is a ``ValueError``."""
        if self.time is None:
            return 0.0
        if t < self.time:
            raise ValueError(f"{what} is older than the filter time {self.time} (no out-of-order)")
        return t - self.time

    def _frame_time(self, t_cam: float, camera_time_offset: float) -> float:
        """The IMU-clock time ``t_cam + camera_time_offset`` of a camera frame stamped ``t_cam``, checked against the
        filter time (a frame before the first IMU sample starts the clock)."""
        t = t_cam + camera_time_offset
        if self.time is None:
            self.time = t
        self._elapsed(t, f"frame at IMU time {t}")
        return t

    def _check_linear(self, residual: np.ndarray, jacobian: np.ndarray, covariance: np.ndarray) -> None:
        n = self.covariance_layout.dim
        if jacobian.shape != (residual.shape[0], n):
            raise ValueError(f"jacobian must have shape ({residual.shape[0]}, {n}) for {type(self).__name__}; got "
                             f"{jacobian.shape}")  # fmt: skip


def world_attitude_error(q_true: ArrayLike, q_est: ArrayLike) -> np.ndarray:
    """``Log(q_true ⊗ q_est*)`` (..., 3): the world-frame attitude error the interface's covariances describe."""
    return dp.rotvec_from_quat(dp.quat_mul(q_true, dp.quat_conj(q_est)))
