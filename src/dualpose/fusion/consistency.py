"""Filter consistency helpers: error-state NEES against a simulation's truth and its χ² band.

Error layout (15,) = ``[δp, δv, δθ, δb_g, δb_a]`` with ``δθ = Log(q̂* ⊗ q_true)`` (body frame), matching the
error-state filter's covariance.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

import dualpose as dp

__all__ = ["error_state", "nees", "nees_band"]


def error_state(
    truth: dict[str, np.ndarray], position: np.ndarray, velocity: np.ndarray, quat: np.ndarray,
    gyro_bias: np.ndarray, accel_bias: np.ndarray,
) -> np.ndarray:  # fmt: skip
    """``x_true ⊟ x̂`` (N, 15) from a simulation ``truth`` dict and estimates (N, ·) at the same times."""
    dtheta = dp.rotvec_from_quat(dp.quat_mul(dp.quat_conj(quat), truth["quat"]))
    return np.concatenate(
        [
            truth["position"] - position,
            truth["velocity"] - velocity,
            dtheta,
            truth["gyro_bias"] - gyro_bias,
            truth["accel_bias"] - accel_bias,
        ],
        axis=1,
    )


def nees(error: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``eᵀ P⁻¹ e`` for errors (N, n) and covariances (N, n, n)."""
    return np.einsum("ni,ni->n", error, np.linalg.solve(covariance, error[..., None])[..., 0])


def nees_band(dim: int, runs: int, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided band for the Monte-Carlo average NEES over ``runs`` runs of a ``dim``-dimensional state:
    ``χ²_{runs·dim}((1 ∓ p)/2) / runs`` (Bar-Shalom et al. 2001, §5.4.2)."""
    lo = chi2.ppf((1.0 - probability) / 2.0, runs * dim) / runs
    hi = chi2.ppf((1.0 + probability) / 2.0, runs * dim) / runs
    return float(lo), float(hi)
