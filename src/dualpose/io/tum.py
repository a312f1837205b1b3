"""TUM RGB-D trajectory files: one pose per line, ``t tx ty tz qx qy qz qw``.

``t`` is in seconds, ``tx ty tz`` the position of the camera/body origin in the world frame (metres) and
``qx qy qz qw`` its orientation body -> world, scalar last (Sturm et al. 2012, the TUM RGB-D benchmark format; the
same layout as dualpose's xyzw quaternions).  Fields are separated by whitespace or by commas (a variant some
tools write); ``#`` starts a comment, on its own line or after the numbers.
"""

from __future__ import annotations

import os

import numpy as np

from dualpose.io._text import check_path, open_for_writing, read_pose_rows
from dualpose.types.trajectory import Trajectory

__all__ = ["read_tum", "write_tum"]

_LAYOUT = "t tx ty tz qx qy qz qw"


def read_tum(path: str | os.PathLike[str]) -> Trajectory:
    """Read a TUM trajectory file.

    Returns
    -------
    Trajectory
        ``stamps`` (N,) s, ``positions`` (N, 3) m, ``quats`` (N, 4) xyzw as written in the file (not normalized),
        ``name`` = the path.

    Raises
    ------
    ValueError
        ``path:line: ...`` for a line without exactly 8 fields, a field that is not a finite number, or a zero
        quaternion.
    """
    p = check_path(path)
    data = read_pose_rows(p, _LAYOUT)
    return Trajectory(data[:, 0], data[:, 1:4], data[:, 4:8], name=p)


def write_tum(
    path: str | os.PathLike[str], trajectory: Trajectory, *, overwrite: bool = False, header: bool = True,
) -> None:
    """Write ``trajectory`` as a TUM file.

    Timestamps are written exactly: from ``stamps_ns`` as ``seconds.nanoseconds`` when present, otherwise with 17
    significant digits (a float64 round trip is exact).  Positions and quaternions use 17 significant digits.

    Parameters
    ----------
    path : path-like
    trajectory : Trajectory
    overwrite : bool
        Replace an existing file; by default an existing file raises ``FileExistsError``.
    header : bool
        Write a ``# timestamp tx ty tz qx qy qz qw`` comment line first.
    """
    if not isinstance(trajectory, Trajectory):
        raise TypeError(f"trajectory must be a dualpose.io.Trajectory; got {type(trajectory).__name__}")
    if trajectory.stamps_ns is not None:
        whole, frac = np.divmod(trajectory.stamps_ns, 1_000_000_000)
        stamps = [f"{w}.{f:09d}" for w, f in zip(whole.tolist(), frac.tolist(), strict=True)]
    else:
        stamps = [f"{s:.17g}" for s in trajectory.stamps.tolist()]
    body = np.hstack([trajectory.positions, trajectory.quats])
    lines = [f"{s} " + " ".join(f"{v:.17g}" for v in row) for s, row in zip(stamps, body.tolist(), strict=True)]
    with open_for_writing(path, overwrite) as f:
        if header:
            f.write("# timestamp tx ty tz qx qy qz qw\n")
        f.write("\n".join(lines))
        f.write("\n")
