"""Camera-IMU recordings on disk: the input format of ``dualpose fuse --data PATH`` (reader and writer).

A recording is a directory (or the sensor file inside it, whose ``files`` entry may point elsewhere)::

    sensors.json          camera intrinsics, body->camera extrinsic, pixel sigma, IMU noise (Kalibr names),
                          gravity, camera time offset, optional rest period; names the other files
    imu.csv               EuRoC IMU CSV (int ns, rad/s, m/s^2) -- or a whitespace text file "t wx wy wz ax ay az" (s)
    correspondences.csv   one 2-D-3-D correspondence per row: timestamp [ns], u [px], v [px], X [m], Y [m], Z [m];
                          consecutive rows with the same timestamp form one frame (camera clock)
    groundtruth.csv       optional: EuRoC ground-truth CSV or a TUM trajectory (for evaluation)

The full specification, with an example sensor file, is in ``docs/fusion.md`` ("Recording format for
``dualpose fuse --data``").  Every problem is reported as a :class:`RecordingError` (a ValueError) naming the file
and, where there is one, the line.  Quaternions are xyzw (scalar last) in the sensor file, like everywhere in
dualpose; EuRoC ground truth stores wxyz and is converted by its reader.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dualpose.io._output import files_in_place
from dualpose.io._text import (
    Table,
    check_path,
    open_for_writing,
    open_input,
    parse_float_columns,
    parse_int_column,
    parse_number,
    read_table,
)
from dualpose.io.detect import read_trajectory
from dualpose.io.euroc import ImuData, read_euroc_imu, write_euroc_groundtruth, write_euroc_imu
from dualpose.io.rosbag import Stamps, is_bag_source, read_bag_imu
from dualpose.types import (
    CameraIntrinsics,
    FilterStart,
    FrameCorrespondences,
    ImuNoise,
    Recording,
    SensorSetup,
    Trajectory,
)
from dualpose.types.imu import STANDARD_GRAVITY
from dualpose.types.trajectory import seconds_from_ns

__all__ = [
    "RecordingError",
    "SENSORS_FILE",
    "read_recording",
    "write_recording",
    "read_imu",
    "read_correspondences",
    "read_sensor_setup",
    "write_sensor_setup",
]

#: name of the sensor file looked up in a recording directory (``sensors.yaml``/``.yml`` also, with PyYAML)
SENSORS_FILE = "sensors.json"
FORMAT_NAME = "dualpose-recording"
FORMAT_VERSION = 1

_DEFAULT_FILES = {"imu": "imu.csv", "correspondences": "correspondences.csv"}
_CORR_LAYOUT = "timestamp [ns], u [px], v [px], X [m], Y [m], Z [m]"
_CORR_HEADER = "#timestamp [ns],u [px],v [px],X [m],Y [m],Z [m]"
_IMU_TEXT_LAYOUT = "t [s] wx wy wz [rad/s] ax ay az [m/s^2]"

# sensor-file schema: key -> (required, kind, help); kinds: num, pos (> 0), nonneg, int (> 0), vec3, quat, str
_CAMERA_KEYS = {
    "fx": (True, "pos", "focal length x, px"),
    "fy": (True, "pos", "focal length y, px"),
    "cx": (True, "num", "principal point x, px"),
    "cy": (True, "num", "principal point y, px"),
    "width": (True, "int", "image width, px"),
    "height": (True, "int", "image height, px"),
    "pixel_sigma": (True, "pos", "pixel noise standard deviation, px"),
    "q_bc": (True, "quat", "camera axes in the body frame, xyzw"),
    "p_bc": (True, "vec3", "camera centre in the body frame, m"),
    "timeshift_cam_imu": (False, "num", "t_imu = t_cam + timeshift_cam_imu, s (default 0)"),
}
_IMU_KEYS = {
    "gyroscope_noise_density": (True, "pos", "rad/s/sqrt(Hz)"),
    "gyroscope_random_walk": (True, "nonneg", "rad/s^2/sqrt(Hz)"),
    "accelerometer_noise_density": (True, "pos", "m/s^2/sqrt(Hz)"),
    "accelerometer_random_walk": (True, "nonneg", "m/s^3/sqrt(Hz)"),
    "gyroscope_initial_bias_sigma": (False, "nonneg", "rad/s (default 0.5 deg/s)"),
    "accelerometer_initial_bias_sigma": (False, "nonneg", "m/s^2 (default 0.05)"),
    "update_rate": (False, "pos", "Hz (default: from the IMU stamps)"),
}
_FILES_KEYS = {
    "imu": (False, "str", "IMU file (default imu.csv), or a sensor_msgs/Imu topic of a ROS bag: BAG:/topic"),
    "correspondences": (False, "str", "correspondence file (default correspondences.csv)"),
    "groundtruth": (False, "str", "ground truth, EuRoC CSV or TUM, or a bag topic BAG:/topic (optional)"),
    "bag_time": (False, "str", "stamps of bag topics: 'header' (default) or 'receive' (the bag's times)"),
}
_TOP_KEYS = {
    "format": (False, "str", f"'{FORMAT_NAME}'"),
    "version": (False, "int", f"{FORMAT_VERSION}"),
    "files": (False, "dict", "file names relative to the sensor file"),
    "camera": (True, "dict", "intrinsics, extrinsic, pixel sigma"),
    "imu": (True, "dict", "noise densities (Kalibr imu.yaml names)"),
    "gravity": (False, "vec3", "world gravity, m/s^2 (default [0, 0, -9.81])"),
    "rest_duration_s": (False, "pos", "leading rest period, s (default: detected)"),
    "initial_state": (False, "dict", "filter start for dualpose fuse --stream (the batch starts from the rest)"),
}
_START_KEYS = {
    "position": (True, "vec3", "p_wb, world frame, m"),
    "quat": (True, "quat", "q_wb, body to world, xyzw"),
    "velocity": (False, "vec3", "v_w, m/s (default 0)"),
    "gyro_bias": (False, "vec3", "rad/s (default 0)"),
    "accel_bias": (False, "vec3", "m/s^2 (default 0)"),
    "position_sigma": (False, "pos", "m (default 0.01)"),
    "velocity_sigma": (False, "pos", "m/s (default 0.01)"),
    "attitude_sigma_deg": (False, "pos", "deg (default 0.5)"),
}


class RecordingError(ValueError):
    """A recording that cannot be read or used; the message names the file and, where there is one, the line."""


# ------------------------------------------------------------------------------------------------ sensor file


class _SensorFile:
    """The parsed sensor file with line lookup for error messages."""

    def __init__(self, path: Path) -> None:
        self.path = path
        try:
            self.text = path.read_text(encoding="utf-8-sig")
        except OSError as exc:
            raise RecordingError(f"{path}: cannot read ({exc.strerror or exc})") from None
        except UnicodeDecodeError as exc:
            raise RecordingError(f"{path}: not a UTF-8 text file ({exc})") from None
        self.yaml = path.suffix.lower() in (".yaml", ".yml")
        if self.yaml:
            try:
                import yaml
            except ImportError:
                raise RecordingError(f"{path}: reading a YAML sensor file needs PyYAML; or write it as JSON") from None
            try:
                self.data = yaml.safe_load(self.text)
            except yaml.YAMLError as exc:
                mark = getattr(exc, "problem_mark", None)
                where = f":{mark.line + 1}" if mark is not None else ""
                raise RecordingError(f"{path}{where}: YAML syntax error: {getattr(exc, 'problem', exc)}") from None
        else:
            try:
                self.data = json.loads(self.text)
            except json.JSONDecodeError as exc:
                msg = f"{path}:{exc.lineno}: JSON syntax error: {exc.msg} (column {exc.colno})"
                raise RecordingError(msg) from None
        if not isinstance(self.data, dict):
            raise RecordingError(f"{path}: the sensor file must hold an object (mapping) at the top level")

    def line(self, dotted: str) -> int | None:
        """1-based line where the (last part of the) dotted key is written, searching after its parent's line."""
        lines = self.text.splitlines()
        start = 0
        for part in dotted.split("."):
            pat = re.compile(rf'(^|[\s{{,])"?{re.escape(part)}"?\s*:')
            for i in range(start, len(lines)):
                if pat.search(lines[i]):
                    start = i
                    break
            else:
                return None
        return start + 1

    def error(self, dotted: str, message: str) -> RecordingError:
        ln = self.line(dotted)
        return RecordingError(f"{self.path}{'' if ln is None else f':{ln}'}: {dotted}: {message}")

    def section(
        self, data: dict[str, Any], prefix: str, schema: dict[str, tuple[bool, str, str]],
    ) -> dict[str, Any]:
        """Validate ``data`` against ``schema`` (unknown keys, missing keys, kinds); returns converted values."""
        out: dict[str, Any] = {}
        for key in data:
            if key not in schema:
                raise self.error(f"{prefix}{key}", f"unknown key (expected: {', '.join(schema)})")
        for key, (required, kind, what) in schema.items():
            name = f"{prefix}{key}"
            if key not in data or data[key] is None:
                if required:
                    where = f" in '{prefix[:-1]}'" if prefix else ""
                    raise RecordingError(f"{self.path}: {name}: missing{where} ({what})")
                continue
            out[key] = self._convert(name, data[key], kind, what)
        return out

    def _convert(self, name: str, v: Any, kind: str, what: str) -> Any:
        """``v`` (a parsed JSON value) converted to ``kind``: a dict, str, float64 array (3,) or unit quaternion
        (4,), int or float."""

        def is_num(x: object) -> bool:
            return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)

        if kind == "dict":
            if not isinstance(v, dict):
                raise self.error(name, f"must be an object ({what}); got {v!r}")
            return v
        if kind == "str":
            if not isinstance(v, (str, int)):
                raise self.error(name, f"must be a string ({what}); got {v!r}")
            return str(v)
        if kind in ("vec3", "quat"):
            n = 3 if kind == "vec3" else 4
            if not (isinstance(v, list) and len(v) == n and all(is_num(x) for x in v)):
                raise self.error(name, f"must be a list of {n} finite numbers ({what}); got {v!r}")
            a = np.asarray(v, dtype=np.float64)
            if kind == "quat":
                nq = float(np.linalg.norm(a))
                if abs(nq - 1.0) > 1e-6:
                    raise self.error(name, f"must be a unit quaternion xyzw (norm {nq:.9g})")
                if abs(nq - 1.0) > 1e-12:  # keep a quaternion written with 17 digits bit-exact
                    a = a / nq
            return a
        if kind == "int":
            if isinstance(v, bool) or not isinstance(v, int) or v <= 0:
                raise self.error(name, f"must be a positive whole number ({what}); got {v!r}")
            return v
        if not is_num(v):
            raise self.error(name, f"must be a finite number ({what}); got {v!r}")
        if kind == "pos" and not v > 0:
            raise self.error(name, f"must be > 0 ({what}); got {v!r}")
        if kind == "nonneg" and not v >= 0:
            raise self.error(name, f"must be >= 0 ({what}); got {v!r}")
        return float(v)


