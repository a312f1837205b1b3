"""Timestamped pose files ``t, x, y, z, qx, qy, qz, qw`` (comma- or whitespace-separated).

One pose per line: ``t`` in seconds (any clock, e.g. Unix epoch), ``x y z`` the position of the sensor/body origin in
the reference frame (metres), ``qx qy qz qw`` its orientation sensor -> reference, Hamilton, scalar last.  Lines
starting with ``#`` and blank lines are skipped.  The separator is taken from the first data line: a comma if it
has one, otherwise runs of whitespace.  Rows are returned in file order, unsorted and with any duplicates: cleaning
is the caller's job (``dualpose.calibration.clean_pose_stream``).
"""

from __future__ import annotations

import os

import numpy as np

from dualpose.io._text import parse_float_columns, read_table

__all__ = ["read_pose_csv"]

_LAYOUT = "t, x, y, z, qx, qy, qz, qw"


def _delimiter(path: str) -> str | None:
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        for line in f:
            s = line.strip()
            if s and not s.startswith("#"):
                return "," if "," in s else None
    return None


def read_pose_csv(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    table = read_table(p, _delimiter(p), (8, 8), _LAYOUT)
    data = parse_float_columns(table, slice(0, 8), _LAYOUT)
    zero = ~(data[:, 4:8] != 0.0).any(axis=1)
    if zero.any():
        raise table.error(int(np.argmax(zero)), "zero quaternion (qx qy qz qw all 0)")
    return data[:, 0].copy(), data[:, 1:4].copy(), data[:, 4:8].copy()
