"""Calibration-target recordings (a rig waved in front of a fixed target, EuRoC ``imu_april`` layout) and the
camera–IMU calibration file ``dualpose fuse --data DIR --calibration CALIB.json`` reads.

A target-recording directory holds::

    imu0.csv              EuRoC IMU CSV (int ns, rad/s, m/s², body frame)
    camN_aprilgrid.csv    per camera: detected target corners, raw (distorted) pixels and target-frame points
                          (:func:`dualpose.io.target.detections.read_target_detections`)
    sensors.yaml          camera models, IMU noise, camera-to-camera poses
                          (:func:`dualpose.io.sensors_yaml.read_rig_sensors`)

The calibration JSON (``dualpose calibrate camera-imu ... --json``) is one object with the keys of
:class:`~dualpose.types.calibration.CameraImuCalibration`: ``camera``, ``rotation_xyzw``, ``translation_m``,
``time_offset_s``, ``reprojection_rms_px`` (required), ``gyro_bias``, ``accel_bias``, ``gravity_target``, ``std``,
``gyro_axes_matrix``, ``accel_axes_matrix`` (optional, may be null; the IMU axis models, 3 x 3 as rows); other keys
(the calibration's own report: residuals, outliers, ...) are not read.  A missing required key is refused, with the
near miss named when there is one (``'rotation_xyz' instead of 'rotation_xyzw'?``).
Every problem is a :class:`~dualpose.io.recording.RecordingError` naming the file (and the
key or line).
"""

from __future__ import annotations

import difflib
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dualpose.io._text import check_path, open_for_writing, open_input
from dualpose.io.euroc import ImuData
from dualpose.io.recording import RecordingError, read_imu
from dualpose.io.sensors_yaml import read_rig_sensors
from dualpose.io.target.detections import read_target_detections
from dualpose.types import _inputs
from dualpose.types.calibration import CameraImuCalibration
from dualpose.types.target import RigSensors, TargetDetections

__all__ = [
    "CALIBRATION_KEYS",
    "TargetRecording",
    "is_target_recording",
    "read_camera_imu_calibration",
    "read_target_recording",
    "write_camera_imu_calibration",
]

IMU_FILE = "imu0.csv"
SENSORS_YAML = "sensors.yaml"
_DETECTIONS = re.compile(r"^(cam\d+)_aprilgrid\.csv$")

#: calibration JSON keys -> required
CALIBRATION_KEYS = {
    "camera": True,
    "rotation_xyzw": True,
    "translation_m": True,
    "time_offset_s": True,
    "reprojection_rms_px": True,
    "gyro_bias": False,
    "accel_bias": False,
    "gravity_target": False,
    "std": False,
    "gyro_axes_matrix": False,
    "accel_axes_matrix": False,
}


@dataclass(frozen=True)
class TargetRecording:
    """A target recording as read: the IMU, every camera's detections and the rig's sensor file.

    ``imu`` (:class:`~dualpose.io.euroc.ImuData`: ``stamps_ns`` (N,), ``stamps`` (N,) s, ``gyro``, ``accel`` (N, 3) body
    frame); ``detections`` camera name -> :class:`~dualpose.types.target.TargetDetections` (raw pixels, target-frame
    points); ``rig`` the :class:`~dualpose.types.target.RigSensors`; ``path`` the directory.
    """

    imu: ImuData
    detections: dict[str, TargetDetections]
    rig: RigSensors
    path: str


