"""Format detection from a file's content (like ``evo``'s readers, but without naming the format by hand)."""

from __future__ import annotations

import os
from itertools import islice
from typing import Literal

from dualpose.io.euroc import read_euroc_groundtruth
from dualpose.io.tum import read_tum
from dualpose.types.trajectory import Trajectory

__all__ = ["detect_format", "read_trajectory"]

Format = Literal["tum", "euroc_groundtruth", "euroc_imu"]


def detect_format(path: str | os.PathLike) -> Format:
    """Tell a TUM trajectory, an EuRoC ground-truth CSV and an EuRoC IMU CSV apart.

    An EuRoC header comment decides (``q_RS_w``/``p_RS_R`` -> ground truth, ``w_RS_S`` and ``a_RS_S`` -> IMU);
    otherwise the first data line does: whitespace-separated with 8 fields -> TUM, comma-separated with an integer
    first field and 7 fields -> IMU, 8 or 17 fields -> ground truth.

    Raises
    ------
    FileNotFoundError
    ValueError
        ``path:line: ...`` when the first data line fits none of the formats, or the file has no data.
    """
    p = str(path)
    with open(p, encoding="utf-8-sig", errors="replace") as f:
        head = list(islice(f, 200))
    for i, raw in enumerate(head, start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            if "q_RS_w" in line or "p_RS_R" in line:
                return "euroc_groundtruth"
            if "w_RS_S" in line and "a_RS_S" in line:
                return "euroc_imu"
            continue
        if "," in line:
            fields = [x.strip() for x in line.split(",")]
            if fields[0].lstrip("-").isdigit():
                if len(fields) == 7:
                    return "euroc_imu"
                if len(fields) in (8, 17):
                    return "euroc_groundtruth"
        elif len(line.split()) == 8:
            return "tum"
        raise ValueError(
            f"{p}:{i}: cannot tell the file format from {line[:80]!r}: expected a TUM line (8 whitespace-separated "
            "fields 't tx ty tz qx qy qz qw') or an EuRoC CSV row (integer ns timestamp, then 6 IMU or 7+ pose fields)"
        )
    raise ValueError(f"{p}: no data lines found (expected a TUM or EuRoC file)")


def read_trajectory(path: str | os.PathLike, fmt: Format | None = None) -> Trajectory:
    """Read a trajectory from a TUM file or an EuRoC ground-truth CSV, detecting the format unless ``fmt`` is given.

    Returns a :class:`~dualpose.io.Trajectory` (quaternions xyzw).  An EuRoC IMU file raises ``ValueError``.
    """
    fmt = detect_format(path) if fmt is None else fmt
    if fmt == "tum":
        return read_tum(path)
    if fmt == "euroc_groundtruth":
        return read_euroc_groundtruth(path)
    if fmt == "euroc_imu":
        raise ValueError(f"{path}: is an EuRoC IMU file (angular rate and acceleration), not a trajectory")
    raise ValueError(f"fmt must be 'tum', 'euroc_groundtruth' or None; got {fmt!r}")
