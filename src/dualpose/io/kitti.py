"""KITTI odometry pose files: one pose per line, the row-major 3x4 matrix ``[R | t]`` (12 numbers).

Geiger, Lenz & Urtasun 2012 (KITTI odometry benchmark, ``devkit/readme.txt``): line ``i`` holds
``r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz``, the pose of frame ``i`` (camera/body -> world: ``p_world = R
p_body + t``), separated by whitespace.  The files carry no stamps: they are in a separate ``times.txt`` (one
number of seconds per line, as in the KITTI sequences) when there is one; without it the pose index is used as
the stamp in seconds (pose ``i`` at ``i`` s, what evo's ``kitti`` mode does).  ``#`` comments and blank lines are
accepted as in the other text formats.
"""

from __future__ import annotations

import os

import numpy as np

import dualpose as dp
from dualpose import _native
from dualpose.io._text import check_path, open_for_writing, read_float_table, read_table
from dualpose.types.trajectory import Trajectory

__all__ = ["read_kitti", "write_kitti"]

_LAYOUT = "r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz"


def read_kitti(path: str | os.PathLike[str], times: str | os.PathLike[str] | None = None) -> Trajectory:
    """Read a KITTI pose file (and its stamps from ``times``, one number of seconds per line).

    Returns
    -------
    Trajectory
        ``stamps`` from ``times`` or ``0, 1, 2, ...`` s, ``positions`` = ``t``, ``quats`` =
        :func:`dualpose.quat_from_matrix` of ``R`` (xyzw, ``w >= 0``), ``name`` = the path.

    Raises
    ------
    TypeError
        ``path`` or ``times`` not a path.
    ValueError
        ``path:line: ...`` for a line without 12 numbers or with a block that is not a rotation (``max |RᵀR −
        I| > 1e-5`` or ``det R <= 0``, see docs/conventions.md); a ``times`` file whose length differs.
    """
    p = check_path(path, "path")
    data = read_float_table(p, 12, None, _LAYOUT)
    mats = data.reshape(-1, 3, 4)
    try:
        quats = dp.quat_from_matrix(mats[:, :, :3])
    except ValueError as exc:
        bad = _first_bad_rotation(mats[:, :, :3])
        table = read_table(p, None, (12, 12), _LAYOUT)
        raise table.error(bad, f"the rotation block is not a rotation matrix ({str(exc).split(': ', 1)[-1]})") from None
    if times is None:
        stamps = np.arange(mats.shape[0], dtype=np.float64)
    else:
        tp = check_path(times, "times")
        stamps = read_float_table(tp, 1, None, "t")[:, 0]
        if stamps.shape[0] != mats.shape[0]:
            raise ValueError(f"{tp}: {stamps.shape[0]} stamps for the {mats.shape[0]} poses of {p}")
    return Trajectory(stamps, mats[:, :, 3].copy(), quats, name=p)


def _first_bad_rotation(r: np.ndarray) -> int:
    """Index of the first matrix of ``r`` (n, 3, 3) that :func:`dualpose.quat_from_matrix` rejects (its criteria and
    tolerance)."""
    g = np.abs(np.einsum("nki,nkj->nij", r, r) - np.eye(3)).max(axis=(1, 2))
    bad = (g > _native.QUAT_FROM_MATRIX_ORTHOGONALITY_TOL) | (np.linalg.det(r) <= 0)
    return int(np.argmax(bad))


def write_kitti(path: str | os.PathLike[str], trajectory: Trajectory, *, overwrite: bool = False) -> None:
    """Write ``trajectory`` as a KITTI pose file (17 significant digits; the stamps are not written).

    An existing file raises ``FileExistsError`` unless ``overwrite`` is true.
    """
    if not isinstance(trajectory, Trajectory):
        raise TypeError(f"trajectory must be a dualpose.io.Trajectory; got {type(trajectory).__name__}")
    check_path(path, "path")
    r = dp.matrix_from_quat(dp.quat_normalize(trajectory.quats))
    rows = np.concatenate([r, trajectory.positions[:, :, None]], axis=2).reshape(-1, 12)
    with open_for_writing(path, overwrite) as f:
        for row in rows.tolist():
            f.write(" ".join(f"{v:.17g}" for v in row))
            f.write("\n")