def is_target_recording(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` is a directory in this layout: it holds a ``camN_aprilgrid.csv``, or both ``imu0.csv`` and
    ``sensors.yaml`` without a ``correspondences.csv`` (a dualpose recording directory, docs/fusion.md, may name its
    IMU file ``imu0.csv`` and its sensor file ``sensors.yaml`` too); :func:`read_target_recording` then names
    whatever else is missing."""
    p = Path(path)
    if not p.is_dir():
        return False
    if any(_DETECTIONS.match(f.name) for f in p.iterdir()):
        return True
    return (p / SENSORS_YAML).is_file() and (p / IMU_FILE).is_file() and not (p / "correspondences.csv").exists()


def read_target_recording(directory: str | os.PathLike[str], cameras: tuple[str, ...] | None = None) -> TargetRecording:
    """Read a target-recording directory (module docstring).

    Parameters
    ----------
    directory : path
    cameras : tuple of str, optional
        The cameras whose detections to read (default: every ``camN_aprilgrid.csv``); each must be in
        ``sensors.yaml``.

    Raises
    ------
    RecordingError
        A missing file (named), an unknown camera (the available ones listed), a malformed file (file and line),
        or detections that do not overlap the IMU in time.
    """
    d = Path(check_path(directory, "directory"))
    if not d.is_dir():
        raise RecordingError(f"{d}: not a directory")
    for name in (SENSORS_YAML, IMU_FILE):
        if not (d / name).is_file():
            raise RecordingError(f"{d}: {name} not found (a target recording holds {IMU_FILE}, {SENSORS_YAML} and "
                                 "camN_aprilgrid.csv)")  # fmt: skip
    rig = read_rig_sensors(d / SENSORS_YAML)
    found = sorted(m.group(1) for m in (_DETECTIONS.match(f.name) for f in d.iterdir()) if m)
    wanted = tuple(found) if cameras is None else tuple(cameras)
    for cam in wanted:
        if cam not in rig.cameras:
            raise RecordingError(f"{d / SENSORS_YAML}: unknown camera {cam!r}; available: {', '.join(rig.cameras)}")
        if not (d / f"{cam}_aprilgrid.csv").is_file():
            raise RecordingError(f"{d}: {cam}_aprilgrid.csv not found (the detections of camera {cam!r}; present: "
                                 f"{', '.join(f'{c}_aprilgrid.csv' for c in found) or 'none'})")  # fmt: skip
    imu = read_imu(d / IMU_FILE)
    detections: dict[str, TargetDetections] = {}
    for cam in wanted:
        det = read_target_detections(d / f"{cam}_aprilgrid.csv")
        seen = det.counts > 0
        if not seen.any():
            raise RecordingError(f"{det.path}: no frame has a detected corner")
        t_seen = det.stamps_ns[seen]
        if t_seen[-1] < imu.stamps_ns[0] or t_seen[0] > imu.stamps_ns[-1]:
            raise RecordingError(
                f"{det.path}: the detections ({t_seen[0]} to {t_seen[-1]} ns) do not overlap the IMU "
                f"({imu.stamps_ns[0]} to {imu.stamps_ns[-1]} ns, {d / IMU_FILE}) in time"
            )
        detections[cam] = det
    return TargetRecording(imu=imu, detections=detections, rig=rig, path=str(d))


def read_camera_imu_calibration(path: str | os.PathLike[str]) -> CameraImuCalibration:
    """Read a camera–IMU calibration JSON (module docstring).

    Raises
    ------
    RecordingError
        ``path: ...`` for a missing file, invalid JSON (with its line), a missing required key (the required keys
        listed, a near miss named) or a value of the wrong shape (naming the key).
    """
    p = check_path(path, "calibration")
    try:
        with open_input(p) as f:
            data = json.loads(f.read().decode("utf-8"))
    except FileNotFoundError:
        raise RecordingError(f"{p}: calibration file not found") from None
    except json.JSONDecodeError as exc:
        raise RecordingError(f"{p}:{exc.lineno}: not valid JSON: {exc.msg}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise RecordingError(f"{p}: cannot read the calibration file: {exc}") from None
    expected = ", ".join(CALIBRATION_KEYS)
    if not isinstance(data, dict):
        raise RecordingError(f"{p}: a camera-IMU calibration is one JSON object with the keys {expected}")
    missing = [k for k, required in CALIBRATION_KEYS.items() if required and data.get(k) is None]
    if missing:
        near = {k: difflib.get_close_matches(k, [d for d in data if d not in CALIBRATION_KEYS], n=1) for k in missing}
        hint = "".join(f"; {v[0]!r} instead of {k!r}?" for k, v in near.items() if v)
        raise RecordingError(f"{p}: missing key(s) {', '.join(map(repr, missing))} (required: "
                             f"{', '.join(k for k, r in CALIBRATION_KEYS.items() if r)}){hint}")  # fmt: skip
    try:
        known = {k: v for k, v in data.items() if k in CALIBRATION_KEYS and not (k == "std" and v is None)}
        calibration = CameraImuCalibration(**known)
        _check_imu_model(data)
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"{p}: {exc}") from None
    return calibration


def _check_imu_model(data: dict[str, Any]) -> None:
    """``imu_model`` (when the file states it, as ``dualpose calibrate camera-imu --json`` does) and the axis
    matrices repeat one fact: ``"scale_misalignment"`` has both matrices, ``"calibrated"`` neither."""
    model = data.get("imu_model")
    if model is None:
        return
    if model not in ("calibrated", "scale_misalignment"):
        raise ValueError(f"imu_model must be 'calibrated' or 'scale_misalignment'; got {model!r}")
    for key in ("gyro_axes_matrix", "accel_axes_matrix"):
        stated = data.get(key) is not None
        if stated != (model == "scale_misalignment"):
            detail = (f"imu_model is {model!r} but {key} is {'given' if stated else 'missing'}: the axis models are "
                      "what 'scale_misalignment' estimates and 'calibrated' does not")  # fmt: skip
            raise _inputs.disagreement("imu_model", key, "the IMU model of the calibration", detail)


def write_camera_imu_calibration(
    path: str | os.PathLike[str], calibration: CameraImuCalibration, *, overwrite: bool = False
) -> Path:
    """Write ``calibration`` as the JSON :func:`read_camera_imu_calibration` reads; refuses to replace an existing
    file unless ``overwrite``.  Returns the path."""
    p = Path(check_path(path, "path"))
    with open_for_writing(p, overwrite) as f:
        f.write(json.dumps(calibration.as_dict(), indent=2) + "\n")
    return p