def _sensor_path(name: str | os.PathLike[str]) -> Path:
    path = Path(name)
    if path.is_dir():
        for name in (SENSORS_FILE, "sensors.yaml", "sensors.yml"):
            if (path / name).is_file():
                return path / name
        raise RecordingError(f"{path}: a recording directory needs a {SENSORS_FILE} (see docs/fusion.md)")
    if path.is_file():
        return path
    raise RecordingError(
        f"{os.fspath(name)}: no such file or directory (expected a recording directory or its {SENSORS_FILE})"
    )


# ------------------------------------------------------------------------------------------------ data files


def _row_line(path: str | os.PathLike[str], k: int) -> int:
    """1-based line number of the k-th data row (not blank, not a ``#`` comment) of a text file."""
    with open_input(path) as raw, io.TextIOWrapper(raw, encoding="utf-8-sig") as f:
        j = -1
        for i, line in enumerate(f, start=1):
            s = line.strip()
            if s and not s.startswith("#"):
                j += 1
                if j == k:
                    return i
    return 0  # pragma: no cover - k is always a valid row index


def _check_increasing(path: str | os.PathLike[str], ns: np.ndarray, strict: bool, what: str) -> None:
    d = np.diff(ns)
    bad = (d <= 0) if strict else (d < 0)
    if bad.any():
        k = int(np.argmax(bad)) + 1
        order = "strictly increasing" if strict else "non-decreasing"
        raise RecordingError(
            f"{path}:{_row_line(path, k)}: {what} timestamps must be {order}; {ns[k]} follows {ns[k - 1]}"
        )


