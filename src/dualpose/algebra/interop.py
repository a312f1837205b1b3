"""Conversions to and from scipy and pytransform3d (see ``docs/conventions.md`` for every peer's layout).

scipy is imported inside the functions only, so ``import dualpose`` stays cheap.  pytransform3d is never imported:
its layouts are plain reorders of dualpose's.

* scipy ``Rotation.as_quat()`` is xyzw, like dualpose, and keeps the sign it was given; ``RigidTransform`` stores a
  matrix, so ``as_dual_quat()`` -- in dualpose's exact layout ``[real xyzw, dual xyzw]`` with
  ``dual = ½ t (x) real`` -- returns the sign its matrix-to-quaternion step picks (scipy 1.17: the largest-magnitude
  component of the real part is positive; neither ``w >= 0`` nor the sign the transform was built from).
* pytransform3d's position–quaternion ``pq`` is ``[x, y, z, qw, qx, qy, qz]`` (scalar-first quaternion); its dual
  quaternions are ``[rw, rx, ry, rz, dw, dx, dy, dz]`` (scalar-first real then dual part, again ``dual = ½ t real``),
  i.e. ``dq[..., [3, 0, 1, 2, 7, 4, 5, 6]]`` of dualpose's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose._validation import as_array, check_finite
from dualpose.algebra import dualquat as _dualquat

__all__ = [
    "quat_from_scipy",
    "scipy_from_quat",
    "dualquat_from_scipy",
    "scipy_from_dualquat",
    "pq_from_dualquat",
    "dualquat_from_pq",
]

_WXYZ = [3, 0, 1, 2]
_XYZW = [1, 2, 3, 0]



def _raise_if_zero(q: np.ndarray, name: str) -> None:
    zero = np.all(q == 0.0, axis=-1)
    if np.any(zero):
        idx = tuple(int(i) for i in np.argwhere(np.atleast_1d(zero))[0])
        raise ValueError(f"{name} must be a nonzero quaternion; element {idx} is zero")


def quat_from_scipy(rotation: Any) -> NDArray[np.float64]:
    """Quaternions (..., 4), xyzw, of a :class:`scipy.spatial.transform.Rotation`.

    scipy's default ``as_quat()`` order is dualpose's (scalar last) and it returns the sign it stores (the sign
    passed to ``Rotation.from_quat``), so ``quat_from_scipy(scipy_from_quat(q))`` is ``q / |q|`` with its sign.
    The batch shape is ``rotation.shape`` (``()`` for a single rotation).
    """
    from scipy.spatial.transform import Rotation

    if not isinstance(rotation, Rotation):
        raise TypeError(f"rotation must be a scipy.spatial.transform.Rotation; got {type(rotation).__name__}")
    return np.asarray(rotation.as_quat(), dtype=np.float64)


def scipy_from_quat(q: ArrayLike) -> Any:
    """A :class:`scipy.spatial.transform.Rotation` from quaternions ``q`` (..., 4), xyzw.

    scipy normalizes ``q``; the sign is kept.  ``q`` must be finite and nonzero (``ValueError`` naming ``q``
    otherwise).  Batches with more than one leading axis need scipy >= 1.17 (N-D ``Rotation``).
    """
    from scipy.spatial.transform import Rotation

    q = as_array(q, "q", 4)
    check_finite(q, "q")
    _raise_if_zero(q, "q")
    return Rotation.from_quat(q)


def dualquat_from_scipy(transform: Any) -> NDArray[np.float64]:
    """Unit dual quaternions (..., 8) ``[real xyzw, dual xyzw]`` of a :class:`scipy.spatial.transform.RigidTransform`.

    This is ``transform.as_dual_quat()``, whose default (scalar-last) layout and ``dual = ½ t (x) real`` are
    dualpose's.  scipy stores a matrix, so the sign is whatever its matrix-to-quaternion step picks (scipy 1.17:
    the real part's largest-magnitude component is positive); apply ``dualquat_canonical`` for ``w >= 0``.
    """
    from scipy.spatial.transform import RigidTransform

    if not isinstance(transform, RigidTransform):
        raise TypeError(f"transform must be a scipy.spatial.transform.RigidTransform; got {type(transform).__name__}")
    return np.asarray(transform.as_dual_quat(), dtype=np.float64)


def scipy_from_dualquat(dq: ArrayLike) -> Any:
    """A :class:`scipy.spatial.transform.RigidTransform` from dual quaternions ``dq`` (..., 8).

    Built as ``RigidTransform.from_components(t, Rotation.from_quat(q))`` with ``(q, t) = qt_from_dualquat(dq)``,
    so the rotation and translation are exactly dualpose's reading of ``dq`` (``from_dual_quat`` would apply
    scipy's own normalization, and it silently maps a zero real part to the identity rotation).  ``dq`` must be
    finite with a nonzero real part (``ValueError`` naming ``dq`` otherwise).
    """
    from scipy.spatial.transform import RigidTransform, Rotation

    dq = as_array(dq, "dq", 8)
    check_finite(dq, "dq")
    _raise_if_zero(dq[..., :4], "the real part of dq")
    q, t = _dualquat.qt_from_dualquat(dq)
    return RigidTransform.from_components(t, Rotation.from_quat(q))


def pq_from_dualquat(dq: ArrayLike) -> NDArray[np.float64]:
    """pytransform3d position–quaternion ``[x, y, z, qw, qx, qy, qz]`` (..., 7) of dual quaternions (..., 8).

    The translation is :func:`~dualpose.algebra.dualquat.qt_from_dualquat`'s; the quaternion is the real part
    reordered to scalar-first, sign kept.  pytransform3d is not imported.
    """
    q, t = _dualquat.qt_from_dualquat(dq)
    return np.concatenate([t, q[..., _WXYZ]], axis=-1)


def dualquat_from_pq(pq: ArrayLike) -> NDArray[np.float64]:
    """Dual quaternions (..., 8) from pytransform3d position–quaternions ``[x, y, z, qw, qx, qy, qz]`` (..., 7).

    Equivalent to ``dualquat_from_qt(pq[..., [4, 5, 6, 3]], pq[..., :3])``; pytransform3d is not imported.
    """
    pq = as_array(pq, "pq", 7)
    return _dualquat.dualquat_from_qt(pq[..., 3:][..., _XYZW], pq[..., :3])
