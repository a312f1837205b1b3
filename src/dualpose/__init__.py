"""dualpose: rigid-body pose with quaternions and dual quaternions.

Quaternions are ``(..., 4)`` float arrays ordered ``[x, y, z, w]`` (scalar last, Hamilton product); dual quaternions
are ``(..., 8)`` arrays ``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real``; twists (exponential coordinates)
are ``(..., 6)`` arrays ``[ω, v]``.  Every function broadcasts over leading axes.  See ``docs/conventions.md``.

Importing dualpose is cheap: the compiled kernels load on first use.
"""

from dualpose.algebra import *  # noqa: F403
from dualpose.algebra import __all__ as _algebra_all

__version__ = "0.1.0"
__all__ = [*_algebra_all, "__version__"]
