"""Quaternion and dual-quaternion algebra (Dantam 2014; Walker 1991 §2).

Layouts: quaternions ``(..., 4)`` xyzw (Hamilton); dual quaternions ``(..., 8)`` = ``[real xyzw, dual xyzw]`` with
``dual = ½ t (x) real``; twists ``(..., 6)`` = ``[ω, v]``.  See ``docs/conventions.md``.

Modules: :mod:`~dualpose.algebra.quat` (quaternions), :mod:`~dualpose.algebra.dualquat` (dual quaternions),
:mod:`~dualpose.algebra.implicit` ((q, t) pairs), :mod:`~dualpose.algebra.lie` (SO(3)/SE(3) Jacobians, adjoints),
:mod:`~dualpose.algebra.derivatives` (quaternion calculus), :mod:`~dualpose.algebra.series` (guarded series),
:mod:`~dualpose.algebra.classes` (``Quaternion``/``DualQuaternion``), :mod:`~dualpose.algebra.interop` (scipy,
pytransform3d).
"""

from dualpose.algebra import classes, derivatives, dualquat, implicit, interop, lie, quat
from dualpose.algebra.classes import *  # noqa: F403
from dualpose.algebra.derivatives import *  # noqa: F403
from dualpose.algebra.dualquat import *  # noqa: F403
from dualpose.algebra.implicit import *  # noqa: F403
from dualpose.algebra.interop import *  # noqa: F403
from dualpose.algebra.lie import *  # noqa: F403
from dualpose.algebra.quat import *  # noqa: F403

# `__all__ +=` of each module's list (rather than one literal with `*` unpacking): type checkers read this form
__all__: list[str] = []
__all__ += quat.__all__
__all__ += dualquat.__all__
__all__ += implicit.__all__
__all__ += lie.__all__
__all__ += derivatives.__all__
__all__ += classes.__all__
__all__ += interop.__all__
