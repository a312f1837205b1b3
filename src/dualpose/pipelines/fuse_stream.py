"""Camera–IMU fusion on a stream of text lines: IMU and camera-correspondence lines in, one pose per IMU line out.

The job behind ``dualpose fuse --stream --calibration FILE`` (docs/fusion.md, "Streaming"; the line formats are
defined there and in :data:`INPUT_FIELDS` / :func:`format_pose`).  :func:`stream_fusion_lines` parses each line,
feeds it to a streaming filter (:class:`~dualpose.estimation.eskf.EskfStream` or
:class:`~dualpose.estimation.hol22.Hol22Stream`, built by :func:`stream_filter` from the calibration file)
and yields one output line per IMU line as soon as it is known:

* ``imu, t, gx, gy, gz, ax, ay, az`` -- an IMU sample (s on the IMU clock, rad/s, m/s², body frame);
* ``cam, t, n, u1, v1, X1, Y1, Z1, ..., un, vn, Xn, Yn, Zn`` -- a camera frame stamped ``t`` (s, camera clock, as in
  ``correspondences.csv``) with ``n`` 2-D–3-D correspondences: undistorted pixel (u right, v down) and landmark in
  the world frame (m).  A frame is filtered at the first IMU line stamped at or after it (before that sample);
* fields separated by commas or whitespace, ``#`` starts a comment, blank and comment lines are skipped;
* output ``t, px, py, pz, qx, qy, qz, qw``: the body (IMU) position in the world frame (m) and ``q_wb`` (xyzw, body →
  world) after the IMU sample at ``t``, every number as Python's ``repr`` (reads back to the same float64).

Errors (a malformed line, a time out of order) are ``ValueError`` s naming the source and line, raised after every
output line of the earlier input lines was yielded.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterable, Iterator
from typing import Any

import numpy as np

from dualpose.algebra.quat import quat_rotate
from dualpose.estimation.eskf import ErrorStateEKF, EskfStream, FrameUpdate, initial_covariance
from dualpose.estimation.hol22 import Hol22EKF, Hol22Stream
from dualpose.io.recording import read_sensor_setup
from dualpose.pipelines._lines import StreamTimes, format_numbers, parse_numbers, split_fields
from dualpose.sim import SimulatedRun
from dualpose.types import Recording, SensorSetup
from dualpose.types._inputs import Doubt, gravity_up_problem
from dualpose.types.recording import RecordingWarning

__all__ = [
    "INPUT_FIELDS",
    "FrameUse",
    "OUTPUT_FIELDS",
    "filter_for_setup",
    "format_pose",
    "parse_fusion_line",
    "recording_lines",
    "stream_filter",
    "stream_fusion_lines",
]

#: the fields of the input lines after their tag; a camera line repeats the last five ``n`` times (1, 2, ...)
INPUT_FIELDS: dict[str, tuple[str, ...]] = {
    "imu": ("t", "gx", "gy", "gz", "ax", "ay", "az"),
    "cam": ("t", "n", "u", "v", "X", "Y", "Z"),
}

#: the fields of an output line
OUTPUT_FIELDS: tuple[str, ...] = ("t", "px", "py", "pz", "qx", "qy", "qz", "qw")


def parse_fusion_line(line: str) -> tuple[str, float, Any, Any] | None:
    """The content of one input line, or None for a blank or comment line.

    Returns
    -------
    ("imu", t, gyro, accel) with gyro, accel lists of 3 floats, or ("cam", t, pixels (n, 2), points (n, 3)) arrays;
    or None.

    Raises
    ------
    ValueError
        An unknown tag, a wrong number of fields, a field that is not a (finite) number, a count ``n`` that is not a
        whole number >= 0 (the message names the field; the caller adds the line).
    """
    fields = split_fields(line, "auto")
    if fields is None:
        return None
    tag, rest = fields[0].lower(), fields[1:]
    if tag == "imu":
        names = INPUT_FIELDS["imu"]
        if len(rest) != len(names):
            raise ValueError(f"an imu line has {len(names) + 1} fields (imu, {', '.join(names)}); got {len(fields)}")
        v = parse_numbers(rest, names, first=2)
        return "imu", v[0], v[1:4], v[4:7]
    if tag != "cam":
        raise ValueError(f"field 1: expected 'imu' or 'cam'; got {fields[0]!r}")
    if len(rest) < 2:
        raise ValueError(f"a cam line starts with cam, t, n (then n times u, v, X, Y, Z); got {len(fields)} fields")
    t, n = parse_numbers(rest[:2], ("t", "n"), first=2)
    if n != int(n) or n < 0:
        raise ValueError(f"field 3 (n): the number of correspondences must be a whole number >= 0; got {rest[1]!r}")
    n = int(n)
    if len(rest) != 2 + 5 * n:
        raise ValueError(f"a cam line with n = {n} has {3 + 5 * n} fields (cam, t, n, then n times u, v, X, Y, Z); "
                         f"got {len(fields)}")  # fmt: skip
    uvxyz = np.array(parse_numbers(rest[2:], _point_field, first=4)).reshape(n, 5)
    return "cam", t, uvxyz[:, :2], uvxyz[:, 2:]


def _point_field(k: int) -> str:
    """Name of the k-th field after ``n`` on a cam line: u1, v1, X1, Y1, Z1, u2, ..."""
    return f"{INPUT_FIELDS['cam'][2 + k % 5]}{k // 5 + 1}"


def format_pose(t: float, position: np.ndarray, quat: np.ndarray) -> str:
    """One output line ``t, px, py, pz, qx, qy, qz, qw`` with its newline; each number the ``repr`` of the float64."""
    return format_numbers([t, *position.tolist(), *quat.tolist()])


def filter_for_setup(setup: SensorSetup | str | os.PathLike[str], filter: str = "eskf") -> ErrorStateEKF | Hol22EKF:
    """The filter of a calibration: an :class:`~dualpose.estimation.eskf.ErrorStateEKF` at the set-up's start
    (diagonal covariance of :func:`~dualpose.estimation.eskf.initial_covariance` with the start's sigmas), or Hol's
    filter started from it (:meth:`Hol22EKF.from_eskf_state <dualpose.estimation.hol22.Hol22EKF.from_eskf_state>`,
    as ``dualpose fuse --filter hol22`` starts).

    Parameters
    ----------
    setup : SensorSetup or path
        The set-up, or a sensor file read by :func:`dualpose.io.recording.read_sensor_setup`.
    filter : {"eskf", "hol22"}
    """
    if not isinstance(setup, SensorSetup):
        setup = read_sensor_setup(setup)
    if filter not in ("eskf", "hol22"):
        raise ValueError(f"filter must be 'eskf' or 'hol22'; got {filter!r}")
    s = setup.start
    P = initial_covariance(s.position_sigma, s.velocity_sigma, s.attitude_sigma, setup.imu_noise)
    eskf = ErrorStateEKF(s.position, s.velocity, s.quat, P, gyro_bias=s.gyro_bias, accel_bias=s.accel_bias,
                         **setup.sensor_options())  # fmt: skip
    return eskf if filter == "eskf" else Hol22EKF.from_eskf_state(eskf.x, eskf.P, setup)


def stream_filter(setup: SensorSetup | str | os.PathLike[str], filter: str = "eskf") -> EskfStream | Hol22Stream:
    """The streaming filter (:class:`~dualpose.estimation.eskf.EskfStream` or
    :class:`~dualpose.estimation.hol22.Hol22Stream`) of :func:`filter_for_setup`."""
    f = filter_for_setup(setup, filter)
    return EskfStream(f) if isinstance(f, ErrorStateEKF) else Hol22Stream(f)


def recording_lines(recording: Recording | SimulatedRun) -> list[str]:
    """A recording (or simulated run) as input lines of :func:`stream_fusion_lines`, in time order (on the IMU clock,
    a frame before the IMU sample at its time), every number as its exact ``repr``.

    Parameters
    ----------
    recording : Recording or SimulatedRun
        ``t`` (N,), ``gyro``, ``accel`` (N, 3), ``frames`` (camera clock), ``time_offset``.

    Returns
    -------
    list of str
        N ``imu`` lines and one ``cam`` line per frame, each with its newline.
    """
    f = recording.frames
    imu = np.column_stack([recording.t, recording.gyro, recording.accel]).tolist()
    lines = [(row[0], 1, "imu, " + format_numbers(row)) for row in imu]
    for j in range(len(f.t)):
        pix, pts = f.frame(j)
        tail = ", " + format_numbers(np.hstack([pix, pts]).ravel()) if len(pix) else "\n"
        text = f"cam, {float(f.t[j])!r}, {len(pix)}{tail}"
        lines.append((float(f.t[j] + recording.time_offset), 0, text))
    lines.sort(key=lambda item: item[:2])
    return [text for _, _, text in lines]


def _pose_slices(stream: EskfStream | Hol22Stream) -> tuple[slice, slice, bool]:
    """Where a state of ``stream`` holds the position and the quaternion, and whether that is Hol's q^{be}."""
    L = stream.state_layout
    hol = "quat_be" in L.names
    return L.slice("position"), L.slice("quat_be" if hol else "quat"), hol


def stream_fusion_lines(
    lines: Iterable[str], stream: EskfStream | Hol22Stream, source: str = "stdin", rate: float | None = None,
    gravity: Any = None,
) -> Iterator[str]:
    """Filter the IMU and camera lines of ``lines`` and yield one output line per IMU line, as soon as it is known.

    Parameters
    ----------
    lines : iterable of str
        Input lines (module docstring); read one at a time, so a pipe or ``sys.stdin`` is consumed as it comes.
    stream : EskfStream or Hol22Stream
        The filter (e.g. :func:`stream_filter`), before its first sample or continuing.
    source : str
        Name of the input in error messages.
    rate : float, optional
        The IMU rate of the set-up (Hz, ``imu.update_rate``): gaps longer than five sample periods and stamps whose
        spacing contradicts it are warned about (default: gaps against the median spacing of the first stamps).
    gravity : array_like, shape (3,), optional
        The set-up's world gravity (m/s²): the first IMU sample of a stream that has not started is refused when its
        specific force, rotated to the world with the start attitude, is more than 90° from ``-gravity`` (the batch
        path's check: gravity pointing up).

    Yields
    ------
    str
        ``t, px, py, pz, qx, qy, qz, qw`` plus a newline (:func:`format_pose`): the pose of the state
        :meth:`update_imu <dualpose.estimation.eskf.EskfStream.update_imu>` returned, bit for bit.

    Raises
    ------
    ValueError
        ``"{source} line N: ..."`` for a malformed line, a sample beyond the plausible IMU range, an input out of time
        order, or a state the filter cannot continue from; everything before the bad line has been yielded by then.

    Warns
    -----
    RecordingWarning
        Naming the line: an IMU gap, stamps that contradict ``rate``; at the end, camera frames that were never used
        or whose correspondences the gate mostly rejected (docs/refusals.md).
    """
    ps, qs, hol = _pose_slices(stream)
    times = StreamTimes(None if rate is None else 1.0 / rate, source, "imu.update_rate", stream.gap_watch)
    frames = FrameUse(source)
    for lineno, line in enumerate(lines, start=1):
        try:
            item = parse_fusion_line(line)
            if item is None:
                continue
            kind, t, a, b = item
            if kind == "cam":
                frames.add(stream.update_camera(t, a, b))
                continue
            times.check(t, lineno)
            if gravity is not None and stream.samples == 0:
                _check_gravity(stream, np.asarray(gravity, dtype=np.float64), b)
            x = stream.update_imu(t, a, b)
            if not np.isfinite(x).all():  # never a NaN line: the filter cannot go on from here
                raise ValueError("the filter's state is not finite; it cannot continue from this sample")
            x = x.tolist()
        except ValueError as exc:
            raise ValueError(f"{source} line {lineno}: {exc}") from None
        q = x[qs]
        yield format_numbers([t, *x[ps], *((-q[0], -q[1], -q[2], q[3]) if hol else q)])  # q_wb = conj(q^{be})
    frames.finish()


def _check_gravity(stream: EskfStream | Hol22Stream, gravity: np.ndarray, accel: Any) -> None:
    """Refuse a ``gravity`` that points up against the first sample's specific force ``accel`` (body frame) rotated
    to the world with the stream's start attitude (:func:`dualpose.types._inputs.gravity_up_problem`)."""
    _, qs, hol = _pose_slices(stream)
    q = stream.state[qs]
    q_wb = np.array([-q[0], -q[1], -q[2], q[3]]) if hol else q
    f_w = quat_rotate(q_wb, np.asarray(accel, dtype=np.float64))
    problem = gravity_up_problem(f_w, gravity, "the set-up")
    if problem:
        raise ValueError(problem)


class FrameUse:
    """Counts what became of a stream's camera frames, and warns at the end when the camera was effectively unused:
    most frames skipped or never filtered (their times, on the IMU clock, outside the IMU samples: a wrong clock
    offset), or most correspondences rejected by the gate (wrong intrinsics or extrinsic).

    ``add`` a frame as the filter takes it (its status is looked at later), or count it yourself: ``given += 1``
    when it is handed to a filter and ``settled`` once its status is no longer ``"pending"``."""

    def __init__(self, source: str) -> None:
        self.source = source
        self.open: list[FrameUpdate] = []
        self.given = self.used = self.points = self.accepted = 0

    def add(self, frame: FrameUpdate) -> None:
        self.given += 1
        self.open.append(frame)
        if len(self.open) > 64:
            self._settle()

    def settled(self, frame: FrameUpdate) -> None:
        """Count a frame whose status is no longer ``"pending"``."""
        if frame.status == "done":
            self.used += 1
            self.points += len(frame.accepted_flags)
            self.accepted += int(frame.accepted_flags.sum())

    def _settle(self) -> None:
        keep = []
        for f in self.open:
            if f.status == "pending":
                keep.append(f)
            else:
                self.settled(f)
        self.open = keep

    def finish(self) -> Doubt | None:
        """At the end of the input: the doubt about the camera (also warned), or None."""
        self._settle()
        if not self.given:
            return None
        unused = self.given - self.used
        if unused > self.given // 2:
            d = Doubt("camera_unused", f"{self.source}: {unused} of the {self.given} camera frames were never used "
                      "(stamped, on the IMU clock, outside the IMU samples): check the camera time offset "
                      "(timeshift_cam_imu) and the stamps' clock")  # fmt: skip
        elif self.points >= 20 and self.accepted < 0.5 * self.points:
            d = Doubt("camera_rejected", f"{self.source}: the χ² gate rejected {self.points - self.accepted} of "
                      f"{self.points} correspondences: check the camera intrinsics, the extrinsic q_bc / p_bc and "
                      "pixel_sigma")  # fmt: skip
        else:
            return None
        warnings.warn(d.message, RecordingWarning, stacklevel=3)
        return d