def _ns_from_decimal_seconds(table: Table, column: int) -> NDArray[np.int64]:
    """Exact int64 nanoseconds from decimal-second strings (``"1403636579.763555584"``); exponent notation is
    converted through float64."""
    out = np.empty(len(table.rows), np.int64)
    for k, row in enumerate(table.rows):
        cell = row[column]
        m = re.fullmatch(r"([+-]?)(\d*)(?:\.(\d*))?", cell)
        try:
            if m is not None and (m.group(2) or m.group(3)):
                frac = (m.group(3) or "")[:9].ljust(9, "0")
                v = int(m.group(2) or "0") * 1_000_000_000 + int(frac)
                out[k] = -v if m.group(1) == "-" else v
            else:
                x = parse_number(cell)
                if not math.isfinite(x):
                    raise ValueError
                out[k] = round(x * 1e9)
        except (ValueError, OverflowError):
            raise table.error(k, f"timestamp [s]: {cell!r} is not a finite number") from None
    return out


def read_imu(path: str | os.PathLike[str], *, bag_time: Stamps = "header") -> ImuData:
    """Read an IMU file: an EuRoC CSV (comma-separated, integer ns stamps) or a whitespace-separated text file
    ``t wx wy wz ax ay az`` with ``t`` in seconds (the TUM style), or the ``sensor_msgs/Imu`` topic of a ROS bag
    ``BAG:/topic`` (:func:`dualpose.io.rosbag.read_bag_imu` with ``stamps=bag_time``, ``"header"`` or
    ``"receive"``).  Stamps must be strictly increasing.

    Raises
    ------
    RecordingError
        ``path:line: ...`` for a malformed row or a stamp out of order.
    """
    p = str(path)
    if is_bag_source(path):
        try:
            return read_bag_imu(path, stamps=bag_time)
        except FileNotFoundError as exc:
            raise RecordingError(f"{p}: IMU bag not found ({exc})") from None
        except (ValueError, ImportError) as exc:
            raise RecordingError(str(exc)) from None
    try:
        with open_input(p) as raw, io.TextIOWrapper(raw, encoding="utf-8-sig") as f:
            first = next((s.strip() for s in f if s.strip() and not s.strip().startswith("#")), "")
        if "," in first:
            imu = read_euroc_imu(p)
        else:
            table = read_table(p, None, (7, 7), _IMU_TEXT_LAYOUT)
            ns = _ns_from_decimal_seconds(table, 0)
            data = parse_float_columns(table, slice(1, 7), _IMU_TEXT_LAYOUT)
            imu = ImuData(ns, seconds_from_ns(ns), data[:, 0:3], data[:, 3:6], p)
    except FileNotFoundError:
        raise RecordingError(f"{p}: IMU file not found") from None
    except RecordingError:
        raise
    except (ValueError, OSError) as exc:
        raise RecordingError(str(exc)) from None
    if len(imu) < 2:
        raise RecordingError(f"{p}: at least two IMU samples are needed; found {len(imu)}")
    _check_increasing(p, imu.stamps_ns, True, "IMU")
    return imu


