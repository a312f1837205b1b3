"""Quaternion and dual-quaternion algebra (Dantam 2014; Walker 1991 §2).

Layouts: quaternions ``(..., 4)`` xyzw (Hamilton); dual quaternions ``(..., 8)`` = ``[real xyzw, dual xyzw]`` with
``dual = ½ t (x) real``; twists ``(..., 6)`` = ``[ω, v]``.  See ``docs/conventions.md``.
"""

from dualpose.algebra.quat import *  # noqa: F403
from dualpose.algebra.quat import __all__ as _quat_all

__all__ = [*_quat_all]
