"""Many independent registration problems in one call: ``(B, n, 3)`` correspondences -> ``B`` poses.

Each problem is solved in closed form by the same compiled kernel as :func:`~dualpose.registration.register_pose`
(centred Walker / Horn / SVD, a 4x4 Jacobi eigen-solve per problem), in one pass without Python loops.
Layouts: quaternions ``(B, 4)`` xyzw, dual quaternions ``(B, 8)`` ``[real xyzw, dual xyzw]``, ``dual = ½ t (x) real``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose.registration import _row as R
from dualpose.registration._inputs import method_code, prepare_batch
from dualpose.registration.estimate import PoseEstimate, bad_input_message

__all__ = ["PoseBatch", "register_pose_batch"]


class PoseBatch:
    """Result of :func:`register_pose_batch`: ``B`` transforms model -> measured, ``p̃ ≈ s R p⁰ + t``.

    The attributes are arrays over the batch axis.

    Attributes
    ----------
    quat : ndarray (B, 4)
        Rotations, xyzw, ``w >= 0``.
    translation : ndarray (B, 3)
    scale, cost, rmsd, eigen_gap : ndarray (B,)
        As in :class:`PoseEstimate` (``rmsd`` over points; over directions when a problem has no points).
    rotation_unique : ndarray (B,) of bool
    method : str

    ``batch[i]`` is the full :class:`PoseEstimate` of problem ``i`` (residuals, degeneracy label, covariance).
    """

    __slots__ = ("_rows", "_data", "method")

    def __init__(self, rows: np.ndarray, method: str, data: tuple[np.ndarray, ...]) -> None:
        self._rows = rows
        self._data = data
        self.method = method

    def __len__(self) -> int:
        result: int = self._rows.shape[0]
        return result

    def __getitem__(self, i: int) -> PoseEstimate:
        i = range(len(self))[i]  # bounds and negative indices
        return PoseEstimate(self._rows[i], self.method, tuple(d[i] for d in self._data))

    quat = property(lambda self: np.ascontiguousarray(self._rows[:, R.QUAT]), doc="Rotations (B, 4) xyzw.")
    translation = property(lambda self: np.ascontiguousarray(self._rows[:, R.TRANSLATION]), doc="Translations (B, 3).")
    scale = property(lambda self: self._rows[:, R.SCALE].copy(), doc="Scales (B,).")
    cost = property(lambda self: self._rows[:, R.COST].copy(), doc="Minimised costs E (B,).")
    eigen_gap = property(lambda self: self._rows[:, R.EIGEN_GAP].copy(), doc="Gaps that decided uniqueness (B,).")
    rotation_unique = property(lambda self: self._rows[:, R.UNIQUE] != 0.0, doc="Unique optimum (B,) bool.")

    @property
    def rmsd(self) -> NDArray[np.float64]:
        """Weighted RMS point residuals (B,) (over directions for problems without points)."""
        bsum = self._data[2].sum(axis=-1)
        asum = self._data[5].sum(axis=-1)
        pts = np.sqrt(np.maximum(self._rows[:, R.POINT_COST], 0.0) / np.where(bsum > 0, bsum, 1.0))
        with np.errstate(invalid="ignore"):  # inf - inf where huge coordinates overflow the cost (point rows)
            dir_cost = np.maximum(self._rows[:, R.COST] - self._rows[:, R.POINT_COST], 0.0)
        dirs = np.sqrt(dir_cost / np.where(asum > 0, asum, 1.0))
        out: NDArray[np.float64] = np.where(bsum > 0, pts, dirs)
        for i in np.flatnonzero(self._rows[:, R.POINT_EXPONENT] != 0):  # extreme spreads only (rare)
            out[i] = self[int(i)].rmsd
        return out

    @property
    def rotation_matrix(self) -> NDArray[np.float64]:
        """Rotation matrices (B, 3, 3)."""
        import dualpose as dp

        return dp.matrix_from_quat(self.quat)

    @property
    def dualquat(self) -> NDArray[np.float64]:
        """Unit dual quaternions (B, 8) of the rigid parts ``p ↦ R p + t``."""
        import dualpose as dp

        return dp.dualquat_from_qt(self.quat, self.translation)

    def __repr__(self) -> str:
        return f"PoseBatch(method={self.method!r}, B={len(self)}, unique={int(self.rotation_unique.sum())}/{len(self)})"


def register_pose_batch(
    model_points: ArrayLike | None,
    measured_points: ArrayLike | None,
    point_weights: ArrayLike | None = None,
    *,
    model_directions: ArrayLike | None = None,
    measured_directions: ArrayLike | None = None,
    direction_weights: ArrayLike | None = None,
    method: str = "dq",
    scale: bool = False,
) -> PoseBatch:
    """Solve ``B`` independent :func:`register_pose` problems in one call.

    Parameters
    ----------
    model_points, measured_points : array_like, shape (B, n, 3), or None
        Corresponding points of each problem (same ``n`` for all; give zero weights to pad shorter problems).
    point_weights : array_like, shape (B, n), optional
        ``β`` per correspondence (default 1).
    model_directions, measured_directions : array_like, shape (B, m, 3), optional
    direction_weights : array_like, shape (B, m), optional
    method : {"dq", "horn", "svd"}
    scale : bool
        Similarity (Umeyama), points only.

    Returns
    -------
    PoseBatch

    Raises
    ------
    ValueError
        As :func:`register_pose`; the message names the first offending problem.
    """
    code = method_code(method)
    data = prepare_batch(
        model_points, measured_points, model_directions, measured_directions, point_weights, direction_weights
    )
    if scale and data[3].shape[1] > 0:
        raise ValueError("scale=True is supported for points only (the direction term does not scale)")
    rows = np.empty((data[0].shape[0], R.ROW_SIZE))
    i = _native.registration_solve_batch(*data, code, bool(scale), rows)  # the first problem with a BAD_INPUT code
    if i >= 0:
        raise ValueError(f"problem {i}: {bad_input_message(rows[i, R.BAD_INPUT])}")
    return PoseBatch(rows, method, data)
