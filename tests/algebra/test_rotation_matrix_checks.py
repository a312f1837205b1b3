"""quat_from_matrix / dualquat_from_matrix refuse reflections, singular and non-orthogonal matrices (scipy's
``Rotation.from_matrix`` raises "Non-positive determinant") and keep accepting matrices rounded to 6-7 digits."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import dualpose as dp
from dualpose.algebra.classes import Quaternion


@pytest.mark.parametrize(
    ("m", "why"),
    [
        (np.diag([1.0, 1.0, -1.0]), "det = -1"),
        (-np.eye(3), "det = -1"),
        (np.zeros((3, 3)), r"max \|RᵀR − I\| = 1 "),
        (np.ones((3, 3)), r"max \|RᵀR − I\| = 3 "),
        (2.0 * np.eye(3), r"max \|RᵀR − I\| = 3 "),
        (np.eye(3) + 1e-3 * np.triu(np.ones((3, 3)), 1), "not orthogonal"),
    ],
)
def test_quat_from_matrix_refuses_non_rotations(m, why):
    with pytest.raises(ValueError, match=rf"^matrix is not a rotation matrix: .*{why}"):
        dp.quat_from_matrix(m)
    if "det" in why:
        with pytest.raises(ValueError, match="Non-positive determinant"):
            Rotation.from_matrix(m)


def test_the_message_names_the_batch_index():
    rng = np.random.default_rng(1)
    m = Rotation.random(12, random_state=rng).as_matrix().reshape(3, 4, 3, 3)
    m[2, 1] = np.diag([1.0, -1.0, 1.0])
    with pytest.raises(ValueError, match=r"^matrix\[2, 1\] is not a rotation matrix: det = -1"):
        dp.quat_from_matrix(m)
    t = np.tile(np.eye(4), (5, 1, 1))
    t[3, :3, :3] = np.diag([1.0, 1.0, -1.0])
    with pytest.raises(ValueError, match=r"^matrix\[3\] is not a rotation matrix"):
        dp.dualquat_from_matrix(t)
    with pytest.raises(ValueError, match=r"^matrix is not a rotation matrix"):
        dp.dualquat_from_matrix(np.diag([1.0, 1.0, -1.0, 1.0]))
    with pytest.raises(ValueError, match="not a rotation matrix"):
        Quaternion.from_matrix(np.zeros((3, 3)))


def test_rounded_matrices_are_still_accepted():
    rng = np.random.default_rng(2)
    r = Rotation.random(1000, random_state=rng)
    for digits in (6, 7, 9):
        m = np.round(r.as_matrix(), digits)
        q = dp.quat_from_matrix(m)
        assert np.all(np.degrees(dp.quat_angle(q, r.as_quat())) < 10.0 ** (1 - digits) * 60)
    near = r.as_matrix() * (1.0 + 4e-6)  # |RᵀR − I| = 8e-6, within the documented 1e-5
    assert np.isfinite(dp.quat_from_matrix(near)).all()
    with pytest.raises(ValueError, match=r"matrix\[0\] is not a rotation matrix"):
        dp.quat_from_matrix(r.as_matrix() * (1.0 + 1e-5))
