"""Filter consistency helpers: error-state NEES against a simulation's truth and its χ² band.

Error layout (15,) = :data:`~dualpose.estimation.state.ESKF_ERROR` with ``δθ = Log(q̂* ⊗ q_true)`` (body frame),
matching the error-state filter's covariance.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.stats import chi2

import dualpose as dp
from dualpose.estimation import eskf, models
from dualpose.estimation.state import ESKF_ERROR, ESKF_STATE
from dualpose.types.recording import SensorRun

__all__ = ["error_state", "filter_from_prior", "nees", "nees_against_truth", "nees_band"]


class _StateEstimates(Protocol):
    """A filter or smoother result with the estimates (N, ·) and covariances (N, 15, 15) that NEES compares."""

    @property
    def position(self) -> np.ndarray: ...
    @property
    def velocity(self) -> np.ndarray: ...
    @property
    def quat(self) -> np.ndarray: ...
    @property
    def gyro_bias(self) -> np.ndarray: ...
    @property
    def accel_bias(self) -> np.ndarray: ...
    @property
    def covariance(self) -> np.ndarray: ...


class _PriorRun(SensorRun, Protocol):
    """A simulated run (:class:`~dualpose.sim.SimulatedRun`): a sensor run with its ``truth`` dict."""

    @property
    def truth(self) -> dict[str, np.ndarray]: ...


def error_state(
    truth: dict[str, np.ndarray], position: np.ndarray, velocity: np.ndarray, quat: np.ndarray,
    gyro_bias: np.ndarray, accel_bias: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """``x_true ⊟ x̂`` (N, 15) from a simulation ``truth`` dict and estimates (N, ·) at the same times."""
    dtheta = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(quat), truth["quat"]))
    n = len(dtheta)
    e = np.empty((n, ESKF_ERROR.dim))
    for block, est in (("position", position), ("velocity", velocity), ("gyro_bias", gyro_bias),
                       ("accel_bias", accel_bias)):  # fmt: skip
        e[:, ESKF_ERROR.slice(block)] = truth[block] - est
    e[:, ESKF_ERROR.slice("attitude")] = dtheta
    return e


def nees(error: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """Normalized estimation error squared ``eᵀ P⁻¹ e`` for errors (N, n) and covariances (N, n, n)."""
    out: NDArray[np.float64] = np.einsum("ni,ni->n", error, np.linalg.solve(covariance, error[..., None])[..., 0])
    return out


def nees_band(dim: int, runs: int, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided band for the Monte-Carlo average NEES over ``runs`` runs of a ``dim``-dimensional state:
    ``χ²_{runs·dim}((1 ∓ p)/2) / runs`` (Bar-Shalom et al. 2001, §5.4.2)."""
    lo = chi2.ppf((1.0 - probability) / 2.0, runs * dim) / runs
    hi = chi2.ppf((1.0 + probability) / 2.0, runs * dim) / runs
    return float(lo), float(hi)


def nees_against_truth(truth: dict[str, np.ndarray], estimate: _StateEstimates) -> np.ndarray:
    """NEES (N,) of a filter or smoother result (``position``, ``velocity``, ``quat``, ``gyro_bias``, ``accel_bias``,
    ``covariance`` (N, 15, 15)) against a simulation's ``truth`` at the same times."""
    e = error_state(truth, estimate.position, estimate.velocity, estimate.quat, estimate.gyro_bias,
                    estimate.accel_bias)  # fmt: skip
    return nees(e, estimate.covariance)


def filter_from_prior(run: _PriorRun, rng: np.random.Generator) -> eskf.ErrorStateEKF:
    """An :class:`~dualpose.estimation.eskf.ErrorStateEKF` for a simulated ``run`` started from a draw of its own prior.

    The initial error ``δx ~ N(0, P0)`` (``P0 = initial_covariance(run.imu_noise)``) is applied with ⊞ to the true
    position, velocity and attitude at ``t[0]`` and to zero biases (the prior covers the turn-on biases), so that
    the filter's initial covariance is honest -- the set-up of a Monte-Carlo NEES test.
    """
    P0 = eskf.initial_covariance(imu_noise=run.imu_noise)
    d = rng.multivariate_normal(np.zeros(ESKF_ERROR.dim), P0)
    tr = run.truth
    z = np.zeros(3)
    x = models.boxplus(ESKF_STATE.assemble(position=tr["position"][0], velocity=tr["velocity"][0], quat=tr["quat"][0],
                                           gyro_bias=z, accel_bias=z), d)  # fmt: skip
    # the drawn bias errors are not applied: the filter starts from zero biases, which its prior covers
    S = ESKF_STATE
    return eskf.ErrorStateEKF.for_run(run, S.get(x, "position"), S.get(x, "velocity"), S.get(x, "quat"), P0)
