"""EuRoC MAV dataset CSV files (Burri et al. 2016): IMU samples and ground-truth states.

Both files start with a ``#`` header line and have integer nanosecond timestamps in the first column, which are
kept exactly as int64 (``stamps_ns``); float seconds are derived with
:func:`~dualpose.types.trajectory.seconds_from_ns`.

- IMU (``mav0/imu0/data.csv``): ``timestamp [ns], w_RS_S_x, w_RS_S_y, w_RS_S_z [rad/s], a_RS_S_x, a_RS_S_y,
  a_RS_S_z [m/s^2]`` -- angular rate and specific force in the sensor frame S.
- Ground truth (``mav0/state_groundtruth_estimate0/data.csv``): ``timestamp, p_RS_R xyz [m], q_RS wxyz, v_RS_R xyz
  [m/s], b_w_RS_S xyz [rad/s], b_a_RS_S xyz [m/s^2]``.  The quaternion is stored **scalar first (wxyz)**; the
  readers return dualpose's scalar-last xyzw, and the writers convert back.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from dualpose.io._text import open_for_writing, parse_float_columns, parse_int_column, read_table
from dualpose.types import _inputs
from dualpose.types.trajectory import Trajectory, seconds_from_ns

__all__ = ["ImuData", "read_euroc_imu", "write_euroc_imu", "read_euroc_groundtruth", "write_euroc_groundtruth"]

_IMU_LAYOUT = "timestamp [ns], wx wy wz [rad/s], ax ay az [m/s^2]"
_GT_LAYOUT = "timestamp [ns], px py pz [m], qw qx qy qz, optionally vx vy vz, bwx bwy bwz, bax bay baz"
_IMU_HEADER = (
    "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
    "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]"
)
_GT_HEADER = (
    "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
    "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], "
    "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]"
)
_GT_EXTRA = ("velocity", "gyro_bias", "accel_bias")


@dataclass(frozen=True)
class ImuData:
    """IMU samples.

    Attributes
    ----------
    stamps_ns : ndarray of int64, shape (N,)
        Exact timestamps, nanoseconds.
    stamps : ndarray, shape (N,)
        The same in float64 seconds (refused when they disagree with ``stamps_ns``).
    gyro : ndarray, shape (N, 3)
        Angular rate of the sensor frame, in the sensor frame, rad/s.
    accel : ndarray, shape (N, 3)
        Specific force (acceleration minus gravity) in the sensor frame, m/s^2.
    name : str
    """

    stamps_ns: np.ndarray
    stamps: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray
    name: str = ""

    def __post_init__(self) -> None:
        """``stamps`` repeat ``stamps_ns`` (:func:`~dualpose.types._inputs.check_stamps_agree`); one row per
        stamp in every array."""
        n = len(self.stamps_ns)
        for name, shape in (("stamps", (n,)), ("gyro", (n, 3)), ("accel", (n, 3))):
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"{name} must have shape {shape} (one row per stamps_ns); got "
                                 f"{np.shape(getattr(self, name))}")  # fmt: skip
        _inputs.check_stamps_agree(self.stamps, self.stamps_ns)

    def __len__(self) -> int:
        return int(self.stamps_ns.shape[0])


def read_euroc_imu(path: str | os.PathLike[str]) -> ImuData:
    """Read an EuRoC IMU CSV (7 comma-separated columns).

    Raises
    ------
    ValueError
        ``path:line: ...`` for a row without 7 fields, a non-integer timestamp or a non-finite value.
    """
    table = read_table(path, ",", (7, 7), _IMU_LAYOUT)
    ns = parse_int_column(table, 0, "timestamp [ns]")
    data = parse_float_columns(table, slice(1, 7), _IMU_LAYOUT)
    return ImuData(ns, seconds_from_ns(ns), data[:, 0:3], data[:, 3:6], table.path)


def write_euroc_imu(path: str | os.PathLike[str], imu: ImuData, *, overwrite: bool = False) -> None:
    """Write ``imu`` as an EuRoC IMU CSV (header line, exact nanosecond stamps, 17 significant digits)."""
    if not isinstance(imu, ImuData):
        raise TypeError(f"imu must be a dualpose.io.ImuData; got {type(imu).__name__}")
    _write_csv(path, _IMU_HEADER, imu.stamps_ns, np.hstack([imu.gyro, imu.accel]), overwrite)


def read_euroc_groundtruth(path: str | os.PathLike[str]) -> Trajectory:
    """Read an EuRoC ground-truth CSV (at least 8 columns; the standard file has 17).

    Returns
    -------
    Trajectory
        ``stamps_ns`` exact, ``stamps`` in seconds, ``positions`` (N, 3), ``quats`` (N, 4) converted to **xyzw**;
        with 17 columns ``extra`` holds ``velocity``, ``gyro_bias``, ``accel_bias`` (N, 3) each.

    Raises
    ------
    ValueError
        ``path:line: ...`` for a row with fewer than 8 fields or a field count other than 8 or 17 (rows must agree),
        a non-integer timestamp, a non-finite value or a zero quaternion.
    """
    table = read_table(path, ",", (8, 17), _GT_LAYOUT)
    ncols = len(table.rows[0])
    if ncols not in (8, 17):
        raise table.error(0, f"expected 8 or 17 fields ({_GT_LAYOUT}), found {ncols}")
    for k, row in enumerate(table.rows):
        if len(row) != ncols:
            raise table.error(k, f"expected {ncols} fields like the first row, found {len(row)}")
    ns = parse_int_column(table, 0, "timestamp [ns]")
    data = parse_float_columns(table, slice(1, ncols), _GT_LAYOUT)
    wxyz = data[:, 3:7]
    zero = ~(wxyz != 0.0).any(axis=1)
    if zero.any():
        raise table.error(int(np.argmax(zero)), "zero quaternion (qw qx qy qz all 0)")
    extra = {}
    if ncols == 17:
        extra = {key: data[:, 7 + 3 * i : 10 + 3 * i] for i, key in enumerate(_GT_EXTRA)}
    return Trajectory(seconds_from_ns(ns), data[:, 0:3], wxyz[:, [1, 2, 3, 0]], ns, table.path, extra)


def write_euroc_groundtruth(path: str | os.PathLike[str], trajectory: Trajectory, *, overwrite: bool = False) -> None:
    """Write ``trajectory`` as an EuRoC ground-truth CSV (quaternion written wxyz).

    Needs ``stamps_ns``.  Writes 17 columns when ``extra`` has ``velocity``, ``gyro_bias`` and ``accel_bias``,
    otherwise the first 8.
    """
    if not isinstance(trajectory, Trajectory):
        raise TypeError(f"trajectory must be a dualpose.io.Trajectory; got {type(trajectory).__name__}")
    if trajectory.stamps_ns is None:
        raise ValueError("trajectory.stamps_ns is required for EuRoC output (integer nanoseconds)")
    cols = [trajectory.positions, trajectory.quats[:, [3, 0, 1, 2]]]
    header = _GT_HEADER
    if all(k in trajectory.extra for k in _GT_EXTRA):
        cols += [np.asarray(trajectory.extra[k], dtype=np.float64).reshape(len(trajectory), 3) for k in _GT_EXTRA]
    else:
        header = ",".join(_GT_HEADER.split(",")[:8])
    _write_csv(path, header, trajectory.stamps_ns, np.hstack(cols), overwrite)


def _write_csv(
    path: str | os.PathLike[str], header: str, stamps_ns: np.ndarray, values: np.ndarray, overwrite: bool
) -> None:
    lines = [
        f"{t}," + ",".join(f"{v:.17g}" for v in row)
        for t, row in zip(np.asarray(stamps_ns, dtype=np.int64).tolist(), values.tolist(), strict=True)
    ]
    with open_for_writing(path, overwrite) as f:
        f.write(header + "\n")
        f.write("\n".join(lines))
        f.write("\n")
