"""Many independent registration problems in one call: ``(B, n, 3)`` correspondences -> ``B`` poses.

Each problem is solved in closed form by the same compiled kernel as :func:`~dualpose.registration.register_pose`
(centred Walker / Horn / SVD, a 4x4 Jacobi eigen-solve per problem), in one pass without Python loops.
Layouts: quaternions ``(B, 4)`` xyzw, dual quaternions ``(B, 8)`` ``[real xyzw, dual xyzw]``, ``dual = ½ t (x) real``.

With dask arrays among the inputs the batch is lazy: ``dask.array.apply_gufunc`` over the batch axis (chunked as
given, each problem's correspondences in one chunk), output dtypes and core sizes explicit, each block solved by the
same kernel as in memory (docs/scaling.md, "Lazy and out-of-core").  dask is never imported here.
"""

from __future__ import annotations

import sys
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dualpose import _native
from dualpose.registration import _row as R
from dualpose.registration._inputs import Problem, check_minimum_data, method_code, prepare_batch
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

    From dask inputs every attribute above is a lazy dask array (nothing is solved until it is computed);
    ``batch[i]`` computes problem ``i`` only, ``batch.compute()`` all problems at once into a NumPy batch.
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
        if isinstance(self._rows, np.ndarray):
            return PoseEstimate(self._rows[i], self.method, tuple(d[i] for d in self._data))
        row, *data = sys.modules["dask"].compute(self._rows[i], *(d[i] for d in self._data))
        return PoseEstimate(row, self.method, cast(Problem, tuple(data)))

    def compute(self) -> PoseBatch:
        """This batch with NumPy arrays: all problems of a lazy batch solved in one pass (a NumPy batch as is)."""
        if isinstance(self._rows, np.ndarray):
            return self
        rows, *data = sys.modules["dask"].compute(self._rows, *self._data)
        return PoseBatch(rows, self.method, cast(Problem, tuple(data)))

    quat = property(lambda self: _contiguous(self._rows[:, R.QUAT]), doc="Rotations (B, 4) xyzw.")
    translation = property(lambda self: _contiguous(self._rows[:, R.TRANSLATION]), doc="Translations (B, 3).")
    scale = property(lambda self: self._rows[:, R.SCALE].copy(), doc="Scales (B,).")
    cost = property(lambda self: self._rows[:, R.COST].copy(), doc="Minimised costs E (B,).")
    eigen_gap = property(lambda self: self._rows[:, R.EIGEN_GAP].copy(), doc="Gaps that decided uniqueness (B,).")
    rotation_unique = property(lambda self: self._rows[:, R.UNIQUE] != 0.0, doc="Unique optimum (B,) bool.")

    @property
    def rmsd(self) -> NDArray[np.float64]:
        """Weighted RMS point residuals (B,) (over directions for problems without points)."""
        if not isinstance(self._rows, np.ndarray):  # lazy: the same NumPy computation on each block of problems
            p0, p1, beta, n0, n1, alpha = self._data
            return cast(NDArray[np.float64], sys.modules["dask.array"].blockwise(
                _rmsd_block, "b", self._rows, "bk", p0, "bnj", p1, "bnj", beta, "bn", n0, "bmj", n1, "bmj",
                alpha, "bm", method=self.method, dtype=np.float64, concatenate=True))  # fmt: skip
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
        if not isinstance(self._rows, np.ndarray):
            return f"PoseBatch(method={self.method!r}, B={len(self)}, lazy)"
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
        Lazy when a dask array is among the inputs (its arrays are dask arrays chunked along ``B`` as the inputs
        are; shapes are checked at the call, values when computed).

    Raises
    ------
    ValueError
        As :func:`register_pose`; the message names the first offending problem.
    """
    code = method_code(method)
    inputs = (model_points, measured_points, model_directions, measured_directions, point_weights, direction_weights)
    if any(type(x).__module__.startswith("dask.") for x in inputs):
        return _lazy_batch(inputs, method, code, scale)
    data = prepare_batch(*inputs)
    return PoseBatch(_solve(data, code, scale, 0), method, data)


def _contiguous(x: Any) -> Any:
    return np.ascontiguousarray(x) if isinstance(x, np.ndarray) else x


def _solve(data: Problem, code: int, scale: bool, offset: int) -> NDArray[np.float64]:
    """The kernel's result rows (B, ROW_SIZE) of checked problems; errors number them from ``offset``."""
    if scale and data[3].shape[1] > 0:
        raise ValueError("scale=True is supported for points only (the direction term does not scale)")
    rows = np.empty((data[0].shape[0], R.ROW_SIZE))
    i = _native.registration_solve_batch(*data, code, bool(scale), rows)  # the first problem with a BAD_INPUT code
    if i >= 0:
        raise ValueError(f"problem {i + offset}: {bad_input_message(rows[i, R.BAD_INPUT])}")
    return rows


