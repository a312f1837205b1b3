"""Pieces shared by the analytic IMU recordings (:mod:`~dualpose.sim.magnetometer_lag`,
:mod:`~dualpose.sim.rest_breaks`): the earth field and the body rate of an analytic orientation."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

import dualpose as dp

__all__ = ["FIELD_ENU", "central_body_rate"]

#: the earth-frame field of the recordings, µT, ENU (north and down components)
FIELD_ENU = np.array([0.0, 20.0, -44.0])


def central_body_rate(
    quat_at: Callable[[np.ndarray], np.ndarray], t: np.ndarray, h: float = 1e-6,
) -> NDArray[np.float64]:
    """Body-frame angular rate ``2 Im(q* ⊗ q̇)``, rad/s, shape (n, 3), of the orientation ``quat_at`` (times (n,) in s
    to xyzw quaternions (n, 4)) at the times ``t``; ``q̇`` by central difference with step ``h`` (s)."""
    q = quat_at(t)
    dq = (quat_at(t + h) - quat_at(t - h)) / (2 * h)
    return 2.0 * dp.quat_mul(dp.quat_conj(q), dq)[:, :3]
