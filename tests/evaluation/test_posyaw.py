"""The 4-DoF (position + yaw) alignment of visual–inertial odometry (Zhang & Scaramuzza 2018)."""

from __future__ import annotations

import numpy as np
import pytest

import dualpose as dp
from dualpose.evaluation.align import align_positions, posyaw_alignment


def test_recovers_a_yaw_and_translation_exactly(rng: np.random.Generator) -> None:
    x = rng.normal(size=(50, 3))
    psi, t = 2.7, np.array([0.4, -1.0, 0.3])
    Rz = dp.matrix_from_quat(dp.quat_from_rotvec([0.0, 0.0, psi]))
    al = posyaw_alignment(x @ Rz.T + t, x)
    np.testing.assert_allclose(al.rotation, Rz, atol=1e-12)
    np.testing.assert_allclose(al.translation, t, atol=1e-12)
    assert align_positions(x @ Rz.T + t, x, "posyaw").method == "posyaw"


def test_fits_no_roll_and_matches_the_least_squares_yaw(rng: np.random.Generator) -> None:
    """With a tilt in the data the rotation stays about z, and its yaw minimises the squared error (a scan)."""
    x = rng.normal(size=(40, 3))
    R = dp.matrix_from_quat(dp.quat_from_rotvec([0.05, -0.03, 0.8]))
    y = x @ R.T + rng.normal(0, 0.01, x.shape)
    al = posyaw_alignment(y, x)
    assert al.rotation[2, 2] == 1.0 and np.all(al.rotation[2, :2] == 0.0)

    def cost(psi: float) -> float:
        Rz = dp.matrix_from_quat(dp.quat_from_rotvec([0.0, 0.0, psi]))
        z = x @ Rz.T
        return float(np.sum((y - z - (y - z).mean(0)) ** 2))

    psi = np.arctan2(al.rotation[1, 0], al.rotation[0, 0])
    scan = np.linspace(psi - 0.01, psi + 0.01, 201)
    assert abs(scan[np.argmin([cost(s) for s in scan])] - psi) <= 1e-4


def test_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match=r"shape \(N >= 2, 3\)"):
        posyaw_alignment(np.zeros((5, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="do not move horizontally"):
        posyaw_alignment(np.c_[np.zeros((5, 2)), np.arange(5.0)], np.c_[np.zeros((5, 2)), np.arange(5.0)])
