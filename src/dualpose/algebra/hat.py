"""The so(3) hat and vee operators: the skew matrix ``[v]×`` of a 3-vector and back (Barfoot 2017, eq. 6.7).

Vectors are ``(..., 3)`` arrays, matrices ``(..., 3, 3)``; both broadcast over leading axes.  The quaternion
module (Walker's Q/W matrices) and the Lie-group module both build on these, so they live below both.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose._validation import as_array

__all__ = ["so3_hat", "so3_vee"]


def so3_hat(v: ArrayLike) -> NDArray[np.float64]:
    """Skew-symmetric matrix ``[v]×`` with ``[v]× u = v × u``.

    Parameters
    ----------
    v : array_like, shape (..., 3)

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``[[0, −z, y], [z, 0, −x], [−y, x, 0]]``.
    """
    v = as_array(v, "v", 3)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros(v.shape[:-1] + (3, 3))
    o[..., 0, 1], o[..., 0, 2] = -z, y
    o[..., 1, 0], o[..., 1, 2] = z, -x
    o[..., 2, 0], o[..., 2, 1] = -y, x
    return o


def so3_vee(matrix: ArrayLike) -> NDArray[np.float64]:
    """Inverse of :func:`so3_hat`: the vector of the skew-symmetric part ``½ (M − Mᵀ)``.

    Parameters
    ----------
    matrix : array_like, shape (..., 3, 3)

    Returns
    -------
    ndarray, shape (..., 3)
        ``½ [M₂₁ − M₁₂, M₀₂ − M₂₀, M₁₀ − M₀₁]`` (exactly ``v`` for ``M = so3_hat(v)``).
    """
    m = as_array(matrix, "matrix", (3, 3))
    return 0.5 * np.stack(
        [m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], axis=-1
    )
