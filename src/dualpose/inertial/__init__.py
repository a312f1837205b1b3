"""Screw-vector inertial integration: rotation-vector and screw-vector update algorithms.

Import explicitly (``import dualpose.inertial``); ``import dualpose`` does not load it.

* :func:`integrate_attitude` / :func:`integrate_pose`: fold gyro angle increments ``(..., K*N, 3)`` or dual
  increments ``(..., K*N, 6)`` into ``(..., K+1, 4)`` quaternions / ``(..., K+1, 8)`` dual quaternions with an
  N-sample algorithm (N = 1..4, ``"coning-optimal"`` or ``"polynomial"`` coefficients, ``"one-plus-previous"``),
  body frame (right multiplication, ``frame="body"``) or space (inertial) frame (left multiplication,
  ``frame="space"``).
* :func:`rotation_vector`, :func:`screw_vector`, :func:`screw_exp`: the per-update pieces.
* :func:`relative_pose`: leader–follower relative pose ``q̂_L* (x) q̂_F``.
* :mod:`dualpose.inertial.motions`: exact motions (classical / dual coning, constant twist, smooth trajectory).

Layouts: quaternions xyzw, dual quaternions ``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real``, dual
increments ``[Δθ, Δu]``.  See ``docs/inertial.md``.
"""

from dualpose.inertial import motions
from dualpose.inertial.coefficients import FAMILIES, coning_coefficients
from dualpose.inertial.integrate import (
    integrate_attitude,
    integrate_pose,
    relative_pose,
    rotation_vector,
    screw_exp,
    screw_vector,
)

__all__ = [
    "FAMILIES",
    "coning_coefficients",
    "integrate_attitude",
    "integrate_pose",
    "relative_pose",
    "rotation_vector",
    "screw_exp",
    "screw_vector",
    "motions",
]