#: the inputs of register_pose_batch in prepare_batch's order, with their core shapes (apply_gufunc notation)
_NAMES = ("model_points", "measured_points", "model_directions", "measured_directions", "point_weights",
          "direction_weights")
_CORES = ("(n,3)", "(n,3)", "(m,3)", "(m,3)", "(n)", "(m)")


def _lazy_batch(inputs: tuple[Any, ...], method: str, code: int, scale: bool) -> PoseBatch:
    """Lazy :func:`register_pose_batch` (a dask array among ``inputs``; dask is imported)."""
    da = sys.modules["dask.array"]
    given = [i for i, x in enumerate(inputs) if x is not None]
    arrays = [da.asarray(inputs[i]) for i in given]
    shapes = dict(zip(given, (a.shape for a in arrays), strict=True))
    for i, a in zip(given, arrays, strict=True):
        if not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
            raise TypeError(f"{_NAMES[i]} must be a real numeric array; got dtype {a.dtype}")
    for i, j in ((0, 1), (2, 3)):
        if (i in shapes) != (j in shapes):
            raise ValueError(f"{_NAMES[i]} and {_NAMES[j]} must be given together")
        for k in (i, j):
            if k in shapes and (len(shapes[k]) != 3 or shapes[k][2] != 3):
                raise ValueError(f"{_NAMES[k]} must have shape (B, n, 3); got shape {shapes[k]}")
        if i in shapes and shapes[i] != shapes[j]:
            raise ValueError(f"{_NAMES[i]} and {_NAMES[j]} must have the same shape; got {shapes[i]} and {shapes[j]}")
    n = shapes[0][1] if 0 in shapes else 0
    m = shapes[2][1] if 2 in shapes else 0
    if 0 not in shapes and 2 not in shapes:
        raise ValueError("give model_points/measured_points, model_directions/measured_directions, or both")
    batch = {shapes[k][0] for k in (0, 2) if k in shapes}
    if len(batch) > 1:
        raise ValueError(f"points have batch shape {shapes[0][:1]} but directions {shapes[2][:1]}")
    (b,) = batch
    for k, d, pair, what in ((4, n, 0, "points"), (5, m, 2, "directions")):
        if k in shapes and pair not in shapes:
            raise ValueError(f"{_NAMES[k]} given without {what}")
        if k in shapes and shapes[k] != (b, d):
            raise ValueError(f"{_NAMES[k]} must have shape {(b, d)} (one weight per correspondence); "
                             f"got shape {shapes[k]}")
    if 4 not in shapes and 5 not in shapes:
        check_minimum_data(n, m)  # with weights, problem by problem when computed
    if scale and m > 0:
        raise ValueError("scale=True is supported for points only (the direction term does not scale)")
    # each problem's correspondences in one chunk; the batch axis as the first dask input has it
    lead = next(a.chunks[0] for a, i in zip(arrays, given, strict=True)
                if type(inputs[i]).__module__.startswith("dask."))
    arrays = [a.rechunk({0: lead, **{ax: -1 for ax in range(1, a.ndim)}}) for a in arrays]
    first = da.arange(b, chunks=(lead,))  # the index of every problem: blocks know their offset

    def block(index: NDArray[np.int64], *blocks: NDArray[Any]) -> tuple[NDArray[np.float64], ...]:
        args: list[Any] = [None] * 6
        for i, x in zip(given, blocks, strict=True):
            args[i] = x
        offset = int(index[0]) if index.size else 0
        data = prepare_batch(*args, offset=offset)
        return (_solve(data, code, scale, offset), *data)

    signature = ",".join(["()", *(_CORES[i] for i in given)]) + "->(r),(n,3),(n,3),(n),(m,3),(m,3),(m)"
    rows, *data = da.apply_gufunc(
        block, signature, first, *arrays, output_dtypes=[np.float64] * 7,
        output_sizes={"r": R.ROW_SIZE, "n": n, "m": m, "3": 3})
    return PoseBatch(rows, method, cast(Problem, tuple(data)))


def _rmsd_block(rows: NDArray[np.float64], *data: NDArray[np.float64], method: str) -> NDArray[np.float64]:
    """:attr:`PoseBatch.rmsd` of one block of problems (NumPy arrays), for the lazy batch."""
    return PoseBatch(rows, method, cast(Problem, data)).rmsd
