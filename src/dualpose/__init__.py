"""dualpose: rigid-body pose with quaternions and dual quaternions.

Quaternions are ``(..., 4)`` float arrays ordered ``[x, y, z, w]`` (scalar last, Hamilton product); dual quaternions
are ``(..., 8)`` arrays ``[real xyzw, dual xyzw]`` with ``dual = ½ t (x) real``; twists (exponential coordinates)
are ``(..., 6)`` arrays ``[ω, v]``.  Every function broadcasts over leading axes.  See ``docs/conventions.md``.

Importing dualpose is cheap: the compiled kernels load on first use.
"""

# the algebra's names, star-imported from the modules that define them (a type checker follows one level of
# `import *` inside the package, not the re-export of dualpose.algebra)
from dualpose.algebra import classes as _classes
from dualpose.algebra import derivatives as _derivatives
from dualpose.algebra import dualquat as _dualquat
from dualpose.algebra import implicit as _implicit
from dualpose.algebra import interop as _interop
from dualpose.algebra import lie as _lie
from dualpose.algebra import quat as _quat
from dualpose.algebra.classes import *  # noqa: F403
from dualpose.algebra.derivatives import *  # noqa: F403
from dualpose.algebra.dualquat import *  # noqa: F403
from dualpose.algebra.implicit import *  # noqa: F403
from dualpose.algebra.interop import *  # noqa: F403
from dualpose.algebra.lie import *  # noqa: F403
from dualpose.algebra.quat import *  # noqa: F403

__version__ = "0.1.0"
__all__: list[str] = []
__all__ += _quat.__all__
__all__ += _dualquat.__all__
__all__ += _implicit.__all__
__all__ += _lie.__all__
__all__ += _derivatives.__all__
__all__ += _classes.__all__
__all__ += _interop.__all__
__all__ += ["__version__"]
