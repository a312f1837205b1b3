"""Format detection from a file's content (like ``evo``'s readers, but without naming the format by hand)."""

from __future__ import annotations

import io
import os
from typing import Literal

from dualpose.io._text import MAX_LINE_BYTES, check_path, open_input
from dualpose.io.euroc import read_euroc_groundtruth
from dualpose.io.kitti import read_kitti
from dualpose.io.rosbag import is_bag_source, read_bag_trajectory
from dualpose.io.tum import read_tum
from dualpose.types.trajectory import Trajectory

__all__ = ["detect_format", "read_trajectory"]

Format = Literal["tum", "kitti", "euroc_groundtruth", "euroc_imu", "rosbag"]

#: what the detection knows, for the error message
_FORMATS = (
    "TUM ('t tx ty tz qx qy qz qw': 8 numbers separated by whitespace or commas), "
    "KITTI (12 numbers 'r11 r12 r13 tx r21 ... tz' of a 3x4 [R|t]), "
    "EuRoC ground-truth CSV (integer ns stamp, then 7 or 16 numbers), EuRoC IMU CSV (integer ns stamp, then 6) "
    "and a topic of a ROS bag (BAG:/topic or BAG:/tf:PARENT:CHILD; BAG a .bag, .db3 or .mcap)"
)


def detect_format(path: str | os.PathLike[str]) -> Format:
    """Tell a TUM trajectory, a KITTI pose file, an EuRoC ground-truth CSV, an EuRoC IMU CSV and a ROS bag apart.

    A bag source ``BAG:/topic`` (:func:`dualpose.io.rosbag.parse_bag_source`) is ``"rosbag"`` without opening it.

    A header comment decides (``q_RS_w``/``p_RS_R`` -> EuRoC ground truth, ``w_RS_S`` and ``a_RS_S`` -> EuRoC IMU,
    the fields ``tx ty tz qx qy qz qw`` -> TUM);
    otherwise the first data line does (a trailing ``# comment`` removed): comma-separated with an integer first
    field and 7 fields -> EuRoC IMU, 8 or 17 fields -> EuRoC ground truth; 8 fields separated by whitespace, or by
    commas with a non-integer first field -> TUM; 12 whitespace-separated fields -> KITTI.

    Raises
    ------
    TypeError
        ``path`` is not a str or path-like.
    FileNotFoundError
    ValueError
        ``path:line: ...`` when the first data line fits none of the formats (the message lists them), or the
        file has no data.
    """
    if is_bag_source(path):
        return "rosbag"
    p = check_path(path)
    with open_input(p) as raw, io.TextIOWrapper(raw, encoding="utf-8-sig", errors="replace") as f:
        head = [f.readline(MAX_LINE_BYTES) for _ in range(200)]
    for i, text in enumerate(head, start=1):
        line = text.strip()
        if not line:
            continue
        if line.startswith("#"):
            if "q_RS_w" in line or "p_RS_R" in line:
                return "euroc_groundtruth"
            if "w_RS_S" in line and "a_RS_S" in line:
                return "euroc_imu"
            if {"tx", "ty", "tz", "qx", "qy", "qz", "qw"} <= set(line.lstrip("#").replace(",", " ").split()):
                return "tum"  # the header write_tum (and evo) write
            continue
        data = line.split("#", 1)[0].strip()
        if "," in data:
            fields = [x.strip() for x in data.split(",")]
            if fields[0].lstrip("-").isdigit():
                if len(fields) == 7:
                    return "euroc_imu"
                if len(fields) in (8, 17):
                    return "euroc_groundtruth"
            elif len(fields) == 8:
                return "tum"
        elif len(data.split()) == 8:
            return "tum"
        elif len(data.split()) == 12:
            return "kitti"
        raise ValueError(f"{p}:{i}: cannot tell the file format from {line[:80]!r}; known formats: {_FORMATS}")
    raise ValueError(f"{p}: no data lines found; known formats: {_FORMATS}")


def read_trajectory(
    path: str | os.PathLike[str],
    fmt: Format | None = None,
    times: str | os.PathLike[str] | None = None,
    *,
    bag_time: Literal["header", "receive"] = "header",
) -> Trajectory:
    """Read a trajectory from a TUM, KITTI or EuRoC ground-truth file or a ROS bag topic, detecting the format unless
    ``fmt`` is given.

    A bag source ``BAG:/topic`` or ``BAG:/tf:PARENT:CHILD`` is read by :func:`dualpose.io.rosbag.read_bag_trajectory`
    with ``stamps=bag_time`` (the messages' header stamps, or the bag's receive times).

    ``times``: the stamps file of a KITTI pose file (one number of seconds per line); without it KITTI poses get
    their index as the stamp in seconds.  Given for another format it raises ``ValueError`` (those files carry
    their stamps).  Returns a :class:`~dualpose.io.Trajectory` (quaternions xyzw).  An EuRoC IMU file raises
    ``ValueError``.
    """
    fmt = detect_format(path) if fmt is None else fmt
    if times is not None and fmt != "kitti":
        raise ValueError(f"{path}: a times file is only used with KITTI pose files; this is {fmt}")
    if fmt == "rosbag":
        return read_bag_trajectory(path, stamps=bag_time)
    check_path(path)
    if fmt == "tum":
        return read_tum(path)
    if fmt == "kitti":
        return read_kitti(path, times)
    if fmt == "euroc_groundtruth":
        return read_euroc_groundtruth(path)
    if fmt == "euroc_imu":
        raise ValueError(f"{path}: is an EuRoC IMU file (angular rate and acceleration), not a trajectory")
    raise ValueError(f"fmt must be 'tum', 'kitti', 'euroc_groundtruth', 'rosbag' or None; got {fmt!r}")
