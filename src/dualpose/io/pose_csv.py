"""Timestamped pose files ``t, x, y, z, qx, qy, qz, qw`` (comma- or whitespace-separated).

One pose per line: ``t`` in seconds (any clock, e.g. Unix epoch), ``x y z`` the position of the sensor/body origin in
the reference frame (metres), ``qx qy qz qw`` its orientation sensor -> reference, Hamilton, scalar last.  Lines
starting with ``#`` and blank lines are skipped.  The separator is taken from the first data line: a comma if it
has one (before any ``#`` comment), otherwise runs of whitespace.  The rows are read as TUM files are
(``dualpose.io._text.read_pose_rows``).  Rows are returned in file order, unsorted and with any duplicates: cleaning
is the caller's job (``dualpose.calibration.clean_pose_stream``).
"""

from __future__ import annotations

import os
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from dualpose.io._text import read_pose_rows
from dualpose.io.rosbag import is_bag_source, read_bag_trajectory

__all__ = ["read_pose_csv", "read_pose_stream"]

_LAYOUT = "t, x, y, z, qx, qy, qz, qw"


def read_pose_csv(path: str | os.PathLike[str]) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Read a ``t, x, y, z, qx, qy, qz, qw`` pose file.

    Parameters
    ----------
    path : path-like

    Returns
    -------
    stamps : ndarray, shape (N,)
        Seconds, in file order.
    positions : ndarray, shape (N, 3)
        Metres.
    quats : ndarray, shape (N, 4)
        xyzw as written (not normalized).

    Raises
    ------
    FileNotFoundError
        When the file does not exist.
    ValueError
        ``path:line: ...`` for a line without exactly 8 fields, a field that is not a finite number, or a zero
        quaternion; ``path: ...`` for a file without data rows.
    """
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise FileNotFoundError(f"{p}: no such file")
    data = read_pose_rows(p, _LAYOUT)
    return data[:, 0].copy(), data[:, 1:4].copy(), data[:, 4:8].copy()


def read_pose_stream(
    path: str | os.PathLike[str], *, bag_time: Literal["header", "receive"] = "header"
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`read_pose_csv`, or the poses of a ROS bag topic ``BAG:/topic`` / ``BAG:/tf:PARENT:CHILD``
    (:func:`dualpose.io.rosbag.read_bag_trajectory` with ``stamps=bag_time``), in the same layout and, like the
    file's rows, in bag order with any duplicate stamps (float seconds from the exact nanoseconds)."""
    if is_bag_source(path):
        tr = read_bag_trajectory(path, stamps=bag_time, strict=False)
        return tr.stamps, tr.positions, tr.quats
    return read_pose_csv(path)