def read_correspondences(
    path: str | os.PathLike[str],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Read a correspondence CSV: ``timestamp [ns], u [px], v [px], X [m], Y [m], Z [m]`` per row.

    A first line whose first field is not an integer is taken as a header; ``#`` lines are comments.  Rows with
    the same timestamp form one frame and must be consecutive (timestamps non-decreasing).

    Returns
    -------
    frame_ns : ndarray of int64, shape (F,)
        Frame stamps, camera clock, ns.
    offsets : ndarray of int64, shape (F + 1,)
        Frame k owns rows ``offsets[k]:offsets[k+1]``.
    pixels : ndarray, shape (M, 2)
    points : ndarray, shape (M, 3)
        World-frame landmark positions, m.

    Raises
    ------
    RecordingError
        ``path:line: ...`` for a row without 6 fields, a non-integer stamp, a non-finite value or a stamp out of
        order.
    """
    p = str(path)
    try:
        table = read_table(p, ",", (6, 6), _CORR_LAYOUT)
        if table.rows and not table.rows[0][0].lstrip("+-").isdigit():
            table.rows.pop(0)
            table.linenos.pop(0)
            if not table.rows:
                raise RecordingError(f"{p}: no data rows (expected {_CORR_LAYOUT})")
        ns = parse_int_column(table, 0, "timestamp [ns]")
        data = parse_float_columns(table, slice(1, 6), _CORR_LAYOUT)
    except FileNotFoundError:
        raise RecordingError(f"{p}: correspondence file not found") from None
    except RecordingError:
        raise
    except (ValueError, OSError) as exc:
        raise RecordingError(str(exc)) from None
    d = np.diff(ns)
    if np.any(d < 0):
        k = int(np.argmax(d < 0)) + 1
        raise RecordingError(
            f"{p}:{table.linenos[k]}: correspondence timestamps must be non-decreasing (rows of a frame together); "
            f"{ns[k]} follows {ns[k - 1]}"
        )
    starts = np.concatenate([[0], np.flatnonzero(d) + 1])
    offsets = np.concatenate([starts, [len(ns)]]).astype(np.int64)
    return ns[starts], offsets, data[:, 0:2].copy(), data[:, 2:5].copy()


def _setup_sections(sf: _SensorFile) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    """The checked top level, ``camera`` and ``imu`` sections of a sensor file."""
    top = sf.section(sf.data, "", _TOP_KEYS)
    if top.get("format", FORMAT_NAME) != FORMAT_NAME:
        raise sf.error("format", f"expected '{FORMAT_NAME}'; got {top['format']!r}")
    if top.get("version", FORMAT_VERSION) != FORMAT_VERSION:
        raise sf.error("version", f"this dualpose reads version {FORMAT_VERSION}; got {top['version']!r}")
    return top, sf.section(top["camera"], "camera.", _CAMERA_KEYS), sf.section(top["imu"], "imu.", _IMU_KEYS)


def _imu_noise(imu_cfg: dict[str, Any], rate: float) -> ImuNoise:
    default_noise = ImuNoise()
    return ImuNoise(
        gyroscope_noise_density=imu_cfg["gyroscope_noise_density"],
        gyroscope_random_walk=imu_cfg["gyroscope_random_walk"],
        accelerometer_noise_density=imu_cfg["accelerometer_noise_density"],
        accelerometer_random_walk=imu_cfg["accelerometer_random_walk"],
        gyroscope_initial_bias_sigma=imu_cfg.get(
            "gyroscope_initial_bias_sigma", default_noise.gyroscope_initial_bias_sigma
        ),
        accelerometer_initial_bias_sigma=imu_cfg.get(
            "accelerometer_initial_bias_sigma", default_noise.accelerometer_initial_bias_sigma
        ),
        update_rate=rate,
    )


#: the sensor file's key for each field of the types layer's messages (the user wrote the file, not the dataclass)
_FILE_KEYS = {
    "imu_noise.update_rate": "imu.update_rate", "imu_noise.": "imu.", "q_bc": "camera.q_bc", "p_bc": "camera.p_bc",
    "pixel_sigma": "camera.pixel_sigma", "time_offset": "camera.timeshift_cam_imu", "rest_seconds": "rest_duration_s",
}  # fmt: skip
_FIELD = re.compile(r"(?<![\w.])(?:" + "|".join(re.escape(k) + ("" if k.endswith(".") else r"(?!\w)")
                                                 for k in _FILE_KEYS) + ")")  # fmt: skip


def _in_file_keys(message: str) -> str:
    """``message`` of a types-layer check with each dataclass field named by its key in the sensor file
    (``imu_noise.update_rate`` -> ``imu.update_rate``, ``time_offset`` -> ``camera.timeshift_cam_imu``)."""
    return _FIELD.sub(lambda m: _FILE_KEYS[m.group(0)], message)


def _sensor_fields(top: dict[str, Any], cam: dict[str, Any]) -> dict[str, Any]:
    """The fields :class:`~dualpose.types.recording.Recording` and :class:`~dualpose.types.recording.SensorSetup`
    share, from the checked top level and ``camera`` section: camera, extrinsic, pixel sigma, time offset, gravity."""
    return {
        "camera": CameraIntrinsics(cam["fx"], cam["fy"], cam["cx"], cam["cy"], cam["width"], cam["height"]),
        "q_bc": cam["q_bc"], "p_bc": cam["p_bc"], "pixel_sigma": cam["pixel_sigma"],
        "time_offset": cam.get("timeshift_cam_imu", 0.0),
        "gravity": top.get("gravity", np.array([0.0, 0.0, -STANDARD_GRAVITY])),
    }  # fmt: skip


def read_sensor_setup(path: str | os.PathLike[str]) -> SensorSetup:
    """Read the sensor set-up and the filter start of a sensor file (``dualpose fuse --stream --calibration``).

    The file is a recording's sensor file (docs/fusion.md; ``camera``, ``imu``, ``gravity`` as there, ``files`` and
    ``rest_duration_s`` ignored) that also gives ``imu.update_rate`` (there are no IMU stamps to take it from) and
    an ``initial_state`` object: ``position`` (m) and ``quat`` (q_wb, xyzw) required; ``velocity``, ``gyro_bias``,
    ``accel_bias`` (default 0), ``position_sigma`` (m), ``velocity_sigma`` (m/s), ``attitude_sigma_deg``.

    Raises
    ------
    RecordingError
        Anything missing or malformed, with the file (and line).
    """
    sf = _SensorFile(_sensor_path(path))
    top, cam, imu_cfg = _setup_sections(sf)
    if "update_rate" not in imu_cfg:
        raise RecordingError(f"{sf.path}: imu.update_rate: missing (the IMU rate, Hz: a stream has no stamps yet)")
    if "initial_state" not in top:
        raise RecordingError(f"{sf.path}: initial_state: missing (where the filter starts: position, quat, ...)")
    st = sf.section(top["initial_state"], "initial_state.", _START_KEYS)
    sig = math.radians(st.pop("attitude_sigma_deg", 0.5))
    try:
        return SensorSetup(
            imu_noise=_imu_noise(imu_cfg, imu_cfg["update_rate"]), start=FilterStart(**st, attitude_sigma=sig),
            **_sensor_fields(top, cam),
        )  # fmt: skip
    except ValueError as exc:
        raise RecordingError(f"{sf.path}: {_in_file_keys(str(exc))}") from None


# ------------------------------------------------------------------------------------------------ recording


def read_recording(path: str | os.PathLike[str]) -> Recording:
    """Read a recording (directory or sensor file) into a :class:`~dualpose.types.recording.Recording`.

    Times are float seconds on the IMU clock's epoch (``seconds_from_ns`` of the files' nanoseconds); the exact
    IMU nanoseconds are kept in ``stamps_ns``.  A ground-truth file, when named, is read with
    :func:`dualpose.io.read_trajectory` (EuRoC CSV or TUM, detected).

    Raises
    ------
    RecordingError
        Anything missing or malformed, with the file (and line).
    """
    sf = _SensorFile(_sensor_path(path))
    top, cam, imu_cfg = _setup_sections(sf)
    files = {**_DEFAULT_FILES, **sf.section(top.get("files", {}), "files.", _FILES_KEYS)}
    base = sf.path.parent
    bag_time = files.get("bag_time", "header")
    if bag_time not in ("header", "receive"):
        raise sf.error("files.bag_time", f"must be 'header' or 'receive'; got {bag_time!r}")

    imu = read_imu(str(base / files["imu"]), bag_time=bag_time)
    frame_ns, offsets, pixels, points = read_correspondences(base / files["correspondences"])
    truth = None
    if "groundtruth" in files:
        gt_path = base / files["groundtruth"]
        try:
            truth = read_trajectory(str(gt_path), bag_time=bag_time)
        except FileNotFoundError:
            raise RecordingError(f"{gt_path}: ground-truth file not found (named in {sf.path})") from None
        except (ValueError, ImportError) as exc:
            raise RecordingError(str(exc)) from None

    noise = _imu_noise(imu_cfg, imu_cfg.get("update_rate", 1.0 / float(np.median(np.diff(imu.stamps)))))
    frames = FrameCorrespondences(seconds_from_ns(frame_ns), offsets, pixels, points)
    try:  # Recording checks the values (IMU ranges, noise parameters, gravity): name the file they came from
        return Recording(
            t=imu.stamps, gyro=imu.gyro, accel=imu.accel, frames=frames, imu_noise=noise, **_sensor_fields(top, cam),
            rest_seconds=top.get("rest_duration_s"), ground_truth=truth, stamps_ns=imu.stamps_ns, name=str(path),
        )  # fmt: skip
    except ValueError as exc:
        src = base / files["imu"] if str(exc).startswith(("gyro", "accel", "t ")) else sf.path
        raise RecordingError(f"{src}: {_in_file_keys(str(exc))}") from None


def _ns(seconds: np.ndarray) -> NDArray[np.int64]:
    return np.round(np.asarray(seconds, dtype=np.float64) * 1e9).astype(np.int64)


def write_recording(directory: str | os.PathLike[str], recording: Recording, *, overwrite: bool = False) -> Path:
    """Write a :class:`~dualpose.types.recording.Recording` as a recording directory that :func:`read_recording`
    (and ``dualpose fuse --data DIR``) reads back.

    Files: ``sensors.json``, ``imu.csv`` (EuRoC), ``correspondences.csv`` and, when there is ground truth,
    ``groundtruth.csv`` (EuRoC; with velocity and biases when the ground truth carries them as ``extra`` columns, as
    :func:`dualpose.sim.recording_from_simulation` makes it).  Float seconds are written as
    nanoseconds rounded to the nearest integer; all values with 17 significant digits (exact round trip).  Frames
    without correspondences are not written (nothing to update with).

    Parameters
    ----------
    directory : path-like
        Created if missing.  The files are written into a temporary sibling directory and appear together when
        all are complete: an error or Ctrl-C while writing leaves ``directory`` as it was (other files in it are
        left alone).
    overwrite : bool
        Replace existing files; by default an existing file raises ``FileExistsError`` (before anything is
        written).

    Returns
    -------
    Path
        The sensor file.
    """
    if not isinstance(recording, Recording):
        raise TypeError(
            f"recording must be a dualpose.types.Recording (dualpose.sim.recording_from_simulation converts a "
            f"simulated run); got {type(recording).__name__}"
        )
    rec = recording
    out = Path(directory)
    names = {"imu": "imu.csv", "correspondences": "correspondences.csv"}
    if rec.ground_truth is not None:
        names["groundtruth"] = "groundtruth.csv"
    # the files are written into a temporary sibling and appear together (dualpose.io._output.files_in_place)
    with files_in_place(out, [SENSORS_FILE, *names.values()], overwrite) as stage:
        stamps_ns = rec.stamps_ns if rec.stamps_ns is not None else _ns(rec.t)
        write_euroc_imu(stage / names["imu"], ImuData(stamps_ns, rec.t, rec.gyro, rec.accel))

        f = rec.frames
        counts = np.diff(f.offsets)
        row_ns = np.repeat(_ns(f.t), counts)
        values = np.hstack([f.pixels, f.points])
        lines = [
            f"{t}," + ",".join(f"{v:.17g}" for v in row)
            for t, row in zip(row_ns.tolist(), values.tolist(), strict=True)
        ]
        with open_for_writing(stage / names["correspondences"], False) as fh:
            fh.write(_CORR_HEADER + "\n")
            fh.write("".join(line + "\n" for line in lines))

        if rec.ground_truth is not None:
            gt = rec.ground_truth
            gt_ns = gt.stamps_ns if gt.stamps_ns is not None else _ns(gt.stamps)
            gt = Trajectory(gt.stamps, gt.positions, gt.quats, gt_ns, gt.name, gt.extra)
            write_euroc_groundtruth(stage / names["groundtruth"], gt)

        sensors = _setup_dict(rec, names)
        if rec.rest_seconds is not None:
            sensors["rest_duration_s"] = float(rec.rest_seconds)
        with open_for_writing(stage / SENSORS_FILE, False) as fh:
            fh.write(json.dumps(sensors, indent=2) + "\n")
    return out / SENSORS_FILE


def _setup_dict(rec: Recording | SensorSetup, files: dict[str, str] | None) -> dict[str, Any]:
    """The sensor file's ``format``, ``version``, (``files``,) ``camera``, ``imu`` and ``gravity`` of ``rec``."""
    c, n = rec.camera, rec.imu_noise
    return {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        **({} if files is None else {"files": files}),
        "camera": {
            "fx": float(c.fx), "fy": float(c.fy), "cx": float(c.cx), "cy": float(c.cy),
            "width": int(c.width), "height": int(c.height), "pixel_sigma": float(rec.pixel_sigma),
            "q_bc": [float(v) for v in rec.q_bc], "p_bc": [float(v) for v in rec.p_bc],
            "timeshift_cam_imu": float(rec.time_offset),
        },
        "imu": {key: float(getattr(n, key)) for key in _IMU_KEYS},
        "gravity": [float(v) for v in rec.gravity],
    }  # fmt: skip


def write_sensor_setup(path: str | os.PathLike[str], setup: SensorSetup, *, overwrite: bool = False) -> Path:
    """Write a :class:`~dualpose.types.recording.SensorSetup` as the sensor file :func:`read_sensor_setup` (and
    ``dualpose fuse --stream --calibration FILE``) reads back exactly (JSON, numbers as their shortest exact text).

    Raises
    ------
    FileExistsError
        When ``path`` exists and ``overwrite`` is False.
    """
    if not isinstance(setup, SensorSetup):
        raise TypeError(f"setup must be a dualpose.types.SensorSetup; got {type(setup).__name__}")
    st = setup.start
    out = _setup_dict(setup, None)  # its "imu" section has update_rate, which a stream needs
    out["initial_state"] = {
        **{k: [float(v) for v in getattr(st, k)] for k in ("position", "quat", "velocity", "gyro_bias", "accel_bias")},
        "position_sigma": float(st.position_sigma), "velocity_sigma": float(st.velocity_sigma),
        "attitude_sigma_deg": math.degrees(st.attitude_sigma),
    }  # fmt: skip
    p = Path(check_path(path))
    with open_for_writing(p, overwrite) as fh:
        fh.write(json.dumps(out, indent=2) + "\n")
    return p
